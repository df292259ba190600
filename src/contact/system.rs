//! All contact pairs of a model on this rank: their surfaces (replicated on every rank), the
//! quadrature points this rank integrates, their projection state, and the evaluation of residual,
//! tangent blocks and resultant forces. Free of PETSc and MPI: the assembler hands in the current
//! displacement of every contact-surface node and takes residual entries and matrix blocks out.
//!
//! Parallel design (first version, measured in BENCHMARKS.md): every rank gets the current
//! displacement of *all* contact-surface nodes by one gather per evaluation (`table_dofs` feeds a
//! PETSc scatter). For surfaces of millions of nodes this allgather must become a bounding-box
//! filtered ghosting of only the partner elements near a rank's own surface elements.
#![allow(clippy::needless_range_loop)]
#![allow(non_snake_case)]

use crate::assembly::{DofMap, MatrixSink};
use crate::contact::kernel::{
    contact_point_pass, gap_and_normal, Area, FrictionIn, OwnPoint, PartnerPoint, Scratch,
    SlipState,
};
use crate::contact::law::{self, Traction};
use crate::contact::projection::{global_search, surface_grid, walk, Positions, Projection};
use crate::contact::rigid::{RigidMotion, RigidShape};
use crate::contact::search::{Aabb, BinGrid};

use crate::contact::surface::{raw_normal, ContactSurface, MAX_FACE_NODES};
use crate::fem::quadrature::tensor_rule;
use std::collections::HashMap;

mod active_set;
mod checkpoint;
mod mean_gap;
pub use active_set::{Settle, MAX_ROUNDS as MAX_ACTIVE_SET_ROUNDS};
pub use checkpoint::ROW as CHECKPOINT_ROW;

/// A contact law with its parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Law {
    /// Eq. (5): penalty `eps_n` on the current surface.
    Penalty { eps_n: f64 },
    /// Eq. (6): van der Waals adhesion (reference traction).
    VanDerWaals { a_h: f64, r0: f64 },
    /// Eq. (7): exponential cohesive zone with material point pairing, plus a penalty `eps_n`
    /// against penetration.
    Cohesive {
        t0: f64,
        g0: f64,
        eps_n: f64,
        /// The penalty against penetration is quadratic in the penetration (else linear).
        quadratic: bool,
    },
}

/// Coulomb friction of a pair (Sauer & De Lorenzis 2015, unbiased two-half-pass): every quadrature
/// point keeps an anchor on the partner where it sticks; see [`crate::contact::kernel::FrictionIn`].
#[derive(Debug, Clone, PartialEq)]
pub struct Friction {
    /// Friction coefficient (> 0).
    pub mu: f64,
    /// Tangential penalty (> 0).
    pub eps_t: f64,
    /// Per load stage: friction on (empty: every stage). A frictionless stage moves each anchor
    /// with its point, so friction starts from the state the stage leaves.
    pub stages: Vec<bool>,
}

impl Friction {
    /// True when friction acts at load `lambda` (stage `s` runs over `(s, s + 1]`).
    pub fn on_at(&self, lambda: f64) -> bool {
        if self.stages.is_empty() {
            return true;
        }
        let s = ((lambda - 1e-9).ceil() - 1.0).max(0.0) as usize;
        self.stages[s.min(self.stages.len() - 1)]
    }
}

/// Where a frictional point sticks: a material point of the partner (deformable: element and
/// surface coordinates; rigid: its position in the rigid body's reference configuration).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Anchor {
    Surface(u32, [f64; 2]),
    Rigid([f64; 3]),
}

/// The partner of a half-pass.
#[derive(Debug, Clone, PartialEq)]
pub enum Partner {
    /// Another contact surface (index into the system's surfaces).
    Surface(usize),
    /// A rigid shape and its motion.
    Rigid(RigidShape, RigidMotion),
}

/// Values per point of [`ContactSystem::point_records`].
pub const POINT_RECORD: usize = 18;

/// A declared contact pair, resolved against the model.
#[derive(Debug, Clone, PartialEq)]
pub struct PairDef {
    /// Name (history columns).
    pub name: String,
    pub law: Law,
    /// Half-passes: (integrated surface, partner). Two-half-pass: both ways; rigid: one.
    pub passes: Vec<(usize, Partner)>,
    /// Points farther than this from the partner are not paired.
    pub search_distance: f64,
    /// Moments of the contact forces are taken about this point [3].
    pub moment_point: [f64; 3],
    /// Reference-configuration box whose points carry no cohesive traction (initially debonded).
    pub debonded: Option<Aabb>,
    /// Reference-configuration box outside which the pair's quadrature points are not integrated.
    pub region: Option<Aabb>,
    /// One-pass (master/slave): the single half-pass also applies the opposite force to the
    /// partner (master) surface.
    pub one_pass: bool,
    /// Coulomb friction (penalty law, and the cohesive law's penalty against penetration).
    pub friction: Option<Friction>,
    /// Penalty law on each surface element's mean normal gap instead of the pointwise one
    /// (two-half-pass only; `gap = "element_mean"`).
    pub element_mean_gap: bool,
}

/// Projection state of one quadrature point.
#[derive(Debug, Clone, Copy, Default)]
struct QPoint {
    /// Surface coordinates on its own element [m].
    xi: [f64; 2],
    /// Gauss weight.
    w: f64,
    /// Reference area element.
    J0: f64,
    /// Last projection (trial state, updated by every evaluation).
    warm: Option<(u32, [f64; 2])>,
    /// Last converged projection.
    committed: Option<(u32, [f64; 2])>,
    /// Projection of the current evaluation: partner element, coordinates, free flags.
    current: Option<Projection>,
    /// Cohesive material pairing (partner element, coordinates), if bonded.
    pairing: Option<(u32, [f64; 2])>,
    /// Contact force of the point at the last evaluation, `t J w` summed over its contributions.
    force: [f64; 3],
    /// Normal gap to the partner at the last evaluation (`None`: no partner within reach).
    gap: Option<f64>,
    /// Friction: the anchor of the last converged step (load-step history).
    anchor: Option<Anchor>,
    /// Friction: the anchor the last evaluation leads to (committed when its step converges).
    anchor_trial: Option<Anchor>,
    /// Friction: stick or slip at the last evaluation.
    slip: SlipState,
    /// Friction: tangential traction and tangential gap to the anchor at the last evaluation
    /// (output only).
    t_t: [f64; 3],
    g_t: [f64; 3],
    /// Reference position (output only).
    X: [f64; 3],
    /// Normal pressure at the last evaluation (output only).
    p_n: f64,
}

/// A surface element this rank integrates.
#[derive(Debug, Clone)]
struct OwnElem {
    e: u32,
    /// Points `points[first..first + n]`.
    first: usize,
    n: usize,
    /// Local (ghosted) index of each unknown, [n_nodes * dim].
    local: Vec<u32>,
    /// The element's basis at its points (their surface coordinates never change), evaluated
    /// once: values [n][n_nodes] and first derivatives [n][n_nodes][m].
    N: Vec<f64>,
    dN: Vec<f64>,
}

impl OwnElem {
    /// Basis values and first derivatives at point `q` (an index into the pass's points).
    fn basis(&self, q: usize) -> (&[f64], &[f64]) {
        let nk = self.N.len() / self.n;
        let m = self.dN.len() / self.N.len();
        let i = q - self.first;
        (
            &self.N[i * nk..(i + 1) * nk],
            &self.dN[i * nk * m..(i + 1) * nk * m],
        )
    }

    /// Current position of point `q` on the element's current nodal positions `x` [n_nodes][dim]
    /// (the sum of [`crate::contact::surface::frame`], with the stored basis).
    fn position(&self, q: usize, x: &[f64], dim: usize) -> [f64; 3] {
        let (N, _) = self.basis(q);
        let mut p = [0.0; 3];
        for (b, &Nb) in N.iter().enumerate() {
            for k in 0..dim {
                p[k] += Nb * x[b * dim + k];
            }
        }
        p
    }
}

