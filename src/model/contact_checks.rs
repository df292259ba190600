//! Set-up checks of the contact pairs, on the reference configuration and the declared stages:
//! inputs that run without an error but whose contact is silently absent or meaningless.
//!
//! - a rigid partner that starts deeper inside its surface than [`START_DEPTH`] of the surface's
//!   element size: an error (the first step would have to push a body out of a partner placed
//!   through it, and the points deeper than the search distance are not paired at all);
//! - a search distance below [`SEARCH_FRACTION`] of the element size: points that move farther
//!   within a Newton iteration lose their partner, the contact force can be zero throughout;
//! - a penalty (`eps_n`, `eps_t`) with `eps h / E` above [`PENALTY_RATIO`]: the tangent's contact
//!   part swamps the bodies' stiffness and Newton stagnates or the factorisation loses the bodies;
//! - a rigid partner whose motion in one nominal step exceeds [`STEP_FRACTION`] of its body's
//!   extent along that motion: it can pass through the body between two steps unseen.

use super::data::Model;
use super::error::ModelError;
use crate::contact::rigid::{RigidMotion, RigidShape};
use crate::contact::{Law, Partner};
use crate::scene::Case;

/// A control point deeper than this fraction of its surface's mean element size inside its rigid
/// partner at the start of the first stage is refused.
pub const START_DEPTH: f64 = 0.5;

/// A search distance below this fraction of the pair's smallest surface element size is warned
/// of. Measured on `cases/hertz_2d.toml` (arc element size 0.098, 0.005 of motion per step): 1e-3
/// and less give zero contact force at every step, 3e-3 and more the default's force.
pub const SEARCH_FRACTION: f64 = 0.1;

/// `eps h / E` above this is warned of. Measured on `cases/hertz_2d.toml` (E = 1, h = 0.098):
/// converged up to eps_n = 1e11 (ratio 1e10), stagnation from eps_n = 1e13 (ratio 1e12), a
/// singular tangent at eps_n = 1e20. The shipped cases' `eps h / E` lie between 12 and 980.
pub const PENALTY_RATIO: f64 = 1e10;

/// A rigid partner's motion in one nominal step above this fraction of its body's extent along
/// the motion is warned of.
pub const STEP_FRACTION: f64 = 0.5;

impl Model {
    /// The checks of this module on every pair of `case`: the warnings, or the error of a rigid
    /// partner that starts deep inside its surface. The front end's (`check`, `run`): a model
    /// built for a test may start anywhere.
    pub fn contact_checks(&self, case: &Case) -> Result<Vec<String>, ModelError> {
        let mut warnings = Vec::new();
        for (i, (pair, spec)) in self.contact_pairs.iter().zip(&case.contact).enumerate() {
            let surfaces: Vec<usize> = pair.passes.iter().map(|(k, _)| *k).collect();
            let h_min = surfaces
                .iter()
                .map(|&k| self.contact_surfaces[k].h)
                .fold(f64::INFINITY, f64::min);
            if pair.search_distance < SEARCH_FRACTION * h_min {
                warnings.push(format!(
                    "contact `{}`: `contact.{i}.search_distance` = {:e} is below {} of the \
                     surfaces' element size {h_min:.3e}: a point that moves farther than that \
                     within a Newton iteration loses its partner, and the contact force can be \
                     zero throughout (the default is twice the largest element size)",
                    pair.name, pair.search_distance, SEARCH_FRACTION
                ));
            }
            let eps_n = match pair.law {
                Law::Penalty { eps_n } | Law::Cohesive { eps_n, .. } => Some(eps_n),
                _ => None,
            };
            let eps_t = spec.eps_t.and(pair.friction.as_ref().map(|f| f.eps_t));
            for (name, eps) in [("eps_n", eps_n), ("eps_t", eps_t)] {
                let Some(eps) = eps else { continue };
                let (ratio, body) = surfaces
                    .iter()
                    .map(|&k| {
                        let s = &self.contact_surfaces[k];
                        let b = &self.bodies[s.body].name;
                        (eps * s.h / case.bodies[b].material.E, b)
                    })
                    .fold((0.0, ""), |m, (r, b)| if r > m.0 { (r, b) } else { m });
                if ratio > PENALTY_RATIO {
                    warnings.push(format!(
                        "contact `{}`: `contact.{i}.{name}` = {eps:e} is absurd against body \
                         `{body}`: {name} h / E = {ratio:.1e} (h the contact surface's element \
                         size, E Young's modulus). Above about {PENALTY_RATIO:.0e} the contact \
                         part of the tangent swamps the bodies' stiffness: Newton stagnates, or \
                         the factorisation loses the bodies' own stiffness and reports a body \
                         that can move freely. The shipped cases use 12 to 980",
                        pair.name
                    ));
                }
            }
            for (k, partner) in &pair.passes {
                if let Partner::Rigid(shape, motion) = partner {
                    self.rigid_start(case, i, &pair.name, *k, &shape.at(motion, 0.0))?;
                    warnings.extend(self.rigid_steps(case, i, &pair.name, *k, shape, motion));
                }
            }
        }
        Ok(warnings)
    }

