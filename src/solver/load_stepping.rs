//! Load stepping with cutback and growth.
//!
//! The load parameter `lambda` runs from 0 to the number of stages; stage `s` is split into its
//! nominal number of equal increments. A step whose Newton solve diverges (or hits an inverted
//! element, a failed projection, ...) is retried from the last converged state with half the
//! increment; the increment never goes below `nominal / 2^max_cutbacks` (the minimum step), and a
//! step that fails at the minimum stops the run with an error naming it. After an easy step the
//! increment grows back by `growth`, never beyond the nominal one.
//!
//! A converged state is accepted only if no element is folded over between its quadrature points
//! (`Assembler::find_tangled`, `crate::fem::untangle`): a tangled one is cut back like a failed
//! attempt, refused by the rescue too, and a step whose every converged state is tangled ends the
//! run with [`SolverError::Tangled`], the last valid step being the last one observed (written).

use super::judge::judge;
use crate::assembly::{prescribed_values, Assembler, ConflictError, DirichletBc};
use crate::petsc::{Matrix, PetscError, Snes, SolveOutcome, Vector};
use std::time::Instant;

/// Newton solves of one attempt that may stop for a new contact sparsity pattern and resume.
const MAX_PATTERN_RETRIES: usize = 4;

/// How the load is stepped.
#[derive(Debug, Clone)]
pub struct StepControl {
    /// Nominal number of increments of each stage. [n_stages]
    pub stage_steps: Vec<usize>,
    /// Halvings allowed below the nominal increment: the smallest increment is
    /// `nominal / 2^max_cutbacks`; a step that fails at that size stops the run.
    pub max_cutbacks: usize,
    /// Factor by which the increment grows back after an easy step.
    pub growth: f64,
    /// A step converging in at most this many Newton iterations is easy.
    pub easy_iterations: usize,
    /// Damped (pseudo-transient) solves allowed to rescue a step that fails at the minimum
    /// increment; 0: none (see [`rescue`]).
    pub pseudo_steps: usize,
    /// Rigid translations that no Dirichlet condition holds, checked on the tangent of every step
    /// that Newton converges: a translation the tangent does not resist stops the run.
    pub translation_probes: Vec<TranslationProbe>,
    /// Newton starts a step from the last converged state extrapolated along the last step of
    /// the same stage (`[solver] predictor = "secant"`); a predicted start that fails is retried
    /// from the converged state at the same increment.
    pub secant_predictor: bool,
    /// The options in force that change when SNES calls a solve converged (`-snes_type ksponly`,
    /// `-snes_atol 1e10`, ...), each with where it was set: named when a step fails the run's own
    /// check of its residual ([`super::judge`]) or fails altogether.
    pub newton_overrides: Vec<String>,
}

/// The secant predictor is given up for the rest of a stage once at least
/// [`PREDICTION_TRIALS`] predicted starts were tried and more than [`PREDICTION_FAILURES`] of
/// them failed: a failed start costs its iterations and a second solve (BENCHMARKS.md, "A secant
/// predictor": two-half-pass pointwise ironing at mesh 4 fails one in three).
const PREDICTION_TRIALS: usize = 8;
const PREDICTION_FAILURES: f64 = 0.2;

/// Whether `failed` of `tried` predicted starts of a stage give the predictor up.
fn predictions_fail(tried: usize, failed: usize) -> bool {
    tried >= PREDICTION_TRIALS && failed as f64 > PREDICTION_FAILURES * tried as f64
}

/// A rigid translation that only contact may hold (a body pressed onto a frictionless plane is
/// free along it): `rows` are this rank's owned unknowns that move with it.
///
/// MUMPS's null-pivot count catches a singular tangent only when roundoff leaves the pivot below
/// its threshold, which depends on the factorisation and on the BLAS kernels. A free translation
/// `t` is in the kernel of the tangent `K` exactly (the internal forces do not change under a
/// translation, nor does a contact that cannot hold it), so `|K t| / (|K|_inf |t|)` is at
/// roundoff level (1e-16) when nothing holds it, and at least the share of the contact rows when
/// contact does (1e-4 and more in the shipped cases): [`FREE_TRANSLATION_TOL`] between the two.
#[derive(Debug, Clone, PartialEq)]
pub struct TranslationProbe {
    /// What moves, e.g. "body `disk`".
    pub what: String,
    /// The axis (0: x, 1: y, 2: z).
    pub axis: usize,
    /// Owned global rows of the unknowns along `axis` of the nodes that move.
    pub rows: Vec<crate::petsc::PetscInt>,
}

/// The largest `|K t| / (|K|_inf |t|)` of a translation `t` that the tangent is taken not to
/// resist (see [`TranslationProbe`]).
pub const FREE_TRANSLATION_TOL: f64 = 1e-10;

/// `|K t| / (|K|_inf |t|)` for the probe's translation `t` on the assembled tangent `jac`; `like`
/// gives the vector layout.
///
/// Collective.
pub fn translation_resistance<'p>(
    jac: &Matrix<'p>,
    like: &Vector<'p>,
    probe: &TranslationProbe,
) -> Result<f64, PetscError> {
    let mut t = like.duplicate()?;
    t.set(0.0)?;
    let (lo, _) = t.ownership_range()?;
    {
        let mut w = t.write()?;
        for &g in &probe.rows {
            w[(g - lo) as usize] = 1.0;
        }
    }
    let t_norm = t.norm2()?;
    if t_norm == 0.0 {
        return Ok(f64::INFINITY);
    }
    let mut kt = like.duplicate()?;
    jac.mult(&t, &mut kt)?;
    let scale = jac.norm_inf()? * t_norm;
    Ok(if scale > 0.0 {
        kt.norm2()? / scale
    } else {
        0.0
    })
}