/// Resultants of one half-pass over this rank's points (sum over ranks for the whole).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct PassResult {
    /// Resultant contact force on the integrated body [3].
    pub force: [f64; 3],
    /// Moment of the contact forces about the pair's moment point [3].
    pub moment: [f64; 3],
    /// Active quadrature points.
    pub n_active: usize,
    /// Largest penetration `max(-g_n, 0)`.
    pub max_penetration: f64,
    /// Active points whose closest point is an edge or corner of a faceted (C0) partner.
    pub n_edge: usize,
    /// Friction: resultant tangential contact force on the integrated body [3].
    pub tangential: [f64; 3],
    /// Friction: sticking and slipping quadrature points.
    pub n_stick: usize,
    pub n_slip: usize,
}

struct Pass {
    k: usize,
    partner: Partner,
    points: Vec<QPoint>,
    elems: Vec<OwnElem>,
    /// Rigid shape at the current load.
    shape: Option<RigidShape>,
    result: PassResult,
}

struct Pair {
    def: PairDef,
    passes: Vec<Pass>,
}

/// One coupling block of the Jacobian: rows of element `k_e` of the pass's surface, columns of
/// `k_e` and of partner element `l_e` (`u32::MAX` for a rigid partner).
pub type Coupling = (u32 /*pass*/, u32 /*k_e*/, u32 /*l_e*/);

/// The COO slot of a coupling block in the current pattern (`None`: not in it).
pub type SlotOf<'a> = dyn Fn(&Coupling) -> Option<usize> + 'a;

/// Every contact pair of the model on this rank.
pub struct ContactSystem {
    dim: usize,
    /// The surface displacement and load of the last successful [`ContactSystem::update`] since
    /// the last commit or rollback: an update at the same state (the Jacobian after the residual
    /// at one iterate) keeps its projections instead of repeating them.
    last_update: Option<(f64, Vec<f64>)>,
    surfaces: Vec<ContactSurface>,
    /// Global node ids whose displacement the system needs (all surface nodes), sorted.
    table: Vec<u32>,
    /// Reference coordinates of the table nodes [n_table][dim].
    X: Vec<f64>,
    /// Per surface, per element: positions of its nodes in `table`. [surface][element][node]
    slots: Vec<Vec<Vec<u32>>>,
    /// Per surface, per element: global unknowns of its nodes [n_nodes * dim] (-1: none).
    gdofs: Vec<Vec<Vec<i32>>>,
    /// Current positions per surface.
    pos: Vec<Positions>,
    grids: Vec<Option<BinGrid>>,
    pairs: Vec<Pair>,
    lambda: f64,
    scratch: Scratch,
    cand: Vec<u32>,
    /// One-pass residual of the master surfaces' nodes, per table node [n_table][dim] (their rows
    /// may belong to elements of other ranks, so they go back through the table's scatter).
    r_table: Vec<f64>,
    /// Scratch residual of one contribution [(n_k + n_l) * dim].
    rc: Vec<f64>,
    /// Tangent blocks of the element being assembled, keyed by partner element; the buffers are
    /// kept between elements and evaluations (no allocation per element once they have grown).
    blocks: Vec<(u32, Vec<f64>)>,
    /// Newton at the kink of the penalty law (see `active_set.rs`).
    active_set: active_set::ActiveSet,
}

/// Evaluation of a pass's point: what kind of partner and traction.
/// `touch`: gaps below it count as touching (round-off tolerance of the penalty's active set).
fn law_traction(law: &Law, touch: f64, g: &[f64; 3], n: &[f64; 3]) -> Traction {
    match *law {
        Law::Penalty { eps_n } => law::penalty(eps_n, touch, g, n),
        Law::VanDerWaals { a_h, r0 } => law::van_der_waals(a_h, r0, g, n),
        Law::Cohesive {
            eps_n,
            quadratic: false,
            ..
        } => law::penalty(eps_n, touch, g, n),
        Law::Cohesive {
            eps_n,
            quadratic: true,
            ..
        } => law::penalty_quadratic(eps_n, g, n),
    }
}

/// Relative round-off tolerance of "touching", in units of the surface's element length.
const TOUCH: f64 = 1e-12;

impl ContactSystem {
    /// Sets up the pairs on `surfaces`; this rank integrates the surface elements of the cells
    /// `cell_part` gives it. Cohesive pairings are found here, in the reference configuration.
    pub fn new(
        dim: usize,
        surfaces: Vec<ContactSurface>,
        defs: Vec<PairDef>,
        coords: &[f64],
        dofs: &DofMap,
        cell_part: &[u32],
        rank: usize,
    ) -> Result<ContactSystem, String> {
        let mut table: Vec<u32> = surfaces
            .iter()
            .flat_map(|s| s.elements.iter().flat_map(|e| e.nodes.iter().copied()))
            .collect();
        table.sort_unstable();
        table.dedup();
        let X: Vec<f64> = table
            .iter()
            .flat_map(|&a| coords[a as usize * dim..(a as usize + 1) * dim].to_vec())
            .collect();
        let index: HashMap<u32, u32> = table
            .iter()
            .enumerate()
            .map(|(i, &a)| (a, i as u32))
            .collect();
        let slots: Vec<Vec<Vec<u32>>> = surfaces
            .iter()
            .map(|s| {
                s.elements
                    .iter()
                    .map(|e| e.nodes.iter().map(|a| index[a]).collect())
                    .collect()
            })
            .collect();
        let gdofs: Vec<Vec<Vec<i32>>> = surfaces
            .iter()
            .map(|s| {
                s.elements
                    .iter()
                    .map(|e| {
                        e.nodes
                            .iter()
                            .flat_map(|&a| (0..dim).map(move |c| (a, c)))
                            .map(|(a, c)| dofs.global(a, c).map_or(-1, |g| g.0))
                            .collect()
                    })
                    .collect()
            })
            .collect();
        let mut sys = ContactSystem {
            dim,
            pos: vec![Positions::default(); surfaces.len()],
            grids: vec![None; surfaces.len()],
            surfaces,
            table,
            X,
            slots,
            gdofs,
            pairs: Vec::new(),
            lambda: 0.0,
            scratch: Scratch::default(),
            cand: Vec::new(),
            r_table: Vec::new(),
            rc: Vec::new(),
            blocks: Vec::new(),
            last_update: None,
            active_set: Default::default(),
        };
        sys.r_table = vec![0.0; sys.table.len() * dim];
        sys.update_positions(&vec![0.0; sys.X.len()]);
        for def in defs {
            let mut passes = Vec::new();
            for (k, partner) in &def.passes {
                let s = &sys.surfaces[*k];
                let mut points = Vec::new();
                let mut elems = Vec::new();
                for (e, el) in s.elements.iter().enumerate() {
                    if cell_part[el.cell] as usize != rank {
                        continue;
                    }
                    let rule =
                        tensor_rule(&el.basis.quadrature_counts()).map_err(|e| e.to_string())?;
                    let first = points.len();
                    let m = dim - 1;
                    let nk = el.basis.n_nodes();
                    let Xe = sys.pos[*k].of(e).to_vec();
                    let (mut bN, mut bdN) = (Vec::new(), Vec::new());
                    let (mut N, mut dN, mut ddN) = (
                        [0.0; MAX_FACE_NODES],
                        [0.0; 2 * MAX_FACE_NODES],
                        [0.0; 4 * MAX_FACE_NODES],
                    );
                    for (q, xi) in rule.points.chunks_exact(m).enumerate() {
                        let mut x2 = [0.0; 2];
                        x2[..m].copy_from_slice(xi);
                        let (xr, a, _) = crate::contact::surface::frame(el, dim, &Xe, &x2);
                        if def.region.as_ref().is_some_and(|b| !b.contains(&xr[..dim])) {
                            continue;
                        }
                        el.basis.eval(&x2[..m], &mut N, &mut dN, &mut ddN);
                        bN.extend_from_slice(&N[..nk]);
                        bdN.extend_from_slice(&dN[..nk * m]);
                        let nu = raw_normal(dim, &a);
                        let J0 = (nu[0] * nu[0] + nu[1] * nu[1] + nu[2] * nu[2]).sqrt();
                        points.push(QPoint {
                            xi: x2,
                            w: rule.weights[q],
                            J0,
                            X: xr,
                            ..Default::default()
                        });
                    }
                    let local = sys.gdofs[*k][e]
                        .iter()
                        .map(|&g| {
                            dofs.local(crate::assembly::GlobalDof(g))
                                .map_or(u32::MAX, |l| l.0)
                        })
                        .collect();
                    if points.len() == first {
                        continue; // outside the pair's region
                    }
                    elems.push(OwnElem {
                        e: e as u32,
                        first,
                        n: points.len() - first,
                        local,
                        N: bN,
                        dN: bdN,
                    });
                }
                passes.push(Pass {
                    k: *k,
                    partner: partner.clone(),
                    points,
                    elems,
                    shape: None,
                    result: PassResult::default(),
                });
            }
            sys.pairs.push(Pair { def, passes });
        }
        sys.pair_cohesive()?;
        Ok(sys)
    }

