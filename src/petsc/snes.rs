//! PETSc's nonlinear solver (SNES) driving a Rust [`NonlinearProblem`] through `extern "C"` trampolines.

use super::error::{call, PetscError};
use super::interface_pc::{self, InterfaceCorrection};
use super::{handle, quiet_errors, sys, Ksp, Matrix, NullSpace, Petsc, PetscInt, Vector};
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
    /// True when the solve should stop after the current Newton iteration (unless it has
    /// converged), for the caller to change something between solves and resume from the iterate
    /// reached (a contact sparsity pattern that no longer holds the Jacobian). Must be the same on
    /// every rank. Collective only in that sense; must not communicate.
    fn stop_requested(&self) -> bool {
        false
    }
    /// True when the run has been asked to stop (a signal): the solve stops after the current
    /// Newton iteration unless it has converged, and [`SolveOutcome::interrupted`] says so.
    /// Called once per Newton iteration on every rank; must return the same on every rank (it may
    /// communicate to agree).
    fn interrupted(&self) -> bool {
        false
    }
    /// Global unknowns of the contact interface at the last Jacobian (any rank's rows; a rank
    /// may name rows another owns), for [`Snes::set_interface_correction`]. Default: none.
    fn interface_dofs(&self) -> Vec<PetscInt> {
        Vec::new()
    }
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
    /// The solve stopped because a linear solve failed (`SNES_DIVERGED_LINEAR_SOLVE`: a Krylov
    /// solve that did not converge), or, with [`Snes::set_iterative`], PETSc raised an error in
    /// it (a preconditioner that could not be set up).
    pub linear_failed: bool,
    /// Linear (Krylov) iterations of this solve, summed over its Newton iterations (one per
    /// Newton iteration for a direct solve).
    pub linear_iterations: usize,
    /// Krylov solves of this solve stopped by their iteration limit and taken as inexact Newton
    /// directions ([`Ksp::set_convergence_test`]).
    pub linear_accepted: usize,
    /// The solve was stopped because the run was asked to stop
    /// ([`NonlinearProblem::interrupted`]); its state is not converged.
    pub interrupted: bool,
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
    /// Stop a solve whose best residual norm has not fallen by [`STAGNATION_FACTOR`] within this
    /// many iterations (0: never).
    stagnation_window: usize,
    /// The next solve starts from a guess (the secant predictor's): it is stopped when its first
    /// Newton iteration raises the residual norm ([`Snes::watch_start`]; one solve only).
    watch_start: bool,
    /// The fraction of each solve's first Newton update that is taken ([`Snes::set_first_update`]).
    first_update: f64,
    /// The rigid-body modes attached to the Jacobian before every solve (for GAMG).
    near_null: Option<NullSpace<'p>>,
    /// The options choose an iterative linear solver: a PETSc error in a solve is a linear
    /// failure (for the caller to retry with [`Snes::use_direct`]), not the end of the run.
    iterative: bool,
    /// [`Snes::use_direct`] is in force.
    on_direct: bool,
    /// The iterative route's preconditioner is GAMG with an exact solve on the contact
    /// interface ([`Snes::set_interface_correction`]); boxed: the PC shell holds its address.
    interface: Option<Box<InterfaceCorrection>>,
    _petsc: PhantomData<&'p Petsc>,
}

/// A solve stagnates when its best residual norm over the last `stagnation_window` iterations is
/// not below this fraction of its best norm before them.
pub const STAGNATION_FACTOR: f64 = 0.9;

