//! The pseudo-transient rescue of a step that fails at the minimum increment.

use super::pattern::solve_resuming;
use super::{SolverError, StepControl, System};
use crate::petsc::{SolveOutcome, Vector};
use crate::solver::judge::judge;

/// The rescue of a step that fails at the minimum increment: damped (pseudo-transient) solves
/// towards the next equilibrium ([`PseudoTransient::rescue`]).
#[derive(Debug)]
pub(super) struct PseudoTransient<'c> {
    /// Damped solves allowed (`[steps] pseudo_steps`); 0: no rescue.
    max_steps: usize,
    /// The options that change when SNES calls a solve converged (for the run's own verdict).
    overrides: &'c [String],
    /// Print every pseudo-step (`NURBS_CONTACT_DEBUG_RESCUE`).
    debug: bool,
}

impl<'c> PseudoTransient<'c> {
    /// The rescue `control` allows.
    pub(super) fn new(control: &'c StepControl, debug: bool) -> Self {
        PseudoTransient {
            max_steps: control.pseudo_steps,
            overrides: &control.newton_overrides,
            debug,
        }
    }

    /// Whether a step failing at the minimum increment is rescued at all.
    pub(super) fn enabled(&self) -> bool {
        self.max_steps > 0
    }

    /// Pseudo-transient rescue of a step that failed at the smallest increment, at the load
    /// already set (its prescribed values and load parameter): a snap-through has no equilibrium
    /// near the last one, so Newton from it diverges however small the step. Damped solves of
    /// `F(u) + c D (u - u_prev) = 0` (`D` the stiffness diagonal at the converged state, `c`
    /// adapted: divided by 2 after a damped solve converges, multiplied by 8 after one fails) let
    /// the state flow towards the next equilibrium, one `u_prev` after another; when the flow
    /// slows down past the snap ([`UndampedTrigger`]), an undamped Newton solve is tried from
    /// there, and the first that converges to an untangled state ends the rescue with a true
    /// equilibrium. Returns that solve and the number of damped solves; an undamped solve that
    /// converges to a folded state ends the rescue at once ([`Rescue::Tangled`]: the flow went
    /// through the body itself); after `pseudo_steps` damped solves without an equilibrium,
    /// [`Rescue::Failed`]. Unless found, `x` is back at the converged state; the run stops.
    ///
    /// Collective.
    pub(super) fn rescue<'p>(
        &self,
        sys: &mut System<'_, 'p>,
        x_conv: &Vector<'p>,
    ) -> Result<Rescue, SolverError> {
        let max_steps = self.max_steps;
        let debug = self.debug;
        x_conv.copy_to(sys.x)?;
        if sys.asm.compute_damping_diagonal(sys.x).is_err() {
            return Ok(Rescue::Failed);
        }
        let mut u_prev = x_conv.duplicate()?;
        x_conv.copy_to(&mut u_prev)?;
        let mut c = Damping::default();
        let mut total_iterations = 0;
        let mut outcome = Rescue::Failed;
        let mut trigger = UndampedTrigger::default();
        for k in 1..=max_steps {
            sys.asm.set_damping(c.0, &u_prev)?;
            u_prev.copy_to(sys.x)?;
            let damped = solve_resuming(sys)?;
            total_iterations += damped.iterations;
            if !damped.converged {
                sys.asm.rollback();
                if !c.stiffen() {
                    break;
                }
                continue;
            }
            // the damped state is the next pseudo-time point: warm starts follow it, the friction
            // anchors stay the last converged step's (the rescue solves this step's equations, it
            // does not change them)
            let force = sys.asm.damping_force_norm(sys.x)?;
            sys.asm.commit_intermediate();
            sys.x.copy_to(&mut u_prev)?;
            c.relax(damped.iterations);
            if debug {
                eprintln!(
                    "rescue {k}: c {:.2e}, damped solve {} iterations, damping force {force:.3e}",
                    c.0, damped.iterations
                );
            }
            if !trigger.observe(force, k == max_steps) {
                continue;
            }
            sys.asm.set_damping(0.0, &u_prev)?;
            let mut plain = solve_resuming(sys)?;
            total_iterations += plain.iterations;
            if plain.converged {
                if let Some(why) = judge(sys.asm, sys.x, &mut plain, self.overrides)? {
                    plain.converged = false;
                    plain.reason = why;
                }
            }
            if debug {
                eprintln!(
                    "  undamped solve: {} after {} iterations",
                    plain.reason, plain.iterations
                );
            }
            if plain.converged {
                // acceptance: an equilibrium folded over somewhere is refused
                if let Some(fold) = sys.asm.find_tangled(sys.x)? {
                    if debug {
                        eprintln!("  refused: {fold}");
                    }
                    outcome = Rescue::Tangled(fold);
                    break;
                }
                plain.iterations = total_iterations;
                outcome = Rescue::Found(plain, k);
                break;
            }
            sys.asm.rollback();
            u_prev.copy_to(sys.x)?;
        }
        sys.asm.set_damping(0.0, &u_prev)?;
        if !matches!(outcome, Rescue::Found(..)) {
            sys.asm.rollback();
            x_conv.copy_to(sys.x)?;
        }
        Ok(outcome)
    }
}