/// One converged load step.
#[derive(Debug, Clone)]
pub struct StepRecord {
    /// Converged step count, from 1.
    pub step: usize,
    /// Stage index, from 0.
    pub stage: usize,
    /// Load parameter reached (stage `s` ends at `s + 1`).
    pub load: f64,
    /// Newton iterations of the converged attempt.
    pub iterations: usize,
    /// Final residual norm.
    pub residual: f64,
    /// Failed attempts before this step converged.
    pub cutbacks: usize,
    /// Residual norm before each Newton iteration of the converged attempt.
    pub residual_history: Vec<f64>,
    /// The attempts cut back before this step converged: (load tried, why it failed).
    pub failed_attempts: Vec<(f64, String)>,
    /// Wall time of this step, all attempts (s).
    pub wall_time: f64,
    /// Damped pseudo-steps that carried this step to its equilibrium (0: a plain Newton solve).
    pub pseudo_steps: usize,
    /// Newton iterations of the attempts that failed and were cut back (not in `iterations`).
    pub failed_iterations: usize,
    /// Augmented Lagrangian rounds of the converged attempt (0 without augmentation).
    pub augmentation_rounds: usize,
    /// Where the load stepping stands after this step (what a checkpoint keeps).
    pub position: LoadPosition,
    /// Times this step was retried with the direct solver after an iterative linear solve failed
    /// (`[solver] linear = "iterative"`; 0 otherwise).
    pub linear_fallbacks: usize,
    /// Linear (Krylov) iterations of all the step's Newton solves (converged, resumed and failed
    /// attempts; not the rescue's): one per Newton iteration for the direct solver.
    pub linear_iterations: usize,
    /// Krylov solves of the step's Newton solves stopped by their iteration limit and taken as
    /// inexact Newton directions (`[solver] krylov_accept`).
    pub linear_accepted: usize,
}

/// Where the load stepping stands after a converged step: enough to continue it exactly (restart).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LoadPosition {
    /// Converged steps so far.
    pub step: usize,
    /// Stage of the next step (the number of stages when all are done).
    pub stage: usize,
    /// Load parameter reached.
    pub lambda: f64,
    /// Increment of the next attempt before clipping to the stage end.
    pub dl: f64,
    /// The secant predictor's state (a restart continues it exactly).
    pub predictor: PredictorState,
}

/// What the secant predictor carries from one step to the next (`[solver] predictor =
/// "secant"`), kept in checkpoints with the converged state before the last one.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PredictorState {
    /// Stage and increment of the last converged step (none before the first step).
    pub last: Option<(usize, f64)>,
    /// The stage whose predicted starts `tried`, `failed` and `given_up` count (none yet).
    pub stage: Option<usize>,
    /// Predicted starts tried in `stage`.
    pub tried: usize,
    /// Predicted starts of `stage` that failed and were retried from the converged state.
    pub failed: usize,
    /// The predictor was given up for the rest of `stage` ([`predictions_fail`]).
    pub given_up: bool,
}

impl PredictorState {
    /// The values a checkpoint keeps ([`PredictorState::from_values`] reads them back).
    pub fn values(&self) -> [f64; 6] {
        let (ls, ldl) = self.last.map_or((-1.0, 0.0), |(s, dl)| (s as f64, dl));
        [
            ls,
            ldl,
            self.stage.map_or(-1.0, |s| s as f64),
            self.tried as f64,
            self.failed as f64,
            f64::from(u8::from(self.given_up)),
        ]
    }

    /// The state of [`values`](Self::values).
    pub fn from_values(v: &[f64; 6]) -> Self {
        let index = |x: f64| (x >= 0.0).then_some(x as usize);
        PredictorState {
            last: index(v[0]).map(|s| (s, v[1])),
            stage: index(v[2]),
            tried: v[3] as usize,
            failed: v[4] as usize,
            given_up: v[5] != 0.0,
        }
    }
}

impl LoadPosition {
    /// The load has passed the start of `stage` (the stage of the next step is under way).
    pub fn stage_started(&self) -> bool {
        self.lambda > self.stage as f64 + 1e-12 * (self.stage as f64).max(1.0)
    }
}

/// What the load stepping does after the observer has seen a converged step.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AfterStep {
    /// Go on with the next step.
    Continue,
    /// Stop here (an interrupt): the run ends with [`SolverError::Interrupted`].
    Stop,
}