    /// Material point pairing of cohesive pairs, in the reference configuration (positions are
    /// still the reference ones).
    fn pair_cohesive(&mut self) -> Result<(), String> {
        for pi in 0..self.pairs.len() {
            if !matches!(self.pairs[pi].def.law, Law::Cohesive { .. }) {
                continue;
            }
            for qi in 0..self.pairs[pi].passes.len() {
                let Partner::Surface(l) = self.pairs[pi].passes[qi].partner else {
                    continue;
                };
                let k = self.pairs[pi].passes[qi].k;
                self.ensure_grid(l, self.pairs[pi].def.search_distance);
                let n_el = self.pairs[pi].passes[qi].elems.len();
                for oe in 0..n_el {
                    let (e, first, n) = {
                        let o = &self.pairs[pi].passes[qi].elems[oe];
                        (o.e as usize, o.first, o.n)
                    };
                    for q in first..first + n {
                        let xi = self.pairs[pi].passes[qi].points[q].xi;
                        let x = self.point_position(k, e, &xi);
                        if let Some(b) = &self.pairs[pi].def.debonded {
                            if b.contains(&x[..self.dim]) {
                                continue;
                            }
                        }
                        let grid = self.grids[l].as_ref().expect("grid built above");
                        let p = global_search(
                            &self.surfaces[l],
                            &self.pos[l],
                            grid,
                            &x,
                            &mut self.cand,
                        )
                        .ok()
                        .flatten();
                        if let Some(p) = p.filter(|p| p.dist <= self.pairs[pi].def.search_distance)
                        {
                            self.pairs[pi].passes[qi].points[q].pairing = Some((p.elem, p.xi));
                        }
                    }
                }
            }
        }
        Ok(())
    }

    /// Global unknown of every table entry [n_table * dim], in table order: the indices of the
    /// gather that feeds [`ContactSystem::update`].
    pub fn table_dofs(&self, dofs: &DofMap) -> Vec<i32> {
        self.table
            .iter()
            .flat_map(|&a| (0..self.dim).map(move |c| (a, c)))
            .map(|(a, c)| dofs.global(a, c).map_or(0, |g| g.0))
            .collect()
    }

    /// The load parameter (moves rigid partners).
    pub fn set_load(&mut self, lambda: f64) {
        self.lambda = lambda;
    }

    fn update_positions(&mut self, u_table: &[f64]) {
        let dim = self.dim;
        for (s, surf) in self.surfaces.iter().enumerate() {
            let p = &mut self.pos[s];
            p.offsets.clear();
            p.offsets.push(0);
            p.x.clear();
            for (e, _) in surf.elements.iter().enumerate() {
                for &t in &self.slots[s][e] {
                    let t = t as usize;
                    for c in 0..dim {
                        p.x.push(self.X[t * dim + c] + u_table[t * dim + c]);
                    }
                }
                p.offsets.push(p.x.len());
            }
            self.grids[s] = None;
        }
    }

    fn point_position(&self, s: usize, e: usize, xi: &[f64; 2]) -> [f64; 3] {
        crate::contact::surface::frame(
            &self.surfaces[s].elements[e],
            self.dim,
            self.pos[s].of(e),
            xi,
        )
        .0
    }

    fn ensure_grid(&mut self, l: usize, dist: f64) {
        if self.grids[l].is_none() {
            self.grids[l] = Some(surface_grid(&self.surfaces[l], &self.pos[l], dist));
        }
    }

    /// Moves to the displacement `u_table` [n_table][dim] and projects every point this rank
    /// integrates. An error is a projection that failed where a partner was in reach: the caller
    /// makes it a domain error, so the step is cut back.
    pub fn update(&mut self, u_table: &[f64]) -> Result<(), String> {
        if let Some((lambda, u)) = &self.last_update {
            if *lambda == self.lambda && u.as_slice() == u_table {
                return Ok(());
            }
        }
        let mut last = self.last_update.take().map(|(_, u)| u).unwrap_or_default();
        self.project_all(u_table)?;
        last.clear();
        last.extend_from_slice(u_table);
        self.last_update = Some((self.lambda, last));
        Ok(())
    }

    fn project_all(&mut self, u_table: &[f64]) -> Result<(), String> {
        if crate::contact::fault::projection_fails() {
            return Err(format!(
                "contact: the projection of the points failed (injected by \
                 NURBS_CONTACT_FAIL_PROJECTION_AT at load {})",
                self.lambda
            ));
        }
        self.update_positions(u_table);
        let dim = self.dim;
        for pi in 0..self.pairs.len() {
            let dist = self.pairs[pi].def.search_distance;
            for qi in 0..self.pairs[pi].passes.len() {
                let k = self.pairs[pi].passes[qi].k;
                let partner = self.pairs[pi].passes[qi].partner.clone();
                match partner {
                    Partner::Rigid(shape, motion) => {
                        self.pairs[pi].passes[qi].shape = Some(shape.at(&motion, self.lambda));
                    }
                    Partner::Surface(l) => {
                        let n_el = self.pairs[pi].passes[qi].elems.len();
                        for oe in 0..n_el {
                            let (e, first, n) = {
                                let o = &self.pairs[pi].passes[qi].elems[oe];
                                (o.e as usize, o.first, o.n)
                            };
                            for q in first..first + n {
                                let qp = self.pairs[pi].passes[qi].points[q];
                                let x = self.pairs[pi].passes[qi].elems[oe].position(
                                    q,
                                    self.pos[k].of(e),
                                    dim,
                                );
                                let mut p = qp
                                    .warm
                                    .and_then(|w| walk(&self.surfaces[l], &self.pos[l], &x, w));
                                if p.is_none_or(|p| p.dist > dist) {
                                    self.ensure_grid(l, dist);
                                    let grid = self.grids[l].as_ref().expect("built above");
                                    let found = global_search(
                                        &self.surfaces[l],
                                        &self.pos[l],
                                        grid,
                                        &x,
                                        &mut self.cand,
                                    )
                                    .map_err(|_| {
                                        format!(
                                            "contact `{}`: the projection of a point of `{}` (element {e}) at {:?} onto `{}` failed on every candidate element",
                                            self.pairs[pi].def.name,
                                            self.surfaces[k].name,
                                            &x[..dim],
                                            self.surfaces[l].name
                                        )
                                    })?;
                                    // the global search sees every element in reach: its answer
                                    // wins (None: no partner in reach, or beyond the surface's end)
                                    p = match found {
                                        Some(f) if p.is_none_or(|p| f.dist < p.dist) => Some(f),
                                        Some(_) => p,
                                        None => None,
                                    };
                                }
                                let p = p.filter(|p| p.dist <= dist);
                                let pt = &mut self.pairs[pi].passes[qi].points[q];
                                pt.current = p;
                                if let Some(p) = p {
                                    pt.warm = Some((p.elem, p.xi));
                                }
                            }
                        }
                    }
                }
            }
        }
        Ok(())
    }