/// Whether a solve with residual norms `norms` (`|F(x_0)|, ..., |F(x_it)|`) has stagnated: its
/// best norm over the last `window` iterations is not below [`STAGNATION_FACTOR`] times its best
/// norm before them (a Newton iteration cycling between iterates, e.g. at the kink of a penalty
/// law, or creeping without progress). Never before `window + 1` norms; `window = 0`: never.
pub fn stagnated(norms: &[f64], window: usize) -> bool {
    if window == 0 || norms.len() <= window {
        return false;
    }
    let (before, recent) = norms.split_at(norms.len() - window);
    let best_before = before.iter().copied().fold(f64::INFINITY, f64::min);
    let best_recent = recent.iter().copied().fold(f64::INFINITY, f64::min);
    best_recent >= STAGNATION_FACTOR * best_before
}
handle!(Snes, sys::SNES, sys::SNESDestroy);

struct Context<'a> {
    problem: &'a mut dyn NonlinearProblem,
    /// The caller's Jacobian wrapper (type-erased `*mut Matrix`): handed back to the problem so the
    /// wrapper's own state (its COO size) is the one PETSc's callbacks see.
    jac: *mut c_void,
    domain: Option<String>,
    fatal: Option<String>,
    /// A Jacobian evaluation raised a domain error: the solve stops after this iteration.
    jacobian_failed: bool,
    /// Residual norms seen by the convergence test, and the stagnation window (0: off).
    norms: Vec<f64>,
    stagnation_window: usize,
    /// The solve was stopped because it stagnated.
    stagnated: bool,
    /// Stop the solve if its first iteration raises the residual norm (a guessed start).
    watch_start: bool,
    /// The solve was stopped for that: the norms before and after the first iteration.
    rose: Option<(f64, f64)>,
    /// A residual evaluation since the last Jacobian (i.e. in this iteration's line search) raised
    /// a domain error: the line search's final step is checked ([`post_check_trampoline`]).
    line_search_domain: bool,
    /// The interface correction to tell the problem's interface after each Jacobian (null: none).
    interface: *mut InterfaceCorrection,
    /// Jacobians evaluated in this solve: 1 during the first Newton iteration's line search.
    jacobians: usize,
    /// The fraction of the first Newton update that is taken ([`Snes::set_first_update`]).
    first_update: f64,
    /// The solve was stopped at the problem's request to stop the run.
    interrupted: bool,
}

/// The first Newton iteration of a solve takes the fraction `first_update` of the step its line
/// search settled on: `w = x + f (w - x)` ([`Snes::set_first_update`]). Returns whether `w`
/// changed.
fn shorten_first_update(
    ctx: &Context,
    ls: sys::SNESLineSearch,
    x: sys::Vec,
    w: sys::Vec,
) -> Result<bool, sys::PetscErrorCode> {
    if ctx.jacobians != 1 || ctx.first_update >= 1.0 {
        return Ok(false);
    }
    let f = ctx.first_update;
    let mut lambda = 0.0;
    // SAFETY: x and w are valid vectors of the line search and ls the live line search, for the
    // duration of the post-check that calls this.
    let err = unsafe {
        let mut e = sys::VecAXPBY(w, 1.0 - f, f, x);
        if e == 0 {
            e = sys::SNESLineSearchGetLambda(ls, &mut lambda);
        }
        if e == 0 {
            e = sys::SNESLineSearchSetLambda(ls, f * lambda);
        }
        e
    };
    if err != 0 {
        return Err(err);
    }
    Ok(true)
}

/// Halvings the line search's post-check tries before it leaves an inadmissible step to SNES.
const POST_CHECK_HALVINGS: usize = 6;

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
            // what cuts a line search's step (each evaluation outside the domain; every rank prints
            // its own message)
            if std::env::var_os("NURBS_CONTACT_DEBUG_DOMAIN").is_some() {
                eprintln!("domain error in a residual evaluation: {msg}");
            }
            ctx.domain = Some(msg);
            ctx.line_search_domain = true;
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