/// Why the load stepping stopped.
#[derive(Debug, thiserror::Error)]
pub enum SolverError {
    /// A step could not be converged even with the smallest allowed increment.
    #[error("load step {step} (stage {stage}, load {load:.6}) failed after {cutbacks} cutbacks: {reason}")]
    StepFailed {
        /// The step that failed (1-based).
        step: usize,
        /// Its stage.
        stage: usize,
        /// The load parameter it was trying to reach last.
        load: f64,
        /// Cutbacks made.
        cutbacks: usize,
        /// SNES's reason or the domain error of the last attempt.
        reason: String,
    },
    /// The tangent is singular: some motion is held by nothing.
    #[error("load step {step} (load {load:.6}): the tangent stiffness is singular (MUMPS found {pivots} null pivots): a body or part can move freely")]
    Singular {
        /// The step (1-based).
        step: usize,
        /// The load it was trying to reach.
        load: f64,
        /// Null pivots.
        pivots: usize,
    },
    /// The tangent does not resist a rigid translation that no Dirichlet condition holds: the
    /// contact pairs do not hold it either.
    #[error("load step {step} (load {load:.6}): the tangent stiffness is singular: nothing resists the translation along {axis} of {what} (|K t| = {ratio:.1e} |K| |t|); the contact pairs cannot hold it, so a Dirichlet condition (or friction) must", axis = ["x", "y", "z"][*axis])]
    FreeTranslation {
        /// The step (1-based).
        step: usize,
        /// The load it reached.
        load: f64,
        /// What moves freely.
        what: String,
        /// The axis.
        axis: usize,
        /// `|K t| / (|K|_inf |t|)`.
        ratio: f64,
    },
    /// PETSc failed.
    #[error(transparent)]
    Petsc(#[from] PetscError),
    /// Boundary conditions contradict each other.
    #[error(transparent)]
    Conflict(#[from] ConflictError),
    /// The observer asked to stop after a converged step (an interrupt).
    #[error("interrupted after {steps} converged load steps (load {load:.6})")]
    Interrupted {
        /// Converged steps, all recorded.
        steps: usize,
        /// Load parameter reached.
        load: f64,
    },
    /// The observer (output writer) failed.
    #[error("while writing results: {0}")]
    Observer(String),
    /// Every state this step converged to is folded over somewhere (`crate::fem::untangle`),
    /// down to the smallest increment and through the rescue: the load drives the body through
    /// itself (or the mesh is too coarse for the deformation). Nothing of it was written.
    #[error("load step {step} (load {load:.6}): the converged state is tangled, an element is folded over: {fold}; no smaller increment reached an untangled equilibrium{}; the results end at the last valid step, {last_step} (load {last_load:.6})", .last_attempt.as_ref().map(|a| format!(" (last attempt: {a})")).unwrap_or_default())]
    Tangled {
        /// The step (1-based).
        step: usize,
        /// The load of the tangled state.
        load: f64,
        /// The first folded element: body, cell, family and where.
        fold: String,
        /// The last accepted (and written) step.
        last_step: usize,
        /// Its load.
        last_load: f64,
        /// Why the last attempt failed, when not for this fold.
        last_attempt: Option<String>,
    },
}

/// What the load stepping hands its observer after every converged step: the step, the converged
/// state, the one before it (with the secant predictor on) and the assembler; it may stop the run.
pub type StepObserverFn<'a, 'p> = dyn FnMut(
        &StepRecord,
        &Vector<'p>,
        Option<&Vector<'p>>,
        &mut Assembler<'p>,
    ) -> Result<AfterStep, String>
    + 'a;

/// Runs all stages. `x` holds the initial displacement and ends with the last converged one.
/// `observer` is called after every converged step (output, history) and may stop the run there.
///
/// Collective.
#[allow(clippy::too_many_arguments)]
pub fn run_load_steps<'p>(
    asm: &mut Assembler<'p>,
    snes: &mut Snes<'p>,
    x: &mut Vector<'p>,
    jac: &mut Matrix<'p>,
    bcs: &[DirichletBc],
    coords: &[f64],
    control: &StepControl,
    observer: &mut dyn FnMut(
        &StepRecord,
        &Vector<'p>,
        &mut Assembler<'p>,
    ) -> Result<AfterStep, String>,
) -> Result<Vec<StepRecord>, SolverError> {
    run_load_steps_from(
        asm,
        snes,
        x,
        jac,
        bcs,
        coords,
        control,
        None,
        None,
        &mut |rec, x, _before, asm| observer(rec, x, asm),
    )
}

/// [`run_load_steps`] continued from `start` (a restart: `x` and the element and contact history
/// already hold that step's converged state), or from load 0 without it. `before` is the converged
/// state before `start`'s (the secant predictor's `u_{n-1}`); without it the first step is not
/// predicted. The observer gets each converged state and the one before it (with the predictor
/// on), which a checkpoint keeps.
///
/// Collective.
#[allow(clippy::too_many_arguments)]
pub fn run_load_steps_from<'p>(
    asm: &mut Assembler<'p>,
    snes: &mut Snes<'p>,
    x: &mut Vector<'p>,
    jac: &mut Matrix<'p>,
    bcs: &[DirichletBc],
    coords: &[f64],
    control: &StepControl,
    start: Option<LoadPosition>,
    before: Option<&Vector<'p>>,
    observer: &mut StepObserverFn<'_, 'p>,
) -> Result<Vec<StepRecord>, SolverError> {
    let mut x_conv = x.duplicate()?;
    x.copy_to(&mut x_conv)?;
    // secant predictor: the converged state before the last one, and the last step's stage and
    // increment (none yet: the first step starts from the converged state, and so does the first
    // after a restart whose checkpoint has no state before its own)
    let mut x_before = if control.secant_predictor {
        Some(x.duplicate()?)
    } else {
        None
    };
    let mut records = Vec::new();
    let mut sizer = StepSizer::new(control);
    let mut step = 0usize;
    // the last step's stage and increment, and the predicted starts of the current stage
    let mut predictions = PredictorState::default();
    if let Some(p) = start {
        sizer.resume(&p);
        step = p.step;
        predictions = p.predictor;
        match (&mut x_before, before) {
            (Some(xb), Some(b)) => b.copy_to(xb)?,
            _ => predictions.last = None,
        }
    }
    while let Some(stage) = sizer.stage() {
        let t_step = Instant::now();
        let mut cutbacks = 0;
        let mut failed_attempts = Vec::new();
        let mut failed_iterations = 0;
        let mut resume = false;
        let mut pattern_retries = 0;
        // iterations of solves that stopped for a new contact pattern and were resumed
        let mut resumed_iterations = 0;
        let mut pseudo = 0;
        let mut linear_fallbacks = 0;
        // the MUMPS fallback failed in this step: Krylov failures are cut back instead
        let mut direct_failed = false;
        let mut linear_iterations = 0;
        let mut linear_accepted = 0;
        // the last attempt of this step that converged to a folded state: (load, where)
        let mut tangled: Option<(f64, String)> = None;
        let mut predicted_failed = false;
        let (out, target) = loop {
            let target = sizer.target();
            let lam = sizer.position(step).lambda;
            if predictions.stage != Some(stage) {
                predictions = PredictorState {
                    last: predictions.last,
                    stage: Some(stage),
                    ..PredictorState::default()
                };
            }
            if x_before.is_some()
                && !predictions.given_up
                && predictions_fail(predictions.tried, predictions.failed)
            {
                predictions.given_up = true;
                eprintln!(
                    "note: step {}: {} of {} predicted starts of stage {stage} failed; Newton \
                     starts from the converged state for the rest of the stage",
                    step + 1,
                    predictions.failed,
                    predictions.tried
                );
            }
            let predictor = match (predictions.last, &x_before) {
                (Some((s, dl)), Some(xb))
                    if s == stage && !predicted_failed && dl > 0.0 && !predictions.given_up =>
                {
                    Some(((target - lam) / dl, xb))
                }
                _ => None,
            };
            if predictor.is_some() && !resume {
                predictions.tried += 1;
            }
            let values = prescribed_values(bcs, &asm.dofs, coords, target)?;
            asm.set_prescribed(&values);
            asm.set_load(target);
            // Newton starts from the converged state: its first iteration lifts the new boundary
            // values into the interior through the tangent, which inverts far fewer elements than
            // starting from a guess that moves only the boundary. After a stop for a new contact
            // sparsity pattern it resumes from the iterate it reached.
            if !resume {
                x_conv.copy_to(x)?;
                // the secant predictor: u_n + r (u_n - u_{n-1}) (prescribed values included,
                // linear in the load within a stage)
                if let Some((r, xb)) = predictor {
                    x.axpy(r, &x_conv)?;
                    x.axpy(-r, xb)?;
                }
            }
            asm.refresh_pattern(x, jac, snes)?;
            if predictor.is_some() && !resume {
                // a predicted start whose first Newton iteration raises the residual norm is
                // outside the region where Newton converges fast (two-half-pass pointwise
                // ironing: 14 iterations where the converged start takes 5-6): it is given up
                // at once, as a failed predicted start
                snes.watch_start();
            }
            let mut out = super::settle::solve_settled(asm, snes, x, jac)?;
            // the run's own verdict: a solve SNES calls converged whose residual is not (an
            // option changed SNES's test) is a failed attempt
            if out.converged {
                if let Some(why) = judge(asm, x, &mut out, &control.newton_overrides)? {
                    out.converged = false;
                    out.reason = why.clone();
                    out.domain_error = Some(why);
                }
            }
            linear_iterations += out.linear_iterations;
            linear_accepted += out.linear_accepted;
            if !out.converged && out.linear_failed && snes.can_fall_back() && !direct_failed {
                // A Krylov solve that failed (or an AMG that could not be set up) says nothing
                // about the step: the attempt is retried as it was, with MUMPS, which stays for
                // the rest of this step (switched back after it), and the fallback is counted.
                if std::env::var_os("NURBS_CONTACT_DEBUG_LINEAR").is_some() {
                    eprintln!(
                        "linear fallback: step {} load {target}: {}",
                        step + 1,
                        out.reason
                    );
                }
                snes.use_direct()?;
                linear_fallbacks += 1;
                failed_iterations += out.iterations + resumed_iterations;
                resumed_iterations = 0;
                pattern_retries = 0;
                asm.rollback();
                resume = false;
                continue;
            }
            if !out.converged && out.linear_failed && snes.on_direct() {
                // The MUMPS fallback failed as a linear solver too (above the size MUMPS fits in
                // memory: the 1e6-unknown twist ran out of it in every cutback while Krylov had
                // converged the longer increments): the attempt is cut back on the Krylov route,
                // and a Krylov failure later in this step is cut back, not retried with MUMPS.
                if std::env::var_os("NURBS_CONTACT_DEBUG_LINEAR").is_some() {
                    eprintln!(
                        "linear fallback failed: step {} load {target}: {}; back to the Krylov \
                         route for this step",
                        step + 1,
                        out.reason
                    );
                }
                snes.use_options()?;
                direct_failed = true;
            }
            // A singular tangent (a body nothing holds) would give an arbitrary answer. A
            // translation that only contact could hold is checked on the tangent itself (exact,
            // whatever the factorisation's roundoff); any other rigid motion through MUMPS's
            // null-pivot count (-mat_mumps_icntl_24 1) in the last factorisation. (Not in every
            // factorisation of the attempt: the first tangent of a step is singular wherever
            // contact holds a body only once it closes during the step, e.g. a disk pressed into
            // a cradle, and Newton goes on correctly from MUMPS's treatment of the null pivot.)
            if out.converged {
                for probe in &control.translation_probes {
                    let ratio = translation_resistance(jac, x, probe)?;
                    if std::env::var_os("NURBS_CONTACT_DEBUG_PROBES").is_some() {
                        eprintln!(
                            "probe: step {} translation {} of {}: |K t| / (|K| |t|) = {ratio:.3e}",
                            step + 1,
                            ["x", "y", "z"][probe.axis],
                            probe.what
                        );
                    }
                    if ratio <= FREE_TRANSLATION_TOL {
                        return Err(SolverError::FreeTranslation {
                            step: step + 1,
                            load: target,
                            what: probe.what.clone(),
                            axis: probe.axis,
                            ratio,
                        });
                    }
                }
            }
            if let Some(pivots) = snes.null_pivots()?.filter(|&p| p > 0) {
                return Err(SolverError::Singular {
                    step: step + 1,
                    load: target,
                    pivots: pivots as usize,
                });
            }
            if out.converged {
                // Step acceptance: the kernel saw det F > 0 at the quadrature points only; a
                // state folded over between them is no equilibrium of the body and is refused
                // like a failed attempt (cut back).
                match asm.find_tangled(x)? {
                    None => break (out, target),
                    Some(fold) => tangled = Some((target, fold)),
                }
            }
            let just_tangled = out.converged;
            resume =
                !just_tangled && asm.pattern_outdated() && pattern_retries < MAX_PATTERN_RETRIES;
            if resume {
                pattern_retries += 1;
                resumed_iterations += out.iterations;
                continue;
            }
            failed_iterations += out.iterations + resumed_iterations;
            resumed_iterations = 0;
            asm.rollback();
            if predictor.is_some() {
                // the predicted start failed: the same increment again from the converged state
                // (its iterations count as failed ones, the attempt is no cutback)
                if std::env::var_os("NURBS_CONTACT_DEBUG_PREDICTOR").is_some() {
                    eprintln!(
                        "predicted start failed: step {} load {target}: {} iterations, {}",
                        step + 1,
                        out.iterations,
                        out.domain_error.as_ref().unwrap_or(&out.reason)
                    );
                }
                predicted_failed = true;
                predictions.failed += 1;
                tangled = None;
                pattern_retries = 0;
                continue;
            }
            let why = match (&tangled, just_tangled) {
                (Some((_, fold)), true) => format!("converged to a tangled state: {fold}"),
                _ if asm.pattern_outdated() => format!(
                    "contact points still needed couplings outside the sparsity pattern after \
                     {MAX_PATTERN_RETRIES} rebuilds in this attempt (last solve: {}{})",
                    out.reason,
                    out.domain_error
                        .as_ref()
                        .map_or(String::new(), |e| format!("; its line search met {e}"))
                ),
                _ => out
                    .domain_error
                    .clone()
                    .unwrap_or_else(|| out.reason.clone()),
            };
            failed_attempts.push((target, why.clone()));
            // what the final error adds to a fold: the last attempt, if it failed otherwise
            let mut last_attempt = (!just_tangled).then_some(why);
            if let Err(min) = sizer.cut_back() {
                if control.pseudo_steps > 0 {
                    match rescue(asm, snes, x, &x_conv, jac, control)? {
                        Rescue::Found(out, k) => {
                            pseudo = k;
                            break (out, target);
                        }
                        Rescue::Tangled(fold) => {
                            tangled = Some((target, fold));
                            last_attempt = None;
                        }
                        Rescue::Failed => {}
                    }
                }
                if let Some((at, fold)) = tangled {
                    return Err(SolverError::Tangled {
                        step: step + 1,
                        load: at,
                        fold,
                        last_step: step,
                        last_load: sizer.position(step).lambda,
                        last_attempt,
                    });
                }
                return Err(SolverError::StepFailed {
                    step: step + 1,
                    stage,
                    load: target,
                    cutbacks,
                    reason: format!(
                        "the minimum increment {min:.3e} was reached{}{}; last attempt: {}",
                        if cutbacks == 0 && control.max_cutbacks > 0 {
                            " (earlier steps had cut the increment down to it)"
                        } else {
                            ""
                        },
                        if control.pseudo_steps > 0 {
                            " and the pseudo-transient rescue found no equilibrium"
                        } else {
                            ""
                        },
                        with_overrides(
                            out.domain_error.unwrap_or(out.reason),
                            &control.newton_overrides
                        )
                    ),
                });
            }
            cutbacks += 1;
            // each attempt has its own budget of pattern rebuilds (a shorter increment may need
            // them as much as the longer one that used them up)
            pattern_retries = 0;
        };
        if snes.on_direct() {
            snes.use_options()?;
        }
        let iterations = out.iterations + resumed_iterations;
        predictions.last = Some((stage, target - sizer.position(step).lambda));
        sizer.accept(target, iterations, cutbacks);
        step += 1;
        let augmentation_rounds = asm.augmentation_rounds();
        asm.commit();
        if let Some(xb) = &mut x_before {
            x_conv.copy_to(xb)?;
        }
        x.copy_to(&mut x_conv)?;
        let rec = StepRecord {
            step,
            stage,
            load: target,
            iterations,
            residual: out.residual_history.last().copied().unwrap_or(0.0),
            cutbacks,
            residual_history: out.residual_history,
            failed_attempts,
            wall_time: t_step.elapsed().as_secs_f64(),
            pseudo_steps: pseudo,
            failed_iterations,
            augmentation_rounds,
            position: LoadPosition {
                predictor: predictions,
                ..sizer.position(step)
            },
            linear_fallbacks,
            linear_iterations,
            linear_accepted,
        };
        let after = observer(&rec, x, x_before.as_ref(), asm).map_err(SolverError::Observer)?;
        let load = rec.load;
        records.push(rec);
        if after == AfterStep::Stop {
            return Err(SolverError::Interrupted { steps: step, load });
        }
    }
    Ok(records)
}

