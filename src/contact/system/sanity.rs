//! Contact that is silently not there, or that its steps cannot follow:
//! - the control points of a half-pass's surface that lie inside its partner (a rigid shape or
//!   the partner surface's body) while none of the half-pass's points is active (a smooth contact
//!   surface lies inside its control points and may not reach a partner that the mesh goes
//!   through; nothing then holds the body there). With two half-passes, either one's active
//!   points hold the pair;
//! - the points of a surface that start inside their partner at load 0 (an initial overlap the
//!   first step has to push out);
//! - the tangential gap a frictional point gathered within one step (its slip and stick over the
//!   step's increment, followed along a straight chord).

use super::ContactSystem;
use crate::contact::pair::Partner;
use crate::contact::rigid::RigidShape;

/// The deepest point of this rank's elements of one half-pass inside its partner
/// ([`ContactSystem::unseen_penetrations`],
/// [`ContactSystem::initial_penetrations`]).
#[derive(Debug, Clone, PartialEq)]
pub struct PassDepth {
    /// The pair's name.
    pub pair: String,
    /// The half-pass's surface, `body.face_set`.
    pub surface: String,
    /// The partner surface, `body.face_set` (`None`: a rigid partner).
    pub partner: Option<String>,
    /// Depth of the deepest point inside the partner (0: none inside), the global node (the
    /// control point itself, or the node of the point's element closest to it) and the point's
    /// position [3].
    pub depth: f64,
    pub node: u32,
    pub position: [f64; 3],
    /// Mean element edge length of the surface.
    pub h: f64,
}

/// The largest tangential gap of this rank's points of one frictional half-pass in the last
/// evaluation: their tangential motion against the partner since the anchors of the last
/// converged step ([`ContactSystem::step_slips`]).
#[derive(Debug, Clone, PartialEq)]
pub struct PassSlip {
    /// The pair's name.
    pub pair: String,
    /// The half-pass's surface, `body.face_set`.
    pub surface: String,
    /// Length of the largest tangential gap, and its point's current position [3].
    pub slip: f64,
    pub position: [f64; 3],
    /// Mean element edge length of the surface.
    pub h: f64,
}

/// Depth of `x` [3] inside `shape` (negative: outside; `None`: no closest point).
fn depth_in_shape(shape: &RigidShape, x: &[f64; 3]) -> Option<f64> {
    let p = shape.project(x)?;
    Some(-(0..3).map(|c| p.g[c] * p.n[c]).sum::<f64>())
}

impl ContactSystem {
    /// Per half-pass (in pair and pass order, the same list on every rank): the active points
    /// of its pair (all half-passes) on this rank at the last evaluation.
    pub fn pair_active(&self) -> Vec<u64> {
        self.pairs
            .iter()
            .flat_map(|p| {
                let n: usize = p.passes.iter().map(|q| q.result.n_active).sum();
                std::iter::repeat_n(n as u64, p.passes.len())
            })
            .collect()
    }

    /// Per half-pass (in pair and pass order, the same list on every rank): the deepest control
    /// point of this rank's surface elements inside the partner at the last evaluation (a rigid
    /// shape, or the partner surface within the pair's search distance), only for the
    /// half-passes `wanted` marks (the others: depth 0). The caller reduces them over the ranks.
    pub fn unseen_penetrations(&mut self, wanted: &[bool]) -> Vec<PassDepth> {
        let dim = self.dim;
        let mut out = Vec::new();
        let mut id = 0;
        for i in 0..self.pairs.len() {
            let dist = self.pairs[i].def.search_distance;
            for j in 0..self.pairs[i].passes.len() {
                let mut d = self.pass_depth(i, j);
                id += 1;
                if !wanted.get(id - 1).copied().unwrap_or(false) {
                    out.push(d);
                    continue;
                }
                let pass = &self.pairs[i].passes[j];
                let (k, shape, partner) = (pass.k, pass.shape.clone(), pass.partner.clone());
                let elems: Vec<usize> = pass.elems.iter().map(|oe| oe.e as usize).collect();
                for e in elems {
                    if !self.pos[k].has(e) {
                        continue;
                    }
                    for a in 0..self.surfaces[k].elements[e].nodes.len() {
                        let mut x = [0.0; 3];
                        x[..dim].copy_from_slice(&self.pos[k].of(e)[a * dim..(a + 1) * dim]);
                        let depth = match (&partner, &shape) {
                            (Partner::Rigid(..), Some(shape)) => depth_in_shape(shape, &x),
                            (Partner::Surface(l), _) => self.depth_below(*l, &x, dist),
                            _ => None,
                        };
                        if let Some(depth) = depth.filter(|&g| g > d.depth) {
                            d.depth = depth;
                            d.node = self.surfaces[k].elements[e].nodes[a];
                            d.position = x;
                        }
                    }
                }
                out.push(d);
            }
        }
        out
    }

