//! Newton at the kink of the penalty law: active-set stabilisation.
//!
//! The penalty traction `eps_n <-g_n>` of eq. (5) is not differentiable at `g_n = 0`. On a faceted
//! surface a point can sit there over a range of loads, and Newton then cycles: the point is active
//! at one iterate, inactive at the next, and the linearisations of the two sides send it back and
//! forth (REPRODUCTION.md 4.1). The remedy is an active-set strategy on top of Newton:
//!
//! - after `freeze_after` Newton iterates (Jacobian evaluations) of a step attempt, a point whose
//!   status (active: `g_n <= touch`, the law's own test) has changed at least three times between iterates
//!   keeps its status at that iterate, for the residual and the tangent alike, until the solve ends:
//!   the system Newton then solves is smooth near those points;
//! - when that solve converges, every frozen status is compared with the one the law gives at the
//!   converged state. If all agree, the frozen residual *is* the law's residual there (the same
//!   branch of eq. (5) at every point, bit for bit), so the state satisfies eq. (5) to the solver's
//!   tolerance and is accepted. Otherwise the disagreeing points take the status the law gives
//!   there (a primal-dual active-set update) and Newton resumes from the converged state; after
//!   [`MAX_ROUNDS`] such rounds every point is released and Newton goes on with the plain law (a
//!   failure then cuts the step back, as without the stabilisation).
//!
//! Only frictionless penalty pairs take part (friction and the cohesive law are left alone).

use super::ContactSystem;
use crate::contact::pair::{Law, TOUCH};

/// Active-set updates of one step attempt before every point is released.
pub const MAX_ROUNDS: usize = 4;

/// Status changes between Newton iterates after which a point is frozen: in, out and in again
/// (a point entering or leaving the contact zone once, or overshooting once, is left alone).
const MIN_FLIPS: u8 = 3;

/// The state of one quadrature point during a step attempt.
#[derive(Debug, Clone, Copy, Default)]
struct Track {
    /// The law's status (active) at the last Newton iterate.
    last: Option<bool>,
    /// Status changes between consecutive iterates.
    flips: u8,
    /// The status the residual and tangent use instead of the law's test.
    frozen: Option<bool>,
}

/// The active-set stabilisation state of a contact system (reset at every commit and rollback).
#[derive(Debug, Clone, Default)]
pub(super) struct ActiveSet {
    /// Freeze after this many Newton iterates of a step attempt (0: never).
    pub(super) freeze_after: usize,
    /// Newton iterates (Jacobian evaluations) since the last reset.
    iterates: usize,
    /// Active-set updates since the last reset.
    rounds: usize,
    /// No more freezing until the next reset (the rounds ran out).
    released: bool,
    /// Per half-pass (numbered over all pairs), per point.
    tracks: Vec<Vec<Track>>,
}

impl ActiveSet {
    /// The status point `q` of half-pass `pass` is held at, if it is frozen.
    pub(crate) fn forced(&self, pass: usize, q: usize) -> Option<bool> {
        self.tracks.get(pass)?.get(q)?.frozen
    }

    /// Back to a fresh step attempt.
    pub(super) fn reset(&mut self) {
        self.iterates = 0;
        self.rounds = 0;
        self.released = false;
        for t in &mut self.tracks {
            t.clear();
        }
    }
}

/// What [`ContactSystem::settle_active_set`] decides: the assembler's [`Settle`].
pub use crate::assembly::Settle;

/// The law's status of a point with normal gap `gap` (`None`: no partner within reach).
fn natural(gap: Option<f64>, touch: f64) -> bool {
    gap.is_some_and(|g| g <= touch)
}

impl ContactSystem {
    /// Newton iterates after which a point whose status keeps changing is frozen (0: never; the
    /// default).
    pub fn set_freeze_after(&mut self, iterates: usize) {
        self.active_set.freeze_after = iterates;
    }

    /// Newton iterates after which a point whose status keeps changing is frozen (0: never).
    pub fn freeze_after(&self) -> usize {
        self.active_set.freeze_after
    }

    /// Frozen points of this rank.
    pub fn frozen_points(&self) -> usize {
        self.active_set
            .tracks
            .iter()
            .flatten()
            .filter(|t| t.frozen.is_some())
            .count()
    }

    /// The half-passes whose points take part: frictionless penalty pairs.
    fn eligible_passes(&self) -> Vec<(usize, usize, usize)> {
        let mut out = Vec::new();
        let mut id = 0;
        for (pi, pair) in self.pairs.iter().enumerate() {
            let on = matches!(pair.def.law, Law::Penalty { .. }) && pair.def.friction.is_none();
            for qi in 0..pair.passes.len() {
                if on {
                    out.push((id, pi, qi));
                }
                id += 1;
            }
        }
        out
    }

