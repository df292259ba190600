//! The run's own verdict on a Newton solve that SNES calls converged.
//!
//! SNES decides convergence by its options: `-snes_type ksponly` stops after one linear solve,
//! `-snes_atol 1e10` accepts the starting state, a loose `-snes_rtol` or `-snes_stol` stops early.
//! None of that may produce a converged step. After every solve SNES calls converged (and after
//! the active-set and augmented Lagrangian rounds that follow it), the load stepping evaluates
//! the residual at the solution itself and accepts the step only when its norm is small against
//! the step's force scale ([`residual_converged`]); a solve that fails this check is a failed
//! attempt like a diverged one (cut back), and its reason names the options in force that
//! changed SNES's test.

use crate::assembly::Assembler;
use crate::petsc::{NonlinearProblem, PetscError, ProblemError, SolveOutcome, Vector};
use mpi::traits::Communicator;

/// The code's absolute tolerance on the residual norm (`-snes_atol`'s default).
pub const NEWTON_ATOL: f64 = 1e-11;
/// The code's tolerance on the residual norm relative to a solve's first one (`-snes_rtol`'s
/// default).
pub const NEWTON_RTOL: f64 = 1e-10;
/// The code's tolerance on the Newton step relative to the solution (`-snes_stol`'s default).
pub const NEWTON_STOL: f64 = 1e-14;
/// The code's Newton iteration limit of one solve (`-snes_max_it`'s default).
pub const NEWTON_MAX_IT: usize = 30;

/// Relative tolerance of the run's own check: a residual norm at most this fraction of the
/// step's force scale is converged. Four orders above [`NEWTON_RTOL`], so that a solve that SNES
/// stops by its step test (`CONVERGED_SNORM_RELATIVE`) at the round-off floor of the residual
/// passes.
pub const JUDGE_RTOL: f64 = 1e-6;
/// Absolute tolerance of the run's own check: a residual norm at most this is converged whatever
/// the scale (ten times [`NEWTON_ATOL`]).
pub const JUDGE_ATOL: f64 = 1e-10;

/// Whether a residual norm `norm` is converged against the force scale `scale` of its step:
/// `norm <= max(JUDGE_ATOL, JUDGE_RTOL * scale)`. NaN is never converged.
pub fn residual_converged(norm: f64, scale: f64) -> bool {
    let scale = if scale.is_finite() { scale } else { 0.0 };
    norm <= JUDGE_ATOL.max(JUDGE_RTOL * scale)
}

/// The run's verdict on a solve `out` that SNES called converged at `x`, evaluating the residual
/// there: when it is converged ([`residual_converged`]) against the step's force scale (the
/// largest residual norm of the solve, or the forces at `x` if larger: at an equilibrium, the
/// reactions), the last entry of `out.residual_history` becomes its norm (the norm SNES computed
/// last, unless an option kept SNES from computing it at the solution) and the result is `None`;
/// otherwise why not, naming `overrides` (the options in force that change SNES's test, with
/// where they were set). The evaluation leaves the assembler's last residual at `x` (the reactions
/// of the output are those of the state accepted).
///
/// Collective.
pub(super) fn judge<'p>(
    asm: &mut Assembler<'p>,
    x: &Vector<'p>,
    out: &mut SolveOutcome,
    overrides: &[String],
) -> Result<Option<String>, PetscError> {
    let claimed = || {
        format!(
            "SNES reported {} after {} Newton iteration{}",
            out.reason,
            out.iterations,
            if out.iterations == 1 { "" } else { "s" }
        )
    };
    let blame = || {
        if overrides.is_empty() {
            String::new()
        } else {
            format!(
                "; SNES's convergence test was changed by {}",
                overrides.join(", ")
            )
        }
    };
    let norm = match residual_norm(asm, x)? {
        Ok(norm) => norm,
        Err(e) => {
            return Ok(Some(format!(
                "{}, but the residual cannot be evaluated at its solution: {e}{}",
                claimed(),
                blame()
            )))
        }
    };
    let seen = out
        .residual_history
        .iter()
        .copied()
        .filter(|r| r.is_finite())
        .fold(0.0, f64::max);
    let scale = seen.max(asm.force_norm());
    if std::env::var_os("NURBS_CONTACT_DEBUG_JUDGE").is_some() && asm.comm().rank() == 0 {
        eprintln!(
            "judge: |F| = {norm:.6e} (SNES's last {:.6e}), largest in the solve {seen:.3e}, \
             forces {:.3e}, ratio {:.3e}",
            out.residual_history.last().copied().unwrap_or(f64::NAN),
            asm.force_norm(),
            norm / scale
        );
    }
    if residual_converged(norm, scale) {
        match out.residual_history.last_mut() {
            Some(last) => *last = norm,
            None => out.residual_history.push(norm),
        }
        return Ok(None);
    }
    Ok(Some(format!(
        "{}, but the residual norm at its solution is {norm:.3e}, above the run's tolerance \
         {:.3e} ({JUDGE_RTOL:e} of the step's force scale {scale:.3e}, at least {JUDGE_ATOL:e}){}",
        claimed(),
        JUDGE_ATOL.max(JUDGE_RTOL * scale),
        blame()
    )))
}

