//! Linear solvers (KSP) and their preconditioners (PC).
//!
//! A [`Ksp`] is owned (created with [`Ksp::new`], destroyed on drop) or borrowed from a SNES
//! ([`crate::petsc::Snes::ksp`]); a [`Pc`] is always borrowed from its KSP, which owns it.

use super::error::{call, PetscError};
use super::{handle, sys, Matrix, Petsc, PetscInt, Vector};
use mpi::raw::AsRaw;
use std::ffi::{c_void, CStr, CString};
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

/// A KSP convergence test as PETSc calls it: `(ksp, iteration, residual norm, reason, context)`.
type ConvergenceTest = unsafe extern "C" fn(
    sys::KSP,
    PetscInt,
    f64,
    *mut sys::KSPConvergedReason,
    *mut c_void,
) -> sys::PetscErrorCode;

/// A request to stop a Krylov solve, asked at every call of its convergence test on every rank:
/// collective, and it must answer alike on every rank (e.g. an all-reduce of a signal flag).
pub type StopQuery = Box<dyn FnMut() -> bool>;

/// The context of [`krylov_test`]: PETSc's default test's own context; the relative true residual
/// that a solve stopped by its iteration limit must have reached (`None`: such a solve fails), the
/// count of solves so accepted, and the relative true residual of the last solve that reached
/// the limit; the stop query, and whether it stopped a solve.
struct KrylovTest {
    default_ctx: *mut c_void,
    accept: Option<f64>,
    accepted: usize,
    last_true: f64,
    stop: Option<StopQuery>,
    stopped: bool,
}

/// PETSc's default convergence test, with two additions. A solve whose stop query answers yes
/// ends at that iteration (`DIVERGED_BREAKDOWN`, and [`Ksp::stopped`] says so), so that a run
/// asked to stop does not wait for the rest of a long Krylov solve. And with `accept`, a solve
/// that reaches its iteration limit (`-ksp_max_it`) with its true residual `|b - A x|` at most
/// `accept |b|` is converged (`CONVERGED_ITS`) instead of `DIVERGED_ITS`: an inexact Newton
/// direction with forcing term `accept` (Eisenstat and Walker's condition on the linearised
/// residual).
unsafe extern "C" fn krylov_test(
    ksp: sys::KSP,
    n: PetscInt,
    rnorm: f64,
    reason: *mut sys::KSPConvergedReason,
    ctx: *mut c_void,
) -> sys::PetscErrorCode {
    // SAFETY: `ctx` is the `KrylovTest` that `Ksp::set_convergence_test` gave PETSc with this
    // function; PETSc passes valid `ksp` and `reason`.
    unsafe {
        let c = &mut *(ctx as *mut KrylovTest);
        let ierr = sys::KSPConvergedDefault(ksp, n, rnorm, reason, c.default_ctx);
        if ierr != 0 {
            return ierr;
        }
        // asked at every call on every rank, whatever the reason so far, since it communicates
        if let Some(stop) = c.stop.as_mut() {
            if stop() && (*reason).0 <= 0 {
                c.stopped = true;
                *reason = sys::KSPConvergedReason::KSP_DIVERGED_BREAKDOWN;
                return 0;
            }
        }
        let Some(rtol) = c.accept else { return 0 };
        if *reason == sys::KSPConvergedReason::KSP_CONVERGED_ITERATING {
            let mut max_it: PetscInt = 0;
            let ierr = sys::KSPGetTolerances(
                ksp,
                std::ptr::null_mut(),
                std::ptr::null_mut(),
                std::ptr::null_mut(),
                &mut max_it,
            );
            if ierr != 0 {
                return ierr;
            }
            if n >= max_it && rnorm.is_finite() {
                // the true residual of the linear system, |b - A x_n| / |b|: with left
                // preconditioning the Krylov method's own norm is the preconditioned one, which
                // near a converged Newton iterate can be 50x the true one's scale (the 1e6 twist)
                // and says little about the direction's quality
                let mut r: sys::Vec = std::ptr::null_mut();
                let mut b: sys::Vec = std::ptr::null_mut();
                let (mut r_norm, mut b_norm) = (f64::INFINITY, 0.0);
                let mut ierr =
                    sys::KSPBuildResidual(ksp, std::ptr::null_mut(), std::ptr::null_mut(), &mut r);
                if ierr == 0 {
                    ierr = sys::VecNorm(r, sys::NormType::NORM_2, &mut r_norm);
                }
                if !r.is_null() {
                    let e = sys::VecDestroy(&mut r);
                    if ierr == 0 {
                        ierr = e;
                    }
                }
                if ierr == 0 {
                    ierr = sys::KSPGetRhs(ksp, &mut b);
                }
                if ierr == 0 {
                    ierr = sys::VecNorm(b, sys::NormType::NORM_2, &mut b_norm);
                }
                if ierr != 0 {
                    return ierr;
                }
                c.last_true = r_norm / b_norm;
                if r_norm.is_finite() && r_norm <= rtol * b_norm {
                    *reason = sys::KSPConvergedReason::KSP_CONVERGED_ITS;
                    c.accepted += 1;
                }
            }
        }
        0
    }
}

