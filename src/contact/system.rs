//! All contact pairs of a model on this rank: their surfaces (topology replicated on every rank),
//! the quadrature points this rank integrates, their projection state, and the evaluation of
//! residual, tangent blocks and resultant forces. Free of PETSc and MPI: the assembler hands in the
//! current displacement of the surface nodes this rank holds and takes residual entries and matrix
//! blocks out.
//!
//! Parallel design (measured in docs/performance/contact.md, "Contact data per rank"): a rank holds the current positions of its own surface elements, of the elements that
//! hold its points and of a *ghost layer* of partner elements within reach of its points
//! (`ghost.rs`); the gather before every evaluation (`table_dofs` feeds a PETSc scatter) carries
//! only their nodes, and `update_positions` touches only them. The layer is refreshed
//! (collectively, by the assembler) when a surface node moves past its margin or a projection
//! needs an element outside it. Still replicated on every rank: the surfaces' topology and basis
//! data and the reference coordinates of every surface node (the next stage ships them with the
//! ghosts, see `ghost.rs`).
#![allow(clippy::needless_range_loop)]
#![allow(non_snake_case)]

use crate::assembly::{DofMap, MatrixSink};
use crate::contact::half_pass::{self, Pass, PassResult};
use crate::contact::kernel::SlipState;
use crate::contact::pair::{Anchor, PairDef, Partner, SlotOf};
use crate::contact::projection::{off_the_edge, surface_grid, walk_from, Absent, Positions};
use crate::contact::search::BinGrid;
use crate::contact::surface::ContactSurface;
use partner_points::PartnerPoint;

mod augment;
mod checkpoint;
mod coupling;
mod footprint;
mod ghost;
mod partner_points;
mod pattern;
mod pressure;
mod sanity;
mod segments;
mod setup;
pub use checkpoint::ROW as CHECKPOINT_ROW;
pub use footprint::Footprint;
pub use pressure::{symmetry_planes, symmetry_ties};
pub use sanity::{PassDepth, PassSlip};
pub(crate) use segments::{segmented, Segments};

/// Values per point of [`ContactSystem::point_records`].
pub const POINT_RECORD: usize = 18;

/// A pair and its half-passes on this rank.
struct Pair {
    def: PairDef,
    passes: Vec<Pass>,
}

/// Every contact pair of the model on this rank.
pub struct ContactSystem {
    dim: usize,
    /// The surface displacement and load of the last successful [`ContactSystem::update`] since
    /// the last commit or rollback: an update at the same state (the Jacobian after the residual
    /// at one iterate) keeps its projections instead of repeating them.
    last_update: Option<(f64, Vec<f64>)>,
    surfaces: Vec<ContactSurface>,
    /// Global ids of every surface node (replicated, as the topology), sorted, and their reference
    /// coordinates [n][dim].
    all_nodes: Vec<u32>,
    all_X: Vec<f64>,
    /// The elements this rank holds positions of (see `ghost.rs`).
    ghost: ghost::Ghosts,
    /// Global node ids whose displacement the system needs (the nodes of the held elements),
    /// sorted.
    table: Vec<u32>,
    /// Reference coordinates of the table nodes [n_table][dim].
    X: Vec<f64>,
    /// Per surface, per element: positions of its nodes in `table` (empty for an element this
    /// rank does not hold). [surface][element][node]
    slots: Vec<Vec<Vec<u32>>>,
    /// Per surface, per element: global unknowns of its nodes [n_nodes * dim] (-1: none).
    gdofs: Vec<Vec<Vec<i32>>>,
    /// Current positions per surface (of the held elements; the others have none).
    pos: Vec<Positions>,
    grids: Vec<Option<BinGrid>>,
    /// Per surface, per element: its basis at its centre, where the global search's projections
    /// start ([`crate::contact::projection::basis_values`] at `xi = 0`; fixed, as the bases).
    centres: Vec<Vec<Vec<f64>>>,
    pairs: Vec<Pair>,
    lambda: f64,
    cand: Vec<u32>,
    /// The half-passes' buffers, and the one-pass residual of master-surface nodes.
    work: half_pass::Work,
}

