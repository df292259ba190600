//! The secant predictor: Newton starts a step from the last converged state extrapolated along
//! the last step of the same stage, and gives that up for the rest of a stage when its starts
//! keep failing.

use crate::petsc::{PetscError, Vector};

/// The secant predictor is given up for the rest of a stage once at least
/// [`PREDICTION_TRIALS`] predicted starts were tried and more than [`PREDICTION_FAILURES`] of
/// them failed: a failed start costs its iterations and a second solve (two-half-pass pointwise
/// ironing at mesh 4 fails one in three).
const PREDICTION_TRIALS: usize = 8;
const PREDICTION_FAILURES: f64 = 0.2;

/// Whether `failed` of `tried` predicted starts of a stage give the predictor up.
fn predictions_fail(tried: usize, failed: usize) -> bool {
    tried >= PREDICTION_TRIALS && failed as f64 > PREDICTION_FAILURES * tried as f64
}

/// What the secant predictor carries from one step to the next (`[solver] predictor =
/// "secant"`), kept in checkpoints with the converged state before the last one.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PredictorState {
    /// Stage and increment of the last converged step (none before the first step).
    pub last: Option<(usize, f64)>,
    /// The stage whose predicted starts `tried`, `failed` and `given_up` count (none yet).
    pub stage: Option<usize>,
    /// Predicted starts tried in `stage`.
    pub tried: usize,
    /// Predicted starts of `stage` that failed and were retried from the converged state.
    pub failed: usize,
    /// The predictor was given up for the rest of `stage` ([`predictions_fail`]).
    pub given_up: bool,
}

impl PredictorState {
    /// The values a checkpoint keeps ([`PredictorState::from_values`] reads them back).
    pub fn values(&self) -> [f64; 6] {
        let (ls, ldl) = self.last.map_or((-1.0, 0.0), |(s, dl)| (s as f64, dl));
        [
            ls,
            ldl,
            self.stage.map_or(-1.0, |s| s as f64),
            self.tried as f64,
            self.failed as f64,
            f64::from(u8::from(self.given_up)),
        ]
    }

    /// The state of [`values`](Self::values).
    pub fn from_values(v: &[f64; 6]) -> Self {
        let index = |x: f64| (x >= 0.0).then_some(x as usize);
        PredictorState {
            last: index(v[0]).map(|s| (s, v[1])),
            stage: index(v[2]),
            tried: v[3] as usize,
            failed: v[4] as usize,
            given_up: v[5] != 0.0,
        }
    }
    /// Counting starts again at a new stage (the last step is kept: a step of another stage
    /// predicts nothing anyway).
    fn enter_stage(&mut self, stage: usize) {
        if self.stage != Some(stage) {
            *self = PredictorState {
                last: self.last,
                stage: Some(stage),
                ..PredictorState::default()
            };
        }
    }

    /// Gives the predictor up for the rest of the stage when too many of its starts failed
    /// ([`predictions_fail`]); true when it does so now.
    fn give_up(&mut self) -> bool {
        let now = !self.given_up && predictions_fail(self.tried, self.failed);
        self.given_up |= now;
        now
    }

    /// The secant factor `r` of an attempt of `increment` in `stage`: the ratio to the last
    /// step's increment, when that step was of the same stage and the predictor is not given up.
    fn factor(&self, stage: usize, increment: f64) -> Option<f64> {
        match self.last {
            Some((s, dl)) if s == stage && dl > 0.0 && !self.given_up => Some(increment / dl),
            _ => None,
        }
    }
}

/// The secant predictor of the load stepping (`[solver] predictor = "secant"`): the start of
/// each attempt, the count of its failures and the converged state before the last one.
pub(super) struct Predictor<'p> {
    state: PredictorState,
    /// `u_{n-1}`, the converged state before the last one; none with the predictor off.
    before: Option<Vector<'p>>,
    /// A predicted start of this step failed: the step's other attempts start from the
    /// converged state.
    failed_in_step: bool,
    /// Print each predicted start that fails (`NURBS_CONTACT_DEBUG_PREDICTOR`).
    debug: bool,
}

impl<'p> Predictor<'p> {
    /// A predictor with nothing to extrapolate yet; `on`: the secant predictor is used, `like`
    /// gives the vector layout.
    pub(super) fn new(on: bool, like: &Vector<'p>, debug: bool) -> Result<Self, PetscError> {
        Ok(Predictor {
            state: PredictorState::default(),
            before: if on { Some(like.duplicate()?) } else { None },
            failed_in_step: false,
            debug,
        })
    }

