//! The stepper: takes one load step after another from its parts, the step sizer, the secant
//! predictor, the linear route, the pattern resume, the acceptance checks and the rescue.

use super::acceptance::Acceptance;
use super::linear_route::LinearRoute;
use super::pattern::{PatternResume, MAX_PATTERN_RETRIES};
use super::predictor::Predictor;
use super::rescue::{PseudoTransient, Rescue};
use super::sizer::StepSizer;
use super::{with_overrides, LoadPosition, SolverError, StepControl, StepRecord, System};
use crate::petsc::{SolveOutcome, Vector};
use crate::solver::judge::{accept_at_floor, judge};
use std::time::Instant;

/// The debug switches of the load stepping: environment variables, read once (set: on).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub(super) struct DebugSwitches {
    /// `NURBS_CONTACT_DEBUG_LINEAR`: each fallback to MUMPS and each return from it.
    pub(super) linear: bool,
    /// `NURBS_CONTACT_DEBUG_PROBES`: each translation probe's ratio.
    pub(super) probes: bool,
    /// `NURBS_CONTACT_DEBUG_PREDICTOR`: each predicted start that failed.
    pub(super) predictor: bool,
    /// `NURBS_CONTACT_DEBUG_RESCUE`: each pseudo-step of the rescue.
    pub(super) rescue: bool,
}

impl DebugSwitches {
    /// The switches set in the environment.
    pub(super) fn from_env() -> Self {
        Self::from_lookup(|name| std::env::var_os(name).is_some())
    }

    /// The switches whose variables `set` says are set.
    fn from_lookup(set: impl Fn(&str) -> bool) -> Self {
        DebugSwitches {
            linear: set("NURBS_CONTACT_DEBUG_LINEAR"),
            probes: set("NURBS_CONTACT_DEBUG_PROBES"),
            predictor: set("NURBS_CONTACT_DEBUG_PREDICTOR"),
            rescue: set("NURBS_CONTACT_DEBUG_RESCUE"),
        }
    }
}

/// How one attempt at a step's target ended.
enum Attempt {
    /// Converged and accepted.
    Accepted(SolveOutcome),
    /// Tried again at the same increment: with MUMPS after a Krylov failure, or from the
    /// converged state after a predicted start failed.
    Retry,
    /// Failed, to be cut back: the last solve, and whether it converged to a folded state.
    Failed(SolveOutcome, bool),
}

/// What one step's attempts have done so far.
#[derive(Debug)]
struct StepLog {
    started: Instant,
    cutbacks: usize,
    /// The attempts cut back: (load tried, why it failed).
    failed_attempts: Vec<(f64, String)>,
    /// Newton iterations of the attempts that were not accepted.
    failed_iterations: usize,
    /// The current attempt's pattern rebuilds.
    pattern: PatternResume,
}

impl StepLog {
    fn new() -> Self {
        StepLog {
            started: Instant::now(),
            cutbacks: 0,
            failed_attempts: Vec::new(),
            failed_iterations: 0,
            pattern: PatternResume::default(),
        }
    }

    /// The attempt ends unaccepted after a last solve of `iterations`: all its solves' iterations
    /// are failed ones.
    fn discard(&mut self, iterations: usize) {
        self.failed_iterations += iterations + self.pattern.end_attempt();
    }
}

/// The load stepping's state between steps and the parts it takes each step with.
pub(super) struct Stepper<'c, 'p> {
    control: &'c StepControl,
    sizer: StepSizer,
    predictor: Predictor<'p>,
    linear: LinearRoute,
    acceptance: Acceptance<'c>,
    rescue: PseudoTransient<'c>,
    /// Converged steps so far.
    step: usize,
    /// The last converged state.
    x_conv: Vector<'p>,
}

impl<'c, 'p> Stepper<'c, 'p> {
    /// A stepper at the converged state `x`: at load 0, or at `start` (a restart, with `before`
    /// the converged state before it for the secant predictor).
    pub(super) fn new(
        control: &'c StepControl,
        x: &Vector<'p>,
        start: Option<LoadPosition>,
        before: Option<&Vector<'p>>,
    ) -> Result<Self, SolverError> {
        let debug = DebugSwitches::from_env();
        let mut x_conv = x.duplicate()?;
        x.copy_to(&mut x_conv)?;
        let mut stepper = Stepper {
            control,
            sizer: StepSizer::new(control),
            predictor: Predictor::new(control.secant_predictor, x, debug.predictor)?,
            linear: LinearRoute::new(debug.linear),
            acceptance: Acceptance::new(&control.translation_probes, debug.probes),
            rescue: PseudoTransient::new(control, debug.rescue),
            step: 0,
            x_conv,
        };
        if let Some(p) = start {
            stepper.sizer.resume(&p);
            stepper.step = p.step;
            stepper.predictor.resume(p.predictor, before)?;
        }
        Ok(stepper)
    }