impl ContactSystem {
    /// Global unknown of every table entry [n_table * dim], in table order: the indices of the
    /// gather that feeds [`ContactSystem::update`].
    pub fn table_dofs(&self, dofs: &DofMap) -> Vec<i32> {
        dofs.gather_indices(&self.table)
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
        self.check_motion(u_table);
        self.segment_all();
        self.ghost.requests.clear();
        self.request_anchors();
        for pair in &mut self.pairs {
            for pass in &mut pair.passes {
                if let Partner::Rigid(shape, motion) = &pass.partner {
                    pass.shape = Some(shape.at(motion, self.lambda));
                }
            }
        }
        let dim = self.dim;
        self.for_each_partner_point(
            |_| true,
            |sys, pt| {
                let PartnerPoint { pair, pass, q, k, e, l, x } = pt;
                let dist = sys.pairs[pair].def.search_distance;
                let ps = &sys.pairs[pair].passes[pass];
                // an unused segment slot: no partner
                if ps.points[q].w == 0.0 {
                    let point = &mut sys.pairs[pair].passes[pass].points[q];
                    (point.current, point.edge) = (None, None);
                    return Ok(());
                }
                let warm = ps.points[q].trial.projection;
                // the partner basis at the warm start is the one the last evaluation used
                let known = warm.and_then(|(f, xi)| ps.bases.get(q).and_then(|b| b.get(f, &xi)));
                let walked = warm.map(|w| walk_from(&sys.surfaces[l], &sys.pos[l], &x, w, known));
                let mut p = match walked {
                    Some(Ok(p)) => p,
                    // outside the ghost layer: the update is repeated after a refresh
                    Some(Err(Absent(f))) => {
                        sys.ghost.requests.push((l as u32, f));
                        None
                    }
                    None => None,
                };
                let failed = |sys: &Self| {
                    format!(
                        "contact `{}`: the projection of a point of `{}` (element {e}) at {:?} onto `{}` failed on every candidate element",
                        sys.pairs[pair].def.name,
                        sys.surfaces[k].name,
                        &x[..dim],
                        sys.surfaces[l].name
                    )
                };
                // The mortar gaps weigh every point's gap, open ones too: a walk from a warm start
                // may hold an orthogonal projection where the closest point of the whole surface
                // lies beyond its end (the gaps then depended on the states evaluated before),
                // and a point beyond the end keeps its distance there (`edge`) so that its gap
                // does not jump as it passes the end. The walk's point seeds the search.
                let mortar = sys.pairs[pair].def.formulation.pressure.is_nodal();
                // (a penetrating point keeps its walk's projection, as the pointwise gap does: the
                // closest point of a deep one may lie elsewhere, even beyond the end)
                let penetrating = p.filter(|p| p.dist <= dist).is_some_and(|p| {
                    let el = &sys.surfaces[l].elements[p.elem as usize];
                    let (y, _, nr) = crate::contact::surface::frame(el, dim, sys.pos[l].of(p.elem as usize), &p.xi);
                    el.sign * (0..dim).map(|c| (x[c] - y[c]) * nr[c]).sum::<f64>() <= 0.0
                });
                let mut edge = None;
                let seed = p.filter(|p| p.dist <= dist);
                // a walk's point within reach that no end of the surface can beat is the answer
                // of the search below (which would only confirm it)
                let settled = mortar
                    && !penetrating
                    && seed.is_some_and(|w| !sys.end_may_be_closest(l, &x, dist, &w));
                if settled {
                    (p, edge) = (seed, None);
                } else if mortar && !penetrating {
                    let best = sys
                        .closest_partner(l, &x, dist, seed)
                        .map_err(|_| failed(sys))?
                        .filter(|b| b.dist <= dist);
                    let beyond = best.is_some_and(|b| off_the_edge(&sys.surfaces[l], &b));
                    let walked = p.filter(|p| p.dist <= dist);
                    // an interior projection the walk found stays (as for the pointwise gap; a
                    // closer interior point elsewhere took partners from converging runs of the
                    // 3D twist: two-half-pass `weighted_mean` then failed on meshes 4 and 8)
                    (p, edge) = match (beyond, walked) {
                        (true, _) => (None, best),
                        (false, Some(w)) => (Some(w), None),
                        (false, None) => (best, None),
                    };
                } else if p.is_none_or(|p| p.dist > dist) {
                    let found = sys.search_partner(l, &x, dist).map_err(|_| failed(sys))?;
                    // the global search sees every element in reach: its answer wins (None: no
                    // partner in reach, or beyond the surface's end)
                    p = match found {
                        Some(f) if p.is_none_or(|p| f.dist < p.dist) => Some(f),
                        Some(_) => p,
                        None => None,
                    };
                }
                let p = p.filter(|p| p.dist <= dist);
                let ps = &mut sys.pairs[pair].passes[pass];
                let point = &mut ps.points[q];
                point.current = p;
                point.edge = edge;
                if let Some(p) = p {
                    point.trial.projection = Some((p.elem, p.xi));
                    // the partner basis at the projection, for the evaluations (and the next
                    // update's warm start)
                    if ps.bases.len() < ps.points.len() {
                        ps.bases.resize(ps.points.len(), Default::default());
                    }
                    ps.bases[q].set(&sys.surfaces[l], p.elem, &p.xi);
                }
                Ok(())
            },
        )
    }