    /// Refuses a control point of surface `k` deeper than [`START_DEPTH`] of its element size
    /// inside `shape` (the partner at the start of the first stage).
    fn rigid_start(
        &self,
        case: &Case,
        i: usize,
        pair: &str,
        k: usize,
        shape: &RigidShape,
    ) -> Result<(), ModelError> {
        let s = &self.contact_surfaces[k];
        let mut deepest: Option<(f64, u32)> = None;
        for el in &s.elements {
            for &n in &el.nodes {
                let x = self.position(n);
                let Some(p) = shape.project(&x) else { continue };
                let depth = -(0..3).map(|c| p.g[c] * p.n[c]).sum::<f64>();
                if depth > deepest.map_or(0.0, |d| d.0) {
                    deepest = Some((depth, n));
                }
            }
        }
        match deepest {
            Some((depth, n)) if depth > START_DEPTH * s.h => Err(ModelError::Contact {
                file: case.file.clone(),
                key: format!("contact.{i}.rigid"),
                msg: format!(
                    "pair `{pair}`: the rigid partner starts {depth:.4e} deep inside `{}` \
                     ({:.1} element sizes of the surface, {:.3e}), at {}: the first step would \
                     have to push the body out of a partner placed through it, and points \
                     deeper than the search distance ({:.3e}) are not paired at all; place the \
                     partner at or outside the surface",
                    s.name,
                    depth / s.h,
                    s.h,
                    self.node_label(n),
                    self.contact_pairs[i].search_distance
                ),
            }),
            _ => Ok(()),
        }
    }

    /// Warnings of stages in which the rigid partner of surface `k` moves, in one nominal step,
    /// more than [`STEP_FRACTION`] of its body's extent along that motion.
    fn rigid_steps(
        &self,
        case: &Case,
        i: usize,
        pair: &str,
        k: usize,
        shape: &RigidShape,
        motion: &RigidMotion,
    ) -> Vec<String> {
        let s = &self.contact_surfaces[k];
        let body = &self.bodies[s.body];
        let mut out = Vec::new();
        let mut first_step = 1;
        for (si, stage) in case.stages.iter().enumerate() {
            let n = stage.steps.max(1);
            let step_of = |j: usize| si as f64 + j as f64 / n as f64;
            // the partner's reference point over the stage's first step (motion is linear in a
            // stage, so every step of it moves the same)
            let (a, b) = (
                anchor(&shape.at(motion, step_of(0))),
                anchor(&shape.at(motion, step_of(1))),
            );
            let mut d = [0, 1, 2].map(|c| b.0[c] - a.0[c]);
            if let Some((axis, along)) = b.1 {
                // a plane moves only along its normal; a cylinder not along its axis
                let t: f64 = (0..3).map(|c| d[c] * axis[c]).sum();
                d = if along {
                    axis.map(|c| c * t)
                } else {
                    [0, 1, 2].map(|c| d[c] - t * axis[c])
                };
            }
            let len = (0..3).map(|c| d[c] * d[c]).sum::<f64>().sqrt();
            if len > 0.0 {
                let u = d.map(|c| c / len);
                let extent = self.extent(body.node_offset, body.n_nodes(), &u);
                if len > STEP_FRACTION * extent {
                    out.push(format!(
                        "contact `{pair}`: in stage {si} `{}` (nominal steps {first_step} to \
                         {}), the rigid partner moves {len:.4e} per step, against an extent of \
                         {extent:.4e} of body `{}` along that motion: it can pass through the \
                         body between two steps unseen (contact is only evaluated at a step's \
                         states); give the stage more steps (`stages.{si}.steps` = {}) or the \
                         partner less motion (`contact.{i}.rigid`)",
                        stage.name,
                        first_step + n - 1,
                        body.name,
                        stage.steps
                    ));
                }
            }
            first_step += n;
        }
        out
    }

    /// Reference position [3] of global node `n`.
    fn position(&self, n: u32) -> [f64; 3] {
        let mut x = [0.0; 3];
        let d = self.dim;
        x[..d].copy_from_slice(&self.coords[n as usize * d..(n as usize + 1) * d]);
        x
    }

    /// Extent along unit `u` of the nodes `first..first + count` (reference positions).
    fn extent(&self, first: u32, count: usize, u: &[f64; 3]) -> f64 {
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for n in first..first + count as u32 {
            let x = self.position(n);
            let t: f64 = (0..3).map(|c| x[c] * u[c]).sum();
            lo = lo.min(t);
            hi = hi.max(t);
        }
        (hi - lo).max(0.0)
    }
}

/// A shape's reference point (a plane's point, a sphere's or cylinder's centre) and, for a plane
/// and a cylinder, its direction with whether motion counts along it (plane normal) or across it
/// (cylinder axis).
fn anchor(shape: &RigidShape) -> ([f64; 3], Option<([f64; 3], bool)>) {
    match shape {
        RigidShape::Plane { point, normal } => (*point, Some((*normal, true))),
        RigidShape::Sphere { center, .. } => (*center, None),
        RigidShape::Cylinder { center, axis, .. } => (*center, Some((*axis, false))),
    }
}
