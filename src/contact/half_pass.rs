//! One half-pass (section 3.2 of Corbett & Sauer 2014): the quadrature points of surface `k` that
//! this rank integrates, each paired with partner `l` (another surface or a rigid shape). Per own
//! element, per point: gather (the element's stored basis and current nodes) -> partner (the
//! point's projection, cohesive pairing or rigid closest point) -> law -> point kernel
//! ([`crate::contact::kernel`]) -> scatter (residual rows of the own element, tangent blocks own x
//! partner element into the sink).
//!
//! Pluggable parts, not branches of one loop:
//! - [`gap`]: where the penalty law's normal gap is taken (pointwise, the paper's; `element_mean`,
//!   one pressure per surface element; `weighted`, one pressure per control point of the surface,
//!   [`weighted`]);
//! - [`friction`]: Coulomb friction's anchors, their blocks and their update.
#![allow(clippy::needless_range_loop)]
#![allow(non_snake_case)]

mod element_mean;
pub(crate) mod friction;
pub(crate) mod gap;
pub(crate) mod mortar;

use crate::assembly::MatrixSink;
use crate::contact::formulation::{Enforcement, Formulation};
use crate::contact::kernel::{
    contact_point_pass, gap_and_normal, Area, OwnPoint, PartnerPoint, PointIn, PointResult,
    Scratch, SlipState,
};
use crate::contact::law::{self, Traction};
use crate::contact::pair::{
    law_traction, Anchor, BlockKey, Coupling, Friction, Law, Partner, SlotOf,
};
use crate::contact::projection::{BasisAt, Positions, Projection};
use crate::contact::rigid::{RigidMotion, RigidShape};
use crate::contact::surface::{raw_normal, ContactSurface, MAX_FACE_NODES};
use friction::AnchorAt;
use gap::Gap;
use mortar::MortarNet;

#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct QPoint {
    /// Surface coordinates on its own element [m].
    pub(crate) xi: [f64; 2],
    /// Gauss weight.
    pub(crate) w: f64,
    /// Reference area element.
    pub(crate) J0: f64,
    /// The load-step history the current evaluations lead to: the last projection (updated by
    /// every evaluation), the friction anchor and the augmented Lagrangian multiplier the current
    /// solves use.
    pub(crate) trial: PointState,
    /// The history of the last converged step ([`ContactSystem::commit`] copies `trial` here,
    /// [`ContactSystem::rollback`] back).
    ///
    /// [`ContactSystem::commit`]: crate::contact::ContactSystem::commit
    /// [`ContactSystem::rollback`]: crate::contact::ContactSystem::rollback
    pub(crate) committed: PointState,
    /// Projection of the current evaluation: partner element, coordinates, free flags.
    pub(crate) current: Option<Projection>,
    /// Mortar gaps: the closest point of the partner surface when it lies beyond the surface's
    /// end (no partner, `current` is `None`), within the search distance. Its distance is the
    /// point's gap in the weighted gaps, and the point's interpolated pressure acts along it.
    pub(crate) edge: Option<Projection>,
    /// Cohesive material pairing (partner element, coordinates), if bonded.
    pub(crate) pairing: Option<(u32, [f64; 2])>,
    /// Contact force of the point at the last evaluation, `t J w` summed over its contributions.
    pub(crate) force: [f64; 3],
    /// Normal gap to the partner at the last evaluation (`None`: no partner within reach).
    pub(crate) gap: Option<f64>,
    /// Friction: stick or slip at the last evaluation.
    pub(crate) slip: SlipState,
    /// Friction: tangential traction and tangential gap to the anchor at the last evaluation
    /// (output only).
    pub(crate) t_t: [f64; 3],
    pub(crate) g_t: [f64; 3],
    /// Reference position (output only).
    pub(crate) X: [f64; 3],
    /// Normal pressure at the last evaluation (output, and the augmented Lagrangian's update).
    pub(crate) p_n: f64,
}

/// A quadrature point's load-step history: all of it is committed when a step converges and
/// rolled back when it fails.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(crate) struct PointState {
    /// Projection onto the partner (element, surface coordinates): the next update's warm start.
    pub(crate) projection: Option<(u32, [f64; 2])>,
    /// Friction: where the point sticks on the partner.
    pub(crate) anchor: Option<Anchor>,
    /// Augmented Lagrangian: the multiplier (a pressure). Zero without augmentation.
    pub(crate) lambda: f64,
}