/// The damping factor `c` of the rescue's pseudo-steps: 1 at first, 8 times larger after a damped
/// solve fails, half as large (down to 1e-10) after one converges easily.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Damping(f64);

impl Default for Damping {
    fn default() -> Self {
        Damping(1.0)
    }
}

impl Damping {
    /// A damped solve at most this many Newton iterations long converged easily.
    const EASY: usize = 4;

    /// A damped solve failed: damps 8 times more. False once `c` exceeds 1e8: no damping makes
    /// the flow converge, the rescue ends.
    fn stiffen(&mut self) -> bool {
        self.0 *= 8.0;
        self.0 <= 1e8
    }

    /// A damped solve converged in `iterations` Newton iterations: an easy one halves `c`.
    fn relax(&mut self, iterations: usize) {
        if iterations <= Self::EASY {
            self.0 = (self.0 * 0.5).max(1e-10);
        }
    }
}

/// How a [`PseudoTransient::rescue`] ended.
pub(super) enum Rescue {
    /// An untangled equilibrium: the undamped solve that reached it and the damped solves taken.
    Found(SolveOutcome, usize),
    /// An undamped solve converged to a folded state (where, as a message); refused.
    Tangled(String),
    /// No equilibrium within the allowed damped solves.
    Failed,
}

/// When the rescue tries an undamped Newton solve, from the damping force `c D (u - u_prev)` after
/// each damped solve (the flow's speed). Near the vanished equilibrium the flow first slows down
/// (it creeps past the ghost of the fold) and no equilibrium is there: undamped solves fail. Then
/// it speeds up (the snap) and slows down again as it nears the next equilibrium. So an undamped
/// solve is tried only while the flow slows down after having sped up at least once, or once it
/// has nearly stopped (the force below [`Self::NEAR_REST`] of its first value: an equilibrium
/// close by, no snap), and at the last pseudo-step. (Trying at every slowing pseudo-step spent up
/// to a third of a hard run's Newton iterations in undamped solves that failed, for the same
/// equilibria.)
#[derive(Debug, Clone, Default)]
struct UndampedTrigger {
    first: Option<f64>,
    last: Option<f64>,
    sped_up: bool,
}

impl UndampedTrigger {
    const NEAR_REST: f64 = 1e-3;

    /// Takes the damping force after a converged damped solve; true: try an undamped solve now.
    fn observe(&mut self, force: f64, last_step: bool) -> bool {
        let first = *self.first.get_or_insert(force);
        let slowing = self.last.is_some_and(|l| force < l);
        if self.last.is_some_and(|l| force > l) {
            self.sped_up = true;
        }
        self.last = Some(force);
        (slowing && self.sped_up) || force < Self::NEAR_REST * first || last_step
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The pseudo-steps at which the trigger tries an undamped solve, for a sequence of damping
    /// forces (the last one is the rescue's last pseudo-step).
    fn tries(forces: &[f64]) -> Vec<usize> {
        let mut t = UndampedTrigger::default();
        (0..forces.len())
            .filter(|&k| t.observe(forces[k], k + 1 == forces.len()))
            .collect()
    }

    #[test]
    fn undamped_solves_are_tried_once_the_flow_slows_down_after_a_snap() {
        // damping forces of a measured rescue (frictional ironing, Q1N2): the flow creeps past the
        // vanished equilibrium, speeds up, and slows down towards the next one
        let snap = [
            4.35e-4, 3.42e-4, 2.44e-4, 1.62e-4, 1.09e-4, 1.17e-5, 1.21e-5, 1.44e-4, 2.90e-3,
            1.43e-2, 2.13e-2, 1.91e-2, 1.5e-2, 1.6e-2,
        ];
        // not while it creeps (every step before the rise), from the first slowing after it
        assert_eq!(tries(&snap), vec![11, 12, 13]);
        // a flow that only slows down: when it has nearly stopped, and at the last pseudo-step
        let rest = [1e-3, 5e-4, 1e-4, 1e-5, 2e-6, 9e-7, 1e-7, 5e-8];
        assert_eq!(tries(&rest), vec![5, 6, 7]);
        let creep = [1e-3, 9e-4, 8e-4, 7e-4];
        assert_eq!(tries(&creep), vec![3]);
        // a single pseudo-step is the last one
        assert_eq!(tries(&[1e-3]), vec![0]);
    }

    #[test]
    fn the_damping_grows_8_fold_after_failures_until_1e8_and_halves_after_easy_solves() {
        let mut c = Damping::default();
        // 8^8 = 1.7e7 is allowed, 8^9 = 1.3e8 ends the rescue: the ninth failure in a row
        let failures = (1..=20).find(|_| !c.stiffen()).unwrap();
        assert_eq!(failures, 9);
        let mut c = Damping(0.5);
        c.relax(5);
        assert_eq!(c, Damping(0.5), "a hard solve keeps it");
        c.relax(4);
        assert_eq!(c, Damping(0.25));
        for _ in 0..100 {
            c.relax(1);
        }
        assert_eq!(c, Damping(1e-10), "down to 1e-10, not to 0");
    }
}
