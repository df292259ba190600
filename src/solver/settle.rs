//! A Newton solve followed by the augmented Lagrangian's rounds
//! (`crate::contact::system::augment`): new multipliers and another solve, until the constraints
//! are satisfied to their tolerance.
//!
//! Where the rounds only place the points of 3D segments again
//! ([`Assembler::places_after_solve`]), the step's first solve stops once its residual norm has
//! fallen to [`PLACEMENT_RTOL`] of its first; the points are placed there if the state moved them, and the
//! solve goes on to its tolerances. A placement changes the residual by the segments' quadrature
//! difference, so the iterations that a full first solve spends below that level before the
//! round are not repeated after it.

use crate::assembly::{Assembler, Augment};
use crate::petsc::{Matrix, Snes, SolveOutcome, Vector};

/// The fall of the residual norm (relative to the solve's first) at which the first solve of a
/// step with 3D segments stops for their placement. Measured on the scale scene e4 (one-pass
/// weighted gap, 6 steps, every step placed once again): placed after the full solve, each round
/// started at a norm of 1e-6..2e-5 and took 1-2 Newton iterations, 47 in all; stopped at 1e-4, 40;
/// at 1e-2, 36 (without segments 38), the placement then moving the norm by less than 10 %.
const PLACEMENT_RTOL: f64 = 1e-2;

/// One Newton solve from `x`, solved again with new multipliers while an augmented pair's
/// constraints are violated (not converged, with the reason, when a pair's rounds run out).
/// Iterations and residual histories of the resumed solves add up.
///
/// Collective.
pub(super) fn solve_settled<'p>(
    asm: &mut Assembler<'p>,
    snes: &mut Snes<'p>,
    x: &mut Vector<'p>,
    jac: &mut Matrix<'p>,
) -> Result<SolveOutcome, crate::petsc::PetscError> {
    let mut out = if asm.places_after_solve() {
        solve_placing(asm, snes, x, jac)?
    } else {
        snes.solve(asm, x, jac)?
    };
    // Augmented Lagrangian rounds (a coupling set without augmentation is satisfied at once):
    // new multipliers, and another solve from the converged state.
    while out.converged {
        match asm.augment(x) {
            Augment::Satisfied => break,
            Augment::Exhausted(why) => {
                out.converged = false;
                out.reason = why.clone();
                out.domain_error = Some(why);
                break;
            }
            Augment::Updated => {
                asm.refresh_pattern(x, jac, snes)?;
                let next = snes.solve(asm, x, jac)?;
                out = chain(out, next);
            }
        }
    }
    Ok(out)
}

/// One Newton solve from `x` that stops at [`PLACEMENT_RTOL`] of its first residual norm (or
/// the solver's tolerances, if looser), has the coupling set place its 3D segments at the state
/// reached (a round of [`Assembler::augment`], when the state moved them), and solves on from
/// there to the solver's tolerances, taken relative to the first solve's start (without a
/// placement, the rest of the same solve: the iteration limit is what the first part left).
/// Iterations and residual histories add up.
///
/// Collective.
fn solve_placing<'p>(
    asm: &mut Assembler<'p>,
    snes: &mut Snes<'p>,
    x: &mut Vector<'p>,
    jac: &mut Matrix<'p>,
) -> Result<SolveOutcome, crate::petsc::PetscError> {
    let t = snes.tolerances()?;
    let max_it = t.max_it.max(0) as usize;
    snes.set_tolerances(t.atol, t.rtol.max(PLACEMENT_RTOL), t.stol, max_it)?;
    let first = snes.solve(asm, x, jac);
    snes.set_tolerances(t.atol, t.rtol, t.stol, max_it)?;
    let first = first?;
    if !first.converged {
        return Ok(first);
    }
    let (placed, its) = match asm.augment(x) {
        Augment::Satisfied => (false, max_it.saturating_sub(first.iterations).max(1)),
        Augment::Updated => {
            asm.refresh_pattern(x, jac, snes)?;
            (true, max_it)
        }
        Augment::Exhausted(why) => {
            return Ok(SolveOutcome {
                converged: false,
                reason: why.clone(),
                domain_error: Some(why),
                ..first
            });
        }
    };
    // the step's tolerance: `rtol` of the first solve's starting norm, or `atol`
    let f0 = first.residual_history.first().copied().unwrap_or(0.0);
    let atol = if f0.is_finite() {
        t.atol.max(t.rtol * f0)
    } else {
        t.atol
    };
    snes.set_tolerances(atol, t.rtol, t.stol, its)?;
    let next = snes.solve(asm, x, jac);
    snes.set_tolerances(t.atol, t.rtol, t.stol, max_it)?;
    let mut next = next?;
    if !placed && !next.residual_history.is_empty() {
        // the same state as the first part's last norm
        next.residual_history.remove(0);
    }
    Ok(chain(first, next))
}

/// Two solves one after the other: iterations and residual histories add up.
fn chain(first: SolveOutcome, next: SolveOutcome) -> SolveOutcome {
    SolveOutcome {
        iterations: first.iterations + next.iterations,
        linear_iterations: first.linear_iterations + next.linear_iterations,
        linear_accepted: first.linear_accepted + next.linear_accepted,
        residual_history: first
            .residual_history
            .into_iter()
            .chain(next.residual_history.iter().copied())
            .collect(),
        ..next
    }
}