/// A surface element this rank integrates.
#[derive(Debug, Clone)]
pub(crate) struct OwnElem {
    pub(crate) e: u32,
    /// Points `points[first..first + n]`, in `slots` reserved from `first` (more than `n` where a
    /// segmented pass placed fewer points than it has room for; the rest have weight 0).
    pub(crate) first: usize,
    pub(crate) n: usize,
    pub(crate) slots: usize,
    /// Local (ghosted) index of each unknown, [n_nodes * dim].
    pub(crate) local: Vec<u32>,
    /// The element's basis at its points (their surface coordinates never change), evaluated
    /// once: values [n][n_nodes] and first derivatives [n][n_nodes][m].
    pub(crate) N: Vec<f64>,
    pub(crate) dN: Vec<f64>,
}

impl OwnElem {
    /// Basis values and first derivatives at point `q` (an index into the pass's points).
    pub(crate) fn basis(&self, q: usize) -> (&[f64], &[f64]) {
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
    pub(crate) fn position(&self, q: usize, x: &[f64], dim: usize) -> [f64; 3] {
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

pub(crate) struct Pass {
    pub(crate) k: usize,
    pub(crate) partner: Partner,
    /// The points of `elems`, then those of `halo`.
    pub(crate) points: Vec<QPoint>,
    pub(crate) elems: Vec<OwnElem>,
    /// Mortar gap: the elements of other ranks that share a control point with `elems`; their
    /// points are projected (each control point's gap needs its whole support), not integrated.
    pub(crate) halo: Vec<OwnElem>,
    /// Mortar gap: the control points of `elems` and `halo`.
    pub(crate) mortar: Option<MortarNet>,
    /// Frictionless one-pass pairs (a weighted gap, or in 2D the pointwise gap under the plain
    /// penalty): the elements' points are placed on segments between the master's element
    /// boundaries (2D) or on the master elements' images (3D) at every update
    /// ([`crate::contact::system`]'s `segments`).
    pub(crate) segments: Option<crate::contact::system::Segments>,
    /// Rigid shape at the current load.
    pub(crate) shape: Option<RigidShape>,
    pub(crate) result: PassResult,
    /// Per point (of `points`; shorter until the first projection): the partner's basis at the
    /// point's last projection, stored by the update for the evaluations (and the next update's
    /// warm start) to read instead of evaluating it again.
    pub(crate) bases: Vec<BasisAt>,
}

impl Pass {
    /// The elements whose points own element `i`'s rows couple with: itself, and under the mortar
    /// gap every element (own or halo) that shares a control point with it.
    pub(crate) fn coupled_elems(&self, i: usize) -> Vec<&OwnElem> {
        match &self.mortar {
            None => vec![&self.elems[i]],
            Some(net) => net.near[i]
                .iter()
                .map(|&j| {
                    let j = j as usize;
                    self.elems
                        .get(j)
                        .unwrap_or_else(|| &self.halo[j - self.elems.len()])
                })
                .collect(),
        }
    }
}

/// The surfaces a half-pass reads: their elements, current positions and unknowns.
pub(crate) struct Geometry<'a> {
    pub dim: usize,
    pub surfaces: &'a [ContactSurface],
    /// Current positions per surface.
    pub pos: &'a [Positions],
    /// Per surface, per element: positions of its nodes in the node table. [surface][element][node]
    pub slots: &'a [Vec<Vec<u32>>],
    /// Per surface, per element: global unknowns of its nodes [n_nodes * dim] (-1: none).
    pub gdofs: &'a [Vec<Vec<i32>>],
}

/// What a half-pass reads of its pair.
pub(crate) struct PairView<'a> {
    /// Passes, pressure distribution, enforcement and law.
    pub formulation: Formulation,
    /// Moments are taken about this point [3].
    pub moment_point: [f64; 3],
    pub search_distance: f64,
    /// Friction acting at the current load (`None`: frictionless, or off in this stage).
    pub friction: Option<&'a Friction>,
    /// The pair has friction in some stage (its points keep stick/slip and anchors).
    pub has_friction: bool,
    /// Load parameter (rigid partners' motion).
    pub lambda: f64,
}

/// Buffers the half-passes reuse (nothing allocates per point once they have grown).
#[derive(Default)]
pub(crate) struct Work {
    /// One-pass residual of the master surfaces' nodes, per table node [n_table][dim] (their rows
    /// may belong to elements of other ranks, so they go back through the table's scatter).
    pub r_table: Vec<f64>,
    /// (surface, element) the last evaluation needed outside the ghost layer (a sliding anchor's
    /// walk): the next update asks for a refresh.
    pub absent: Vec<(u32, u32)>,
    scratch: Scratch,
    /// Residual of the own element being assembled [n_k * dim].
    r: Vec<f64>,
    /// Residual of one one-pass contribution [(n_k + n_l) * dim].
    rc: Vec<f64>,
    /// Tangent blocks of the own element being assembled, keyed by partner element; `n_used` of
    /// them in use (the buffers are kept between elements and evaluations).
    blocks: Blocks,
    n_used: usize,
    /// One-pass mortar gap: blocks of the master rows of partner element `.0` times the columns of
    /// block key `.1` (rows of one block of the element's region, columns of another), `n_cross`
    /// in use; and the master rows of one control point's `G_A`, per partner element (element,
    /// its number of rows, the rows).
    cross: Vec<(u32, u32, Vec<f64>)>,
    n_cross: usize,
    g_master: Vec<(u32, usize, [f64; 3 * MAX_FACE_NODES])>,
}

impl Work {
    /// The slot of the tangent block coupling the current own element with partner element `le`.
    fn block(&mut self, le: u32, len: usize) -> usize {
        block_slot(&mut self.blocks, &mut self.n_used, le, len)
    }
}

/// The sink and the slot of each coupling block, in a Jacobian evaluation.
pub(crate) type Jacobian<'a, 'b, 'c> = Option<(&'a mut dyn MatrixSink, &'b SlotOf<'c>)>;

