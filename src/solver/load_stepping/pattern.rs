//! The pattern resume: a Newton solve stops when the contact points need couplings outside the
//! sparsity pattern (`Assembler::pattern_outdated`); the pattern is rebuilt and Newton goes on
//! from the iterate it reached, a few times per attempt.

use super::{SolverError, System};
use crate::petsc::SolveOutcome;

/// Newton solves of one attempt that may stop for a new contact sparsity pattern and resume.
pub(super) const MAX_PATTERN_RETRIES: usize = 4;

/// The pattern rebuilds of one attempt: how many it has made and the Newton iterations of the
/// solves it resumed.
#[derive(Debug, Default)]
pub(super) struct PatternResume {
    rebuilds: usize,
    iterations: usize,
}

impl PatternResume {
    /// After a solve of `iterations` Newton iterations: true when it stopped for a new sparsity
    /// pattern (not converged, the pattern `outdated`) and the attempt has rebuilds left. The
    /// rebuild is counted and the solve's iterations kept; Newton goes on from its iterate.
    pub(super) fn resume(&mut self, converged: bool, outdated: bool, iterations: usize) -> bool {
        let resume = !converged && outdated && self.rebuilds < MAX_PATTERN_RETRIES;
        if resume {
            self.rebuilds += 1;
            self.iterations += iterations;
        }
        resume
    }

    /// The attempt ends (converged, failed or retried): the iterations of the solves it resumed.
    /// The next attempt has the whole budget of rebuilds again (a shorter increment may need them
    /// as much as the longer one that used them up).
    pub(super) fn end_attempt(&mut self) -> usize {
        std::mem::take(self).iterations
    }
}

/// One Newton solve from `x` that may stop for a new contact sparsity pattern and resume; when
/// the rebuilds run out, one more solve on the pattern in hand. Iterations add up.
///
/// Collective.
pub(super) fn solve_resuming(sys: &mut System<'_, '_>) -> Result<SolveOutcome, SolverError> {
    let mut pattern = PatternResume::default();
    loop {
        sys.asm.refresh_pattern(sys.x, sys.jac, sys.snes)?;
        let mut out = sys.solve()?;
        let outdated = sys.asm.pattern_outdated();
        if pattern.resume(out.converged, outdated, out.iterations) {
            continue;
        }
        let mut iterations = out.iterations + pattern.end_attempt();
        if !out.converged && outdated {
            out = sys.solve()?;
            iterations += out.iterations;
        }
        out.iterations = iterations;
        return Ok(out);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_attempt_resumes_at_most_four_times_and_each_attempt_has_its_own_budget() {
        let mut p = PatternResume::default();
        // a converged solve, or one that failed for another reason, is not resumed
        assert!(!p.resume(true, true, 3));
        assert!(!p.resume(false, false, 3));
        for k in 1..=MAX_PATTERN_RETRIES {
            assert!(p.resume(false, true, k), "rebuild {k}");
        }
        assert!(!p.resume(false, true, 7), "the budget is spent");
        // the resumed solves' iterations (1 + 2 + 3 + 4), not the refused ones'
        assert_eq!(p.end_attempt(), 10);
        assert!(p.resume(false, true, 5), "a new attempt, a new budget");
        assert_eq!(p.end_attempt(), 5);
        assert_eq!(p.end_attempt(), 0);
    }
}
