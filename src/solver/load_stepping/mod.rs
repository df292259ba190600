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
//!
//! [`run_load_steps_from`] hands each step to the stepper (`stepper`), which takes it with its
//! parts, one module each: the step sizer ([`StepSizer`]: cutback, growth, minimum increment),
//! the secant predictor (`predictor`, with the rule that gives it up for a stage), the linear
//! route (`linear_route`: an iterative solver's MUMPS fallback), the pattern resume (`pattern`:
//! Newton going on after a contact sparsity pattern rebuild), the acceptance checks
//! (`acceptance`: translation probes, null pivots, folded elements) and the rescue (`rescue`:
//! pseudo-transient solves at the minimum increment). The debug switches
//! `NURBS_CONTACT_DEBUG_LINEAR`, `_PROBES`, `_PREDICTOR` and `_RESCUE` are read once, when the
//! stepping starts.

mod acceptance;
mod linear_route;
mod pattern;
mod predictor;
mod rescue;
mod sizer;
mod stepper;

pub use acceptance::{translation_resistance, TranslationProbe, FREE_TRANSLATION_TOL};
pub use predictor::PredictorState;
pub use sizer::StepSizer;

use crate::assembly::{prescribed_values, Assembler, ConflictError, DirichletBc};
use crate::petsc::{Matrix, NonlinearProblem, PetscError, Snes, SolveOutcome, Vector};
use stepper::Stepper;

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

impl LoadPosition {
    /// The load has passed the start of `stage` (the stage of the next step is under way).
    pub fn stage_started(&self) -> bool {
        self.lambda > self.stage as f64 + 1e-12 * (self.stage as f64).max(1.0)
    }
}

/// What the load stepping shows its observer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StepEvent {
    /// A step converged (its record, its state).
    Converged,
    /// The run was asked to stop within the step after this converged one: that step was given
    /// up, and the state is this converged step's again (evaluated at it, so its fields can be
    /// written); the run ends with [`SolverError::Interrupted`] whatever the observer answers.
    StoppedAfter,
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
    /// The run was asked to stop (a signal) while a step was being solved: the stepper has
    /// returned to the last converged state; [`run_load_steps_from`] ends the run with
    /// [`SolverError::Interrupted`] instead.
    #[error("interrupted within a load step")]
    InterruptedInStep,
    /// The observer asked to stop after a converged step, or a stop request ended the step after
    /// it (an interrupt).
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

/// What the load stepping hands its observer after every converged step (and, after a stop
/// within the next step, once more): the event, the step, the converged state, the one before it
/// (with the secant predictor on) and the assembler; it may stop the run.
pub type StepObserverFn<'a, 'p> = dyn FnMut(
        StepEvent,
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
        &mut |event, rec, x, _before, asm| match event {
            StepEvent::Converged => observer(rec, x, asm),
            StepEvent::StoppedAfter => Ok(AfterStep::Stop),
        },
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
    let mut stepper = Stepper::new(control, x, start, before)?;
    let mut sys = System {
        asm,
        snes,
        x,
        jac,
        bcs,
        coords,
    };
    let mut records: Vec<StepRecord> = Vec::new();
    while let Some(stage) = stepper.stage() {
        let rec = match stepper.step(&mut sys, stage) {
            Ok(rec) => rec,
            Err(SolverError::InterruptedInStep) => {
                // the step in progress is given up: the run ends at the last converged step
                if let Some(last) = records.last() {
                    observer(
                        StepEvent::StoppedAfter,
                        last,
                        sys.x,
                        stepper.before(),
                        sys.asm,
                    )
                    .map_err(SolverError::Observer)?;
                }
                let (steps, load) = stepper.converged();
                return Err(SolverError::Interrupted { steps, load });
            }
            Err(e) => return Err(e),
        };
        let after = observer(StepEvent::Converged, &rec, sys.x, stepper.before(), sys.asm)
            .map_err(SolverError::Observer)?;
        let (steps, load) = (rec.step, rec.load);
        records.push(rec);
        if after == AfterStep::Stop {
            return Err(SolverError::Interrupted { steps, load });
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

/// The system a load step solves: the assembler, the Newton solver, the unknowns and the tangent,
/// with the Dirichlet conditions and the node coordinates their values depend on.
pub(super) struct System<'a, 'p> {
    pub(super) asm: &'a mut Assembler<'p>,
    pub(super) snes: &'a mut Snes<'p>,
    pub(super) x: &'a mut Vector<'p>,
    pub(super) jac: &'a mut Matrix<'p>,
    pub(super) bcs: &'a [DirichletBc],
    pub(super) coords: &'a [f64],
}

impl System<'_, '_> {
    /// The load parameter `target` and the prescribed values it gives.
    fn set_load(&mut self, target: f64) -> Result<(), SolverError> {
        let values = prescribed_values(self.bcs, &self.asm.dofs, self.coords, target)?;
        self.asm.set_prescribed(&values);
        self.asm.set_load(target);
        Ok(())
    }

    /// One Newton solve from `x`, with its augmented Lagrangian rounds; a solve stopped by a
    /// request to stop the run is [`SolverError::InterruptedInStep`].
    ///
    /// Collective.
    fn solve(&mut self) -> Result<SolveOutcome, SolverError> {
        let out = super::settle::solve_settled(self.asm, self.snes, self.x, self.jac)?;
        if out.interrupted {
            return Err(SolverError::InterruptedInStep);
        }
        Ok(out)
    }

    /// Evaluates the residual at `x`, so that the coupling set's points and the elements' states
    /// are those of `x` (after a step was given up, for the output of the converged state `x`
    /// holds again).
    ///
    /// Collective.
    fn evaluate(&mut self) -> Result<(), SolverError> {
        let mut f = self.x.duplicate()?;
        NonlinearProblem::residual(&mut *self.asm, self.x, &mut f).map_err(|e| {
            SolverError::Observer(format!(
                "the last converged state, evaluated again for its output: {e}"
            ))
        })
    }
}