/// `reason` with the options that changed SNES's convergence test appended, unless it names them
/// already.
fn with_overrides(reason: String, overrides: &[String]) -> String {
    match overrides.first() {
        Some(first) if !reason.contains(first.as_str()) => format!(
            "{reason} (the Newton solver ran with {})",
            overrides.join(", ")
        ),
        _ => reason,
    }
}

/// One Newton solve from `x` that may stop for a new contact sparsity pattern and resume.
fn solve_resuming<'p>(
    asm: &mut Assembler<'p>,
    snes: &mut Snes<'p>,
    x: &mut Vector<'p>,
    jac: &mut Matrix<'p>,
) -> Result<SolveOutcome, SolverError> {
    let mut iterations = 0;
    for _ in 0..=MAX_PATTERN_RETRIES {
        asm.refresh_pattern(x, jac, snes)?;
        let mut out = super::settle::solve_settled(asm, snes, x, jac)?;
        iterations += out.iterations;
        if out.converged || !asm.pattern_outdated() {
            out.iterations = iterations;
            return Ok(out);
        }
    }
    let mut out = super::settle::solve_settled(asm, snes, x, jac)?;
    out.iterations += iterations;
    Ok(out)
}

/// Pseudo-transient rescue of a step that failed at the smallest increment, at the load already
/// set (its prescribed values and load parameter): a snap-through has no equilibrium near the last
/// one, so Newton from it diverges however small the step. Damped solves of
/// `F(u) + c D (u - u_prev) = 0` (`D` the stiffness diagonal at the converged state, `c` adapted:
/// divided by 2 after a damped solve converges, multiplied by 8 after one fails) let the state
/// flow towards the next equilibrium, one `u_prev` after another; when the flow slows down past
/// the snap ([`UndampedTrigger`]), an undamped Newton solve is tried from there, and the first
/// that converges to an untangled state ends the rescue with a true equilibrium. Returns that
/// solve and the number of damped solves; an undamped solve that converges to a folded state
/// ends the rescue at once ([`Rescue::Tangled`]: the flow went through the body itself); after
/// `max_steps` damped solves without an equilibrium, [`Rescue::Failed`]. Unless found, `x` is
/// back at the converged state; the run stops.
///
/// Collective.
fn rescue<'p>(
    asm: &mut Assembler<'p>,
    snes: &mut Snes<'p>,
    x: &mut Vector<'p>,
    x_conv: &Vector<'p>,
    jac: &mut Matrix<'p>,
    control: &StepControl,
) -> Result<Rescue, SolverError> {
    let max_steps = control.pseudo_steps;
    x_conv.copy_to(x)?;
    if asm.compute_damping_diagonal(x).is_err() {
        return Ok(Rescue::Failed);
    }
    let mut u_prev = x_conv.duplicate()?;
    x_conv.copy_to(&mut u_prev)?;
    let mut c = 1.0;
    let mut total_iterations = 0;
    let mut outcome = Rescue::Failed;
    let mut trigger = UndampedTrigger::default();
    let debug = std::env::var_os("NURBS_CONTACT_DEBUG_RESCUE").is_some();
    for k in 1..=max_steps {
        asm.set_damping(c, &u_prev)?;
        u_prev.copy_to(x)?;
        let damped = solve_resuming(asm, snes, x, jac)?;
        total_iterations += damped.iterations;
        if !damped.converged {
            asm.rollback();
            c *= 8.0;
            if c > 1e8 {
                break;
            }
            continue;
        }
        // the damped state is the next pseudo-time point: warm starts follow it, the friction
        // anchors stay the last converged step's (the rescue solves this step's equations, it
        // does not change them)
        let force = asm.damping_force_norm(x)?;
        asm.commit_intermediate();
        x.copy_to(&mut u_prev)?;
        if damped.iterations <= 4 {
            c = (c * 0.5).max(1e-10);
        }
        if debug {
            eprintln!(
                "rescue {k}: c {c:.2e}, damped solve {} iterations, damping force {force:.3e}",
                damped.iterations
            );
        }
        if !trigger.observe(force, k == max_steps) {
            continue;
        }
        asm.set_damping(0.0, &u_prev)?;
        let mut plain = solve_resuming(asm, snes, x, jac)?;
        total_iterations += plain.iterations;
        if plain.converged {
            if let Some(why) = judge(asm, x, &mut plain, &control.newton_overrides)? {
                plain.converged = false;
                plain.reason = why;
            }
        }
        if debug {
            eprintln!(
                "  undamped solve: {} after {} iterations",
                plain.reason, plain.iterations
            );
        }
        if plain.converged {
            // acceptance: an equilibrium folded over somewhere is refused
            if let Some(fold) = asm.find_tangled(x)? {
                if debug {
                    eprintln!("  refused: {fold}");
                }
                outcome = Rescue::Tangled(fold);
                break;
            }
            plain.iterations = total_iterations;
            outcome = Rescue::Found(plain, k);
            break;
        }
        asm.rollback();
        u_prev.copy_to(x)?;
    }
    asm.set_damping(0.0, &u_prev)?;
    if !matches!(outcome, Rescue::Found(..)) {
        asm.rollback();
        x_conv.copy_to(x)?;
    }
    Ok(outcome)
}

