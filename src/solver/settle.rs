//! A Newton solve that ends on the contact law's own active set (see
//! `crate::contact::system::active_set`): while a converged solve held contact points at a status
//! the law does not give them at the converged state, those points are updated and Newton resumes.

use crate::assembly::Assembler;
use crate::contact::Settle;
use crate::petsc::{Matrix, Snes, SolveOutcome, Vector};

/// Resumed solves after a converged one, at most (the active-set rounds end before).
const MAX_RESUMES: usize = crate::contact::system::MAX_ACTIVE_SET_ROUNDS + 2;

/// One Newton solve from `x`, resumed from its converged state while frozen contact points
/// disagree with the law there. Iterations and residual histories of the resumed solves add up.
///
/// Collective.
pub(super) fn solve_settled<'p>(
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
        asm.refresh_pattern(x, jac)?;
        let next = snes.solve(asm, x, jac)?;
        out = SolveOutcome {
            iterations: out.iterations + next.iterations,
            linear_iterations: out.linear_iterations + next.linear_iterations,
            residual_history: out
                .residual_history
                .into_iter()
                .chain(next.residual_history.iter().copied())
                .collect(),
            ..next
        };
    }
    Ok(out)
}