    /// The coupling blocks the current projections need (sorted, unique). Cohesive pairings
    /// always couple; penalty-type points couple when their traction is active.
    pub fn couplings(&self) -> Vec<Coupling> {
        let mut out = Vec::new();
        let mut pass_id = 0u32;
        for pair in &self.pairs {
            for pass in &pair.passes {
                for oe in &pass.elems {
                    if pass.shape.is_some() {
                        out.push((pass_id, oe.e, u32::MAX));
                        continue;
                    }
                    for q in oe.first..oe.first + oe.n {
                        let qp = &pass.points[q];
                        if let Some(p) = qp.current {
                            out.push((pass_id, oe.e, p.elem));
                        }
                        if let Some((l, _)) = qp.pairing {
                            out.push((pass_id, oe.e, l));
                        }
                        if let Some(Anchor::Surface(l, _)) = qp.anchor {
                            if pair.def.friction.is_some() {
                                out.push((pass_id, oe.e, l));
                            }
                        }
                    }
                }
                pass_id += 1;
            }
        }
        out.sort_unstable();
        out.dedup();
        out
    }

    /// The couplings to reserve in the sparsity pattern: for every point with a partner (or a
    /// cohesive pairing), its partner element and the elements within `ring` side-neighbour steps of
    /// it, so that points sliding to a neighbouring element during the next Newton solves still find
    /// their block (`ring = 0`: exactly the current couplings). Rigid partners couple an element
    /// with itself only. Sorted, unique.
    pub fn band_couplings(&mut self, ring: usize) -> Vec<Coupling> {
        let mut out = self.approach_couplings(ring);
        let mut pass_id = 0u32;
        let mut near: Vec<u32> = Vec::new();
        for pair in &self.pairs {
            for pass in &pair.passes {
                let l = match pass.partner {
                    Partner::Surface(l) => Some(l),
                    Partner::Rigid(..) => None,
                };
                for oe in &pass.elems {
                    let Some(l) = l else {
                        out.push((pass_id, oe.e, u32::MAX));
                        continue;
                    };
                    for q in oe.first..oe.first + oe.n {
                        let qp = &pass.points[q];
                        let anchor = match qp.anchor {
                            Some(Anchor::Surface(la, _)) if pair.def.friction.is_some() => Some(la),
                            _ => None,
                        };
                        for le in qp
                            .current
                            .map(|p| p.elem)
                            .into_iter()
                            .chain(qp.pairing.map(|p| p.0))
                            .chain(anchor)
                        {
                            near.clear();
                            near.push(le);
                            let mut front = 0;
                            for _ in 0..ring {
                                let end = near.len();
                                for i in front..end {
                                    for nb in self.surfaces[l].elements[near[i] as usize]
                                        .neighbours
                                        .iter()
                                        .flatten()
                                    {
                                        if !near.contains(&nb.0) {
                                            near.push(nb.0);
                                        }
                                    }
                                }
                                front = end;
                            }
                            out.extend(near.iter().map(|&f| (pass_id, oe.e, f)));
                        }
                    }
                }
                pass_id += 1;
            }
        }
        out.sort_unstable();
        out.dedup();
        out
    }

    /// With `ring >= 1`, the couplings of points that have no partner yet but lie within the search
    /// distance of a partner element's box: the elements they may reach during the next solves
    /// (a contact zone that grows, as under an indenter, then needs no pattern rebuild).
    fn approach_couplings(&mut self, ring: usize) -> Vec<Coupling> {
        let mut out = Vec::new();
        if ring == 0 {
            return out;
        }
        let mut pass_id = 0u32;
        for pi in 0..self.pairs.len() {
            let dist = self.pairs[pi].def.search_distance;
            for qi in 0..self.pairs[pi].passes.len() {
                let (k, partner) = {
                    let p = &self.pairs[pi].passes[qi];
                    (p.k, p.partner.clone())
                };
                if let Partner::Surface(l) = partner {
                    let waiting: Vec<(u32, [f64; 2])> = {
                        let pass = &self.pairs[pi].passes[qi];
                        pass.elems
                            .iter()
                            .flat_map(|oe| {
                                (oe.first..oe.first + oe.n)
                                    .filter(|&q| pass.points[q].current.is_none())
                                    .map(move |q| (oe.e, pass.points[q].xi))
                            })
                            .collect()
                    };
                    if !waiting.is_empty() {
                        self.ensure_grid(l, dist);
                    }
                    for (e, xi) in waiting {
                        let x = self.point_position(k, e as usize, &xi);
                        let grid = self.grids[l].as_ref().expect("built above");
                        grid.candidates(&x[..self.dim], &mut self.cand);
                        out.extend(self.cand.iter().map(|&f| (pass_id, e, f)));
                    }
                }
                pass_id += 1;
            }
        }
        out
    }

    /// Rows (own element, constrained rows dropped by the caller) and columns of a coupling block.
    pub fn block_dofs(&self, c: &Coupling) -> (Vec<i32>, Vec<i32>) {
        let (pass, k_e, l_e) = *c;
        let (k, partner, one_pass) = self.pass_surfaces(pass as usize);
        let own = &self.gdofs[k][k_e as usize][..];
        let mut cols = own.to_vec();
        if let Some(l) = partner {
            cols.extend_from_slice(&self.gdofs[l][l_e as usize]);
        }
        let rows = if one_pass { cols.clone() } else { own.to_vec() };
        (rows, cols)
    }

    fn pass_surfaces(&self, pass: usize) -> (usize, Option<usize>, bool) {
        let mut i = 0;
        for pair in &self.pairs {
            for p in &pair.passes {
                if i == pass {
                    let l = match p.partner {
                        Partner::Surface(l) => Some(l),
                        Partner::Rigid(..) => None,
                    };
                    return (p.k, l, pair.def.one_pass && l.is_some());
                }
                i += 1;
            }
        }
        unreachable!("pass index out of range")
    }

