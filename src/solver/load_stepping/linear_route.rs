//! The linear route of a load step: the linear solver the options choose, the direct (MUMPS)
//! fallback after an iterative solve fails, and the step's linear counters.

use crate::petsc::{PetscError, Snes, SolveOutcome};

/// What a step does after a Newton solve, as far as the linear solver is concerned.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Switch {
    /// Nothing to change.
    Keep,
    /// A Krylov solve failed: the attempt is retried as it was, with MUMPS.
    ToDirect,
    /// The MUMPS fallback failed too: back to the Krylov route, and the attempt is cut back.
    BackToKrylov,
}

/// The linear solver of a load step and what it counted. A Krylov solve that failed (or an AMG
/// that could not be set up) says nothing about the step: the attempt is retried as it was with
/// MUMPS, which stays for the rest of the step (switched back after it). When MUMPS fails as a
/// linear solver too (above the size it fits in memory: the 1e6-unknown twist ran out of it in
/// every cutback while Krylov had converged the longer increments), the attempt is cut back on
/// the Krylov route, and a Krylov failure later in the step is cut back, not retried with MUMPS.
#[derive(Debug, Default)]
pub(super) struct LinearRoute {
    /// Attempts of this step retried with MUMPS.
    pub(super) fallbacks: usize,
    /// The MUMPS fallback failed in this step: Krylov failures are cut back instead.
    direct_failed: bool,
    /// Linear iterations of this step's Newton solves.
    pub(super) iterations: usize,
    /// Krylov solves of this step taken as inexact Newton directions at their iteration limit.
    pub(super) accepted: usize,
    /// Print each fallback and each return (`NURBS_CONTACT_DEBUG_LINEAR`).
    debug: bool,
}

impl LinearRoute {
    /// A route that prints its switches when `debug`.
    pub(super) fn new(debug: bool) -> Self {
        LinearRoute {
            debug,
            ..LinearRoute::default()
        }
    }

    /// A new step: counters at zero, the fallback available again.
    pub(super) fn begin_step(&mut self) {
        *self = LinearRoute::new(self.debug);
    }

    /// The switch after a solve whose linear solver failed (`linear_failed`, the solve not
    /// converged), given whether the solver can fall back and whether it is on the fallback.
    fn switch(&self, linear_failed: bool, can_fall_back: bool, on_direct: bool) -> Switch {
        if linear_failed && can_fall_back && !self.direct_failed {
            Switch::ToDirect
        } else if linear_failed && on_direct {
            Switch::BackToKrylov
        } else {
            Switch::Keep
        }
    }

    /// After a Newton solve of step `step` (0-based) at `target`: counts its linear iterations
    /// and switches the linear solver as `out` requires. True: the attempt is retried as it was,
    /// now with MUMPS (counted as a fallback).
    ///
    /// Collective.
    pub(super) fn after_solve(
        &mut self,
        snes: &mut Snes<'_>,
        out: &SolveOutcome,
        step: usize,
        target: f64,
    ) -> Result<bool, PetscError> {
        self.iterations += out.linear_iterations;
        self.accepted += out.linear_accepted;
        let failed = !out.converged && out.linear_failed;
        match self.switch(failed, snes.can_fall_back(), snes.on_direct()) {
            Switch::Keep => Ok(false),
            Switch::ToDirect => {
                if self.debug {
                    eprintln!(
                        "linear fallback: step {} load {target}: {}",
                        step + 1,
                        out.reason
                    );
                }
                snes.use_direct()?;
                self.fallbacks += 1;
                Ok(true)
            }
            Switch::BackToKrylov => {
                if self.debug {
                    eprintln!(
                        "linear fallback failed: step {} load {target}: {}; back to the Krylov \
                         route for this step",
                        step + 1,
                        out.reason
                    );
                }
                snes.use_options()?;
                self.direct_failed = true;
                Ok(false)
            }
        }
    }

    /// The step is over: back to the linear solver the options choose.
    ///
    /// Collective.
    pub(super) fn end_step(&self, snes: &mut Snes<'_>) -> Result<(), PetscError> {
        if snes.on_direct() {
            snes.use_options()?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_krylov_failure_falls_back_to_mumps_once_per_step_and_not_after_mumps_failed() {
        let mut r = LinearRoute::new(false);
        // a solve that did not fail in its linear solver changes nothing
        assert_eq!(r.switch(false, true, false), Switch::Keep);
        // without an iterative solver to fall back from (MUMPS from the start), nothing either
        assert_eq!(r.switch(true, false, false), Switch::Keep);
        // Krylov failed: retry with MUMPS
        assert_eq!(r.switch(true, true, false), Switch::ToDirect);
        // MUMPS failed too: back to Krylov; a later Krylov failure is cut back
        assert_eq!(r.switch(true, false, true), Switch::BackToKrylov);
        r.direct_failed = true;
        assert_eq!(r.switch(true, true, false), Switch::Keep);
        // the next step may fall back again
        r.fallbacks = 1;
        r.iterations = 40;
        r.begin_step();
        assert_eq!((r.fallbacks, r.iterations, r.direct_failed), (0, 0, false));
        assert_eq!(r.switch(true, true, false), Switch::ToDirect);
    }
}