/// Frees the context of [`krylov_test`] (PETSc calls it when the test is replaced or the KSP
/// destroyed).
unsafe extern "C" fn destroy_krylov_test(ctx: *mut c_void) -> sys::PetscErrorCode {
    // SAFETY: `ctx` came from `Box::into_raw` in `Ksp::set_convergence_test`, and PETSc calls
    // this once.
    unsafe {
        let c = Box::from_raw(ctx as *mut KrylovTest);
        sys::KSPConvergedDefaultDestroy(c.default_ctx)
    }
}

impl Ksp<'_> {
    /// Installs [`krylov_test`]: PETSc's default test; with `accept`, a Krylov solve stopped by
    /// its iteration limit whose true residual `|b - A x|` is at most `accept |b|` is accepted as
    /// an inexact Newton direction (`CONVERGED_ITS`) instead of failing (`DIVERGED_ITS`); with
    /// `stop`, a solve ends at the first iteration at which the query answers yes
    /// ([`Ksp::stopped`]). Other solves are judged by PETSc's default test (in the method's own
    /// norm).
    ///
    /// Collective.
    pub fn set_convergence_test(
        &mut self,
        accept: Option<f64>,
        stop: Option<StopQuery>,
    ) -> Result<(), PetscError> {
        let mut default_ctx = std::ptr::null_mut();
        // SAFETY: PETSc allocates the default test's context.
        unsafe { call!(KSPConvergedDefaultCreate(&mut default_ctx))? };
        let ctx = Box::into_raw(Box::new(KrylovTest {
            default_ctx,
            accept,
            accepted: 0,
            last_true: f64::NAN,
            stop,
            stopped: false,
        }));
        // SAFETY: valid handle; PETSc owns `ctx` from here and frees it with the destroy function.
        unsafe {
            call!(KSPSetConvergenceTest(
                self.raw,
                Some(krylov_test),
                ctx as *mut c_void,
                Some(destroy_krylov_test)
            ))
        }
    }

    /// [`krylov_test`]'s context, when that test is installed.
    fn krylov_test(&mut self) -> Result<Option<&mut KrylovTest>, PetscError> {
        let mut test: Option<ConvergenceTest> = None;
        let mut ctx: *mut c_void = std::ptr::null_mut();
        // SAFETY: valid handle; PETSc writes the test's function pointer and context.
        unsafe {
            call!(KSPGetConvergenceTest(
                self.raw,
                &mut test,
                &mut ctx,
                std::ptr::null_mut()
            ))?
        };
        let ours: ConvergenceTest = krylov_test;
        if test.map(|t| t as usize) != Some(ours as usize) || ctx.is_null() {
            return Ok(None);
        }
        // SAFETY: the test is ours, so its context is the `KrylovTest` it was installed with,
        // which PETSc keeps alive while the test is installed.
        Ok(Some(unsafe { &mut *(ctx as *mut KrylovTest) }))
    }

    /// Whether the stop query of [`Ksp::set_convergence_test`] ended a solve since the last call
    /// (which clears it); `false` when that test is not installed.
    pub fn stopped(&mut self) -> Result<bool, PetscError> {
        Ok(self
            .krylov_test()?
            .is_some_and(|c| std::mem::replace(&mut c.stopped, false)))
    }

    /// The state of [`Ksp::set_convergence_test`]'s acceptance at the limit: the solves it
    /// accepted so far, and the relative true residual `|b - A x| / |b|` of the last solve that
    /// reached the iteration limit (NaN before one did); `None` when that test is not installed
    /// or accepts nothing.
    pub fn limit_state(&mut self) -> Result<Option<(usize, f64)>, PetscError> {
        Ok(self
            .krylov_test()?
            .filter(|c| c.accept.is_some())
            .map(|c| (c.accepted, c.last_true)))
    }

    /// Solves accepted at the iteration limit by [`Ksp::set_convergence_test`] so far (0 when that
    /// test is not installed).
    pub fn accepted_at_limit(&mut self) -> Result<usize, PetscError> {
        Ok(self.limit_state()?.map_or(0, |(n, _)| n))
    }
}
