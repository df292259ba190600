//! Linear solvers (KSP) and their preconditioners (PC).
//!
//! A [`Ksp`] is owned (created with [`Ksp::new`], destroyed on drop) or borrowed from a SNES
//! ([`crate::petsc::Snes::ksp`]); a [`Pc`] is always borrowed from its KSP, which owns it.

use super::error::{call, PetscError};
use super::{handle, sys, Matrix, Petsc, PetscInt, Vector};
use mpi::raw::AsRaw;
use std::ffi::{CStr, CString};
use std::marker::PhantomData;

/// A PETSc `KSP`.
pub struct Ksp<'p> {
    raw: sys::KSP,
    owned: bool,
    _petsc: PhantomData<&'p Petsc>,
}
handle!(Ksp, sys::KSP, sys::KSPDestroy);

/// A PETSc `PC`, borrowed from the KSP that owns it.
pub struct Pc<'k> {
    raw: sys::PC,
    owned: bool,
    _ksp: PhantomData<&'k ()>,
}
handle!(Pc, sys::PC, sys::PCDestroy);

/// The result of one [`Ksp::solve`].
#[derive(Debug, Clone)]
pub struct KspOutcome {
    /// KSP converged (reason > 0).
    pub converged: bool,
    /// KSP's converged reason as text.
    pub reason: String,
    /// Iterations (1 for a direct solve with `preonly`).
    pub iterations: usize,
}

fn c_string(s: &str) -> Result<CString, PetscError> {
    CString::new(s).map_err(|_| PetscError {
        code: 62,
        function: "type name",
        message: format!("`{s}` contains a NUL byte"),
    })
}

impl<'p> Ksp<'p> {
    /// A new KSP on the guard's communicator.
    ///
    /// Collective.
    pub fn new(petsc: &'p Petsc) -> Result<Self, PetscError> {
        let mut raw = std::ptr::null_mut();
        // SAFETY: valid communicator; the KSP is destroyed on drop.
        unsafe { call!(KSPCreate(petsc.comm().as_raw(), &mut raw))? };
        Ok(Ksp {
            raw,
            owned: true,
            _petsc: PhantomData,
        })
    }

    /// Wraps a KSP owned by PETSc (a SNES's) without taking ownership.
    ///
    /// # Safety
    /// `raw` must stay valid while the wrapper is used.
    pub(crate) unsafe fn borrowed(raw: sys::KSP) -> Self {
        Ksp {
            raw,
            owned: false,
            _petsc: PhantomData,
        }
    }

    /// Sets the KSP type, e.g. `preonly`, `gmres`, `cg`.
    pub fn set_type(&mut self, kind: &str) -> Result<(), PetscError> {
        let k = c_string(kind)?;
        // SAFETY: valid handle; PETSc copies the type name.
        unsafe { call!(KSPSetType(self.raw, k.as_ptr())) }
    }

    /// Sets the operator (and the matrix the preconditioner is built from).
    pub fn set_operators(&mut self, a: &Matrix) -> Result<(), PetscError> {
        // SAFETY: valid handles; PETSc takes its own reference to the matrix.
        unsafe { call!(KSPSetOperators(self.raw, a.as_raw(), a.as_raw())) }
    }

    /// Relative, absolute and divergence tolerances and the iteration limit.
    pub fn set_tolerances(
        &mut self,
        rtol: f64,
        atol: f64,
        dtol: f64,
        max_it: usize,
    ) -> Result<(), PetscError> {
        // SAFETY: valid handle.
        unsafe {
            call!(KSPSetTolerances(
                self.raw,
                rtol,
                atol,
                dtol,
                max_it as PetscInt
            ))
        }
    }

    /// Applies `-ksp_*` / `-pc_*` options.
    pub fn set_from_options(&mut self) -> Result<(), PetscError> {
        // SAFETY: valid handle.
        unsafe { call!(KSPSetFromOptions(self.raw)) }
    }

    /// The preconditioner, borrowed.
    pub fn pc(&mut self) -> Result<Pc<'_>, PetscError> {
        let mut raw = std::ptr::null_mut();
        // SAFETY: valid handle; the PC belongs to this KSP and is not destroyed by the wrapper.
        unsafe { call!(KSPGetPC(self.raw, &mut raw))? };
        Ok(Pc {
            raw,
            owned: false,
            _ksp: PhantomData,
        })
    }

    /// Solves `A x = b`. A diverged solve is reported in the outcome, not as an error.
    ///
    /// Collective.
    pub fn solve(&mut self, b: &Vector, x: &mut Vector) -> Result<KspOutcome, PetscError> {
        let mut reason = sys::KSPConvergedReason(0);
        let mut its: PetscInt = 0;
        let mut text: *const std::os::raw::c_char = std::ptr::null();
        // SAFETY: valid handles with compatible layouts (PETSc checks); the reason string is static.
        unsafe {
            call!(KSPSolve(self.raw, b.as_raw(), x.as_raw()))?;
            call!(KSPGetConvergedReason(self.raw, &mut reason))?;
            call!(KSPGetIterationNumber(self.raw, &mut its))?;
            call!(KSPGetConvergedReasonString(self.raw, &mut text))?;
        }
        let reason_text = if text.is_null() {
            reason.0.to_string()
        } else {
            // SAFETY: PETSc returns a static NUL-terminated string.
            unsafe { CStr::from_ptr(text) }
                .to_string_lossy()
                .into_owned()
        };
        Ok(KspOutcome {
            converged: reason.0 > 0,
            reason: reason_text,
            iterations: its.max(0) as usize,
        })
    }
}

impl Pc<'_> {
    /// Sets the PC type, e.g. `lu`, `cholesky`, `jacobi`.
    pub fn set_type(&mut self, kind: &str) -> Result<(), PetscError> {
        let k = c_string(kind)?;
        // SAFETY: valid handle; PETSc copies the type name.
        unsafe { call!(PCSetType(self.raw, k.as_ptr())) }
    }

    /// Chooses the package of a factorisation PC, e.g. `mumps`, `superlu_dist`, `petsc`.
    pub fn set_factor_solver_type(&mut self, package: &str) -> Result<(), PetscError> {
        let k = c_string(package)?;
        // SAFETY: valid handle; PETSc copies the name.
        unsafe { call!(PCFactorSetMatSolverType(self.raw, k.as_ptr())) }
    }
}