    /// The stage of the next step, or `None` when all stages are done.
    pub(super) fn stage(&self) -> Option<usize> {
        self.sizer.stage()
    }

    /// The converged state before the last one (with the secant predictor on).
    pub(super) fn before(&self) -> Option<&Vector<'p>> {
        self.predictor.before()
    }

    /// Converged steps (a restart's included) and the load they reached.
    pub(super) fn converged(&self) -> (usize, f64) {
        (self.step, self.sizer.lambda())
    }

    /// The next load step, in `stage`: attempts from the last converged state until one is
    /// accepted, cut back after each failure and rescued at the minimum increment; then the
    /// step is committed. `sys.x` ends with its state. A request to stop the run during a solve
    /// gives the step up: [`SolverError::InterruptedInStep`], with `sys.x`, the load and the
    /// element and contact states back at the last converged step.
    ///
    /// Collective.
    pub(super) fn step(
        &mut self,
        sys: &mut System<'_, 'p>,
        stage: usize,
    ) -> Result<StepRecord, SolverError> {
        match self.take_step(sys, stage) {
            Err(SolverError::InterruptedInStep) => {
                // (a stop within the rescue leaves its damping on)
                sys.asm.set_damping(0.0, sys.x)?;
                sys.asm.rollback();
                self.x_conv.copy_to(sys.x)?;
                sys.set_load(self.sizer.lambda())?;
                sys.evaluate()?;
                Err(SolverError::InterruptedInStep)
            }
            r => r,
        }
    }

    /// [`Stepper::step`] without the return to the converged state after a stop request.
    ///
    /// Collective.
    fn take_step(
        &mut self,
        sys: &mut System<'_, 'p>,
        stage: usize,
    ) -> Result<StepRecord, SolverError> {
        let mut log = StepLog::new();
        self.predictor.begin_step();
        self.linear.begin_step();
        self.acceptance.begin_step();
        let (out, target, pseudo_steps) = loop {
            let target = self.sizer.target();
            match self.attempt(sys, stage, target, &mut log)? {
                Attempt::Accepted(out) => break (out, target, 0),
                Attempt::Retry => {}
                Attempt::Failed(out, folded) => {
                    if let Some((out, k)) =
                        self.cut_back_or_rescue(sys, stage, target, out, folded, &mut log)?
                    {
                        break (out, target, k);
                    }
                }
            }
        };
        self.linear.end_step(sys.snes)?;
        self.commit(sys, stage, target, out, pseudo_steps, log)
    }

    /// One attempt at `target`: Newton from the converged state (or the secant predictor's
    /// start), resumed from its iterate across pattern rebuilds, each solve judged, its linear
    /// route switched and its state checked.
    ///
    /// Collective.
    fn attempt(
        &mut self,
        sys: &mut System<'_, 'p>,
        stage: usize,
        target: f64,
        log: &mut StepLog,
    ) -> Result<Attempt, SolverError> {
        let mut resumed = false;
        loop {
            let increment = target - self.sizer.lambda();
            let predicted = self.predictor.factor(self.step, stage, increment);
            sys.set_load(target)?;
            // Newton starts from the converged state: its first iteration lifts the new boundary
            // values into the interior through the tangent, which inverts far fewer elements than
            // starting from a guess that moves only the boundary. After a stop for a new contact
            // sparsity pattern it resumes from the iterate it reached.
            if !resumed {
                self.x_conv.copy_to(sys.x)?;
                if let Some(r) = predicted {
                    self.predictor.start(r, sys.x, &self.x_conv)?;
                }
            }
            sys.asm.refresh_pattern(sys.x, sys.jac, sys.snes)?;
            if predicted.is_some() && !resumed {
                // a predicted start whose first Newton iteration raises the residual norm is
                // outside the region where Newton converges fast (two-half-pass pointwise
                // ironing: 14 iterations where the converged start takes 5-6): it is given up
                // at once, as a failed predicted start
                sys.snes.watch_start();
            }
            let out = self.solve(sys)?;
            if self.linear.after_solve(sys.snes, &out, self.step, target)? {
                log.discard(out.iterations);
                sys.asm.rollback();
                return Ok(Attempt::Retry);
            }
            if self.acceptance.accepts(sys, &out, self.step, target)? {
                return Ok(Attempt::Accepted(out));
            }
            resumed = log
                .pattern
                .resume(out.converged, sys.asm.pattern_outdated(), out.iterations);
            if resumed {
                continue;
            }
            log.discard(out.iterations);
            sys.asm.rollback();
            if predicted.is_some() {
                // the same increment again from the converged state (its iterations count as
                // failed ones, the attempt is no cutback)
                let why = out.domain_error.as_ref().unwrap_or(&out.reason);
                self.predictor
                    .failed(self.step, target, out.iterations, why);
                self.acceptance.tangled = None;
                return Ok(Attempt::Retry);
            }
            let folded = out.converged;
            return Ok(Attempt::Failed(out, folded));
        }
    }

    /// A Newton solve from `sys.x` and the run's own verdict on it: a solve that stopped at a state
    /// the default tolerances accept is converged whatever SNES's reason ([`accept_at_floor`]); a
    /// solve SNES calls converged whose residual is not (an option changed SNES's test) is a
    /// failed one.
    ///
    /// Collective.
    fn solve(&self, sys: &mut System<'_, 'p>) -> Result<SolveOutcome, SolverError> {
        let mut out = sys.solve()?;
        accept_at_floor(sys.asm, sys.x, &mut out)?;
        if out.converged {
            if let Some(why) = judge(sys.asm, sys.x, &mut out, &self.control.newton_overrides)? {
                out.converged = false;
                out.reason = why.clone();
                out.domain_error = Some(why);
            }
        }
        Ok(out)
    }

    /// After the failed attempt at `target` (its last solve `out`, `folded`: converged to a
    /// folded state): the increment is cut back (`None`: attempt again); at the minimum
    /// increment the rescue's equilibrium and pseudo-steps, or the error that stops the run.
    ///
    /// Collective.
    fn cut_back_or_rescue(
        &mut self,
        sys: &mut System<'_, 'p>,
        stage: usize,
        target: f64,
        out: SolveOutcome,
        folded: bool,
        log: &mut StepLog,
    ) -> Result<Option<(SolveOutcome, usize)>, SolverError> {
        let fold = match &self.acceptance.tangled {
            Some((_, fold)) if folded => Some(fold.as_str()),
            _ => None,
        };
        let why = failure_reason(&out, fold, sys.asm.pattern_outdated());
        log.failed_attempts.push((target, why.clone()));
        // what the final error adds to a fold: the last attempt, if it failed otherwise
        let mut last_attempt = (!folded).then_some(why);
        let Err(min) = self.sizer.cut_back() else {
            log.cutbacks += 1;
            return Ok(None);
        };
        if self.rescue.enabled() {
            match self.rescue.rescue(sys, &self.x_conv)? {
                Rescue::Found(out, k) => return Ok(Some((out, k))),
                Rescue::Tangled(fold) => {
                    self.acceptance.tangled = Some((target, fold));
                    last_attempt = None;
                }
                Rescue::Failed => {}
            }
        }
        Err(self.stop(stage, target, out, min, last_attempt, log))
    }

    /// Why the run stops at a step that failed at the minimum increment `min` (and in the
    /// rescue): a folded state if any attempt reached one, else the last attempt `out`.
    fn stop(
        &self,
        stage: usize,
        target: f64,
        out: SolveOutcome,
        min: f64,
        last_attempt: Option<String>,
        log: &StepLog,
    ) -> SolverError {
        if let Some((at, fold)) = self.acceptance.tangled.clone() {
            return SolverError::Tangled {
                step: self.step + 1,
                load: at,
                fold,
                last_step: self.step,
                last_load: self.sizer.lambda(),
                last_attempt,
            };
        }
        let control = self.control;
        SolverError::StepFailed {
            step: self.step + 1,
            stage,
            load: target,
            cutbacks: log.cutbacks,
            reason: format!(
                "the minimum increment {min:.3e} was reached{}{}; last attempt: {}",
                if log.cutbacks == 0 && control.max_cutbacks > 0 {
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
        }
    }

    /// The accepted solve `out` at `target` (after `pseudo_steps` of the rescue, 0: none)
    /// becomes the converged state; its record.
    ///
    /// Collective.
    fn commit(
        &mut self,
        sys: &mut System<'_, 'p>,
        stage: usize,
        target: f64,
        out: SolveOutcome,
        pseudo_steps: usize,
        mut log: StepLog,
    ) -> Result<StepRecord, SolverError> {
        let iterations = out.iterations + log.pattern.end_attempt();
        let increment = target - self.sizer.lambda();
        self.sizer.accept(target, iterations, log.cutbacks);
        self.step += 1;
        let augmentation_rounds = sys.asm.augmentation_rounds();
        sys.asm.commit();
        self.predictor.accept(stage, increment, &self.x_conv)?;
        sys.x.copy_to(&mut self.x_conv)?;
        Ok(StepRecord {
            step: self.step,
            stage,
            load: target,
            iterations,
            residual: out.residual_history.last().copied().unwrap_or(0.0),
            cutbacks: log.cutbacks,
            residual_history: out.residual_history,
            failed_attempts: log.failed_attempts,
            wall_time: log.started.elapsed().as_secs_f64(),
            pseudo_steps,
            failed_iterations: log.failed_iterations,
            augmentation_rounds,
            position: LoadPosition {
                predictor: self.predictor.state(),
                ..self.sizer.position(self.step)
            },
            linear_fallbacks: self.linear.fallbacks,
            linear_iterations: self.linear.iterations,
            linear_accepted: self.linear.accepted,
        })
    }
}

/// Why an attempt failed: the fold it converged to, the sparsity pattern it kept outgrowing
/// (`pattern_outdated` after the last rebuild), or its last solve's reason.
fn failure_reason(out: &SolveOutcome, fold: Option<&str>, pattern_outdated: bool) -> String {
    match fold {
        Some(fold) => format!("converged to a tangled state: {fold}"),
        None if pattern_outdated => format!(
            "contact points still needed couplings outside the sparsity pattern after \
             {MAX_PATTERN_RETRIES} rebuilds in this attempt (last solve: {}{})",
            out.reason,
            out.domain_error
                .as_ref()
                .map_or(String::new(), |e| format!("; its line search met {e}"))
        ),
        None => out
            .domain_error
            .clone()
            .unwrap_or_else(|| out.reason.clone()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_debug_switch_reads_its_own_variable() {
        let only = |name: &'static str| DebugSwitches::from_lookup(move |n| n == name);
        assert_eq!(
            DebugSwitches::from_lookup(|_| false),
            DebugSwitches::default()
        );
        assert!(only("NURBS_CONTACT_DEBUG_LINEAR").linear);
        assert!(only("NURBS_CONTACT_DEBUG_PROBES").probes);
        assert!(only("NURBS_CONTACT_DEBUG_PREDICTOR").predictor);
        assert!(only("NURBS_CONTACT_DEBUG_RESCUE").rescue);
        let linear = only("NURBS_CONTACT_DEBUG_LINEAR");
        assert!(!linear.probes && !linear.predictor && !linear.rescue);
    }

    fn outcome(reason: &str, domain_error: Option<&str>) -> SolveOutcome {
        SolveOutcome {
            converged: false,
            reason: reason.into(),
            iterations: 3,
            residual_history: Vec::new(),
            domain_error: domain_error.map(String::from),
            linear_failed: false,
            linear_iterations: 0,
            linear_accepted: 0,
            interrupted: false,
        }
    }

    #[test]
    fn a_failed_attempt_says_fold_then_pattern_then_its_domain_error_then_snes_reason() {
        let plain = outcome("DIVERGED_MAX_IT", None);
        let domain = outcome("DIVERGED_FUNCTION_DOMAIN", Some("inverted element 7"));
        assert_eq!(
            failure_reason(&domain, Some("body `a` cell 3"), true),
            "converged to a tangled state: body `a` cell 3"
        );
        assert_eq!(
            failure_reason(&domain, None, true),
            "contact points still needed couplings outside the sparsity pattern after 4 \
             rebuilds in this attempt (last solve: DIVERGED_FUNCTION_DOMAIN; its line search \
             met inverted element 7)"
        );
        assert_eq!(failure_reason(&domain, None, false), "inverted element 7");
        assert_eq!(failure_reason(&plain, None, false), "DIVERGED_MAX_IT");
    }
}
