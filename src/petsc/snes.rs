//! PETSc's nonlinear solver (SNES) driving a Rust [`NonlinearProblem`] through `extern "C"` trampolines.

use super::error::{call, PetscError};
use super::{handle, sys, Ksp, Matrix, Petsc, PetscInt, Vector};
use mpi::raw::AsRaw;
use std::ffi::{c_void, CStr};
use std::marker::PhantomData;
use std::panic::{catch_unwind, AssertUnwindSafe};

/// Why a residual or Jacobian evaluation could not be completed.
#[derive(Debug, Clone, thiserror::Error)]
pub enum ProblemError {
    /// The state is outside the problem's domain (an inverted element, a failed projection): SNES is
    /// told through `SNESSetFunctionDomainError` and the load step is cut back. Must be raised on every
    /// rank alike (the problem reduces the flag itself before returning it).
    #[error("domain error: {0}")]
    Domain(String),
    /// Anything else: the solve stops with this message.
    #[error("{0}")]
    Fatal(String),
}

/// What SNES asks of the problem being solved.
pub trait NonlinearProblem {
    /// `f = F(x)`. Collective.
    fn residual(&mut self, x: &Vector, f: &mut Vector) -> Result<(), ProblemError>;
    /// `J = dF/dx (x)`. Collective.
    fn jacobian(&mut self, x: &Vector, j: &mut Matrix) -> Result<(), ProblemError>;
}

/// The result of one [`Snes::solve`].
#[derive(Debug, Clone)]
pub struct SolveOutcome {
    /// SNES converged (reason > 0).
    pub converged: bool,
    /// SNES's converged reason as text, e.g. `CONVERGED_FNORM_RELATIVE`.
    pub reason: String,
    /// Newton iterations taken.
    pub iterations: usize,
    /// Residual norm before each Newton iteration and after the last: `[|F(x0)|, |F(x1)|, ...]`.
    pub residual_history: Vec<f64>,
    /// The last domain error raised by the problem, if any.
    pub domain_error: Option<String>,
}

const HISTORY_LEN: usize = 1000;

/// A PETSc SNES with its convergence history buffers.
pub struct Snes<'p> {
    raw: sys::SNES,
    owned: bool,
    history: Vec<f64>,
    /// Linear iterations per Newton step; PETSc writes here, so the buffer must live as long as
    /// the SNES even though nothing reads it.
    #[allow(dead_code)]
    history_its: Vec<PetscInt>,
    _petsc: PhantomData<&'p Petsc>,
}
handle!(Snes, sys::SNES, sys::SNESDestroy);

struct Context<'a> {
    problem: &'a mut dyn NonlinearProblem,
    /// The caller's Jacobian wrapper (type-erased `*mut Matrix`): handed back to the problem so the
    /// wrapper's own state (its COO size) is the one PETSc's callbacks see.
    jac: *mut c_void,
    domain: Option<String>,
    fatal: Option<String>,
    /// The Jacobian evaluation raised a domain error: the convergence test stops the solve.
    jacobian_domain: bool,
}

/// PETSc's code for "error in user callback" (PETSC_ERR_USER in petscerror.h).
const PETSC_ERR_USER: sys::PetscErrorCode = 83;

fn panic_text(p: Box<dyn std::any::Any + Send>) -> String {
    if let Some(s) = p.downcast_ref::<&str>() {
        (*s).to_string()
    } else if let Some(s) = p.downcast_ref::<String>() {
        s.clone()
    } else {
        "unknown panic".into()
    }
}

unsafe extern "C" fn residual_trampoline(
    snes: sys::SNES,
    x: sys::Vec,
    f: sys::Vec,
    ctx: *mut c_void,
) -> sys::PetscErrorCode {
    // SAFETY: ctx is the &mut Context installed by `solve`, alive for the whole SNESSolve; x and f are
    // valid vectors owned by SNES for the duration of this call.
    let ctx = unsafe { &mut *(ctx as *mut Context) };
    let xv = unsafe { Vector::borrowed(x) };
    let mut fv = unsafe { Vector::borrowed(f) };
    match catch_unwind(AssertUnwindSafe(|| ctx.problem.residual(&xv, &mut fv))) {
        Ok(Ok(())) => 0,
        Ok(Err(ProblemError::Domain(msg))) => {
            ctx.domain = Some(msg);
            // SAFETY: snes is the live solver calling us.
            unsafe { sys::SNESSetFunctionDomainError(snes) }
        }
        Ok(Err(ProblemError::Fatal(msg))) => {
            ctx.fatal = Some(msg);
            PETSC_ERR_USER
        }
        Err(p) => {
            ctx.fatal = Some(format!("panic in residual evaluation: {}", panic_text(p)));
            PETSC_ERR_USER
        }
    }
}

