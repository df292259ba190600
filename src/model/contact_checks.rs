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
//!   extent along that motion: it can pass through the body between two steps unseen;
//! - a rigid circle, sphere or cylinder whose centre starts inside the body of its surface: an
//!   error (the partner lies in the body, out of reach of the surface's points);
//! - a turn (a `rotation` condition on a body of a frictional pair, or a rigid partner's rotation)
//!   that moves the contact surface, in one nominal step of a stage with friction, by more than
//!   its element size: the return mapping slides each point along the chord of one step, and a
//!   turn of 180 degrees or more per step is not even told apart from the opposite turn;
//! - a rigid partner of a frictional pair that translates along its surface, in one nominal step
//!   of a stage with friction, by more than the surface's element size: the stick and slip of
//!   the slide are not resolved, and the contact zone jumps by more than an element;
//! - a rigid partner that turns, in one nominal step of a stage without friction, by 180 degrees
//!   or more, or that sweeps the surface's farthest control points from its axis by more than
//!   [`STEP_FRACTION`] of the body's size.

use super::data::{Body, Model};
use super::error::ModelError;
use crate::contact::rigid::{RigidMotion, RigidShape};
use crate::contact::{Law, PairDef, Partner};
use crate::scene::{BcSpec, Case};

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
    /// The checks of this module on every pair of `case`: sets
    /// [`contact_warnings`](Model::contact_warnings) and [`absurd_penalties`](Model::absurd_penalties),
    /// or gives the error of a rigid partner that starts inside its body. The front end's
    /// (`check`, `run`): a model built for a test may start anywhere.
    pub fn contact_checks(&mut self, case: &Case) -> Result<(), ModelError> {
        let mut warnings = Vec::new();
        let mut absurd = Vec::new();
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
            let eps_n = match pair.formulation.law {
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
                    absurd.push(format!(
                        "`contact.{i}.{name}` = {eps:e} of pair `{}` ({name} h / E = {ratio:.1e})",
                        pair.name
                    ));
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
                    self.rigid_inside(case, i, &pair.name, *k, &shape.at(motion, 0.0))?;
                    warnings.extend(self.rigid_steps(case, i, &pair.name, *k, shape, motion));
                    warnings.extend(self.rigid_slides(case, i, pair, *k, shape, motion));
                    warnings.extend(self.rigid_turns(case, i, pair, *k, motion));
                }
            }
            warnings.extend(self.frictional_turns(case, i, pair));
        }
        self.contact_warnings = warnings;
        self.absurd_penalties = absurd;
        Ok(())
    }

    /// Refuses a rigid circle, sphere or cylinder (not a cavity) whose centre lies in a cell of
    /// the body of surface `k` (the partner at the start of the first stage).
    fn rigid_inside(
        &self,
        case: &Case,
        i: usize,
        pair: &str,
        k: usize,
        shape: &RigidShape,
    ) -> Result<(), ModelError> {
        let (center, what) = match shape {
            RigidShape::Sphere {
                center,
                inside: false,
                ..
            } => (center, if self.dim == 2 { "circle" } else { "sphere" }),
            RigidShape::Cylinder {
                center,
                inside: false,
                ..
            } => (center, "cylinder"),
            _ => return Ok(()),
        };
        let s = &self.contact_surfaces[k];
        let body = &self.bodies[s.body];
        match cell_containing(body, center) {
            Some(c) => Err(ModelError::Contact {
                file: case.file.clone(),
                key: format!("contact.{i}.rigid"),
                msg: format!(
                    "pair `{pair}`: the rigid {what}'s centre {:?} starts inside body `{}` (in \
                     its cell {c}): the partner lies in the body, where the points of `{}` do \
                     not reach it, and the body would run through it unhindered; place the \
                     partner outside the body",
                    &center[..self.dim],
                    body.name,
                    s.name
                ),
            }),
            None => Ok(()),
        }
    }

    /// Warnings of stages with friction on pair `i` in which a turn moves the pair's surfaces by
    /// more than their element size per nominal step (or by 180 degrees or more): a `rotation`
    /// condition on one of the pair's bodies or the pair's rigid partner's rotation, at the
    /// pair's surface control point farthest from the axis (on the turned body).
    fn frictional_turns(&self, case: &Case, i: usize, pair: &PairDef) -> Vec<String> {
        let Some(friction) = &pair.friction else {
            return Vec::new();
        };
        let h = pair
            .passes
            .iter()
            .map(|(k, _)| self.contact_surfaces[*k].h)
            .fold(f64::INFINITY, f64::min);
        let bodies: Vec<&str> = pair
            .passes
            .iter()
            .map(|(k, _)| self.bodies[self.contact_surfaces[*k].body].name.as_str())
            .collect();
        let mut turns: Vec<Turn> = Vec::new();
        for (j, bc) in case.bcs.iter().enumerate() {
            let BcSpec::Rotation(r) = bc else { continue };
            if !bodies.contains(&r.body.as_str()) {
                continue;
            }
            // the control points of the pair's surfaces on the turned body: they slide
            let nodes: Vec<u32> = pair
                .passes
                .iter()
                .map(|(k, _)| &self.contact_surfaces[*k])
                .filter(|s| self.bodies[s.body].name == r.body)
                .flat_map(|s| s.elements.iter().flat_map(|e| e.nodes.iter().copied()))
                .collect();
            let mut c = [0.0; 3];
            for (d, v) in r.center.iter().take(3).enumerate() {
                c[d] = *v;
            }
            turns.push((
                format!("the rotation of `{}.{}` (`bcs.{j}`)", r.body, r.set),
                format!("bcs.{j}.angle_deg"),
                r.angle_deg.iter().map(|a| a.to_radians()).collect(),
                unit(r.axis.unwrap_or([0.0, 0.0, 1.0])),
                c,
                nodes,
            ));
        }
        for (k, partner) in &pair.passes {
            if let Partner::Rigid(_, motion) = partner {
                if motion.angles.is_empty() {
                    continue;
                }
                let nodes = self.contact_surfaces[*k]
                    .elements
                    .iter()
                    .flat_map(|e| e.nodes.iter().copied())
                    .collect();
                turns.push((
                    "the rigid partner's rotation".to_string(),
                    format!("contact.{i}.rigid.angle_deg"),
                    motion.angles.clone(),
                    motion.axis,
                    motion.center,
                    nodes,
                ));
            }
        }
        let mut out = Vec::new();
        for (what, key, angles, axis, center, nodes) in turns {
            let radius = self.radius_about_axis(nodes.iter().copied(), center, axis);
            let mut first_step = 1;
            for (si, stage) in case.stages.iter().enumerate() {
                let n = stage.steps.max(1);
                let before = if si == 0 {
                    0.0
                } else {
                    angles.get(si - 1).copied().unwrap_or(0.0)
                };
                let turn = (angles.get(si).copied().unwrap_or(before) - before).abs() / n as f64;
                let on = friction.stages.get(si).copied().unwrap_or(true);
                if on && (turn * radius > h || turn >= std::f64::consts::PI) {
                    let half = if turn >= std::f64::consts::PI {
                        " (a turn of 180 degrees or more per step is not even told apart from \
                         the opposite turn: the step can end where it began)"
                    } else {
                        ""
                    };
                    out.push(format!(
                        "contact `{}`: in stage {si} `{}` (nominal steps {first_step} to {}), \
                         {what} turns {:.4} degrees per step, moving contact control points \
                         {:.4e} from its axis by {:.4e} per step, against the contact \
                         surfaces' element size {h:.4e}: friction follows each step along a straight chord, so the \
                         stick and slip of the turn are not resolved{half}; give the stage more \
                         steps (`stages.{si}.steps` = {}) or turn less per stage (`{key}`)",
                        pair.name,
                        stage.name,
                        first_step + n - 1,
                        turn.to_degrees(),
                        radius,
                        turn * radius,
                        stage.steps
                    ));
                }
                first_step += n;
            }
        }
        out
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

    /// Warnings of stages with friction on pair `i` in which its rigid partner (of surface `k`)
    /// translates along the surface by more than the surface's element size per nominal step:
    /// the tangential part of the stage's translation, against the plane's normal or, for a
    /// circle, sphere or cylinder, against the direction from the surface's control point closest
    /// to its centre (or axis) to that centre.
    fn rigid_slides(
        &self,
        case: &Case,
        i: usize,
        pair: &PairDef,
        k: usize,
        shape: &RigidShape,
        motion: &RigidMotion,
    ) -> Vec<String> {
        let Some(friction) = &pair.friction else {
            return Vec::new();
        };
        if motion.translations.is_empty() {
            return Vec::new();
        }
        let s = &self.contact_surfaces[k];
        let shift = |lambda: f64| {
            crate::assembly::dirichlet::stage_lerp(
                &motion.translations,
                lambda,
                [0.0; 3],
                |a, b, f| [0, 1, 2].map(|c| a[c] + (b[c] - a[c]) * f),
            )
        };
        let mut out = Vec::new();
        let mut first_step = 1;
        for (si, stage) in case.stages.iter().enumerate() {
            let n = stage.steps.max(1);
            let on = friction.stages.get(si).copied().unwrap_or(true);
            let (a, b) = (shift(si as f64), shift(si as f64 + 1.0));
            let d = [0, 1, 2].map(|c| (b[c] - a[c]) / n as f64);
            // the partner's normal towards the surface at the start of the stage
            let normal = match shape.at(motion, si as f64) {
                RigidShape::Plane { normal, .. } => unit(normal),
                RigidShape::Sphere { center, .. } => self.towards(s, &center, None),
                RigidShape::Cylinder { center, axis, .. } => {
                    self.towards(s, &center, Some(unit(axis)))
                }
            };
            let t: f64 = (0..3).map(|c| d[c] * normal[c]).sum();
            let slide = (0..3)
                .map(|c| (d[c] - t * normal[c]).powi(2))
                .sum::<f64>()
                .sqrt();
            if on && slide > s.h {
                out.push(format!(
                    "contact `{}`: in stage {si} `{}` (nominal steps {first_step} to {}), the \
                     rigid partner slides {slide:.4e} per step along surface `{}`, more than its \
                     element size {:.4e}: friction follows each step along one straight chord, \
                     so the stick and slip of the slide are not resolved, and the contact zone \
                     jumps by more than an element between two steps; give the stage more steps \
                     (`stages.{si}.steps` = {}) or the partner less motion \
                     (`contact.{i}.rigid.translation`)",
                    pair.name,
                    stage.name,
                    first_step + n - 1,
                    s.name,
                    s.h,
                    stage.steps
                ));
            }
            first_step += n;
        }
        out
    }

    /// Warnings of stages without friction on pair `i` in which its rigid partner (of surface
    /// `k`) turns, per nominal step, by 180 degrees or more (not told apart from the opposite
    /// turn), or moves the surface's control points farthest from its axis by more than
    /// [`STEP_FRACTION`] of the body's largest extent (it can pass through the body between two
    /// steps unseen). Stages with friction: [`Model::frictional_turns`].
    fn rigid_turns(
        &self,
        case: &Case,
        i: usize,
        pair: &PairDef,
        k: usize,
        motion: &RigidMotion,
    ) -> Vec<String> {
        if motion.angles.is_empty() {
            return Vec::new();
        }
        let s = &self.contact_surfaces[k];
        let body = &self.bodies[s.body];
        let (axis, center) = (motion.axis, motion.center);
        let radius = self.radius_about_axis(
            s.elements.iter().flat_map(|e| e.nodes.iter().copied()),
            center,
            axis,
        );
        let size = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
            .iter()
            .take(self.dim)
            .map(|u| self.extent(body.node_offset, body.n_nodes(), u))
            .fold(0.0, f64::max);
        let mut out = Vec::new();
        let mut first_step = 1;
        for (si, stage) in case.stages.iter().enumerate() {
            let n = stage.steps.max(1);
            let frictional = pair
                .friction
                .as_ref()
                .is_some_and(|f| f.stages.get(si).copied().unwrap_or(true));
            let before = if si == 0 {
                0.0
            } else {
                motion.angles.get(si - 1).copied().unwrap_or(0.0)
            };
            let after = motion.angles.get(si).copied().unwrap_or(before);
            let turn = (after - before).abs() / n as f64;
            let half = turn >= std::f64::consts::PI;
            if !frictional && (half || turn * radius > STEP_FRACTION * size) {
                let why = if half {
                    "a turn of 180 degrees or more per step is not told apart from the opposite \
                     turn, and the partner sweeps through the body between two steps unseen"
                } else {
                    "it can pass through the body between two steps unseen (contact is only \
                     evaluated at a step's states)"
                };
                out.push(format!(
                    "contact `{}`: in stage {si} `{}` (nominal steps {first_step} to {}), the \
                     rigid partner turns {:.4e} degrees per step, which moves it by {:.4e} per \
                     step at the control point of surface `{}` farthest from its axis \
                     ({radius:.4e}), against the size {size:.4e} of body `{}`: {why}; give the \
                     stage more steps \
                     (`stages.{si}.steps` = {}) or the partner less turn \
                     (`contact.{i}.rigid.rotation_deg`)",
                    pair.name,
                    stage.name,
                    first_step + n - 1,
                    turn.to_degrees(),
                    turn * radius,
                    s.name,
                    body.name,
                    stage.steps
                ));
            }
            first_step += n;
        }
        out
    }

    /// Unit direction from the control point of surface `s` closest to `center` (or to the axis
    /// through it along unit `axis`) towards it, in the reference configuration; the parts along
    /// `axis` left out.
    fn towards(
        &self,
        s: &crate::contact::surface::ContactSurface,
        center: &[f64; 3],
        axis: Option<[f64; 3]>,
    ) -> [f64; 3] {
        let across = |x: [f64; 3]| {
            let d = [0, 1, 2].map(|c| center[c] - x[c]);
            match axis {
                Some(a) => {
                    let t: f64 = (0..3).map(|c| d[c] * a[c]).sum();
                    [0, 1, 2].map(|c| d[c] - t * a[c])
                }
                None => d,
            }
        };
        let len = |v: &[f64; 3]| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        let closest = s
            .elements
            .iter()
            .flat_map(|e| e.nodes.iter())
            .map(|&n| across(self.position(n)))
            .min_by(|a, b| len(a).total_cmp(&len(b)));
        unit(closest.unwrap_or([0.0; 3]))
    }

    /// Reference position [3] of global node `n`.
    /// The largest distance of `nodes` (reference positions) from the axis through `center`
    /// along the unit vector `axis`.
    fn radius_about_axis(
        &self,
        nodes: impl Iterator<Item = u32>,
        center: [f64; 3],
        axis: [f64; 3],
    ) -> f64 {
        nodes
            .map(|n| {
                let x = self.position(n);
                let d = [0, 1, 2].map(|c| x[c] - center[c]);
                let t: f64 = (0..3).map(|c| d[c] * axis[c]).sum();
                (0..3)
                    .map(|c| (d[c] - t * axis[c]).powi(2))
                    .sum::<f64>()
                    .sqrt()
            })
            .fold(0.0, f64::max)
    }

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

/// What turns (for the message), its key, its angles per stage in radians, unit axis, a point
/// on the axis, and the contact control points it moves.
type Turn = (String, String, Vec<f64>, [f64; 3], [f64; 3], Vec<u32>);

/// `v` normalised (unchanged if zero).
fn unit(v: [f64; 3]) -> [f64; 3] {
    let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    if l > 0.0 {
        v.map(|c| c / l)
    } else {
        v
    }
}

/// The first cell of `body`'s mesh whose corners' simplices (two triangles of a quad, six
/// tetrahedra of a hexahedron about its 0-6 diagonal) contain `x` [3].
fn cell_containing(body: &Body, x: &[f64; 3]) -> Option<usize> {
    let m = &body.mesh;
    let d = m.dim;
    let at = |n: u32| -> [f64; 3] {
        let mut p = [0.0; 3];
        p[..d].copy_from_slice(&m.coords[n as usize * d..(n as usize + 1) * d]);
        p
    };
    const TRIS: [[usize; 3]; 2] = [[0, 1, 2], [0, 2, 3]];
    const TETS: [[usize; 4]; 6] = [
        [0, 1, 2, 6],
        [0, 2, 3, 6],
        [0, 3, 7, 6],
        [0, 7, 4, 6],
        [0, 4, 5, 6],
        [0, 5, 1, 6],
    ];
    (0..m.n_cells()).find(|&c| {
        let nodes = m.cell(c);
        if d == 2 && nodes.len() >= 4 {
            TRIS.iter()
                .any(|t| in_simplex(&t.map(|a| at(nodes[a])), x, 2))
        } else if d == 3 && nodes.len() >= 8 {
            TETS.iter()
                .any(|t| in_simplex(&t.map(|a| at(nodes[a])), x, 3))
        } else {
            false
        }
    })
}

/// Whether `x` lies in the simplex of `v` (a triangle in the plane for `dim` 2, a tetrahedron for
/// 3), boundary included: its barycentric coordinates all non-negative.
fn in_simplex<const N: usize>(v: &[[f64; 3]; N], x: &[f64; 3], dim: usize) -> bool {
    let sub = |a: &[f64; 3], b: &[f64; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    let det = |p: &[[f64; 3]]| -> f64 {
        let e: Vec<[f64; 3]> = p[1..].iter().map(|q| sub(q, &p[0])).collect();
        if dim == 2 {
            e[0][0] * e[1][1] - e[0][1] * e[1][0]
        } else {
            e[0][0] * (e[1][1] * e[2][2] - e[1][2] * e[2][1])
                - e[0][1] * (e[1][0] * e[2][2] - e[1][2] * e[2][0])
                + e[0][2] * (e[1][0] * e[2][1] - e[1][1] * e[2][0])
        }
    };
    let total = det(&v[..]);
    if total == 0.0 {
        return false;
    }
    (0..N).all(|a| {
        let mut p = *v;
        p[a] = *x;
        det(&p[..]) / total >= 0.0
    })
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