/// One half-pass's fixed context during an evaluation.
struct HalfPass<'a> {
    geo: &'a Geometry<'a>,
    pair: &'a PairView<'a>,
    pass_id: u32,
    /// Integrated surface and deformable partner surface (`None`: rigid).
    k: usize,
    l: Option<usize>,
    /// Rigid partner's shape at the current load, and its motion.
    shape: Option<&'a RigidShape>,
    motion: Option<&'a RigidMotion>,
    /// Gaps below this count as touching.
    touch: f64,
    jacobian: bool,
}

/// What one point leaves for output and the next step.
#[derive(Default)]
struct PointOut {
    force: [f64; 3],
    gap: Option<f64>,
    anchor_trial: Option<Anchor>,
    slip: SlipState,
    t_t: [f64; 3],
    g_t: [f64; 3],
    p_n: f64,
    /// An element of the partner surface the point needed and this rank does not hold.
    absent: Option<u32>,
}

/// One contribution of a point: partner element (`u32::MAX`: rigid), partner point, the area its
/// traction is measured on, and whether it is the cohesive pairing.
type Contribution<'a> = (u32, PartnerPoint<'a>, Area, bool);

/// Evaluates half-pass `pass` (number `pass_id` over all pairs) with the projections of the last
/// update: residual into `f_local` (ghosted local vector), with `jac` its tangent blocks into the sink, resultants into
/// `pass.result`.
pub(crate) fn run(
    pass: &mut Pass,
    pass_id: u32,
    pair: &PairView,
    geo: &Geometry,
    work: &mut Work,
    f_local: &mut [f64],
    jac: &mut Jacobian,
) {
    let Pass {
        k,
        partner,
        points,
        elems,
        halo,
        mortar,
        shape,
        result,
        bases,
        segments: _,
    } = pass;
    let hp = HalfPass {
        geo,
        pair,
        pass_id,
        k: *k,
        l: match partner {
            Partner::Surface(l) => Some(*l),
            Partner::Rigid(..) => None,
        },
        shape: shape.as_ref(),
        motion: match partner {
            Partner::Rigid(_, m) => Some(m),
            Partner::Surface(_) => None,
        },
        touch: crate::contact::pair::TOUCH * geo.surfaces[*k].h,
        jacobian: jac.is_some(),
    };
    let mut gap = Gap::new(pair.formulation.pressure, mortar.as_mut());
    let all: Vec<&OwnElem> = elems.iter().chain(halo.iter()).collect();
    gap.begin_pass(&hp, &all, points);
    let mut res = PassResult::default();
    for (i, oe) in elems.iter().enumerate() {
        hp.element(i, oe, points, bases, &mut gap, work, &mut res);
        gap.end_element(&hp, i, &all, points, work);
        hp.scatter(oe, work, f_local, jac);
    }
    *result = res;
}