/// How a [`rescue`] ended.
enum Rescue {
    /// An untangled equilibrium: the undamped solve that reached it and the damped solves taken.
    Found(SolveOutcome, usize),
    /// An undamped solve converged to a folded state (where, as a message); refused.
    Tangled(String),
    /// No equilibrium within the allowed damped solves.
    Failed,
}

/// When the rescue tries an undamped Newton solve, from the damping force `c D (u - u_prev)` after
/// each damped solve (the flow's speed). Near the vanished equilibrium the flow first slows down
/// (it creeps past the ghost of the fold) and no equilibrium is there: undamped solves fail. Then
/// it speeds up (the snap) and slows down again as it nears the next equilibrium. So an undamped
/// solve is tried only while the flow slows down after having sped up at least once, or once it
/// has nearly stopped (the force below [`Self::NEAR_REST`] of its first value: an equilibrium
/// close by, no snap), and at the last pseudo-step. (Trying at every slowing pseudo-step, as
/// before, spent up to a third of a hard run's Newton iterations in undamped solves that failed,
/// for the same equilibria: BENCHMARKS.md, "The pseudo-transient rescue".)
#[derive(Debug, Clone, Default)]
struct UndampedTrigger {
    first: Option<f64>,
    last: Option<f64>,
    sped_up: bool,
}