/// Whether the code's default tolerances accept a residual norm `norm` of a solve whose first
/// norm was `first`: `norm <= max(NEWTON_ATOL, NEWTON_RTOL * first)`. NaN is never accepted.
pub fn within_default_tolerances(norm: f64, first: f64) -> bool {
    let first = if first.is_finite() { first } else { 0.0 };
    norm <= NEWTON_ATOL.max(NEWTON_RTOL * first)
}

/// A solve `out` that SNES ended without converging (stagnation, its iteration limit, a failed
/// line search) at a state `x` that the code's default tolerances accept: tolerances tightened
/// below the residual's round-off floor (`-snes_atol 1e-13` on a stiff case) leave Newton
/// iterating at the floor until the stagnation test stops it, and that state is the converged
/// one. Only a solve whose last norm SNES computed is already within those tolerances, and that
/// met no domain error or linear failure, is checked: the residual is evaluated at `x`, and when
/// its norm is accepted ([`within_default_tolerances`] against the solve's first norm) it
/// becomes the last entry of `out.residual_history`, `out` is marked converged and its reason
/// says why; otherwise `out` is left as it was.
///
/// Collective.
pub(super) fn accept_at_floor<'p>(
    asm: &mut Assembler<'p>,
    x: &Vector<'p>,
    out: &mut SolveOutcome,
) -> Result<(), PetscError> {
    let (Some(&first), Some(&last)) = (out.residual_history.first(), out.residual_history.last())
    else {
        return Ok(());
    };
    if out.converged
        || out.linear_failed
        || out.domain_error.is_some()
        || out.iterations == 0
        || !within_default_tolerances(last, first)
    {
        return Ok(());
    }
    let Ok(norm) = residual_norm(asm, x)? else {
        return Ok(());
    };
    if within_default_tolerances(norm, first) {
        out.converged = true;
        out.reason = format!(
            "{}, at a residual norm of {norm:.3e}, within the default tolerances \
             (absolute {NEWTON_ATOL:e}, {NEWTON_RTOL:e} of the first norm {first:.3e}): accepted",
            out.reason
        );
        if let Some(l) = out.residual_history.last_mut() {
            *l = norm;
        }
    }
    Ok(())
}

/// The residual norm at `x`, or the domain error that kept the residual from being evaluated there
/// (a fatal one is an error).
///
/// Collective.
fn residual_norm<'p>(
    asm: &mut Assembler<'p>,
    x: &Vector<'p>,
) -> Result<Result<f64, String>, PetscError> {
    let mut f = x.duplicate()?;
    match asm.residual(x, &mut f) {
        Ok(()) => Ok(Ok(f.norm2()?)),
        Err(ProblemError::Domain(e)) => Ok(Err(e)),
        Err(ProblemError::Fatal(message)) => Err(PetscError {
            code: 83,
            function: "residual evaluation of the convergence check",
            message,
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_residual_is_judged_against_its_force_scale() {
        // the default test's outcomes pass: relative 1e-10, absolute 1e-11
        assert!(residual_converged(NEWTON_RTOL * 3.0, 3.0));
        assert!(residual_converged(NEWTON_ATOL, 1e-30));
        // the round-off floor of a stiff case stopped by the step test
        assert!(residual_converged(2e-9, 1e4));
        // a start accepted by `-snes_atol 1e10` (the residual is the whole scale), and a linear
        // step of a nonlinear problem left at a percent of it
        assert!(!residual_converged(0.0287, 0.0287));
        assert!(!residual_converged(1e-3, 0.1));
        assert!(!residual_converged(f64::NAN, 1.0));
        assert!(!residual_converged(1.0, f64::NAN));
    }

    #[test]
    fn the_default_tolerances_accept_what_snes_would_have() {
        assert!(within_default_tolerances(NEWTON_ATOL, 1e-30));
        assert!(within_default_tolerances(3e-12, 1.0));
        assert!(within_default_tolerances(0.9e-6, 1e4));
        assert!(!within_default_tolerances(2e-6, 1e4));
        assert!(!within_default_tolerances(f64::NAN, 1.0));
        assert!(!within_default_tolerances(1e-3, f64::NAN));
    }
}