/// SNES convergence test: PETSc's default, except that a Jacobian domain error stops the solve
/// (`DIVERGED_JACOBIAN_DOMAIN`), so that the caller can, e.g., rebuild the sparsity pattern.
unsafe extern "C" fn converged_trampoline(
    snes: sys::SNES,
    it: PetscInt,
    xnorm: f64,
    gnorm: f64,
    fnorm: f64,
    reason: *mut sys::SNESConvergedReason,
    ctx: *mut c_void,
) -> sys::PetscErrorCode {
    // SAFETY: ctx is the &mut Context installed by `solve`, alive for the whole SNESSolve; reason
    // is SNES's own output slot.
    let ctx = unsafe { &mut *(ctx as *mut Context) };
    if ctx.jacobian_domain {
        // SAFETY: as above.
        unsafe { *reason = sys::SNESConvergedReason::SNES_DIVERGED_JACOBIAN_DOMAIN };
        return 0;
    }
    // SAFETY: the live solver and its arguments, passed through; the default test takes no context.
    unsafe {
        sys::SNESConvergedDefault(snes, it, xnorm, gnorm, fnorm, reason, std::ptr::null_mut())
    }
}

unsafe extern "C" fn jacobian_trampoline(
    _snes: sys::SNES,
    x: sys::Vec,
    j: sys::Mat,
    _p: sys::Mat,
    ctx: *mut c_void,
) -> sys::PetscErrorCode {
    // SAFETY: as in residual_trampoline; j is the matrix we registered, alive during the call.
    let ctx = unsafe { &mut *(ctx as *mut Context) };
    let xv = unsafe { Vector::borrowed(x) };
    // SAFETY: ctx.jac points to the `Matrix` the caller passed to `solve`, which is not used by the
    // caller while SNESSolve runs; SNES hands back the same Mat we registered, checked here.
    let caller = unsafe { &mut *(ctx.jac as *mut Matrix) };
    let mut borrowed;
    let jm: &mut Matrix = if caller.as_raw() == j {
        caller
    } else {
        // SAFETY: j is a valid Mat owned by SNES for the duration of the call.
        borrowed = unsafe { Matrix::borrowed(j) };
        &mut borrowed
    };
    match catch_unwind(AssertUnwindSafe(|| ctx.problem.jacobian(&xv, jm))) {
        Ok(Ok(())) => 0,
        Ok(Err(ProblemError::Domain(msg))) => {
            // Not `SNESSetJacobianDomainError`: PETSc 3.18 ignores it unless told to check, and
            // then never clears it, so every later solve of this SNES would stop at once. The
            // convergence test ([`converged_trampoline`]) stops this solve instead; the Newton step
            // already under way uses the previous matrix.
            ctx.domain = Some(msg);
            ctx.jacobian_domain = true;
            0
        }
        Ok(Err(ProblemError::Fatal(msg))) => {
            ctx.fatal = Some(msg);
            PETSC_ERR_USER
        }
        Err(p) => {
            ctx.fatal = Some(format!("panic in Jacobian evaluation: {}", panic_text(p)));
            PETSC_ERR_USER
        }
    }
}

impl<'p> Snes<'p> {
    /// A Newton solver with line search (`newtonls`) and a direct LU solve by MUMPS, unless the options
    /// database (command line, case file) says otherwise: options are applied last.
    ///
    /// Collective.
    pub fn new(petsc: &'p Petsc) -> Result<Self, PetscError> {
        let mut raw = std::ptr::null_mut();
        let mut history = vec![0.0; HISTORY_LEN];
        let mut history_its = vec![0; HISTORY_LEN];
        // SAFETY: valid communicator; KSP and PC are borrowed from the SNES and not destroyed by us; the
        // history buffers live in the returned struct and never reallocate.
        unsafe {
            call!(SNESCreate(petsc.comm().as_raw(), &mut raw))?;
            call!(SNESSetType(raw, sys::SNESNEWTONLS.as_ptr()))?;
            let mut ksp_raw = std::ptr::null_mut();
            call!(SNESGetKSP(raw, &mut ksp_raw))?;
            let mut ksp = Ksp::borrowed(ksp_raw);
            ksp.set_type("preonly")?;
            let mut pc = ksp.pc()?;
            pc.set_type("lu")?;
            pc.set_factor_solver_type("mumps")?;
            call!(SNESSetConvergenceHistory(
                raw,
                history.as_mut_ptr(),
                history_its.as_mut_ptr(),
                HISTORY_LEN as PetscInt,
                sys::PetscBool(1)
            ))?;
        }
        Ok(Snes {
            raw,
            owned: true,
            history,
            history_its,
            _petsc: PhantomData,
        })
    }