impl HalfPass<'_> {
    /// The points of own element `oe` (number `i`): their residual into `work.r`, their blocks
    /// into `work.blocks`.
    #[allow(clippy::too_many_arguments)]
    fn element(
        &self,
        i: usize,
        oe: &OwnElem,
        points: &mut [QPoint],
        bases: &[BasisAt],
        gap: &mut Gap,
        work: &mut Work,
        res: &mut PassResult,
    ) {
        let (dim, e) = (self.geo.dim, oe.e as usize);
        let nk = self.geo.surfaces[self.k].elements[e].basis.n_nodes();
        let x = self.geo.pos[self.k].of(e);
        work.r.clear();
        work.r.resize(nk * dim, 0.0);
        work.n_used = 0;
        work.n_cross = 0;
        let g_mean = gap.begin_element(self, oe, points, x);
        for q in oe.first..oe.first + oe.n {
            let qp = points[q];
            let (bN, bdN) = oe.basis(q);
            let own = OwnPoint {
                N: bN,
                dN: bdN,
                x,
                w: qp.w,
                J0: qp.J0,
            };
            let mut po = PointOut::default();
            let p_mortar = gap.mortar_pressure(i, q - oe.first);
            let known = match (qp.current, bases.get(q)) {
                (Some(p), Some(b)) => b.get(p.elem, &p.xi),
                _ => None,
            };
            for c in self.contributions(&own, &qp, known).into_iter().flatten() {
                let gm = (&*gap, g_mean, p_mortar);
                self.contribution(&own, &qp, q, c, gm, work, res, &mut po);
            }
            if let (Some(f), Some(l)) = (po.absent, self.l) {
                work.absent.push((l as u32, f));
            }
            let p = &mut points[q];
            p.force = po.force;
            p.gap = po.gap;
            p.trial.anchor = po.anchor_trial;
            p.slip = po.slip;
            p.t_t = po.t_t;
            p.g_t = po.g_t;
            p.p_n = po.p_n;
        }
    }

    /// The partners of an own point: the law's (projection or rigid closest point) and the
    /// cohesive material pairing. `known`: the partner's basis at the projection, if stored.
    fn contributions<'s>(
        &'s self,
        own: &OwnPoint,
        qp: &QPoint,
        known: Option<&'s [f64]>,
    ) -> [Option<Contribution<'s>>; 2] {
        let dim = self.geo.dim;
        let nk = own.N.len();
        let mut xk = [0.0; 3];
        if self.shape.is_some() {
            for a in 0..nk {
                for c in 0..dim {
                    xk[c] += own.N[a] * own.x[a * dim + c];
                }
            }
        }
        let area = area_of(&self.pair.formulation.law);
        // (mortar gaps: a point beyond the partner's end carries its interpolated pressure along
        // its distance to the end, as its gap weighs in: no jump where it passes the end)
        let first = self
            .partner(qp.current, &xk, known)
            .or_else(|| self.beyond_partner(qp.edge))
            .map(|(le, pp)| (le, pp, area, false));
        let second = match (self.shape, self.l, qp.pairing) {
            (None, Some(l), Some((le, xi0))) => Some((
                le,
                PartnerPoint::Material {
                    el: &self.geo.surfaces[l].elements[le as usize],
                    y: self.geo.pos[l].of(le as usize),
                    xi: xi0,
                },
                Area::Reference,
                true,
            )),
            _ => None,
        };
        [first, second]
    }

    /// The law's partner of an own point at `xk` [3] (its current position; used for a rigid
    /// partner only): the rigid shape's closest point within the search distance, or the point's
    /// current projection onto surface `l` (`basis`: the partner's basis there, if known, see
    /// [`PartnerPoint::Projected`]). Returns the partner element (`u32::MAX`: rigid).
    fn partner<'s>(
        &'s self,
        current: Option<Projection>,
        xk: &[f64; 3],
        basis: Option<&'s [f64]>,
    ) -> Option<(u32, PartnerPoint<'s>)> {
        let dist = self.pair.search_distance;
        match (self.shape, self.l) {
            (Some(shape), _) => shape
                .project(xk)
                .filter(|rp| {
                    (rp.g[0] * rp.g[0] + rp.g[1] * rp.g[1] + rp.g[2] * rp.g[2]).sqrt() <= dist
                })
                .map(|rp| (u32::MAX, PartnerPoint::Rigid(rp))),
            (None, Some(l)) => current.map(|p| self.projected(l, p, basis, false)),
            (None, None) => None,
        }
    }

    /// Projection `p` onto partner surface `l` as the kernel's partner point.
    fn projected<'s>(
        &'s self,
        l: usize,
        p: Projection,
        basis: Option<&'s [f64]>,
        beyond: bool,
    ) -> (u32, PartnerPoint<'s>) {
        let le = p.elem as usize;
        let el = &self.geo.surfaces[l].elements[le];
        let y = self.geo.pos[l].of(le);
        let (xi, free) = (p.xi, p.free);
        let pp = PartnerPoint::Projected {
            el,
            y,
            xi,
            free,
            basis,
            beyond,
        };
        (p.elem, pp)
    }

    /// The closest point `edge` of the partner surface beyond its end (mortar gaps, see
    /// [`QPoint::edge`]), as a partner whose normal is the gap's direction.
    fn beyond_partner(&self, edge: Option<Projection>) -> Option<(u32, PartnerPoint<'_>)> {
        Some(self.projected(self.l?, edge?, None, true))
    }

    /// The traction of one contribution: the cohesive law on a material pairing; else the
    /// pressure of the control points (`p_mortar`, mortar gap), or the pair's law at the gap the
    /// gap part gives (`g_mean`), or shifted by the point's multiplier `lambda` (augmented
    /// Lagrangian).
    fn traction(
        &self,
        cohesive: bool,
        p_mortar: Option<f64>,
        g_mean: Option<f64>,
        lambda: f64,
        g: &[f64; 3],
        n: &[f64; 3],
    ) -> Traction {
        let Formulation {
            law, enforcement, ..
        } = self.pair.formulation;
        if cohesive {
            match law {
                Law::Cohesive { t0, g0, .. } => law::cohesive(t0, g0, g),
                _ => Traction::ZERO,
            }
        } else if let Some(p) = p_mortar {
            mortar::pressure_traction(p, n)
        } else if let (Some(gm), Law::Penalty { eps_n }) = (g_mean, law) {
            gap::mean_penalty(eps_n, self.touch, gm, g, n)
        } else if let (Enforcement::Augmented(_), Law::Penalty { eps_n }) = (enforcement, law) {
            law::penalty_augmented(eps_n, lambda, self.touch, g, n)
        } else {
            law_traction(&law, self.touch, g, n)
        }
    }

    /// One contribution of point `q`: the kernel, the gap part's and friction's tangent terms, the
    /// master rows of a one-pass pair, the point's output and the pass's resultants.
    #[allow(clippy::too_many_arguments)]
    fn contribution(
        &self,
        own: &OwnPoint,
        qp: &QPoint,
        q: usize,
        (le, pp, area, cohesive): Contribution,
        (gap, g_mean, p_mortar): (&Gap, Option<f64>, Option<f64>),
        work: &mut Work,
        res: &mut PassResult,
        po: &mut PointOut,
    ) {
        let dim = self.geo.dim;
        let m = dim - 1;
        let nk = own.N.len();
        let on_edge =
            matches!(&pp, PartnerPoint::Projected { free, .. } if !free[..m].iter().all(|&f| f));
        let nl = match &pp {
            PartnerPoint::Rigid(_) => 0,
            PartnerPoint::Projected { el, .. } | PartnerPoint::Material { el, .. } => {
                el.basis.n_nodes()
            }
        };
        let nc = (nk + nl) * dim;
        let rows = if self.pair.formulation.one_pass() {
            nc
        } else {
            nk * dim
        };
        let kb = self.jacobian.then(|| work.block(le, rows * nc));
        let at: Option<AnchorAt> = match (self.pair.friction, cohesive, qp.committed.anchor) {
            (Some(f), false, Some(a)) => friction::anchor_at(self, f, a),
            _ => None,
        };
        let master = self.pair.formulation.one_pass() && nl > 0;
        work.rc.clear();
        work.rc.resize(nc, 0.0);
        let lawf = |g: &[f64; 3], n: &[f64; 3]| {
            self.traction(cohesive, p_mortar, g_mean, qp.trial.lambda, g, n)
        };
        let input = PointIn {
            dim,
            own,
            partner: &pp,
            law: &lawf,
            friction: at.as_ref().map(|a| &a.fin),
            area,
            one_pass: master,
        };
        let K = kb.map(|i| &mut work.blocks[i].1[..]);
        let r = if master { &mut work.rc } else { &mut work.r };
        let pr = contact_point_pass(&input, r, K, &mut work.scratch);
        if self.jacobian && !cohesive {
            gap.correct(self, own, q, &pr, g_mean, work);
        }
        if master {
            self.master_rows(le, nk, work);
        }
        if !cohesive {
            po.gap = Some(pr.g[0] * pr.n[0] + pr.g[1] * pr.n[1] + pr.g[2] * pr.n[2]);
            po.p_n = pr.p_n;
            if !self.jacobian && debug_points() {
                self.trace_point(qp, q, le, &pp, &pr);
            }
        }
        if let Some(a) = &at {
            if self.jacobian {
                // one-pass: the master element's basis at the projection, for its rows
                let nl_at = if master {
                    gap_and_normal(dim, &pr.x, &pp).map(|pg| (pg.basis, pg.n_nodes))
                } else {
                    None
                };
                let m = nl_at.as_ref().map(|(b, n)| (le, &b[..*n]));
                friction::anchor_block(self, own, a, &pr.friction, m, work);
            }
        }
        if self.pair.has_friction && !cohesive && pr.active {
            friction::record(self, own, qp, &pr, res, po);
        }
        for c in 0..3 {
            po.force[c] += pr.force[c];
        }
        if pr.active {
            res.add(&pr, cohesive, on_edge, &self.pair.moment_point);
        }
    }

    /// A one-pass contribution: its own rows into the element's residual, its master rows into
    /// the table's residual (their rows may belong to elements of other ranks).
    fn master_rows(&self, le: u32, nk: usize, work: &mut Work) {
        let dim = self.geo.dim;
        for (v, rv) in work.r.iter_mut().zip(&work.rc[..nk * dim]) {
            *v += rv;
        }
        let l = self.l.expect("a master surface");
        for (b, &t) in self.geo.slots[l][le as usize].iter().enumerate() {
            for c in 0..dim {
                work.r_table[t as usize * dim + c] += work.rc[(nk + b) * dim + c];
            }
        }
    }

    /// `NURBS_CONTACT_DEBUG_POINTS`: one line on stderr per law contribution of a residual
    /// evaluation (the last line of a point at a load is its converged state): load, half-pass,
    /// the point's reference x, its index, partner element, partner coordinate xi (2D: the first),
    /// whether the projection is orthogonal (1) or held on an edge (0), current position x y,
    /// normal gap, pressure, normal n_x n_y, force f_x f_y.
    fn trace_point(&self, qp: &QPoint, q: usize, le: u32, pp: &PartnerPoint, pr: &PointResult) {
        let (xi, free) = match pp {
            PartnerPoint::Projected { xi, free, .. } => (xi[0], free[0]),
            _ => (f64::NAN, true),
        };
        let g_n = pr.g[0] * pr.n[0] + pr.g[1] * pr.n[1] + pr.g[2] * pr.n[2];
        eprintln!(
            "POINT {:.9} {} {:.9} {} {} {:.15e} {} {:.15e} {:.15e} {:.15e} {:.15e} {:.15e} {:.15e} {:.15e} {:.15e}",
            self.pair.lambda,
            self.pass_id,
            qp.X[0],
            q,
            le,
            xi,
            free as u8,
            pr.x[0],
            pr.x[1],
            g_n,
            pr.p_n,
            pr.n[0],
            pr.n[1],
            pr.force[0],
            pr.force[1]
        );
    }

    /// The element's residual into the local vector and its blocks into the sink.
    fn scatter(&self, oe: &OwnElem, work: &Work, f_local: &mut [f64], jac: &mut Jacobian) {
        let e = oe.e as usize;
        for (i, &li) in oe.local.iter().enumerate() {
            if li != u32::MAX {
                f_local[li as usize] += work.r[i];
            }
        }
        if let Some((sink, slot_of)) = jac.as_mut() {
            for (le, kb) in &work.blocks[..work.n_used] {
                let c: Coupling = (self.pass_id, oe.e, *le);
                let own_rows = &self.geo.gdofs[self.k][e];
                let key = BlockKey::decode(*le);
                let cols = match key {
                    BlockKey::Own(e2) => self.geo.gdofs[self.k][e2 as usize].clone(),
                    BlockKey::Rigid => own_rows.clone(),
                    BlockKey::Partner(l_e) | BlockKey::Reach(l_e) => {
                        let l = self.l.expect("a partner surface");
                        let mut cols = own_rows.clone();
                        cols.extend_from_slice(&self.geo.gdofs[l][l_e as usize]);
                        cols
                    }
                };
                // one-pass: a partner block's rows are the own element's and the partner's (an
                // own-columns block of the mortar gap, and a `Reach` block, keep the own rows)
                let rows =
                    if self.pair.formulation.one_pass() && matches!(key, BlockKey::Partner(_)) {
                        &cols
                    } else {
                        own_rows
                    };
                if let Some(slot) = slot_of(&c) {
                    sink.add_block(slot, rows, &cols, kb);
                } else if let Some(slot) = reach_in_partner(slot_of, c) {
                    // (the pattern reserved the partner's rows too: the own rows are its first)
                    sink.add_cross((slot, 0), (slot, 0), rows, &cols, kb);
                }
            }
            // one-pass mortar gap: master rows of a partner element's block times the columns
            // of another block of the element
            for (le, key, kb) in &work.cross[..work.n_cross] {
                let l = self.l.expect("a master surface");
                let own_rows = &self.geo.gdofs[self.k][e];
                let (cols, col_from) = match BlockKey::decode(*key) {
                    BlockKey::Own(e2) => (&self.geo.gdofs[self.k][e2 as usize], 0),
                    BlockKey::Partner(l_e) | BlockKey::Reach(l_e) => {
                        (&self.geo.gdofs[l][l_e as usize], own_rows.len())
                    }
                    BlockKey::Rigid => unreachable!("one-pass cross blocks have a master surface"),
                };
                let rows = &self.geo.gdofs[l][*le as usize];
                let col_block = (self.pass_id, oe.e, *key);
                let (Some(rs), Some(cs)) = (
                    slot_of(&(self.pass_id, oe.e, *le)),
                    slot_of(&col_block).or_else(|| reach_in_partner(slot_of, col_block)),
                ) else {
                    continue;
                };
                sink.add_cross((rs, own_rows.len()), (cs, col_from), rows, cols, kb);
            }
        }
    }
}