unsafe extern "C" fn jacobian_trampoline(
    _snes: sys::SNES,
    x: sys::Vec,
    j: sys::Mat,
    _p: sys::Mat,
    ctx: *mut c_void,
) -> sys::PetscErrorCode {
    // SAFETY: as in residual_trampoline; j is the matrix we registered, alive during the call.
    let ctx = unsafe { &mut *(ctx as *mut Context) };
    // a new Newton iteration: its line search starts after this Jacobian
    ctx.line_search_domain = false;
    ctx.jacobians += 1;
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
        Ok(Ok(())) => {
            if !ctx.interface.is_null() {
                // SAFETY: the correction is owned by the Snes running this solve and not used
                // elsewhere during it.
                let interface = unsafe { &mut *ctx.interface };
                interface.requested = ctx.problem.interface_dofs();
            }
            0
        }
        Ok(Err(ProblemError::Domain(msg))) => {
            // Not `SNESSetJacobianDomainError`: PETSc 3.18 ignores that flag unless told to check
            // it (SNES then goes on with the previous matrix and its factorisation, a chord step),
            // and once checked it stays set for every later solve of the same SNES. The
            // convergence test stops the solve after this iteration instead.
            ctx.domain = Some(msg);
            ctx.jacobian_failed = true;
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

/// The line search's post-check: when a residual evaluation of this line search fell outside the
/// domain (an inverted element, a failed projection), the step it settled on, `w = x - lambda y`,
/// is evaluated before SNES takes it, and halved while it is outside the domain too. PETSc's `l2`
/// search cuts lambda after a failed evaluation but then takes its secant step unchecked, which
/// can land in the failed region again (from 1 to 0.5 and 0.25, then the secant 0.80, measured on
/// the 3D contact scene at 54,252 unknowns), and SNES then stops with
/// `DIVERGED_FUNCTION_DOMAIN` although a shorter step reduced the residual. Costs nothing in a
/// line search without a domain error. Every rank takes the same branch: the problem raises a
/// domain error on every rank alike.
unsafe extern "C" fn post_check_trampoline(
    ls: sys::SNESLineSearch,
    x: sys::Vec,
    y: sys::Vec,
    w: sys::Vec,
    _changed_y: *mut sys::PetscBool,
    changed_w: *mut sys::PetscBool,
    ctx: *mut c_void,
) -> sys::PetscErrorCode {
    // SAFETY: ctx is the &mut Context installed by `solve`, alive for the whole SNESSolve.
    let ctx = unsafe { &mut *(ctx as *mut Context) };
    match shorten_first_update(ctx, ls, x, w) {
        // SAFETY: changed_w is valid for this call.
        Ok(true) => unsafe { *changed_w = sys::PetscBool(1) },
        Ok(false) => {}
        Err(e) => return e,
    }
    if !ctx.line_search_domain {
        return 0;
    }
    ctx.line_search_domain = false;
    // SAFETY: x, y, w are valid vectors of the line search for the duration of this call.
    let (xv, yv, wv) = unsafe {
        (
            Vector::borrowed(x),
            Vector::borrowed(y),
            Vector::borrowed(w),
        )
    };
    let Ok(mut f) = xv.duplicate() else {
        return PETSC_ERR_USER;
    };
    // the step length the search settled on, from w = x - lambda y (PETSc 3.18's `l2` sets the
    // line search's lambda only after this check)
    let (mut dy, mut yy) = (0.0, 0.0);
    // SAFETY: valid vectors of the same layout; f is ours.
    let err = unsafe {
        let mut e = sys::VecWAXPY(f.as_raw(), -1.0, w, x);
        if e == 0 {
            e = sys::VecDot(f.as_raw(), y, &mut dy);
        }
        if e == 0 {
            e = sys::VecDot(y, y, &mut yy);
        }
        e
    };
    if err != 0 {
        return err;
    }
    if yy <= 0.0 {
        return 0;
    }
    let mut lambda = dy / yy;
    for _ in 0..POST_CHECK_HALVINGS {
        match catch_unwind(AssertUnwindSafe(|| ctx.problem.residual(&wv, &mut f))) {
            Ok(Ok(())) => return 0,
            Ok(Err(ProblemError::Domain(msg))) => ctx.domain = Some(msg),
            Ok(Err(ProblemError::Fatal(msg))) => {
                ctx.fatal = Some(msg);
                return PETSC_ERR_USER;
            }
            Err(p) => {
                ctx.fatal = Some(format!("panic in residual evaluation: {}", panic_text(p)));
                return PETSC_ERR_USER;
            }
        }
        lambda *= 0.5;
        // w = x - lambda y
        // SAFETY: valid vectors of the same layout; changed_w and ls are valid for this call.
        let err = unsafe {
            let e = sys::VecWAXPY(wv.as_raw(), -lambda, yv.as_raw(), xv.as_raw());
            if e != 0 {
                e
            } else {
                *changed_w = sys::PetscBool(1);
                sys::SNESLineSearchSetLambda(ls, lambda)
            }
        };
        if err != 0 {
            return err;
        }
    }
    // still outside: SNES evaluates it, meets the domain error and the step is cut back
    0
}

/// SNES's default convergence test, then a stop (`SNES_DIVERGED_JACOBIAN_DOMAIN`) when a Jacobian
/// evaluation failed or the problem asks for one ([`NonlinearProblem::stop_requested`]), a stop
/// (`SNES_DIVERGED_MAX_IT`, reported as `DIVERGED_STAGNATION`) when the solve [`stagnated`], and
/// one (reported as `DIVERGED_PREDICTED_START`) when a watched start's first iteration raised the
/// residual norm; first of all a stop (reported as `INTERRUPTED`) of a solve that has not
/// converged when the run was asked to stop ([`NonlinearProblem::interrupted`]).
unsafe extern "C" fn converged_trampoline(
    snes: sys::SNES,
    it: PetscInt,
    xnorm: f64,
    snorm: f64,
    fnorm: f64,
    reason: *mut sys::SNESConvergedReason,
    ctx: *mut c_void,
) -> sys::PetscErrorCode {
    // SAFETY: snes and reason are valid for this call; the default test takes no context.
    let err = unsafe {
        sys::SNESConvergedDefault(snes, it, xnorm, snorm, fnorm, reason, std::ptr::null_mut())
    };
    if err != 0 {
        return err;
    }
    // SAFETY: ctx is the &mut Context installed by `solve`, alive for the whole SNESSolve.
    let ctx = unsafe { &mut *(ctx as *mut Context) };
    // SAFETY: reason points to SNES's reason, written just above.
    let r = unsafe { &mut *reason };
    // asked at every iteration on every rank, whatever the reason so far, since it may communicate
    if ctx.problem.interrupted() && r.0 <= 0 {
        ctx.interrupted = true;
        *r = sys::SNESConvergedReason::SNES_DIVERGED_JACOBIAN_DOMAIN;
        return 0;
    }
    if r.0 == 0 && (ctx.jacobian_failed || ctx.problem.stop_requested()) {
        *r = sys::SNESConvergedReason::SNES_DIVERGED_JACOBIAN_DOMAIN;
    }
    if r.0 == 0 && (ctx.stagnation_window > 0 || ctx.watch_start) && fnorm.is_finite() {
        ctx.norms.push(fnorm);
        if ctx.watch_start && ctx.norms.len() == 2 && ctx.norms[1] > ctx.norms[0] {
            ctx.rose = Some((ctx.norms[0], ctx.norms[1]));
            *r = sys::SNESConvergedReason::SNES_DIVERGED_MAX_IT;
        } else if ctx.stagnation_window > 0 && stagnated(&ctx.norms, ctx.stagnation_window) {
            ctx.stagnated = true;
            *r = sys::SNESConvergedReason::SNES_DIVERGED_MAX_IT;
        }
    }
    0
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
            // PETSc 3.18 ignores a Jacobian domain error unless asked to check it: SNES then goes
            // on with the previous matrix and its factorisation (the operator's state is
            // unchanged), i.e. a chord iteration that converges linearly. A Jacobian that cannot be
            // formed (a contact block outside the sparsity pattern) must stop the solve instead.
            call!(SNESSetCheckJacobianDomainError(raw, sys::PetscBool(1)))?;
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
            stagnation_window: 0,
            watch_start: false,
            first_update: 1.0,
            near_null: None,
            iterative: false,
            on_direct: false,
            interface: None,
            _petsc: PhantomData,
        })
    }

    /// Lets go of the Jacobian the last solves used, before a new sparsity pattern is built on the
    /// new matrix `next`: the SNES takes `next` as its Jacobian storage (the callbacks stay; they are
    /// registered again by every [`Snes::solve`]), and the linear solver drops its operators and
    /// what it built from them (GAMG's hierarchy or MUMPS's factors, the Krylov vectors; the types
    /// and options stay). The old matrix is then freed with its last handle, instead of living on
    /// in the SNES and the KSP while the new pattern is built beside it. Everything dropped is
    /// built again by the next solve, which sets the linear solver up for the new matrix anyway.
    ///
    /// Collective.
    pub fn release_operators(&mut self, next: &Matrix) -> Result<(), PetscError> {
        let m = next.as_raw();
        // SAFETY: valid handles; SNESSetJacobian takes its own references to `m` (and drops its
        // references to the old matrix); a null callback and context keep the registered ones.
        unsafe {
            call!(SNESSetJacobian(self.raw, m, m, None, std::ptr::null_mut()))?;
        }
        let iterative = self.iterative && !self.on_direct;
        if let Some(interface) = &mut self.interface {
            interface.release()?;
        }
        let mut ksp = self.ksp()?;
        if iterative {
            // KSPReset alone leaves GAMG's level solvers holding operators of the old sizes (the
            // next set-up fails: "Cannot change local size of Amat after use"); without a PC the
            // reset has nothing to trip over, and the options database gives the PC back, as
            // after a MUMPS fallback ([`Snes::use_options`]).
            ksp.pc()?.set_type("none")?;
        }
        // SAFETY: valid handle, borrowed from the SNES for this call.
        unsafe { call!(KSPReset(ksp.as_raw()))? };
        if iterative {
            ksp.set_from_options()?;
        }
        Ok(())
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

    /// Stops a solve whose best residual norm has not fallen by 10 % ([`STAGNATION_FACTOR`]) within
    /// `window` Newton iterations (0: never): a cycling or creeping solve fails early, so the step
    /// is cut back without spending the rest of the iteration limit.
    pub fn set_stagnation_window(&mut self, window: usize) {
        self.stagnation_window = window;
    }

    /// Each [`solve`](Self::solve) takes the fraction `f` (in (0, 1]) of its first Newton update,
    /// after the line search (`[solver] first_update`); 1: the whole update, as SNES alone.
    pub fn set_first_update(&mut self, f: f64) {
        self.first_update = f;
    }

    /// The next [`solve`](Self::solve) starts from a guess, not from an equilibrium: it stops
    /// (not converged, `DIVERGED_PREDICTED_START`) when its first Newton iteration raises the
    /// residual norm, so that the caller can start again from the equilibrium. Applies to the
    /// next solve only.
    pub fn watch_start(&mut self) {
        self.watch_start = true;
    }

    /// Attaches `space` (rigid-body modes) as the near-null space of the Jacobian before every
    /// solve: the contact pattern rebuild replaces the matrix, and GAMG reads the space from the
    /// matrix it is set up with.
    pub fn set_near_null_space(&mut self, space: NullSpace<'p>) {
        self.near_null = Some(space);
    }

    /// Preconditions the iterative route with GAMG followed by an exact (MUMPS LU) solve on the
    /// unknowns of the contact interface, [`NonlinearProblem::interface_dofs`] widened by
    /// `layers` layers of matrix neighbours (`z = AMG(r); z += P_I A_II^{-1} P_I^T (r - A z)`),
    /// in place of the PC the options choose, from the next solve on; `symmetric`: then
    /// `z += AMG(r - A z)` once more. Not with [`Snes::use_direct`] in force (its LU stays).
    pub fn set_interface_correction(&mut self, layers: usize, symmetric: bool) {
        self.interface = Some(Box::new(InterfaceCorrection::new(layers, symmetric)));
    }

    /// Marks the linear solver as iterative: a PETSc error raised in a solve (an AMG set-up that
    /// fails) is then reported as a linear failure ([`SolveOutcome::linear_failed`]) instead of an
    /// `Err`, so that the caller can retry with [`Snes::use_direct`].
    pub fn set_iterative(&mut self, iterative: bool) {
        self.iterative = iterative;
    }

    /// The linear solver is iterative and not switched to the direct fallback: a linear failure
    /// can be retried with [`Snes::use_direct`].
    pub fn can_fall_back(&self) -> bool {
        self.iterative && !self.on_direct
    }

    /// [`Snes::use_direct`] is in force.
    pub fn on_direct(&self) -> bool {
        self.on_direct
    }

    /// Switches the linear solver to the direct one (`preonly` + LU by MUMPS, reading the
    /// `-mat_mumps_*` options), until [`Snes::use_options`].
    ///
    /// Collective.
    pub fn use_direct(&mut self) -> Result<(), PetscError> {
        {
            let mut ksp = self.ksp()?;
            ksp.set_type("preonly")?;
            let mut pc = ksp.pc()?;
            pc.set_type("lu")?;
            pc.set_factor_solver_type("mumps")?;
        }
        self.on_direct = true;
        Ok(())
    }

    /// Back from [`Snes::use_direct`] to the linear solver the options database chooses (the
    /// `-ksp_*`/`-pc_*` options are read again).
    ///
    /// Collective.
    pub fn use_options(&mut self) -> Result<(), PetscError> {
        {
            let mut ksp = self.ksp()?;
            ksp.set_from_options()?;
            // a factorisation that failed leaves its reason on the PC, which the next KSP set-up
            // would report as the new preconditioner's failure (DIVERGED_PC_FAILED in 0
            // iterations, FACTOR_OTHER) before setting it up
            let pc = ksp.pc()?;
            // SAFETY: valid handle, borrowed from the KSP for this call.
            unsafe {
                call!(PCSetFailedReason(
                    pc.as_raw(),
                    sys::PCFailedReason::PC_NOERROR
                ))?
            };
        }
        self.on_direct = false;
        Ok(())
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
        if let Some(space) = &self.near_null {
            jac.set_near_null_space(space)?;
        }
        let accepted_before = self.ksp()?.accepted_at_limit()?;
        let on_direct = self.on_direct;
        let mut ksp = self.ksp()?;
        let pc = ksp.pc()?.as_raw();
        drop(ksp);
        let interface: *mut InterfaceCorrection = match &mut self.interface {
            Some(i) if !on_direct => {
                let i: *mut InterfaceCorrection = &mut **i;
                // SAFETY: the box stays at its address while the Snes lives, and the Snes
                // destroys its PC (SNESDestroy on drop) before its fields are dropped.
                unsafe { interface_pc::install(pc, i)? };
                i
            }
            _ => std::ptr::null_mut(),
        };
        let jac_raw = jac.as_raw();
        let mut ctx = Context {
            problem,
            jac: jac as *mut Matrix as *mut c_void,
            domain: None,
            fatal: None,
            jacobian_failed: false,
            norms: Vec::new(),
            stagnation_window: self.stagnation_window,
            stagnated: false,
            watch_start: std::mem::take(&mut self.watch_start),
            rose: None,
            line_search_domain: false,
            interface,
            jacobians: 0,
            first_update: self.first_update,
            interrupted: false,
        };
        let ctx_ptr = &mut ctx as *mut Context as *mut c_void;
        // SAFETY: ctx outlives SNESSolve (it is on this stack frame); the callbacks are re-registered
        // with this pointer before every solve, so a stale pointer is never used.
        unsafe {
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
            let mut ls = std::ptr::null_mut();
            call!(SNESGetLineSearch(self.raw, &mut ls))?;
            call!(SNESLineSearchSetPostCheck(
                ls,
                Some(post_check_trampoline),
                ctx_ptr
            ))?;
            // replaces a `-snes_convergence_test` choice: ours is the default test plus the stops
            call!(SNESSetConvergenceTest(
                self.raw,
                Some(converged_trampoline),
                ctx_ptr,
                None
            ))?;
        }
        let raw = self.raw;
        let x_raw = x.as_raw();
        // a stop of an earlier Krylov solve is not this solve's
        self.ksp()?.stopped()?;
        // SAFETY: valid handles; the context installed above lives on this stack frame.
        let run = || unsafe { call!(SNESSolve(raw, std::ptr::null_mut(), x_raw)) };
        let fall_back = self.can_fall_back();
        let solve_result = if fall_back { quiet_errors(run) } else { run() };
        if let Some(msg) = ctx.fatal.take() {
            return Err(PetscError {
                code: PETSC_ERR_USER,
                function: "SNESSolve callback",
                message: msg,
            });
        }
        if let Err(e) = solve_result {
            if !fall_back {
                return Err(e);
            }
            // an iterative linear solver that PETSc could not run (e.g. GAMG's set-up failed):
            // a linear failure, which the caller retries with the direct solver
            let mut its: PetscInt = 0;
            // SAFETY: valid handle.
            unsafe { call!(SNESGetIterationNumber(self.raw, &mut its))? };
            return Ok(SolveOutcome {
                converged: false,
                reason: format!(
                    "DIVERGED_LINEAR_SOLVE (PETSc error in the linear solver, {}: {})",
                    e.function, e.message
                ),
                iterations: its.max(0) as usize,
                residual_history: Vec::new(),
                domain_error: ctx.domain,
                linear_failed: true,
                linear_iterations: 0,
                linear_accepted: 0,
                interrupted: ctx.interrupted,
            });
        }
        let mut reason = sys::SNESConvergedReason(0);
        let mut its: PetscInt = 0;
        let mut text: *const std::os::raw::c_char = std::ptr::null();
        let mut hist_ptr: *mut f64 = std::ptr::null_mut();
        let mut hist_its: *mut PetscInt = std::ptr::null_mut();
        let mut n_hist: PetscInt = 0;
        let mut lin_its: PetscInt = 0;
        // SAFETY: valid handle; the strings and history pointers refer to PETSc-owned static text and our
        // own buffers.
        unsafe {
            call!(SNESGetConvergedReason(self.raw, &mut reason))?;
            call!(SNESGetIterationNumber(self.raw, &mut its))?;
            call!(SNESGetLinearSolveIterations(self.raw, &mut lin_its))?;
            call!(SNESGetConvergedReasonString(self.raw, &mut text))?;
            call!(SNESGetConvergenceHistory(
                self.raw,
                &mut hist_ptr,
                &mut hist_its,
                &mut n_hist
            ))?;
        }
        // a Krylov solve ended by the stop query of the KSP's convergence test (a request to stop
        // the run, answered alike on every rank)
        if reason.0 < 0 && self.ksp()?.stopped()? {
            ctx.interrupted = true;
        }
        let reason_text = if ctx.interrupted {
            "INTERRUPTED (the run was asked to stop)".to_string()
        } else if let Some((before, after)) = ctx.rose.filter(|_| reason.0 < 0) {
            format!(
                "DIVERGED_PREDICTED_START (the first Newton iteration from the predicted start \
                 raised the residual norm from {before:.3e} to {after:.3e})"
            )
        } else if ctx.stagnated && reason.0 < 0 {
            format!(
                "DIVERGED_STAGNATION (the residual norm fell by less than {:.0} % in {} iterations)",
                100.0 * (1.0 - STAGNATION_FACTOR),
                self.stagnation_window
            )
        } else if text.is_null() {
            format!("{}", reason.0)
        } else {
            // SAFETY: PETSc returns a static NUL-terminated string.
            unsafe { CStr::from_ptr(text) }
                .to_string_lossy()
                .into_owned()
        };
        let linear_failed = reason == sys::SNESConvergedReason::SNES_DIVERGED_LINEAR_SOLVE;
        // which linear solver failed and how (a Krylov limit, a preconditioner, MUMPS out of
        // memory): the cutback and fallback messages and the step's failed attempts say it
        let reason_text = if linear_failed {
            format!("{reason_text} ({})", self.linear_failure_detail()?)
        } else {
            reason_text
        };
        let limit = self.ksp()?.limit_state()?;
        let linear_accepted = limit.map_or(0, |(n, _)| n) - accepted_before;
        if linear_accepted > 0 && std::env::var_os("NURBS_CONTACT_DEBUG_LINEAR").is_some() {
            eprintln!(
                "linear: {linear_accepted} Krylov solve(s) accepted at the iteration limit, the \
                 last with true residual {:.2e} of |b|",
                limit.map_or(f64::NAN, |(_, r)| r)
            );
        }
        let n = (n_hist.max(0) as usize).min(self.history.len());
        Ok(SolveOutcome {
            converged: reason.0 > 0,
            reason: reason_text,
            iterations: its.max(0) as usize,
            residual_history: self.history[..n].to_vec(),
            domain_error: ctx.domain,
            linear_failed,
            linear_iterations: lin_its.max(0) as usize,
            linear_accepted,
            interrupted: ctx.interrupted,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::stagnated;

    #[test]
    fn a_two_cycle_stagnates_after_the_window_and_newton_does_not() {
        // the residual norms of a Newton solve cycling at a penalty kink (ironing, Q1N2.1 mesh 4)
        let cycle = [
            3.52e-4, 1.43e-4, 4.77e-5, 4.36e-5, 9.55e-5, 4.91e-5, 1.06e-4, 5.61e-5, 1.06e-4,
            5.76e-5, 1.06e-4,
        ];
        let first = (1..=cycle.len())
            .find(|&n| stagnated(&cycle[..n], 6))
            .unwrap();
        // the best norm (4.36e-5) is at index 3; six later norms do not beat 0.9 of the best
        // before them (4.77e-5)
        assert_eq!(first, 9);
        assert!(!stagnated(&cycle, 0));
        // quadratic convergence, and a slow but steady decrease by 0.85 per iteration, never
        let newton = [1.0, 0.3, 0.05, 1e-3, 1e-6, 1e-12];
        let creeping: Vec<f64> = (0..40).map(|i| 0.85f64.powi(i)).collect();
        for n in 1..=creeping.len() {
            assert!(!stagnated(&creeping[..n], 6));
            assert!(!stagnated(&newton[..n.min(newton.len())], 2));
        }
        // a solve that climbs over a hump and then falls (ironing Q1N2.1, a 27-iteration step):
        // the default window (10) lets it through (8 would stop it after 10 norms)
        let hump = [
            0.045, 0.034, 0.039, 0.10, 0.45, 0.14, 0.083, 0.059, 0.047, 0.038, 0.027, 0.020, 0.018,
            0.015, 0.038, 0.037, 0.072, 0.034, 0.020, 0.011, 0.0039, 3.1e-4, 1.9e-6,
        ];
        for n in 1..=hump.len() {
            assert!(!stagnated(&hump[..n], 10), "stopped after {n} norms");
        }
    }
}
