//! The step sizer: the increment of the next attempt, its cutback after a failure and its growth
//! after easy steps, apart from any solver so that it can be tested alone.

use super::{LoadPosition, PredictorState, StepControl};

/// The step-size logic of the load stepping, apart from any solver so it can be tested alone.
///
/// Increments are in units of the load parameter; each stage starts from its own nominal increment
/// `1 / steps`. A cutback halves the increment actually tried (which may have been clipped to the
/// stage end), never below `nominal / 2^max_cutbacks`. After an easy step without cutbacks the
/// increment grows by `growth`, up to the nominal one. A remainder of a stage smaller than a quarter
/// of the current increment is taken together with the step before it, so no sliver steps remain.
#[derive(Debug, Clone)]
pub struct StepSizer {
    steps: Vec<usize>,
    max_cutbacks: usize,
    growth: f64,
    easy_iterations: usize,
    stage: usize,
    lambda: f64,
    dl: f64,
}

impl StepSizer {
    /// A sizer at load 0, stage 0.
    pub fn new(control: &StepControl) -> Self {
        let mut s = StepSizer {
            steps: control.stage_steps.clone(),
            max_cutbacks: control.max_cutbacks.min(60),
            growth: control.growth.max(1.0),
            easy_iterations: control.easy_iterations,
            stage: 0,
            lambda: 0.0,
            dl: 0.0,
        };
        s.dl = s.nominal();
        s
    }

    fn nominal(&self) -> f64 {
        1.0 / self.steps.get(self.stage).copied().unwrap_or(1).max(1) as f64
    }

    fn minimum(&self) -> f64 {
        self.nominal() / 2f64.powi(self.max_cutbacks as i32)
    }

    fn stage_end(&self) -> f64 {
        (self.stage + 1) as f64
    }

    /// The position after `step` converged steps.
    pub fn position(&self, step: usize) -> LoadPosition {
        LoadPosition {
            step,
            stage: self.stage,
            lambda: self.lambda,
            dl: self.dl,
            predictor: PredictorState::default(),
        }
    }

    /// Continues from a position of [`position`](Self::position) (a restart). A stage the
    /// position has not started begins with its own nominal increment, from the steps it has now
    /// (a restart may change them); within a stage the increment is the position's, at most the
    /// stage's nominal one. With the same steps this is the increment the run would have taken.
    pub fn resume(&mut self, p: &LoadPosition) {
        self.stage = p.stage;
        self.lambda = p.lambda;
        self.dl = if p.stage_started() {
            p.dl.min(self.nominal())
        } else {
            self.nominal()
        };
    }

    /// The load parameter reached.
    pub fn lambda(&self) -> f64 {
        self.lambda
    }

    /// The stage of the next step, or `None` when all stages are done.
    pub fn stage(&self) -> Option<usize> {
        (self.stage < self.steps.len()).then_some(self.stage)
    }

    /// The load the next attempt should reach.
    pub fn target(&self) -> f64 {
        let end = self.stage_end();
        let t = self.lambda + self.dl;
        if end - t < 0.25 * self.dl {
            end
        } else {
            t
        }
    }

    /// The attempt at [`target`](Self::target) failed: halve the increment actually tried. Returns
    /// the minimum increment as the error when the halved increment would be below it.
    pub fn cut_back(&mut self) -> Result<(), f64> {
        let tried = self.target() - self.lambda;
        let min = self.minimum();
        if tried / 2.0 < min * (1.0 - 1e-9) {
            return Err(min);
        }
        self.dl = tried / 2.0;
        Ok(())
    }

