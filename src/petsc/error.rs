//! PETSc error codes as Rust errors.

use super::sys;
use std::ffi::CStr;

/// A PETSc call returned a non-zero error code.
#[derive(Debug, Clone, thiserror::Error)]
#[error("PETSc error {code} in {function}: {message}")]
pub struct PetscError {
    /// PETSc's error code.
    pub code: i32,
    /// The PETSc function that failed.
    pub function: &'static str,
    /// PETSc's text for the code (its detailed traceback goes to stderr through PETSc's handler).
    pub message: String,
}

/// Turns a PETSc error code into a `Result`, with PETSc's message.
pub fn check(code: sys::PetscErrorCode, function: &'static str) -> Result<(), PetscError> {
    if code == 0 {
        return Ok(());
    }
    let mut text: *const std::os::raw::c_char = std::ptr::null();
    // SAFETY: PetscErrorMessage only writes a pointer to a static string into `text`; the specific
    // message argument may be null.
    let ierr = unsafe { sys::PetscErrorMessage(code, &mut text, std::ptr::null_mut()) };
    let message = if ierr == 0 && !text.is_null() {
        // SAFETY: PETSc returned a pointer to a NUL-terminated static string.
        unsafe { CStr::from_ptr(text) }
            .to_string_lossy()
            .into_owned()
    } else {
        "unknown error".to_string()
    };
    Err(PetscError {
        code,
        function,
        message,
    })
}

/// Calls a PETSc function and converts its error code: `call!(VecSet(x, 0.0))`.
macro_rules! call {
    ($f:ident ( $($arg:expr),* $(,)? )) => {
        $crate::petsc::check($crate::petsc::sys::$f($($arg),*), stringify!($f))
    };
}
pub(crate) use call;