    /// Continues a run from a checkpoint's `state`; `before` is the converged state before its
    /// own (without it the first step is not predicted).
    pub(super) fn resume(
        &mut self,
        state: PredictorState,
        before: Option<&Vector<'p>>,
    ) -> Result<(), PetscError> {
        self.state = state;
        match (&mut self.before, before) {
            (Some(xb), Some(b)) => b.copy_to(xb)?,
            _ => self.state.last = None,
        }
        Ok(())
    }

    /// A new step: its first attempt may be predicted.
    pub(super) fn begin_step(&mut self) {
        self.failed_in_step = false;
    }

    /// Before each solve of step `step` (0-based) in `stage`, whose attempt takes `increment`:
    /// the secant factor when the attempt is predicted. Gives the predictor up for the rest of
    /// the stage, with a note, once too many of the stage's starts failed.
    pub(super) fn factor(&mut self, step: usize, stage: usize, increment: f64) -> Option<f64> {
        // counted per stage even with the predictor off (checkpoints keep the stage)
        self.state.enter_stage(stage);
        self.before.as_ref()?;
        if self.state.give_up() {
            eprintln!(
                "note: step {}: {} of {} predicted starts of stage {stage} failed; Newton \
                 starts from the converged state for the rest of the stage",
                step + 1,
                self.state.failed,
                self.state.tried
            );
        }
        if self.failed_in_step {
            return None;
        }
        self.state.factor(stage, increment)
    }

    /// Starts a predicted attempt: `x` (the converged state `x_conv`, prescribed values
    /// included) becomes `u_n + r (u_n - u_{n-1})`, prescribed values being linear in the load
    /// within a stage.
    pub(super) fn start(
        &mut self,
        r: f64,
        x: &mut Vector<'p>,
        x_conv: &Vector<'p>,
    ) -> Result<(), PetscError> {
        self.state.tried += 1;
        if let Some(xb) = &self.before {
            x.axpy(r, x_conv)?;
            x.axpy(-r, xb)?;
        }
        Ok(())
    }

    /// The predicted start of step `step` (0-based) at `target` failed (`iterations`, `why`):
    /// the same increment is tried again from the converged state.
    pub(super) fn failed(&mut self, step: usize, target: f64, iterations: usize, why: &str) {
        if self.debug {
            eprintln!(
                "predicted start failed: step {} load {target}: {iterations} iterations, {why}",
                step + 1
            );
        }
        self.failed_in_step = true;
        self.state.failed += 1;
    }

    /// A step of `increment` in `stage` converged; `x_conv` is the converged state before it.
    pub(super) fn accept(
        &mut self,
        stage: usize,
        increment: f64,
        x_conv: &Vector<'p>,
    ) -> Result<(), PetscError> {
        self.state.last = Some((stage, increment));
        if let Some(xb) = &mut self.before {
            x_conv.copy_to(xb)?;
        }
        Ok(())
    }

    /// What a checkpoint keeps of the predictor.
    pub(super) fn state(&self) -> PredictorState {
        self.state
    }

    /// The converged state before the last one (with the predictor on).
    pub(super) fn before(&self) -> Option<&Vector<'p>> {
        self.before.as_ref()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_predictor_is_given_up_when_more_than_a_fifth_of_eight_or_more_starts_fail() {
        assert!(!predictions_fail(7, 7), "too few tries to judge");
        assert!(!predictions_fail(8, 1));
        assert!(predictions_fail(8, 2));
        assert!(!predictions_fail(100, 20));
        assert!(predictions_fail(100, 21));
    }

    #[test]
    fn predicted_starts_are_counted_per_stage_and_given_up_once() {
        let mut p = PredictorState::default();
        p.enter_stage(0);
        // nothing to extrapolate before the first step
        assert_eq!(p.factor(0, 0.1), None);
        p.last = Some((0, 0.2));
        assert_eq!(p.factor(0, 0.1), Some(0.5));
        // a step of another stage predicts nothing, nor does a zero increment
        assert_eq!(p.factor(1, 0.1), None);
        p.last = Some((0, 0.0));
        assert_eq!(p.factor(0, 0.1), None);
        p.last = Some((0, 0.2));
        // 2 of 8 starts failed: given up, once, and no factor for the rest of the stage
        (p.tried, p.failed) = (8, 2);
        assert!(p.give_up());
        assert!(!p.give_up(), "already given up");
        assert_eq!(p.factor(0, 0.1), None);
        p.enter_stage(0);
        assert!(p.given_up, "the same stage keeps its count");
        // a new stage counts afresh and keeps the last step
        p.enter_stage(1);
        assert_eq!(
            p,
            PredictorState {
                last: Some((0, 0.2)),
                stage: Some(1),
                ..PredictorState::default()
            }
        );
        p.last = Some((1, 0.25));
        assert_eq!(p.factor(1, 0.5), Some(2.0));
    }
}