    /// The attempt converged at `target` in `iterations` Newton iterations after `cutbacks` failures.
    pub fn accept(&mut self, target: f64, iterations: usize, cutbacks: usize) {
        self.lambda = target;
        if iterations <= self.easy_iterations && cutbacks == 0 {
            self.dl = (self.dl * self.growth).min(self.nominal());
        }
        if self.stage_end() - self.lambda <= 1e-12 * self.stage_end() {
            self.lambda = self.stage_end();
            self.stage += 1;
            // Each stage starts from its own nominal increment.
            self.dl = self.nominal();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_resumed_stage_not_yet_started_takes_its_new_step_count() {
        let control = |steps: Vec<usize>| control(steps, 8);
        // a run of 3 + 1 steps stopped after the first stage
        let mut old = StepSizer::new(&control(vec![3, 1]));
        for _ in 0..3 {
            let t = old.target();
            old.accept(t, 1, 0);
        }
        let p = old.position(3);
        assert_eq!((p.stage, p.lambda, p.dl), (1, 1.0, 1.0));
        // resumed with the second stage in 4 steps: a quarter of it, not the whole
        let mut new = StepSizer::new(&control(vec![3, 4]));
        new.resume(&p);
        assert!((new.target() - 1.25).abs() < 1e-12, "{}", new.target());
        // with the same steps, the increment the run would have taken
        let mut same = StepSizer::new(&control(vec![3, 1]));
        same.resume(&p);
        assert_eq!(same.target(), old.target());
        // within a started stage the position's (cut-back) increment stays
        let mut mid = StepSizer::new(&control(vec![3, 4]));
        mid.resume(&LoadPosition {
            step: 4,
            stage: 1,
            lambda: 1.1,
            dl: 0.05,
            predictor: PredictorState::default(),
        });
        assert!((mid.target() - 1.15).abs() < 1e-12, "{}", mid.target());
    }
    fn control(steps: Vec<usize>, max_cutbacks: usize) -> StepControl {
        StepControl {
            translation_probes: Vec::new(),
            stage_steps: steps,
            max_cutbacks,
            growth: 2.0,
            easy_iterations: 4,
            pseudo_steps: 0,
            secant_predictor: false,
            newton_overrides: Vec::new(),
        }
    }

    /// Drives the sizer with a rule deciding which targets fail; returns the accepted loads.
    fn drive(c: &StepControl, mut fails: impl FnMut(f64, f64) -> bool) -> Result<Vec<f64>, f64> {
        let mut s = StepSizer::new(c);
        let mut loads = Vec::new();
        let mut lambda = 0.0;
        while s.stage().is_some() {
            let mut cut = 0;
            loop {
                let t = s.target();
                if !fails(lambda, t) {
                    s.accept(t, 3, cut);
                    lambda = t;
                    loads.push(t);
                    break;
                }
                s.cut_back()?;
                cut += 1;
            }
            assert!(loads.len() < 10_000, "runaway");
        }
        Ok(loads)
    }

    #[test]
    fn nominal_steps_reach_every_stage_end_exactly() {
        let loads = drive(&control(vec![4, 2], 3), |_, _| false).unwrap();
        assert_eq!(loads, vec![0.25, 0.5, 0.75, 1.0, 1.5, 2.0]);
    }

    #[test]
    fn a_cutback_halves_the_increment_actually_tried_at_a_stage_end() {
        // From 0.75 the clipped attempt to 1.0 fails once: the retry must be 0.875, not 1.0 again.
        // With max_cutbacks = 1 a repeat of the same 0.25 attempt would exhaust the budget.
        let c = control(vec![4], 1);
        let mut failed = false;
        let loads = drive(&c, |from, to| {
            let fail = !failed && (from - 0.75).abs() < 1e-12 && (to - 1.0).abs() < 1e-12;
            failed |= fail;
            fail
        });
        assert_eq!(loads.unwrap(), vec![0.25, 0.5, 0.75, 0.875, 1.0]);
    }

    #[test]
    fn each_stage_starts_from_its_own_nominal_increment() {
        // Stage 0 has 100 tiny steps; stage 1 has 2, which must be 2 steps, not 50.
        let loads = drive(&control(vec![100, 2], 4), |_, _| false).unwrap();
        assert_eq!(loads.len(), 102);
        assert!((loads[100] - 1.5).abs() < 1e-12 && (loads[101] - 2.0).abs() < 1e-12);
    }

    #[test]
    fn the_minimum_increment_stops_a_step_that_always_fails() {
        let err = drive(&control(vec![2], 3), |from, _| from >= 0.5).unwrap_err();
        assert!((err - 0.5 / 8.0).abs() < 1e-15);
    }

    #[test]
    fn increments_grow_back_after_easy_steps_and_leave_no_slivers() {
        // One failure at the first attempt from 0: cut to 0.125; the next step (no cutback, easy)
        // keeps 0.125 and then grows back to the nominal 0.25.
        let mut failed = false;
        let loads = drive(&control(vec![4], 4), |from, _| {
            if from == 0.0 && !failed {
                failed = true;
                return true;
            }
            false
        })
        .unwrap();
        assert_eq!(loads, vec![0.125, 0.25, 0.5, 0.75, 1.0]);
        for w in loads.windows(2) {
            assert!(w[1] - w[0] >= 0.125 - 1e-12, "sliver step in {loads:?}");
        }
    }

    #[test]
    fn a_step_that_keeps_failing_is_halved_max_cutbacks_times_and_then_refused() {
        let mut s = StepSizer::new(&control(vec![2], 3));
        let mut tried = vec![s.target()];
        while s.cut_back().is_ok() {
            tried.push(s.target());
        }
        assert_eq!(tried, vec![0.5, 0.25, 0.125, 0.0625]);
        // refused again, the increment left at the minimum
        assert_eq!(s.cut_back(), Err(0.0625));
        assert_eq!(s.target(), 0.0625);
        // a hard step (not easy) at the minimum keeps it; easy steps grow it back, doubling
        s.accept(0.0625, 5, 3);
        assert_eq!(s.target(), 0.125);
        s.accept(0.125, 4, 0);
        assert_eq!(s.target(), 0.25);
        s.accept(0.25, 4, 0);
        assert_eq!(s.target(), 0.5);
        s.accept(0.5, 4, 0);
        // back at the nominal increment
        assert_eq!(s.target(), 1.0);
    }
}