    /// Adds the contact residual of this rank's points to `f_local` (ghosted local vector) and, with
    /// `jac`, each coupling block to the sink at the slot `slot_of` gives it. Uses the projections
    /// of the last [`ContactSystem::update`].
    pub fn assemble(
        &mut self,
        f_local: &mut [f64],
        mut jac: Option<(&mut dyn MatrixSink, &SlotOf)>,
    ) {
        let dim = self.dim;
        let m = dim - 1;
        let jacobian = jac.is_some();
        let mut pass_id = 0u32;
        let (mut N, mut dN) = ([0.0; MAX_FACE_NODES], [0.0; 2 * MAX_FACE_NODES]);
        self.r_table.fill(0.0);
        // blocks of the current own element, keyed by partner element
        let mut blocks = std::mem::take(&mut self.blocks);
        let mut n_used;
        let mut r = Vec::new();
        let mut mean = mean_gap::ElementMean::default();
        for pi in 0..self.pairs.len() {
            let law = self.pairs[pi].def.law;
            let element_mean = self.pairs[pi].def.element_mean_gap;
            let mpt = self.pairs[pi].def.moment_point;
            let dist = self.pairs[pi].def.search_distance;
            let one_pass = self.pairs[pi].def.one_pass;
            let lambda = self.lambda;
            let friction = self.pairs[pi]
                .def
                .friction
                .clone()
                .filter(|f| f.on_at(lambda));
            let has_friction = self.pairs[pi].def.friction.is_some();
            for qi in 0..self.pairs[pi].passes.len() {
                let pass = &mut self.pairs[pi].passes[qi];
                let motion = match &pass.partner {
                    Partner::Rigid(_, m) => Some(m.clone()),
                    Partner::Surface(_) => None,
                };
                let k = pass.k;
                let l = match pass.partner {
                    Partner::Surface(l) => Some(l),
                    Partner::Rigid(..) => None,
                };
                let mut res = PassResult::default();
                let touch = TOUCH * self.surfaces[k].h;
                for oe in &pass.elems {
                    let e = oe.e as usize;
                    let el = &self.surfaces[k].elements[e];
                    let nk = el.basis.n_nodes();
                    let x = self.pos[k].of(e);
                    r.clear();
                    r.resize(nk * dim, 0.0);
                    n_used = 0;
                    // `gap = "element_mean"`: the equivalent gap -p/eps_n of the element's mean pressure (mean_gap.rs)
                    let mut g_mean = None;
                    if element_mean {
                        let area: f64 = (oe.first..oe.first + oe.n)
                            .map(|q| pass.points[q].w * pass.points[q].J0)
                            .sum();
                        mean.start(nk, area);
                        for q in oe.first..oe.first + oe.n {
                            let qp = pass.points[q];
                            let (bN, _) = oe.basis(q);
                            let mut xk = [0.0; 3];
                            for a in 0..nk {
                                for c in 0..dim {
                                    xk[c] += bN[a] * x[a * dim + c];
                                }
                            }
                            let Some((le, pp)) = contact_partner(
                                pass.shape.as_ref(),
                                l,
                                qp.current,
                                &xk,
                                dist,
                                &self.surfaces,
                                &self.pos,
                            ) else {
                                continue;
                            };
                            if let Some(pg) = gap_and_normal(dim, &xk, &pp) {
                                let (g, n) = (pg.g, pg.n);
                                let g_n = g[0] * n[0] + g[1] * n[1] + g[2] * n[2];
                                let c = qp.w * qp.J0;
                                let p = mean_gap::MeanPoint {
                                    q,
                                    le,
                                    n,
                                    nl_vals: pg.basis,
                                    nl: pg.n_nodes,
                                    c,
                                    active: false,
                                };
                                mean.add(p, &bN[..nk], g_n, touch);
                            }
                        }
                        if mean.finish() {
                            g_mean = Some(mean.g);
                        }
                    }
                    for q in oe.first..oe.first + oe.n {
                        let qp = pass.points[q];
                        let (bN, bdN) = oe.basis(q);
                        N[..nk].copy_from_slice(bN);
                        dN[..nk * m].copy_from_slice(bdN);
                        let own = OwnPoint {
                            N: &N[..nk],
                            dN: &dN[..nk * m],
                            x,
                            w: qp.w,
                            J0: qp.J0,
                        };
                        // (partner element, partner point, law, area) of each contribution
                        let mut contributions: [Option<(u32, PartnerPoint, Area, bool)>; 2] =
                            [None, None];
                        let mut xk = [0.0; 3];
                        if pass.shape.is_some() {
                            for a in 0..nk {
                                for c in 0..dim {
                                    xk[c] += N[a] * x[a * dim + c];
                                }
                            }
                        }
                        contributions[0] = contact_partner(
                            pass.shape.as_ref(),
                            l,
                            qp.current,
                            &xk,
                            dist,
                            &self.surfaces,
                            &self.pos,
                        )
                        .map(|(le, pp)| (le, pp, area_of(&law), false));
                        if let (None, Some(l), Some((le, xi0))) = (&pass.shape, l, qp.pairing) {
                            contributions[1] = Some((
                                le,
                                PartnerPoint::Material {
                                    el: &self.surfaces[l].elements[le as usize],
                                    y: self.pos[l].of(le as usize),
                                    xi: xi0,
                                },
                                Area::Reference,
                                true,
                            ));
                        }
                        let mut fsum = [0.0; 3];
                        let mut gap = None;
                        let mut anchor_trial = None;
                        let mut slip = SlipState::None;
                        let (mut t_t, mut g_t, mut p_n) = ([0.0; 3], [0.0; 3], 0.0);
                        for (le, pp, area, cohesive) in contributions.into_iter().flatten() {
                            let on_edge = matches!(&pp, PartnerPoint::Projected { free, .. } if !free[..m].iter().all(|&f| f));
                            let nl = match &pp {
                                PartnerPoint::Rigid(_) => 0,
                                PartnerPoint::Projected { el, .. }
                                | PartnerPoint::Material { el, .. } => el.basis.n_nodes(),
                            };
                            let nc = (nk + nl) * dim;
                            let rows = if one_pass { nc } else { nk * dim };
                            let kb = jac
                                .as_ref()
                                .map(|_| block_slot(&mut blocks, &mut n_used, le, rows * nc));
                            // friction: the committed anchor's current position (and the anchor
                            // element's basis there, for its block)
                            let mut anchor_el: Option<(u32, [f64; MAX_FACE_NODES], usize)> = None;
                            let fin = match (&friction, cohesive, qp.anchor) {
                                (Some(f), false, Some(a)) => {
                                    let xa = match (a, l, &motion) {
                                        (Anchor::Surface(la, xia), Some(l), _) => {
                                            let ela = &self.surfaces[l].elements[la as usize];
                                            let ya = self.pos[l].of(la as usize);
                                            let (mut Na, mut dNa, mut ddNa) = (
                                                [0.0; MAX_FACE_NODES],
                                                [0.0; 2 * MAX_FACE_NODES],
                                                [0.0; 4 * MAX_FACE_NODES],
                                            );
                                            ela.basis.eval(&xia[..m], &mut Na, &mut dNa, &mut ddNa);
                                            let na = ela.basis.n_nodes();
                                            let mut xa = [0.0; 3];
                                            for b in 0..na {
                                                for c in 0..dim {
                                                    xa[c] += Na[b] * ya[b * dim + c];
                                                }
                                            }
                                            anchor_el = Some((la, Na, na));
                                            Some(xa)
                                        }
                                        (Anchor::Rigid(X), None, Some(mo)) => {
                                            Some(mo.apply(&X, lambda))
                                        }
                                        _ => None,
                                    };
                                    xa.map(|anchor| FrictionIn {
                                        mu: f.mu,
                                        eps_t: f.eps_t,
                                        anchor,
                                    })
                                }
                                _ => None,
                            };
                            let kslice = kb.map(|i| &mut blocks[i].1[..]);
                            let forced = self.active_set.forced(pass_id as usize, q);
                            let lawf = |g: &[f64; 3], n: &[f64; 3]| -> Traction {
                                if cohesive {
                                    match law {
                                        Law::Cohesive { t0, g0, .. } => law::cohesive(t0, g0, g),
                                        _ => Traction::ZERO,
                                    }
                                } else if let (Some(gm), Law::Penalty { eps_n }) = (g_mean, law) {
                                    // the point's gap moved along its normal to the element's equivalent gap
                                    let gn = g[0] * n[0] + g[1] * n[1] + g[2] * n[2];
                                    let gs = [0, 1, 2].map(|i| g[i] + (gm - gn) * n[i]);
                                    law::penalty(eps_n, touch, &gs, n)
                                } else if let (Some(f), Law::Penalty { eps_n }) = (forced, law) {
                                    active_set::forced_penalty(eps_n, f, g, n)
                                } else {
                                    law_traction(&law, touch, g, n)
                                }
                            };
                            let master = one_pass && nl > 0;
                            self.rc.clear();
                            self.rc.resize(nc, 0.0);
                            let pr = contact_point_pass(
                                dim,
                                &own,
                                &pp,
                                &lawf,
                                fin.as_ref(),
                                area,
                                master,
                                if master { &mut self.rc } else { &mut r },
                                kslice,
                                &mut self.scratch,
                            );
                            if let (Some(gm), true, Law::Penalty { eps_n }) =
                                (g_mean, jacobian && !cohesive, law)
                            {
                                if gm <= touch {
                                    let jw = point_area(dim, &own) * qp.w;
                                    // d t / d p: the normal, plus the slip direction in slip
                                    let fo = &pr.friction;
                                    let d = if fo.state == SlipState::Slip && pr.p_n > 0.0 {
                                        [0, 1, 2].map(|c| pr.n[c] + fo.t_t[c] / pr.p_n)
                                    } else {
                                        pr.n
                                    };
                                    mean.correct(
                                        dim,
                                        q,
                                        &N[..nk],
                                        jw,
                                        eps_n,
                                        d,
                                        &mut blocks,
                                        &mut |b: &mut Blocks, le, len| {
                                            block_slot(b, &mut n_used, le, len)
                                        },
                                    );
                                }
                            }
                            if master {
                                for (v, rv) in r.iter_mut().zip(&self.rc[..nk * dim]) {
                                    *v += rv;
                                }
                                let l = l.expect("a master surface");
                                for (b, &t) in self.slots[l][le as usize].iter().enumerate() {
                                    for c in 0..dim {
                                        self.r_table[t as usize * dim + c] +=
                                            self.rc[(nk + b) * dim + c];
                                    }
                                }
                            }
                            if !cohesive {
                                gap =
                                    Some(pr.g[0] * pr.n[0] + pr.g[1] * pr.n[1] + pr.g[2] * pr.n[2]);
                                p_n = pr.p_n;
                            }
                            // friction: the anchor's block, the state and the anchor this
                            // evaluation leads to
                            let fo = pr.friction;
                            if let (Some((la, Na, na)), Some(_)) = (anchor_el, jac.as_ref()) {
                                if fo.state != SlipState::None {
                                    let nca = (nk + na) * dim;
                                    let ib =
                                        block_slot(&mut blocks, &mut n_used, la, nk * dim * nca);
                                    let kb = &mut blocks[ib].1;
                                    let Jw = point_area(dim, &own) * qp.w;
                                    for a in 0..nk {
                                        for i in 0..dim {
                                            let row = (a * dim + i) * nca;
                                            for b in 0..na {
                                                for j in 0..dim {
                                                    kb[row + (nk + b) * dim + j] -=
                                                        N[a] * Jw * fo.dt_dxa[3 * i + j] * Na[b];
                                                }
                                            }
                                        }
                                    }
                                }
                            }
                            if has_friction && !cohesive && pr.active {
                                slip = fo.state;
                                (t_t, g_t) = (fo.t_t, fo.g_t);
                                res.n_stick += (fo.state == SlipState::Stick) as usize;
                                res.n_slip += (fo.state == SlipState::Slip) as usize;
                                let Jw = point_area(dim, &own) * qp.w;
                                for c in 0..3 {
                                    res.tangential[c] += fo.t_t[c] * Jw;
                                }
                                // where the point sticks from the next step on
                                let xp = [0, 1, 2].map(|c| pr.x[c] - pr.g[c]);
                                let target = match fo.state {
                                    SlipState::Stick => None,
                                    SlipState::Slip => Some(fo.slip_target),
                                    SlipState::None => Some(xp),
                                };
                                anchor_trial = match (target, l, &pass.shape, &motion) {
                                    (None, ..) => qp.anchor,
                                    (Some(t), Some(l), ..) => {
                                        let start = qp.current.map(|p| (p.elem, p.xi));
                                        let onto = if fo.state == SlipState::Slip {
                                            start.and_then(|w| {
                                                walk(&self.surfaces[l], &self.pos[l], &t, w)
                                            })
                                        } else {
                                            None
                                        };
                                        match onto {
                                            Some(p) => Some(Anchor::Surface(p.elem, p.xi)),
                                            None => start.map(|(e, xi)| Anchor::Surface(e, xi)),
                                        }
                                    }
                                    (Some(t), None, Some(shape), Some(mo)) => {
                                        let on = shape
                                            .project(&t)
                                            .map(|rp| [0, 1, 2].map(|c| t[c] - rp.g[c]))
                                            .unwrap_or(xp);
                                        Some(Anchor::Rigid(mo.inverse(&on, lambda)))
                                    }
                                    _ => None,
                                };
                            }
                            for c in 0..3 {
                                fsum[c] += pr.force[c];
                            }
                            if pr.active {
                                if !cohesive {
                                    res.n_active += 1;
                                    res.n_edge += on_edge as usize;
                                }
                                let g_n = pr.g[0] * pr.n[0] + pr.g[1] * pr.n[1] + pr.g[2] * pr.n[2];
                                if !cohesive {
                                    res.max_penetration = res.max_penetration.max(-g_n);
                                }
                                let d = [0, 1, 2].map(|c| pr.x[c] - mpt[c]);
                                for c in 0..3 {
                                    res.force[c] += pr.force[c];
                                }
                                let mo = [
                                    d[1] * pr.force[2] - d[2] * pr.force[1],
                                    d[2] * pr.force[0] - d[0] * pr.force[2],
                                    d[0] * pr.force[1] - d[1] * pr.force[0],
                                ];
                                for c in 0..3 {
                                    res.moment[c] += mo[c];
                                }
                            }
                        }
                        pass.points[q].force = fsum;
                        pass.points[q].gap = gap;
                        pass.points[q].anchor_trial = anchor_trial;
                        pass.points[q].slip = slip;
                        pass.points[q].t_t = t_t;
                        pass.points[q].g_t = g_t;
                        pass.points[q].p_n = p_n;
                    }
                    for (i, &li) in oe.local.iter().enumerate() {
                        if li != u32::MAX {
                            f_local[li as usize] += r[i];
                        }
                    }
                    if let Some((sink, slot_of)) = jac.as_mut() {
                        for (le, kb) in &blocks[..n_used] {
                            let c: Coupling = (pass_id, oe.e, *le);
                            let own_rows = &self.gdofs[k][e];
                            let mut cols = own_rows.clone();
                            if let Some(l) = l {
                                if *le != u32::MAX {
                                    cols.extend_from_slice(&self.gdofs[l][*le as usize]);
                                }
                            }
                            let rows = if one_pass && l.is_some() {
                                &cols
                            } else {
                                own_rows
                            };
                            if let Some(slot) = slot_of(&c) {
                                sink.add_block(slot, rows, &cols, kb);
                            }
                        }
                    }
                }
                pass.result = res;
                pass_id += 1;
            }
        }
        self.blocks = blocks;
        if jacobian {
            self.observe_iterate();
        }
    }