/// The slot of the [`BlockKey::Partner`] block with the columns of `Reach` block `c` (the same
/// columns, and the own element's rows first), where the pattern reserved that instead.
fn reach_in_partner(slot_of: &SlotOf, c: Coupling) -> Option<usize> {
    match BlockKey::decode(c.2) {
        BlockKey::Reach(l_e) => slot_of(&(c.0, c.1, l_e)),
        _ => None,
    }
}

impl PassResult {
    /// Adds an active contribution: force and moment about `mpt`; counts and penetration of the
    /// law's contributions (not a cohesive pairing's).
    fn add(
        &mut self,
        pr: &crate::contact::kernel::PointResult,
        cohesive: bool,
        on_edge: bool,
        mpt: &[f64; 3],
    ) {
        if !cohesive {
            self.n_active += 1;
            self.n_edge += on_edge as usize;
        }
        let g_n = pr.g[0] * pr.n[0] + pr.g[1] * pr.n[1] + pr.g[2] * pr.n[2];
        if !cohesive {
            self.max_penetration = self.max_penetration.max(-g_n);
        }
        let d = [0, 1, 2].map(|c| pr.x[c] - mpt[c]);
        for c in 0..3 {
            self.force[c] += pr.force[c];
        }
        let mo = [
            d[1] * pr.force[2] - d[2] * pr.force[1],
            d[2] * pr.force[0] - d[0] * pr.force[2],
            d[0] * pr.force[1] - d[1] * pr.force[0],
        ];
        for c in 0..3 {
            self.moment[c] += mo[c];
        }
    }
}

/// Tangent blocks of the current own element, keyed by partner element.
pub(crate) type Blocks = Vec<(u32, Vec<f64>)>;

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

/// True when `NURBS_CONTACT_DEBUG_POINTS` is set (read once): [`HalfPass::trace_point`].
fn debug_points() -> bool {
    static ON: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    *ON.get_or_init(|| std::env::var_os("NURBS_CONTACT_DEBUG_POINTS").is_some())
}