    /// After the tangent of a Newton iterate was assembled (its gaps are those of the iterate):
    /// counts status changes and freezes the points that keep changing.
    pub(super) fn observe_iterate(&mut self) {
        let a = &mut self.active_set;
        if a.freeze_after == 0 || a.released {
            return;
        }
        a.iterates += 1;
        let n_pass: usize = self.pairs.iter().map(|p| p.passes.len()).sum();
        if a.tracks.len() < n_pass {
            a.tracks.resize(n_pass, Vec::new());
        }
        for (id, pi, qi) in self.eligible_passes() {
            let pass = &self.pairs[pi].passes[qi];
            let touch = TOUCH * self.surfaces[pass.k].h;
            let a = &mut self.active_set;
            let tracks = &mut a.tracks[id];
            tracks.resize(pass.points.len(), Track::default());
            for (t, p) in tracks.iter_mut().zip(&pass.points) {
                let now = natural(p.gap, touch);
                if t.last.is_some_and(|l| l != now) {
                    t.flips = t.flips.saturating_add(1);
                }
                t.last = Some(now);
                if t.frozen.is_none() && t.flips >= MIN_FLIPS && a.iterates >= a.freeze_after {
                    // the status at this iterate: the residual just evaluated here is unchanged
                    t.frozen = Some(now);
                    if std::env::var_os("NURBS_CONTACT_DEBUG_ACTIVE_SET").is_some() {
                        eprintln!(
                            "active set: iterate {} freezes pass {id} point at X {:?} {} (gap {:?})",
                            a.iterates,
                            &p.X[..2],
                            if now { "active" } else { "inactive" },
                            p.gap
                        );
                    }
                }
            }
        }
    }

    /// This rank's frozen points whose status disagrees with the law at the last evaluation (the
    /// converged state).
    pub fn inconsistent_points(&self) -> usize {
        let mut n = 0;
        for (id, pi, qi) in self.eligible_passes() {
            let pass = &self.pairs[pi].passes[qi];
            let touch = TOUCH * self.surfaces[pass.k].h;
            let Some(tracks) = self.active_set.tracks.get(id) else {
                continue;
            };
            for (t, p) in tracks.iter().zip(&pass.points) {
                if t.frozen.is_some_and(|f| f != natural(p.gap, touch)) {
                    n += 1;
                }
            }
        }
        n
    }