    /// Resultants of every half-pass over this rank's points, pair by pair.
    pub fn results(&self) -> Vec<(String, Vec<PassResult>)> {
        self.pairs
            .iter()
            .map(|p| {
                (
                    p.def.name.clone(),
                    p.passes.iter().map(|q| q.result).collect(),
                )
            })
            .collect()
    }

    /// This rank's quadrature points for output, [`POINT_RECORD`] values each: the point's key
    /// (half-pass number over all pairs, surface element, index of the point in the element: the
    /// same on any number of ranks), its reference position [3], current position [3], normal
    /// pressure of the contact law (penalty-type contributions), normal gap (`NaN` without a partner in reach), friction state (0 none, 1 stick,
    /// 2 slip), tangential traction [3] and tangential gap to the anchor [3] at the last evaluation.
    pub fn point_records(&self) -> Vec<f64> {
        let dim = self.dim;
        let mut out = Vec::new();
        let mut pass_id = 0usize;
        for pair in &self.pairs {
            for pass in &pair.passes {
                let k = pass.k;
                for oe in &pass.elems {
                    let e = oe.e as usize;
                    let el = &self.surfaces[k].elements[e];
                    for q in oe.first..oe.first + oe.n {
                        let qp = &pass.points[q];
                        let (x, _, _) =
                            crate::contact::surface::frame(el, dim, self.pos[k].of(e), &qp.xi);
                        let p = qp.p_n;
                        let state = match qp.slip {
                            SlipState::None => 0.0,
                            SlipState::Stick => 1.0,
                            SlipState::Slip => 2.0,
                        };
                        out.extend([pass_id as f64, oe.e as f64, (q - oe.first) as f64]);
                        out.extend(qp.X);
                        out.extend(x);
                        out.extend([p, qp.gap.unwrap_or(f64::NAN), state]);
                        out.extend(qp.t_t);
                        out.extend(qp.g_t);
                    }
                }
                pass_id += 1;
            }
        }
        out
    }

    /// Per pair: true when it has Coulomb friction (its results carry tangential forces and
    /// stick/slip counts).
    pub fn frictional(&self) -> Vec<bool> {
        self.pairs
            .iter()
            .map(|p| p.def.friction.is_some())
            .collect()
    }