impl UndampedTrigger {
    const NEAR_REST: f64 = 1e-3;

    /// Takes the damping force after a converged damped solve; true: try an undamped solve now.
    fn observe(&mut self, force: f64, last_step: bool) -> bool {
        let first = *self.first.get_or_insert(force);
        let slowing = self.last.is_some_and(|l| force < l);
        if self.last.is_some_and(|l| force > l) {
            self.sped_up = true;
        }
        self.last = Some(force);
        (slowing && self.sped_up) || force < Self::NEAR_REST * first || last_step
    }
}

/// The step-size logic of the load stepping, apart from any solver so it can be tested alone.
///
/// Increments are in units of the load parameter; each stage starts from its own nominal increment
/// `1 / steps`. A cutback halves the increment actually tried (which may have been clipped to the
/// stage end), never below `nominal / 2^max_cutbacks`. After an easy step without cutbacks the
/// increment grows by `growth`, up to the nominal one. A remainder of a stage smaller than a quarter
/// of the current increment is taken together with the step before it, so no sliver steps remain.
#[derive(Debug, Clone)]
pub struct StepSizer {
    steps: Vec<usize>,
    max_cutbacks: usize,
    growth: f64,
    easy_iterations: usize,
    stage: usize,
    lambda: f64,
    dl: f64,
}