    /// After a converged Newton solve, given the number of inconsistent frozen points on all ranks
    /// (the sum of [`inconsistent_points`](Self::inconsistent_points)) and whether any rank had
    /// frozen points: releases every point when all agree with the law, else gives the disagreeing
    /// ones the law's status (or releases all once [`MAX_ROUNDS`] updates were made). The same
    /// decision on every rank.
    pub fn settle_active_set(&mut self, any_frozen: bool, inconsistent: usize) -> Settle {
        if !any_frozen {
            return Settle::Free;
        }
        if std::env::var_os("NURBS_CONTACT_DEBUG_ACTIVE_SET").is_some() {
            eprintln!(
                "active set: converged with {} frozen, {inconsistent} inconsistent (round {})",
                self.frozen_points(),
                self.active_set.rounds
            );
        }
        let release = |a: &mut ActiveSet| {
            for t in a.tracks.iter_mut().flatten() {
                t.frozen = None;
            }
        };
        if inconsistent == 0 {
            release(&mut self.active_set);
            return Settle::Consistent;
        }
        self.active_set.rounds += 1;
        if self.active_set.rounds > MAX_ROUNDS {
            release(&mut self.active_set);
            self.active_set.released = true;
            return Settle::Resume;
        }
        for (id, pi, qi) in self.eligible_passes() {
            let pass = &self.pairs[pi].passes[qi];
            let touch = TOUCH * self.surfaces[pass.k].h;
            let Some(tracks) = self.active_set.tracks.get_mut(id) else {
                continue;
            };
            for (t, p) in tracks.iter_mut().zip(&pass.points) {
                if t.frozen.is_some() {
                    t.frozen = Some(natural(p.gap, touch));
                }
            }
        }
        Settle::Resume
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::contact::tests::Harness;

    /// A faceted (Q1C1) half disk over a rigid flat; returns the harness and the smallest gap of
    /// its points at zero displacement (the lowest points, which a vertical shift brings to the
    /// kink).
    fn scene(freeze_after: usize) -> (Harness, f64) {
        let case = crate::contact::tests::case_rigid(
            2,
            "Q1C1",
            "{ shape = \"plane\", point = [0.0, 0.0], normal = [0.0, 1.0] }",
        );
        let mut h = Harness::new(&case);
        h.sys.set_freeze_after(freeze_after);
        let u0 = vec![0.0; h.n()];
        h.eval(&u0, false);
        let g0 = h
            .sys
            .point_records()
            .chunks_exact(super::super::POINT_RECORD)
            .map(|r| r[10])
            .fold(f64::INFINITY, f64::min);
        assert!(g0 > 1e-3, "the lowest point is above the flat: {g0}");
        (h, g0)
    }

    /// Vertical shift putting the lowest points at normal gap `g`.
    fn at_gap(h: &Harness, g0: f64, g: f64) -> Vec<f64> {
        h.displacement(&|_, _| vec![0.0, g - g0])
    }

    #[test]
    fn points_that_alternate_at_the_kink_are_frozen_and_settled_on_the_law() {
        let (mut h, g0) = scene(3);
        let (ua, ub) = (at_gap(&h, g0, -1e-7), at_gap(&h, g0, 1e-7));
        let (plain_b, _) = h.eval(&ub, false);
        // Newton iterates alternating across the kink: inactive, active, inactive, active
        for (i, u) in [&ub, &ua, &ub, &ua].into_iter().enumerate() {
            assert_eq!(h.sys.frozen_points(), 0, "frozen before iterate {}", i + 1);
            h.eval(u, true);
        }
        // fourth iterate, third change: the lowest points are held active
        let frozen = h.sys.frozen_points();
        assert!(frozen >= 1, "nothing frozen after a 2-cycle");
        // at the inactive side the held points now pull (the linear branch continued): the
        // residual differs from the law's, and the tangent keeps their stiffness
        let (held_b, k) = h.eval(&ub, true);
        let diff = held_b
            .iter()
            .zip(&plain_b)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(diff > 0.0, "a held point changes nothing");
        assert!(k.unwrap().iter().any(|&v| v != 0.0), "no held stiffness");
        // converged there: the held status disagrees with the law; an update gives them the law's
        assert_eq!(h.sys.inconsistent_points(), frozen);
        assert_eq!(h.sys.settle_active_set(true, frozen), Settle::Resume);
        assert_eq!(
            h.sys.frozen_points(),
            frozen,
            "still held, with the law's status"
        );
        assert_eq!(h.sys.inconsistent_points(), 0);
        let (updated_b, _) = h.eval(&ub, false);
        assert_eq!(
            updated_b, plain_b,
            "consistent: the law's residual, bit for bit"
        );
        // converged with every held point consistent: all released, the state is the law's
        assert_eq!(h.sys.settle_active_set(true, 0), Settle::Consistent);
        assert_eq!(h.sys.frozen_points(), 0);
        assert_eq!(h.eval(&ub, false).0, plain_b);
    }

    #[test]
    fn alternating_points_are_left_alone_before_the_iterate_limit_and_without_the_option() {
        for (freeze_after, iterates) in [(0, 8), (6, 5), (1, 3)] {
            let (mut h, g0) = scene(freeze_after);
            let (ua, ub) = (at_gap(&h, g0, -1e-7), at_gap(&h, g0, 1e-7));
            for i in 0..iterates {
                h.eval(if i % 2 == 0 { &ua } else { &ub }, true);
            }
            assert_eq!(h.sys.frozen_points(), 0, "freeze_after {freeze_after}");
        }
        // residual evaluations (line search trials) are not iterates
        let (mut h, g0) = scene(1);
        let (ua, ub) = (at_gap(&h, g0, -1e-7), at_gap(&h, g0, 1e-7));
        for i in 0..6 {
            h.eval(if i % 2 == 0 { &ua } else { &ub }, false);
        }
        assert_eq!(h.sys.frozen_points(), 0);
    }

    #[test]
    fn active_set_rounds_end_with_every_point_released_and_a_commit_starts_afresh() {
        let (mut h, g0) = scene(2);
        let (ua, ub) = (at_gap(&h, g0, -1e-7), at_gap(&h, g0, 1e-7));
        let cycle = |h: &mut Harness| {
            for u in [&ub, &ua, &ub, &ua] {
                h.eval(u, true);
            }
        };
        cycle(&mut h);
        let frozen = h.sys.frozen_points();
        assert!(frozen >= 1);
        // a pair of active sets that never agree with the law (a fold at the kink)
        for _ in 0..MAX_ROUNDS {
            assert_eq!(h.sys.settle_active_set(true, frozen), Settle::Resume);
            assert_eq!(h.sys.frozen_points(), frozen);
        }
        assert_eq!(h.sys.settle_active_set(true, frozen), Settle::Resume);
        assert_eq!(h.sys.frozen_points(), 0, "released after the last round");
        cycle(&mut h);
        assert_eq!(h.sys.frozen_points(), 0, "no freezing after the release");
        assert_eq!(h.sys.settle_active_set(false, 0), Settle::Free);
        // the next step attempt starts afresh
        h.sys.commit();
        cycle(&mut h);
        assert_eq!(h.sys.frozen_points(), frozen);
        h.sys.rollback();
        assert_eq!(h.sys.frozen_points(), 0);
    }
}