    /// Per half-pass (as [`ContactSystem::unseen_penetrations`]): the deepest quadrature point of
    /// this rank's surface elements inside the partner in the reference configuration with the
    /// rigid partners at load 0, named by the node of its element closest to it. Moves the held
    /// positions to the reference configuration (the next update moves them back).
    pub fn initial_penetrations(&mut self) -> Vec<PassDepth> {
        let dim = self.dim;
        let zero = vec![0.0; self.table.len() * dim];
        self.update_positions(&zero);
        self.last_update = None;
        let mut out = Vec::new();
        for i in 0..self.pairs.len() {
            let dist = self.pairs[i].def.search_distance;
            for j in 0..self.pairs[i].passes.len() {
                let mut d = self.pass_depth(i, j);
                let pass = &self.pairs[i].passes[j];
                let k = pass.k;
                let shape = match &pass.partner {
                    Partner::Rigid(shape, motion) => Some(shape.at(motion, 0.0)),
                    Partner::Surface(_) => None,
                };
                let partner = pass.partner.clone();
                let points: Vec<(usize, [f64; 3])> = pass
                    .elems
                    .iter()
                    .flat_map(|oe| {
                        pass.points[oe.first..oe.first + oe.n]
                            .iter()
                            .filter(|q| q.w != 0.0)
                            .map(move |q| (oe.e as usize, q.X))
                    })
                    .collect();
                for (e, x) in points {
                    let depth = match (&partner, &shape) {
                        (Partner::Rigid(..), Some(shape)) => depth_in_shape(shape, &x),
                        (Partner::Surface(l), _) => self.depth_below(*l, &x, dist),
                        _ => None,
                    };
                    let Some(depth) = depth.filter(|&g| g > d.depth) else {
                        continue;
                    };
                    d.depth = depth;
                    d.position = x;
                    // the element's node closest to the point
                    let el = &self.surfaces[k].elements[e];
                    let mut best = f64::INFINITY;
                    for &n in &el.nodes {
                        let X = &self.all_X[self.node_index(n) * dim..][..dim];
                        let r: f64 = (0..dim).map(|c| (X[c] - x[c]).powi(2)).sum();
                        if r < best {
                            best = r;
                            d.node = n;
                        }
                    }
                }
                out.push(d);
            }
        }
        out
    }

    /// Per frictional half-pass (in pair and pass order, the same list on every rank): the
    /// largest tangential gap of this rank's points at the last evaluation (0 in a stage without
    /// friction). The caller reduces them over the ranks.
    pub fn step_slips(&self) -> Vec<PassSlip> {
        let mut out = Vec::new();
        for pair in self.pairs.iter().filter(|p| p.def.friction.is_some()) {
            for pass in &pair.passes {
                let surface = &self.surfaces[pass.k];
                let mut s = PassSlip {
                    pair: pair.def.name.clone(),
                    surface: surface.name.clone(),
                    slip: 0.0,
                    position: [0.0; 3],
                    h: surface.h,
                };
                // a stage without friction carries no tangential gaps of its own
                let on = pair
                    .def
                    .friction
                    .as_ref()
                    .is_some_and(|f| f.on_at(self.lambda));
                for oe in pass.elems.iter().filter(|_| on) {
                    if !self.pos[pass.k].has(oe.e as usize) {
                        continue;
                    }
                    for q in oe.first..oe.first + oe.n {
                        let qp = &pass.points[q];
                        let g = qp.g_t.iter().map(|c| c * c).sum::<f64>().sqrt();
                        if qp.w != 0.0 && qp.gap.is_some() && g > s.slip {
                            s.slip = g;
                            s.position = self.point_position(pass.k, oe.e as usize, &qp.xi);
                        }
                    }
                }
                out.push(s);
            }
        }
        out
    }

    /// The empty [`PassDepth`] of pass `j` of pair `i` (no point inside yet).
    fn pass_depth(&self, i: usize, j: usize) -> PassDepth {
        let pass = &self.pairs[i].passes[j];
        let surface = &self.surfaces[pass.k];
        PassDepth {
            pair: self.pairs[i].def.name.clone(),
            surface: surface.name.clone(),
            partner: match pass.partner {
                Partner::Surface(l) => Some(self.surfaces[l].name.clone()),
                Partner::Rigid(..) => None,
            },
            depth: 0.0,
            node: u32::MAX,
            position: [0.0; 3],
            h: surface.h,
        }
    }

    /// Depth of `x` [3] below surface `l` (negative: above it), when its closest point on the
    /// held elements lies within `dist` and not beyond the surface's end.
    fn depth_below(&mut self, l: usize, x: &[f64; 3], dist: f64) -> Option<f64> {
        let p = self.search_partner(l, x, dist).ok()??;
        if p.dist > dist {
            return None;
        }
        let el = &self.surfaces[l].elements[p.elem as usize];
        let (y, _, nr) =
            crate::contact::surface::frame(el, self.dim, self.pos[l].of(p.elem as usize), &p.xi);
        let side: f64 = el.sign * (0..self.dim).map(|c| (x[c] - y[c]) * nr[c]).sum::<f64>();
        Some(if side <= 0.0 { p.dist } else { -p.dist })
    }
}