    /// Adds the contact residual of this rank's points to `f_local` (ghosted local vector) and, with
    /// `jac`, each coupling block to the sink at the slot `slot_of` gives it. Uses the projections
    /// of the last [`ContactSystem::update`].
    pub fn assemble(
        &mut self,
        f_local: &mut [f64],
        mut jac: Option<(&mut dyn MatrixSink, &SlotOf)>,
    ) {
        self.work.r_table.fill(0.0);
        self.work.absent.clear();
        let geo = half_pass::Geometry {
            dim: self.dim,
            surfaces: &self.surfaces,
            pos: &self.pos,
            slots: &self.slots,
            gdofs: &self.gdofs,
        };
        let mut pass_id = 0u32;
        for pair in &mut self.pairs {
            let def = &pair.def;
            let view = half_pass::PairView {
                formulation: def.formulation,
                moment_point: def.moment_point,
                search_distance: def.search_distance,
                friction: def.friction.as_ref().filter(|f| f.on_at(self.lambda)),
                has_friction: def.friction.is_some(),
                lambda: self.lambda,
            };
            for pass in &mut pair.passes {
                half_pass::run(
                    pass,
                    pass_id,
                    &view,
                    &geo,
                    &mut self.work,
                    f_local,
                    &mut jac,
                );
                pass_id += 1;
            }
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
                // 3D segments: the set-up points' count per element (the grid's, fixed; an
                // element grown for more shows its first ones)
                let shown = pass
                    .segments
                    .as_ref()
                    .filter(|s| s.three_d())
                    .map(|s| s.per_element());
                for oe in &pass.elems {
                    let e = oe.e as usize;
                    let el = &self.surfaces[k].elements[e];
                    let n = shown.map_or(oe.slots, |s| s.min(oe.slots));
                    for q in oe.first..oe.first + n {
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
                        // an unused segment slot carries no pressure or gap: NaN
                        let (p, g) = match qp.w == 0.0 {
                            true => (f64::NAN, f64::NAN),
                            false => (p, qp.gap.unwrap_or(f64::NAN)),
                        };
                        out.extend([p, g, state]);
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

    /// Per own element of half-pass `pass` of pair `pair`, per point: its normal pressure, its
    /// normal gap (NaN without a partner) and its reference weight `w J0`, at the last evaluation.
    /// The mortar gap's weighted gaps of a pass at the last evaluation (empty without it).
    #[cfg(test)]
    pub(crate) fn weighted_gaps(&self, pair: usize, pass: usize) -> Vec<f64> {
        let ps = &self.pairs[pair].passes[pass];
        ps.mortar.as_ref().map_or(Vec::new(), |m| m.gaps().to_vec())
    }

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
        &self.work.r_table
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
                if let (true, Partner::Surface(l)) =
                    (pair.def.formulation.one_pass(), &pass.partner)
                {
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
        self.pairs.iter().any(|p| p.def.formulation.one_pass())
    }

    /// Indices in [`ContactSystem::all_surface_nodes`] of the nodes of surface `s`, sorted.
    pub fn surface_nodes(&self, s: usize) -> Vec<u32> {
        let mut v: Vec<u32> = self.surfaces[s]
            .elements
            .iter()
            .flat_map(|el| el.nodes.iter().map(|a| self.node_index(*a) as u32))
            .collect();
        v.sort_unstable();
        v.dedup();
        v
    }

    /// Global ids of every surface node, sorted (the index of the output's L2 projections).
    pub fn all_surface_nodes(&self) -> &[u32] {
        &self.all_nodes
    }

    /// Index of surface node `a` in [`ContactSystem::all_surface_nodes`].
    fn node_index(&self, a: u32) -> usize {
        self.all_nodes.binary_search(&a).expect("a surface node")
    }

    /// Global node ids of the table entries.
    pub fn table(&self) -> &[u32] {
        &self.table
    }

    /// Keeps the current projections as warm starts of the next step.
    pub fn commit(&mut self) {
        self.forget_trial();
        self.each_point_mut(|q| q.committed = q.trial);
        for net in self.mortar_nets_mut() {
            net.lambda_committed.clone_from(&net.lambda);
        }
    }

    /// Commits the projection warm starts only: the friction anchors stay those of the last
    /// converged load step. For the intermediate states of a solver device (the damped rescue's
    /// pseudo-time points), which must not change the step's discrete problem: a rescued step's
    /// frictional return mapping still starts from the previous step's anchors, as any step's does.
    pub fn commit_warm_starts(&mut self) {
        self.forget_trial();
        self.each_point_mut(|q| q.committed.projection = q.trial.projection);
    }

    /// Returns the warm starts to the last committed state.
    pub fn rollback(&mut self) {
        self.forget_trial();
        self.each_point_mut(|q| q.trial = q.committed);
        for net in self.mortar_nets_mut() {
            net.lambda.clone_from(&net.lambda_committed);
        }
    }

    /// Drops what the evaluations since the last commit or rollback left: the cached update.
    fn forget_trial(&mut self) {
        self.last_update = None;
    }

    /// The one walk over every quadrature point this rank integrates (pair, half-pass, point).
    fn each_point_mut(&mut self, f: impl FnMut(&mut half_pass::QPoint)) {
        self.pairs
            .iter_mut()
            .flat_map(|p| &mut p.passes)
            .flat_map(|pass| &mut pass.points)
            .for_each(f);
    }

    /// The control nets of the mortar-gap passes.
    fn mortar_nets_mut(&mut self) -> impl Iterator<Item = &mut half_pass::mortar::MortarNet> {
        self.pairs
            .iter_mut()
            .flat_map(|p| &mut p.passes)
            .filter_map(|pass| pass.mortar.as_mut())
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
