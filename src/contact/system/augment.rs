//! Augmented Lagrangian enforcement (Uzawa) of penalty pairs with `augmented = { tol, max }`: each
//! quadrature point carries a multiplier `lambda` (a pressure) that shifts the penalty law,
//! `t = <lambda - eps_n g_N> n` ([`crate::contact::law::penalty_augmented`]). After a converged
//! Newton solve every point's multiplier becomes its pressure there, `lambda <- <lambda - eps_n
//! g_N>`, and Newton solves again; at the fixed point `lambda = p` the active points have
//! `g_N = 0` whatever `eps_n`. The rounds end when the pair's largest violation of the contact
//! conditions at its points is at most `tol`: a penetration `-g_N`, or the opening `g_N` of a
//! point that still carries pressure.
//!
//! The pointwise constraints are more than the surfaces can always meet: two deformable surfaces
//! each drive their own points' gaps to zero against the other's (non-matching) surface, and an
//! enriched surface has more contact points than control points. The rounds then stall at a
//! violation set by that mismatch, and `tol` must lie above it (docs/user-guide/contact.md,
//! "Augmented Lagrangian").
//!
//! Under the mortar gap the multipliers and the violations are the control points'
//! ([`crate::contact::half_pass::mortar`]).
//!
//! Multipliers are load-step history: the solves of a step start from those of the last converged
//! step, a cut back returns to them, checkpoints keep them.
//!
//! The same rounds place the points of 3D segments at the converged state: those placed at a load
//! step's start and held through its solve are placed again where the converged state's images of
//! the master elements moved by more than `SETTLE` from them, and Newton solves again (at most
//! [`SEGMENT_ROUNDS`] times a step), so the answer depends on the load steps only through kinks
//! left within `SETTLE` of the points' segment boundaries.

use super::ContactSystem;
use crate::assembly::Augment;

/// Most solves a load step makes again for its 3D segments' placement (a layout that changes
/// topology between converged states would otherwise alternate).
const SEGMENT_ROUNDS: usize = 3;

impl ContactSystem {
    /// Whether a pair is augmented or a pass is integrated over 3D segments: exactly when
    /// [`augmentation_violations`](Self::augmentation_violations) is not empty, without
    /// computing it.
    pub fn augments(&self) -> bool {
        self.pairs.iter().any(|p| {
            p.def.formulation.augmented().is_some()
                || p.passes.iter().any(|ps| {
                    ps.segments
                        .as_ref()
                        .is_some_and(super::segments::Segments::three_d)
                })
        })
    }

    /// This rank's largest violation of the contact conditions per pair at the last evaluation
    /// (0 for pairs without augmentation), then with 3D segments each pair's drift of its placed
    /// points ([`ContactSystem::segment_drift`]); empty when no pair is augmented or segmented in
    /// 3D.
    pub fn augmentation_violations(&self) -> Vec<f64> {
        let drift = self.segment_drift();
        if drift.is_empty()
            && self
                .pairs
                .iter()
                .all(|p| p.def.formulation.augmented().is_none())
        {
            return Vec::new();
        }
        let mut out = self.multiplier_violations();
        out.extend(drift);
        out
    }

    /// Whether a pass is integrated over 3D segments and no pair is augmented: the rounds after
    /// a converged solve then only place the segments' points again
    /// ([`crate::assembly::CouplingSet::places_after_solve`]).
    pub fn places_after_solve(&self) -> bool {
        self.pairs
            .iter()
            .all(|p| p.def.formulation.augmented().is_none())
            && self.pairs.iter().flat_map(|p| &p.passes).any(|ps| {
                ps.segments
                    .as_ref()
                    .is_some_and(super::segments::Segments::three_d)
            })
    }

    /// Per pair, the largest violation of the contact conditions at its points at the last
    /// evaluation (0 without augmentation).
    fn multiplier_violations(&self) -> Vec<f64> {
        self.pairs
            .iter()
            .map(|pair| {
                if pair.def.formulation.augmented().is_none() {
                    return 0.0;
                }
                pair.passes
                    .iter()
                    .map(|pass| match &pass.mortar {
                        Some(net) => net.violation(),
                        None => pass
                            .points
                            .iter()
                            .filter_map(|q| {
                                q.gap
                                    .map(|g| if q.p_n > 0.0 { g.abs() } else { (-g).max(0.0) })
                            })
                            .fold(0.0, f64::max),
                    })
                    .fold(0.0, f64::max)
            })
            .collect()
    }

    /// After a converged solve, given each pair's largest violation over all ranks (`violations`,
    /// from [`augmentation_violations`](Self::augmentation_violations)) and the rounds this step
    /// has made: satisfied when every augmented pair is within its `tol`; else, unless a pair
    /// that is not has used its `max` rounds, every augmented point's multiplier becomes its
    /// pressure at the last evaluation. The same decision on every rank.
    pub fn augment(&mut self, violations: &[f64], rounds: usize) -> Augment {
        let n = self.pairs.len();
        let (violations, drift) = violations.split_at(n.min(violations.len()));
        let mut satisfied = true;
        for (pair, &v) in self.pairs.iter().zip(violations) {
            let Some(a) = pair.def.formulation.augmented() else {
                continue;
            };
            if v <= a.tol {
                continue;
            }
            satisfied = false;
            if rounds >= a.max {
                return Augment::Exhausted(format!(
                    "contact `{}`: the augmented Lagrangian left a violation of {v:.3e} > tol \
                     {:.3e} after {rounds} rounds (raise `augmented.max` or `eps_n`, or `augmented.tol` above \
                     what the surfaces can meet: two deformable surfaces' passes, and enriched \
                     surfaces' points, cannot all reach a zero gap)",
                    pair.def.name, a.tol
                ));
            }
        }
        // the 3D segments' points away from the converged state's layout: placed again
        let drifted = drift.iter().any(|&d| d > super::segments::SETTLE);
        if std::env::var_os("NURBS_CONTACT_DEBUG_SEGMENTS").is_some() {
            eprintln!(
                "seg3d: load {}: converged with drift {drift:?} after {rounds} rounds",
                self.lambda
            );
        }
        if drifted && (rounds < SEGMENT_ROUNDS || !satisfied) {
            self.release_segments(drift);
        }
        if satisfied {
            return match drifted && rounds < SEGMENT_ROUNDS {
                true => Augment::Updated,
                false => Augment::Satisfied,
            };
        }
        for pair in self
            .pairs
            .iter_mut()
            .filter(|p| p.def.formulation.augmented().is_some())
        {
            for pass in &mut pair.passes {
                if let Some(net) = &mut pass.mortar {
                    net.augment();
                    continue;
                }
                for q in &mut pass.points {
                    q.trial.lambda = if q.gap.is_some() { q.p_n.max(0.0) } else { 0.0 };
                }
            }
        }
        Augment::Updated
    }
}