impl StepSizer {
    /// A sizer at load 0, stage 0.
    pub fn new(control: &StepControl) -> Self {
        let mut s = StepSizer {
            steps: control.stage_steps.clone(),
            max_cutbacks: control.max_cutbacks.min(60),
            growth: control.growth.max(1.0),
            easy_iterations: control.easy_iterations,
            stage: 0,
            lambda: 0.0,
            dl: 0.0,
        };
        s.dl = s.nominal();
        s
    }

    fn nominal(&self) -> f64 {
        1.0 / self.steps.get(self.stage).copied().unwrap_or(1).max(1) as f64
    }

    fn minimum(&self) -> f64 {
        self.nominal() / 2f64.powi(self.max_cutbacks as i32)
    }

    fn stage_end(&self) -> f64 {
        (self.stage + 1) as f64
    }

    /// The position after `step` converged steps.
    pub fn position(&self, step: usize) -> LoadPosition {
        LoadPosition {
            step,
            stage: self.stage,
            lambda: self.lambda,
            dl: self.dl,
            predictor: PredictorState::default(),
        }
    }

    /// Continues from a position of [`position`](Self::position) (a restart). A stage the
    /// position has not started begins with its own nominal increment, from the steps it has now
    /// (a restart may change them); within a stage the increment is the position's, at most the
    /// stage's nominal one. With the same steps this is the increment the run would have taken.
    pub fn resume(&mut self, p: &LoadPosition) {
        self.stage = p.stage;
        self.lambda = p.lambda;
        self.dl = if p.stage_started() {
            p.dl.min(self.nominal())
        } else {
            self.nominal()
        };
    }

    /// The stage of the next step, or `None` when all stages are done.
    pub fn stage(&self) -> Option<usize> {
        (self.stage < self.steps.len()).then_some(self.stage)
    }

    /// The load the next attempt should reach.
    pub fn target(&self) -> f64 {
        let end = self.stage_end();
        let t = self.lambda + self.dl;
        if end - t < 0.25 * self.dl {
            end
        } else {
            t
        }
    }

    /// The attempt at [`target`](Self::target) failed: halve the increment actually tried. Returns
    /// the minimum increment as the error when the halved increment would be below it.
    pub fn cut_back(&mut self) -> Result<(), f64> {
        let tried = self.target() - self.lambda;
        let min = self.minimum();
        if tried / 2.0 < min * (1.0 - 1e-9) {
            return Err(min);
        }
        self.dl = tried / 2.0;
        Ok(())
    }

