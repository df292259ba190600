//! Load stepping with cutback and growth.
//!
//! The load parameter `lambda` runs from 0 to the number of stages; stage `s` is split into its
//! nominal number of equal increments. A step whose Newton solve diverges (or hits an inverted
//! element, a failed projection, ...) is retried from the last converged state with half the
//! increment; the increment never goes below `nominal / 2^max_cutbacks` (the minimum step), and a
//! step that fails at the minimum stops the run with an error naming it. After an easy step the
//! increment grows back by `growth`, never beyond the nominal one.

use crate::assembly::{prescribed_values, Assembler, ConflictError, DirichletBc};
use crate::petsc::{Matrix, PetscError, Snes, Vector};
use std::time::Instant;

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
    /// Wall time of this step, all attempts (s).
    pub wall_time: f64,
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
    /// PETSc failed.
    #[error(transparent)]
    Petsc(#[from] PetscError),
    /// Boundary conditions contradict each other.
    #[error(transparent)]
    Conflict(#[from] ConflictError),
    /// The observer (output writer) failed.
    #[error("while writing results: {0}")]
    Observer(String),
}

/// Runs all stages. `x` holds the initial displacement and ends with the last converged one.
/// `observer` is called after every converged step (output, history).
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
    observer: &mut dyn FnMut(&StepRecord, &Vector<'p>, &mut Assembler<'p>) -> Result<(), String>,
) -> Result<Vec<StepRecord>, SolverError> {
    let mut x_conv = x.duplicate()?;
    x.copy_to(&mut x_conv)?;
    let mut records = Vec::new();
    let mut lambda = 0.0f64;
    let mut step = 0usize;
    let mut dl = f64::INFINITY;
    for (stage, &n_steps) in control.stage_steps.iter().enumerate() {
        let nominal = 1.0 / n_steps.max(1) as f64;
        let dl_min = nominal / 2f64.powi(control.max_cutbacks.min(60) as i32);
        let stage_end = (stage + 1) as f64;
        dl = dl.min(nominal);
        while stage_end - lambda > 1e-9 * nominal {
            let t_step = Instant::now();
            let mut cutbacks = 0;
            let outcome = loop {
                let mut target = (lambda + dl).min(stage_end);
                // Do not leave a sliver of a step at the end of a stage.
                if stage_end - target < 1e-6 * nominal {
                    target = stage_end;
                }
                let values = prescribed_values(bcs, &asm.dofs, coords, target)?;
                asm.set_prescribed(&values);
                // Newton starts from the converged state: its first iteration lifts the new boundary
                // values into the interior through the tangent, which inverts far fewer elements than
                // starting from a guess that moves only the boundary.
                x_conv.copy_to(x)?;
                let out = snes.solve(asm, x, jac)?;
                if out.converged {
                    break (out, target);
                }
                asm.rollback();
                if dl / 2.0 < dl_min * (1.0 - 1e-9) {
                    return Err(SolverError::StepFailed {
                        step: step + 1,
                        stage,
                        load: target,
                        cutbacks,
                        reason: format!(
                            "the minimum increment {dl_min:.3e} was reached; last attempt: {}",
                            out.domain_error.unwrap_or(out.reason)
                        ),
                    });
                }
                cutbacks += 1;
                dl /= 2.0;
            };
            let (out, target) = outcome;
            lambda = target;
            step += 1;
            asm.commit();
            x.copy_to(&mut x_conv)?;
            let rec = StepRecord {
                step,
                stage,
                load: lambda,
                iterations: out.iterations,
                residual: out.residual_history.last().copied().unwrap_or(0.0),
                cutbacks,
                residual_history: out.residual_history,
                wall_time: t_step.elapsed().as_secs_f64(),
            };
            observer(&rec, x, asm).map_err(SolverError::Observer)?;
            records.push(rec);
            if out.iterations <= control.easy_iterations && cutbacks == 0 {
                dl = (dl * control.growth).min(nominal);
            }
        }
    }
    Ok(records)
}