    /// Names of the half-passes of each pair: the integrated surface's name.
    pub fn pass_names(&self) -> Vec<(String, Vec<String>)> {
        self.pairs
            .iter()
            .map(|p| {
                (
                    p.def.name.clone(),
                    p.passes
                        .iter()
                        .map(|q| self.surfaces[q.k].name.clone())
                        .collect(),
                )
            })
            .collect()
    }

    /// This rank's right-hand sides of the L2 projections of the contact pressure and the normal gap
    /// (Sauer 2013): per surface, `f_A = int N_A p da` with `p = -t . nu_k` (`nu_k` the surface's own
    /// outward normal: positive in compression, negative in adhesion), and `int N_A g_n da` with
    /// `g_n` capped at the search distance where no partner is within reach. Indexed
    /// `[surface][table node]`, flattened; sum over ranks before [`ContactSystem::l2_project`].
    pub fn l2_rhs(&self) -> (Vec<f64>, Vec<f64>) {
        let (dim, nt) = (self.dim, self.table.len());
        let mut fp = vec![0.0; self.surfaces.len() * nt];
        let mut fg = vec![0.0; self.surfaces.len() * nt];
        self.each_surface_point(false, |pair, k, e, qp, N, nu| {
            let el = &self.surfaces[k].elements[e];
            let J = (nu[0] * nu[0] + nu[1] * nu[1] + nu[2] * nu[2]).sqrt();
            let p = -el.sign * (0..dim).map(|c| qp.force[c] * nu[c]).sum::<f64>() / J;
            let g = qp
                .gap
                .unwrap_or(pair.def.search_distance)
                .min(pair.def.search_distance);
            for (b, &t) in self.slots[k][e].iter().enumerate() {
                fp[k * nt + t as usize] += N[b] * p;
                fg[k * nt + t as usize] += N[b] * g * J * qp.w;
            }
        });
        (fp, fg)
    }

    /// Calls `f(pair, surface, element, point, basis values, raw normal)` for every quadrature
    /// point this rank integrates (of the frictional pairs only with `frictional_only`), with the
    /// surface's own basis and raw normal (length: the area factor) at the point's current
    /// position.
    fn each_surface_point(
        &self,
        frictional_only: bool,
        mut f: impl FnMut(&Pair, usize, usize, &QPoint, &[f64], [f64; 3]),
    ) {
        let (dim, m) = (self.dim, self.dim - 1);
        let (mut N, mut dN, mut ddN) = (
            [0.0; MAX_FACE_NODES],
            [0.0; 2 * MAX_FACE_NODES],
            [0.0; 4 * MAX_FACE_NODES],
        );
        for pair in &self.pairs {
            if frictional_only && pair.def.friction.is_none() {
                continue;
            }
            for pass in &pair.passes {
                let k = pass.k;
                for oe in &pass.elems {
                    let e = oe.e as usize;
                    let el = &self.surfaces[k].elements[e];
                    for qp in &pass.points[oe.first..oe.first + oe.n] {
                        el.basis.eval(&qp.xi[..m], &mut N, &mut dN, &mut ddN);
                        let (_, _, nu) =
                            crate::contact::surface::frame(el, dim, self.pos[k].of(e), &qp.xi);
                        f(pair, k, e, qp, &N[..el.basis.n_nodes()], nu);
                    }
                }
            }
        }
    }

    /// This rank's right-hand sides of the L2 projections of friction onto each surface's own
    /// interpolation: `int N_A t_T,c da` per component `c < dim` of the tangential traction on the
    /// surface's body (as [`POINT_RECORD`]'s), then `int N_A chi_stick da` and `int N_A chi_slip da`
    /// with `chi` the indicator of the points that stick / slip (so the projections are the local
    /// fractions of sticking and slipping contact, both 0 out of contact). Indexed
    /// `[surface][block][table node]` with `dim + 2` blocks per surface, flattened; zero for
    /// frictionless pairs. Sum over ranks before [`ContactSystem::l2_project`].
    pub fn l2_rhs_friction(&self) -> Vec<f64> {
        let (dim, nt) = (self.dim, self.table.len());
        let nb = dim + 2;
        let mut f = vec![0.0; self.surfaces.len() * nb * nt];
        self.each_surface_point(true, |_, k, e, qp, N, nu| {
            let jw = (nu[0] * nu[0] + nu[1] * nu[1] + nu[2] * nu[2]).sqrt() * qp.w;
            let mut v = [0.0; 5];
            v[..dim].copy_from_slice(&qp.t_t[..dim]);
            v[dim] = (qp.slip == SlipState::Stick) as u8 as f64;
            v[dim + 1] = (qp.slip == SlipState::Slip) as u8 as f64;
            for (b, &t) in self.slots[k][e].iter().enumerate() {
                for (c, vc) in v[..nb].iter().enumerate() {
                    f[(k * nb + c) * nt + t as usize] += N[b] * vc * jw;
                }
            }
        });
        f
    }

    /// Solves `M x = f` on surface `s` with the consistent mass matrix `M_AB = int N_A N_B da` of its
    /// own interpolation in the current configuration (conjugate gradients, Jacobi-preconditioned,
    /// matrix-free over the surface's elements). `f`: `[table node]` (the slice of
    /// [`ContactSystem::l2_rhs`] for `s`). Returns values per table node (zero off the surface).
    ///
    /// `nominal`: the mass matrix of the reference configuration instead, `M_AB = int N_A N_B dA`;
    /// with the pressure's right-hand side (`int N_A p da`) this gives the nominal pressure, the
    /// contact force per reference area (the measure a geometrically linear theory such as Hertz's
    /// predicts; it differs from the current one by the surface stretch).
    pub fn l2_project(&self, s: usize, f: &[f64], nominal: bool) -> Vec<f64> {
        let (dim, m, nt) = (self.dim, self.dim - 1, self.table.len());
        let surf = &self.surfaces[s];
        // element mass matrices, once
        let mut blocks: Vec<Vec<f64>> = Vec::with_capacity(surf.elements.len());
        let (mut N, mut dN, mut ddN) = (
            [0.0; MAX_FACE_NODES],
            [0.0; 2 * MAX_FACE_NODES],
            [0.0; 4 * MAX_FACE_NODES],
        );
        let mut diag = vec![0.0; nt];
        let mut Xe = Vec::new();
        for (e, el) in surf.elements.iter().enumerate() {
            let n = el.basis.n_nodes();
            let mut Me = vec![0.0; n * n];
            let x_e: &[f64] = if nominal {
                Xe.clear();
                for &t in &self.slots[s][e] {
                    Xe.extend_from_slice(&self.X[t as usize * dim..(t as usize + 1) * dim]);
                }
                &Xe
            } else {
                self.pos[s].of(e)
            };
            let Ok(rule) = tensor_rule(&el.basis.quadrature_counts()) else {
                blocks.push(Me);
                continue;
            };
            for (q, xi) in rule.points.chunks_exact(m).enumerate() {
                let mut x2 = [0.0; 2];
                x2[..m].copy_from_slice(xi);
                el.basis.eval(xi, &mut N, &mut dN, &mut ddN);
                let (_, _, nu) = crate::contact::surface::frame(el, dim, x_e, &x2);
                let J = (nu[0] * nu[0] + nu[1] * nu[1] + nu[2] * nu[2]).sqrt();
                for a in 0..n {
                    for b in 0..n {
                        Me[a * n + b] += N[a] * N[b] * J * rule.weights[q];
                    }
                }
            }
            for (a, &t) in self.slots[s][e].iter().enumerate() {
                diag[t as usize] += Me[a * n + a].abs();
            }
            blocks.push(Me);
        }
        let on: Vec<bool> = diag.iter().map(|&d| d > 0.0).collect();
        let apply = |v: &[f64], out: &mut [f64]| {
            out.fill(0.0);
            for (e, Me) in blocks.iter().enumerate() {
                let sl = &self.slots[s][e];
                let n = sl.len();
                for a in 0..n {
                    let mut acc = 0.0;
                    for b in 0..n {
                        acc += Me[a * n + b] * v[sl[b] as usize];
                    }
                    out[sl[a] as usize] += acc;
                }
            }
        };
        // preconditioned conjugate gradients on the surface's nodes
        let mut x = vec![0.0; nt];
        let mut r: Vec<f64> = (0..nt).map(|i| if on[i] { f[i] } else { 0.0 }).collect();
        let mut z: Vec<f64> = (0..nt)
            .map(|i| if on[i] { r[i] / diag[i] } else { 0.0 })
            .collect();
        let mut p = z.clone();
        let mut ap = vec![0.0; nt];
        let mut rz: f64 = r.iter().zip(&z).map(|(a, b)| a * b).sum();
        let r0 = r.iter().map(|v| v * v).sum::<f64>().sqrt();
        for _ in 0..10 * nt.max(10) {
            if r.iter().map(|v| v * v).sum::<f64>().sqrt() <= 1e-14 * r0.max(1e-300) {
                break;
            }
            apply(&p, &mut ap);
            let pap: f64 = p.iter().zip(&ap).map(|(a, b)| a * b).sum();
            if pap <= 0.0 {
                break;
            }
            let alpha = rz / pap;
            for i in 0..nt {
                x[i] += alpha * p[i];
                r[i] -= alpha * ap[i];
                z[i] = if on[i] { r[i] / diag[i] } else { 0.0 };
            }
            let rz_new: f64 = r.iter().zip(&z).map(|(a, b)| a * b).sum();
            let beta = rz_new / rz;
            rz = rz_new;
            for i in 0..nt {
                p[i] = z[i] + beta * p[i];
            }
        }
        x
    }

