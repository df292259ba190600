//! A Newton solve that ends on the contact law's own active set (see
//! `crate::contact::system::active_set`): while a converged solve held contact points at a status
//! the law does not give them at the converged state, those points are updated and Newton resumes.
//! Then the augmented Lagrangian's rounds (`crate::contact::system::augment`): new multipliers
//! and another such solve, until the constraints are satisfied to their tolerance.

use crate::assembly::{Assembler, Augment, Settle};
use crate::petsc::{Matrix, Snes, SolveOutcome, Vector};

/// Resumed solves after a converged one, at most (the active-set rounds end before).
const MAX_RESUMES: usize = crate::contact::system::MAX_ACTIVE_SET_ROUNDS + 2;

/// One Newton solve from `x`, resumed from its converged state while frozen contact points
/// disagree with the law there, and solved again with new multipliers while an augmented pair's
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
    let mut out = solve_active_set(asm, snes, x, jac)?;
    // Augmented Lagrangian rounds (a coupling set without augmentation is satisfied at once):
    // new multipliers, and a settled solve from the converged state.
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
                let next = solve_active_set(asm, snes, x, jac)?;
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

/// One Newton solve from `x`, resumed while frozen contact points disagree with the law.
fn solve_active_set<'p>(
    asm: &mut Assembler<'p>,
    snes: &mut Snes<'p>,
    x: &mut Vector<'p>,
    jac: &mut Matrix<'p>,
) -> Result<SolveOutcome, crate::petsc::PetscError> {
    let mut out = snes.solve(asm, x, jac)?;
    for _ in 0..MAX_RESUMES {
        if !out.converged || asm.settle_active_set(x) != Settle::Resume {
            break;
        }
        asm.refresh_pattern(x, jac, snes)?;
        let next = snes.solve(asm, x, jac)?;
        out = chain(out, next);
    }
    Ok(out)
}