    /// The attempt converged at `target` in `iterations` Newton iterations after `cutbacks` failures.
    pub fn accept(&mut self, target: f64, iterations: usize, cutbacks: usize) {
        self.lambda = target;
        if iterations <= self.easy_iterations && cutbacks == 0 {
            self.dl = (self.dl * self.growth).min(self.nominal());
        }
        if self.stage_end() - self.lambda <= 1e-12 * self.stage_end() {
            self.lambda = self.stage_end();
            self.stage += 1;
            // Each stage starts from its own nominal increment.
            self.dl = self.nominal();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_resumed_stage_not_yet_started_takes_its_new_step_count() {
        let control = |steps: Vec<usize>| control(steps, 8);
        // a run of 3 + 1 steps stopped after the first stage
        let mut old = StepSizer::new(&control(vec![3, 1]));
        for _ in 0..3 {
            let t = old.target();
            old.accept(t, 1, 0);
        }
        let p = old.position(3);
        assert_eq!((p.stage, p.lambda, p.dl), (1, 1.0, 1.0));
        // resumed with the second stage in 4 steps: a quarter of it, not the whole
        let mut new = StepSizer::new(&control(vec![3, 4]));
        new.resume(&p);
        assert!((new.target() - 1.25).abs() < 1e-12, "{}", new.target());
        // with the same steps, the increment the run would have taken
        let mut same = StepSizer::new(&control(vec![3, 1]));
        same.resume(&p);
        assert_eq!(same.target(), old.target());
        // within a started stage the position's (cut-back) increment stays
        let mut mid = StepSizer::new(&control(vec![3, 4]));
        mid.resume(&LoadPosition {
            step: 4,
            stage: 1,
            lambda: 1.1,
            dl: 0.05,
            predictor: PredictorState::default(),
        });
        assert!((mid.target() - 1.15).abs() < 1e-12, "{}", mid.target());
    }

    /// The pseudo-steps at which the trigger tries an undamped solve, for a sequence of damping
    /// forces (the last one is the rescue's last pseudo-step).
    fn tries(forces: &[f64]) -> Vec<usize> {
        let mut t = UndampedTrigger::default();
        (0..forces.len())
            .filter(|&k| t.observe(forces[k], k + 1 == forces.len()))
            .collect()
    }

    #[test]
    fn undamped_solves_are_tried_once_the_flow_slows_down_after_a_snap() {
        // damping forces of a measured rescue (frictional ironing, Q1N2): the flow creeps past the
        // vanished equilibrium, speeds up, and slows down towards the next one
        let snap = [
            4.35e-4, 3.42e-4, 2.44e-4, 1.62e-4, 1.09e-4, 1.17e-5, 1.21e-5, 1.44e-4, 2.90e-3,
            1.43e-2, 2.13e-2, 1.91e-2, 1.5e-2, 1.6e-2,
        ];
        // not while it creeps (every step before the rise), from the first slowing after it
        assert_eq!(tries(&snap), vec![11, 12, 13]);
        // a flow that only slows down: when it has nearly stopped, and at the last pseudo-step
        let rest = [1e-3, 5e-4, 1e-4, 1e-5, 2e-6, 9e-7, 1e-7, 5e-8];
        assert_eq!(tries(&rest), vec![5, 6, 7]);
        let creep = [1e-3, 9e-4, 8e-4, 7e-4];
        assert_eq!(tries(&creep), vec![3]);
        // a single pseudo-step is the last one
        assert_eq!(tries(&[1e-3]), vec![0]);
    }

    #[test]
    fn the_predictor_is_given_up_when_more_than_a_fifth_of_eight_or_more_starts_fail() {
        assert!(!predictions_fail(7, 7), "too few tries to judge");
        assert!(!predictions_fail(8, 1));
        assert!(predictions_fail(8, 2));
        assert!(!predictions_fail(100, 20));
        assert!(predictions_fail(100, 21));
    }

    fn control(steps: Vec<usize>, max_cutbacks: usize) -> StepControl {
        StepControl {
            translation_probes: Vec::new(),
            stage_steps: steps,
            max_cutbacks,
            growth: 2.0,
            easy_iterations: 4,
            pseudo_steps: 0,
            secant_predictor: false,
            newton_overrides: Vec::new(),
        }
    }

    /// Drives the sizer with a rule deciding which targets fail; returns the accepted loads.
    fn drive(c: &StepControl, mut fails: impl FnMut(f64, f64) -> bool) -> Result<Vec<f64>, f64> {
        let mut s = StepSizer::new(c);
        let mut loads = Vec::new();
        let mut lambda = 0.0;
        while s.stage().is_some() {
            let mut cut = 0;
            loop {
                let t = s.target();
                if !fails(lambda, t) {
                    s.accept(t, 3, cut);
                    lambda = t;
                    loads.push(t);
                    break;
                }
                s.cut_back()?;
                cut += 1;
            }
            assert!(loads.len() < 10_000, "runaway");
        }
        Ok(loads)
    }

    #[test]
    fn nominal_steps_reach_every_stage_end_exactly() {
        let loads = drive(&control(vec![4, 2], 3), |_, _| false).unwrap();
        assert_eq!(loads, vec![0.25, 0.5, 0.75, 1.0, 1.5, 2.0]);
    }

    #[test]
    fn a_cutback_halves_the_increment_actually_tried_at_a_stage_end() {
        // From 0.75 the clipped attempt to 1.0 fails once: the retry must be 0.875, not 1.0 again.
        // With max_cutbacks = 1 a repeat of the same 0.25 attempt would exhaust the budget.
        let c = control(vec![4], 1);
        let mut failed = false;
        let loads = drive(&c, |from, to| {
            let fail = !failed && (from - 0.75).abs() < 1e-12 && (to - 1.0).abs() < 1e-12;
            failed |= fail;
            fail
        });
        assert_eq!(loads.unwrap(), vec![0.25, 0.5, 0.75, 0.875, 1.0]);
    }

    #[test]
    fn each_stage_starts_from_its_own_nominal_increment() {
        // Stage 0 has 100 tiny steps; stage 1 has 2, which must be 2 steps, not 50.
        let loads = drive(&control(vec![100, 2], 4), |_, _| false).unwrap();
        assert_eq!(loads.len(), 102);
        assert!((loads[100] - 1.5).abs() < 1e-12 && (loads[101] - 2.0).abs() < 1e-12);
    }

    #[test]
    fn the_minimum_increment_stops_a_step_that_always_fails() {
        let err = drive(&control(vec![2], 3), |from, _| from >= 0.5).unwrap_err();
        assert!((err - 0.5 / 8.0).abs() < 1e-15);
    }

    #[test]
    fn increments_grow_back_after_easy_steps_and_leave_no_slivers() {
        // One failure at the first attempt from 0: cut to 0.125; the next step (no cutback, easy)
        // keeps 0.125 and then grows back to the nominal 0.25.
        let mut failed = false;
        let loads = drive(&control(vec![4], 4), |from, _| {
            if from == 0.0 && !failed {
                failed = true;
                return true;
            }
            false
        })
        .unwrap();
        assert_eq!(loads, vec![0.125, 0.25, 0.5, 0.75, 1.0]);
        for w in loads.windows(2) {
            assert!(w[1] - w[0] >= 0.125 - 1e-12, "sliver step in {loads:?}");
        }
    }
}
