//! A Newton solve followed by the augmented Lagrangian's rounds
//! (`crate::contact::system::augment`): new multipliers and another solve, until the constraints
//! are satisfied to their tolerance.

use crate::assembly::{Assembler, Augment};
use crate::petsc::{Matrix, Snes, SolveOutcome, Vector};

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
    let mut out = snes.solve(asm, x, jac)?;
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