    /// Per own element of half-pass `pass` of pair `pair`, per point: its normal pressure, its
    /// normal gap (NaN without a partner) and its reference weight `w J0`, at the last evaluation.
    #[cfg(test)]
    pub(crate) fn points_per_element(&self, pair: usize, pass: usize) -> Vec<Vec<(f64, f64, f64)>> {
        let ps = &self.pairs[pair].passes[pass];
        ps.elems
            .iter()
            .map(|oe| {
                (oe.first..oe.first + oe.n)
                    .map(|q| {
                        let p = &ps.points[q];
                        (p.p_n, p.gap.unwrap_or(f64::NAN), p.w * p.J0)
                    })
                    .collect()
            })
            .collect()
    }

    /// The one-pass residual of master-surface nodes from the last [`ContactSystem::assemble`],
    /// per table node [n_table][dim] (zero without one-pass pairs).
    pub fn table_residual(&self) -> &[f64] {
        &self.r_table
    }

    /// Global nodes on which this rank's contact points may put a force: the nodes of every own
    /// element that carries points, and every node of a one-pass pair's master surface.
    pub fn loaded_nodes(&self) -> Vec<u32> {
        let mut out = Vec::new();
        for pair in &self.pairs {
            for pass in &pair.passes {
                for oe in pass.elems.iter().filter(|oe| oe.n > 0) {
                    out.extend_from_slice(&self.surfaces[pass.k].elements[oe.e as usize].nodes);
                }
                if let (true, Partner::Surface(l)) = (pair.def.one_pass, &pass.partner) {
                    for el in &self.surfaces[*l].elements {
                        out.extend_from_slice(&el.nodes);
                    }
                }
            }
        }
        out.sort_unstable();
        out.dedup();
        out
    }

    /// True when some pair is one-pass (its master rows go back through the table).
    pub fn has_one_pass(&self) -> bool {
        self.pairs.iter().any(|p| p.def.one_pass)
    }

    /// Table indices of the nodes of surface `s`, sorted.
    pub fn surface_nodes(&self, s: usize) -> Vec<u32> {
        let mut v: Vec<u32> = self.slots[s].iter().flatten().copied().collect();
        v.sort_unstable();
        v.dedup();
        v
    }

    /// Global node ids of the table entries.
    pub fn table(&self) -> &[u32] {
        &self.table
    }

    /// Keeps the current projections as warm starts of the next step.
    pub fn commit(&mut self) {
        self.commit_warm_starts();
        for pair in &mut self.pairs {
            for pass in &mut pair.passes {
                for q in &mut pass.points {
                    q.anchor = q.anchor_trial;
                }
            }
        }
    }

    /// Commits the projection warm starts only: the friction anchors stay those of the last
    /// converged load step. For the intermediate states of a solver device (the damped rescue's
    /// pseudo-time points), which must not change the step's discrete problem: a rescued step's
    /// frictional return mapping still starts from the previous step's anchors, as any step's does.
    pub fn commit_warm_starts(&mut self) {
        self.last_update = None;
        self.active_set.reset();
        for pair in &mut self.pairs {
            for pass in &mut pair.passes {
                for q in &mut pass.points {
                    q.committed = q.warm;
                }
            }
        }
    }

    /// Returns the warm starts to the last committed state.
    pub fn rollback(&mut self) {
        self.last_update = None;
        self.active_set.reset();
        for pair in &mut self.pairs {
            for pass in &mut pair.passes {
                for q in &mut pass.points {
                    q.warm = q.committed;
                    q.anchor_trial = q.anchor;
                }
            }
        }
    }

    /// The contact surfaces.
    pub fn surfaces(&self) -> &[ContactSurface] {
        &self.surfaces
    }

    /// Number of table nodes.
    pub fn n_table(&self) -> usize {
        self.table.len()
    }
}

/// The law's partner of an own point at `xk` [3] (its current position; used for a rigid
/// partner only): the rigid shape's closest point within `dist`, or the point's current
/// projection onto surface `l`. Returns the partner element (`u32::MAX`: rigid) and the point.
#[allow(clippy::too_many_arguments)]
fn contact_partner<'a>(
    shape: Option<&RigidShape>,
    l: Option<usize>,
    current: Option<Projection>,
    xk: &[f64; 3],
    dist: f64,
    surfaces: &'a [ContactSurface],
    pos: &'a [Positions],
) -> Option<(u32, PartnerPoint<'a>)> {
    match (shape, l) {
        (Some(shape), _) => shape
            .project(xk)
            .filter(|rp| (rp.g[0] * rp.g[0] + rp.g[1] * rp.g[1] + rp.g[2] * rp.g[2]).sqrt() <= dist)
            .map(|rp| (u32::MAX, PartnerPoint::Rigid(rp))),
        (None, Some(l)) => current.map(|p| {
            let le = p.elem as usize;
            (
                p.elem,
                PartnerPoint::Projected {
                    el: &surfaces[l].elements[le],
                    y: pos[l].of(le),
                    xi: p.xi,
                    free: p.free,
                },
            )
        }),
        (None, None) => None,
    }
}

/// Tangent blocks of the current own element, keyed by partner element.
type Blocks = Vec<(u32, Vec<f64>)>;

/// The slot of the tangent block coupling the current own element with partner element `le`,
/// zeroed to `len` entries when it is new for this element.
fn block_slot(blocks: &mut Blocks, n_used: &mut usize, le: u32, len: usize) -> usize {
    if let Some(i) = blocks[..*n_used].iter().position(|(b, _)| *b == le) {
        return i;
    }
    if *n_used == blocks.len() {
        blocks.push((le, Vec::new()));
    }
    let (key, buf) = &mut blocks[*n_used];
    *key = le;
    buf.clear();
    buf.resize(len, 0.0);
    *n_used += 1;
    *n_used - 1
}

/// The current area element of an own point (what the penalty law's traction is measured on).
fn point_area(dim: usize, own: &OwnPoint) -> f64 {
    let m = dim - 1;
    let mut a = [[0.0; 3]; 2];
    for (b, row) in own.x.chunks_exact(dim).enumerate() {
        for i in 0..m {
            for c in 0..dim {
                a[i][c] += own.dN[b * m + i] * row[c];
            }
        }
    }
    let nu = raw_normal(dim, &a);
    (nu[0] * nu[0] + nu[1] * nu[1] + nu[2] * nu[2]).sqrt()
}

fn area_of(law: &Law) -> Area {
    match law {
        Law::Penalty { .. } | Law::Cohesive { .. } => Area::Current,
        Law::VanDerWaals { .. } => Area::Reference,
    }
}