    /// The linear solver of the Newton steps, borrowed (e.g. to change its type or PC).
    pub fn ksp(&mut self) -> Result<Ksp<'_>, PetscError> {
        let mut raw = std::ptr::null_mut();
        // SAFETY: valid handle; the KSP belongs to the SNES and is not destroyed by the wrapper.
        unsafe { call!(SNESGetKSP(self.raw, &mut raw))? };
        // SAFETY: the SNES keeps its KSP alive at least as long as this borrow of the SNES.
        Ok(unsafe { Ksp::borrowed(raw) })
    }

    /// Sets tolerances (absolute, relative, step) and the iteration limit; `-snes_*` options override.
    pub fn set_tolerances(
        &mut self,
        atol: f64,
        rtol: f64,
        stol: f64,
        max_it: usize,
    ) -> Result<(), PetscError> {
        // SAFETY: valid handle; PETSC_DEFAULT (-2) keeps max function evaluations.
        unsafe {
            call!(SNESSetTolerances(
                self.raw,
                atol,
                rtol,
                stol,
                max_it as PetscInt,
                -2
            ))
        }
    }

    /// Applies the options database (`-snes_*`, `-ksp_*`, `-pc_*`, ...). Call after setting defaults.
    pub fn set_from_options(&mut self) -> Result<(), PetscError> {
        // SAFETY: valid handle.
        unsafe { call!(SNESSetFromOptions(self.raw)) }
    }

    /// Solves `F(x) = 0` starting from `x`, with `jac` as the Jacobian storage.
    ///
    /// A diverged solve is not an `Err`: the outcome says why, so the caller can cut the step back.
    /// `Err` means PETSc itself failed or the problem raised a fatal error.
    ///
    /// Collective.
    pub fn solve(
        &mut self,
        problem: &mut dyn NonlinearProblem,
        x: &mut Vector,
        jac: &mut Matrix,
    ) -> Result<SolveOutcome, PetscError> {
        let jac_raw = jac.as_raw();
        let mut ctx = Context {
            problem,
            jac: jac as *mut Matrix as *mut c_void,
            domain: None,
            fatal: None,
            jacobian_domain: false,
        };
        let ctx_ptr = &mut ctx as *mut Context as *mut c_void;
        // SAFETY: ctx outlives SNESSolve (it is on this stack frame); the callbacks are re-registered
        // with this pointer before every solve, so a stale pointer is never used.
        let solve_result = unsafe {
            call!(SNESSetFunction(
                self.raw,
                std::ptr::null_mut(),
                Some(residual_trampoline),
                ctx_ptr
            ))?;
            call!(SNESSetJacobian(
                self.raw,
                jac_raw,
                jac_raw,
                Some(jacobian_trampoline),
                ctx_ptr
            ))?;
            call!(SNESSetConvergenceTest(
                self.raw,
                Some(converged_trampoline),
                ctx_ptr,
                None
            ))?;
            call!(SNESSolve(self.raw, std::ptr::null_mut(), x.as_raw()))
        };
        if let Some(msg) = ctx.fatal.take() {
            return Err(PetscError {
                code: PETSC_ERR_USER,
                function: "SNESSolve callback",
                message: msg,
            });
        }
        solve_result?;
        let mut reason = sys::SNESConvergedReason(0);
        let mut its: PetscInt = 0;
        let mut text: *const std::os::raw::c_char = std::ptr::null();
        let mut hist_ptr: *mut f64 = std::ptr::null_mut();
        let mut hist_its: *mut PetscInt = std::ptr::null_mut();
        let mut n_hist: PetscInt = 0;
        // SAFETY: valid handle; the strings and history pointers refer to PETSc-owned static text and our
        // own buffers.
        unsafe {
            call!(SNESGetConvergedReason(self.raw, &mut reason))?;
            call!(SNESGetIterationNumber(self.raw, &mut its))?;
            call!(SNESGetConvergedReasonString(self.raw, &mut text))?;
            call!(SNESGetConvergenceHistory(
                self.raw,
                &mut hist_ptr,
                &mut hist_its,
                &mut n_hist
            ))?;
        }
        let reason_text = if text.is_null() {
            format!("{}", reason.0)
        } else {
            // SAFETY: PETSc returns a static NUL-terminated string.
            unsafe { CStr::from_ptr(text) }
                .to_string_lossy()
                .into_owned()
        };
        let n = (n_hist.max(0) as usize).min(self.history.len());
        Ok(SolveOutcome {
            converged: reason.0 > 0,
            reason: reason_text,
            iterations: its.max(0) as usize,
            residual_history: self.history[..n].to_vec(),
            domain_error: ctx.domain,
        })
    }
}
