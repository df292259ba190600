//! The mortar gap (`gap = "weighted"`): the normal gap weighted by each control point's basis
//! function.
//!
//! On the integrated surface, every weight node `A` (a control point, or with `weighted_linear` a
//! corner of the linear parent) gets the weighted gap `g_A = sum_q R_A(xi_q) c_q g_N,q / W_A`,
//! `W_A = sum_q R_A(xi_q) c_q`, over the quadrature points `q` of the elements in `A`'s support
//! (`c_q = w_q J_q`, current area as the paper's penalty law; `R_A` non-negative, so `g_A` is a
//! convex average of the point gaps). A point's gap is its signed distance to its projection;
//! where the closest point of the whole partner surface to an open point lies beyond the
//! partner's end (a walk from a warm start may hold an interior projection there: the gaps would
//! depend on the states evaluated before), the point keeps its distance to that closest point as
//! its gap, and its traction acts along that distance's direction `g / |g|` (both continuous as
//! it passes the end: at the end the orthogonal projection becomes that closest point, and its
//! normal the gap's direction). A point with no partner point within the search distance counts
//! as open by that distance. The pressure lives on the weight nodes, `p_A = -eps_n g_A` where
//! `g_A <= touch` (else 0), and every point carries the traction `t_q = p_q n_q` on its current
//! area, `p_q = sum_A R_A(xi_q) p_A`: one pressure field interpolated by the weight functions,
//! instead of one pressure per quadrature point.
//!
//! With `G_A,a = sum_q R_A N_a c_q n_q` (the own rows) the residual is `r = -sum_A p_A G_A` and
//! the tangent `K = K_kernel + sum_{A active} eps_n / W_A G_A (x) D_A`, with
//! `D_A = W_A dg_A = sum_q R_A(xi_q) w_q [J_q n_q . (N_b(xi_q) du_b - N^l_b(xi_p,q) dy_b)
//! + (g_N,q - g_A) dJ_q]` (closest-point and edge projections alike: `d g_N = n . dg`; `dJ_q`
//! the variation of the area element, also of points without a partner). `K_kernel` is the point
//! kernel with the pressure held fixed (`dt/dn = p I`, `dt/dg = 0`, and the current area's
//! variation); the second part couples an element's rows with the unknowns of every element that
//! shares a weight node with it and with their points' partners: blocks keyed
//! [`OWN_COLUMNS`]` | e'` (columns of own-surface element `e'`) and the usual partner blocks.
//!
//! The current area (not the reference one) keeps the two half-passes' forces alike when a
//! surface stretches: on ironing the reference-area version gave the cylinder's pass 14 % more
//! force than the block's.
//!
//! `gap = "weighted_mean"` (`mean`): the same weights applied to the points' penalty pressures
//! instead of their gaps, `p_A = sum_q R_A(xi_q) c_q p_q / W_A`, `p_q = -eps_n g_N,q` where
//! `g_N,q <= touch` (else 0): points join a control point's pressure one by one, as in
//! `element_mean`, so no control point at the edge of the contact zone stays open while points of
//! its support penetrate. Its variation, carried as `D_A = -W_A dp_A / eps_n` so that the tangent
//! above applies unchanged: `sum_q R_A w_q [H_q J_q n_q . (N_b du_b - N^l_b dy_b) + (p_A - p_q) /
//! eps_n dJ_q]`, `H_q` the point's active flag.
//!
//! Coulomb friction (`mu`): each point's tangential traction is the pointwise return mapping of
//! the kernel with the interpolated pressure `p_q` as its normal pressure (stick: `-eps_t g_T`;
//! slip: `mu p_q s_q`), so a slipping point's traction is `p_q (n_q + mu s_q)` and its rows in
//! `G_A` carry `n_q + mu s_q` instead of `n_q`; the kernel's tangent holds `p_q` fixed (as for
//! the normal part). Stick and slip, anchors and their updates are the pointwise ones.
//!
//! Augmented Lagrangian (`augmented = { tol, max }`): each control point carries a multiplier
//! `lambda_A` (a pressure), `p_A = lambda_A - eps_n g_A` where `g_A <= lambda_A / eps_n + touch`;
//! after a converged solve `lambda_A <- <p_A>` until every `|g_A|` of a pressed control point (and
//! every weighted penetration `-g_A` of an open one) is within `tol`; the points' own gaps may
//! still vary about their control points' `g_A`. With `lambda = 0` it is the plain penalty.
//!
//! One-pass (`algorithm = "one_pass"`): the slave surface's control points carry the pressure,
//! and each slave point's traction goes with the opposite sign to its master element at the
//! projection (the kernel's master rows). Those rows vary with the control points' pressures
//! too: `-c N^l_b t` of each point of the element, times `eps_n / W_A D_A`, whose columns are those
//! of other blocks of the element (own-surface elements and other partner elements), so they go
//! as cross blocks (rows of the partner's block, columns of another block of the same region,
//! [`crate::assembly::MatrixSink::add_cross`]). Frictionless, the slave's elements are integrated
//! over segments between the master's element boundaries (2D) or over the master elements' images
//! (3D) (the system's `segments`), so the master's forces of a uniform pressure are exact on
//! non-matching meshes; with friction (or in 3D with `NURBS_CONTACT_SEGMENTS_3D=0`) the slave's
//! element rule runs across those boundaries and they are not (as for the one-pass pointwise gap).
//!
//! `g_A` needs every point of `A`'s support, also those of elements another rank integrates:
//! each rank keeps a halo of the elements that share a control point with its own ones and
//! projects their points too (they are not integrated).
#![allow(clippy::needless_range_loop)]
#![allow(non_snake_case)]

use super::{block_slot, HalfPass, OwnElem, QPoint, Work};
use crate::contact::kernel::{gap_and_normal, SlipState};
use crate::contact::law::Traction;
use crate::contact::pair::BlockKey;
use crate::contact::surface::{raw_normal, MAX_FACE_NODES};
use std::collections::HashMap;

/// Jacobian columns of a control point: per block key, the column values.
type Columns = Vec<(u32, Vec<f64>)>;

/// A point's partner at the current evaluation.
#[derive(Debug, Clone, Copy)]
struct MPoint {
    /// Partner element (`u32::MAX`: rigid).
    le: u32,
    /// Normal [3] (the traction's direction).
    n: [f64; 3],
    /// The gap's direction [3]: `g_n` is the distance along it, `d g_n = m . (dx - dy)`. It is
    /// `n` where the projection is orthogonal; where round-off leaves a projection held at an
    /// element's end "free" though the point lies beyond it, the distance keeps the gap
    /// continuous where `n . g` would not be.
    m: [f64; 3],
    /// Partner basis at the projection [nl], and its size (0: rigid).
    nl_vals: [f64; MAX_FACE_NODES],
    nl: usize,
    /// Normal gap.
    g_n: f64,
}

/// The control points of one half-pass's surface near this rank's elements, and the state of an
/// evaluation.
#[derive(Debug, Clone, Default)]
pub(crate) struct MortarNet {
    /// Per element of the pass (its own elements, then its halo): its weight nodes (indices into
    /// the per-node vectors below): the surface's control points (`gap = "weighted"`), or the linear
    /// parent's corners (`gap = "weighted_linear"`).
    elem_cps: Vec<Vec<u32>>,
    /// Per element as `elem_cps`: the weight functions at its points [n_points][n_weight nodes].
    phi: Vec<Vec<f64>>,
    /// Per control point: the elements (indices as in `elem_cps`) whose basis it belongs to.
    support: Vec<Vec<u32>>,
    /// Per control point: `W_A` (reference).
    w: Vec<f64>,
    /// Per own element: the elements sharing a control point with it, itself included (indices
    /// as in `elem_cps`), sorted.
    pub(crate) near: Vec<Vec<u32>>,
    /// Per weight node: its global node, and whether it belongs to an own element (its pressure
    /// acts on this rank).
    pub(crate) node: Vec<u32>,
    own: Vec<bool>,
    /// Augmented Lagrangian: per control point, the multiplier the current solves use and the one
    /// of the last converged step (load-step history). Zero without augmentation.
    pub(crate) lambda: Vec<f64>,
    pub(crate) lambda_committed: Vec<f64>,
    /// Per control point: pressed (in the law's active set) at the current evaluation.
    active: Vec<bool>,
    /// Per point of the pass: its partner at the current evaluation.
    pts: Vec<Option<MPoint>>,
    /// Per point of the pass: its normal gap as the weights take it (the search distance without a
    /// partner), its current area element `J` and tangent vectors (for `dJ`).
    gq: Vec<f64>,
    area: Vec<(f64, [[f64; 3]; 2])>,
    /// Per control point: weighted gap and pressure at the current evaluation.
    g: Vec<f64>,
    p: Vec<f64>,
    /// The pressure is the weighted mean of the points' penalty pressures (`weighted_mean`) instead
    /// of the penalty of the weighted gap.
    pub(crate) mean: bool,
    /// Per point of the pass (`mean`): its penalty pressure; the pass's contact tolerance.
    pq: Vec<f64>,
    touch: f64,
    /// Per control point: its Jacobian columns `D_A` (block key, values), built when first needed
    /// in a Jacobian evaluation.
    d: Vec<Option<Columns>>,
}

impl MortarNet {
    /// The weight nodes of `elems` and `halo`: per element (own, then halo) its weight nodes'
    /// global ids `nodes` and its weight functions at its points `phi` [n_points][n_nodes]; and
    /// the nodes' weights `W_A` from `points`.
    pub(crate) fn new(
        nodes: &[Vec<u32>],
        phi: Vec<Vec<f64>>,
        elems: &[OwnElem],
        halo: &[OwnElem],
        points: &[QPoint],
    ) -> MortarNet {
        let mut index: HashMap<u32, u32> = HashMap::new();
        let mut net = MortarNet {
            phi,
            ..Default::default()
        };
        for ids in nodes {
            let cps = ids
                .iter()
                .map(|&t| {
                    let n = index.len() as u32;
                    *index.entry(t).or_insert(n)
                })
                .collect();
            net.elem_cps.push(cps);
        }
        let n_cp = index.len();
        net.support = vec![Vec::new(); n_cp];
        net.w = vec![0.0; n_cp];
        net.node = vec![0; n_cp];
        for (&t, &a) in &index {
            net.node[a as usize] = t;
        }
        net.own = vec![false; n_cp];
        for cps in &net.elem_cps[..elems.len()] {
            for &a in cps {
                net.own[a as usize] = true;
            }
        }
        net.lambda = vec![0.0; n_cp];
        net.lambda_committed = vec![0.0; n_cp];
        for (i, (oe, cps)) in elems.iter().chain(halo).zip(&net.elem_cps).enumerate() {
            for (b, &a) in cps.iter().enumerate() {
                // a collapsed control point (the NURBS hemisphere's two rim poles) appears more
                // than once in an element's list: the element is once in its support
                if net.support[a as usize].last() != Some(&(i as u32)) {
                    net.support[a as usize].push(i as u32);
                }
                for q in oe.first..oe.first + oe.n {
                    let phi = net.weights(i, q - oe.first);
                    net.w[a as usize] += phi[b] * points[q].w * points[q].J0;
                }
            }
        }
        net.near = (0..elems.len())
            .map(|i| {
                let mut v: Vec<u32> = net.elem_cps[i]
                    .iter()
                    .flat_map(|&a| net.support[a as usize].iter().copied())
                    .collect();
                v.sort_unstable();
                v.dedup();
                v
            })
            .collect();
        net
    }

    /// Before the elements of an evaluation: every point's partner and gap (own and halo
    /// elements, `all` in the order of `elem_cps`), then each control point's weighted gap and
    /// pressure.
    pub(super) fn begin(&mut self, hp: &HalfPass, all: &[&OwnElem], points: &[QPoint], eps_n: f64) {
        let dim = hp.geo.dim;
        // every point of an element's range is written below; the slots after it (a segmented
        // pass's unused ones) are never read
        self.pts.resize(points.len(), None);
        for oe in all {
            let x = hp.geo.pos[hp.k].of(oe.e as usize);
            for q in oe.first..oe.first + oe.n {
                self.pts[q] = None;
                let xk = oe.position(q, x, dim);
                if let Some((le, pp)) = hp.partner(points[q].current, &xk, None) {
                    if let Some(pg) = gap_and_normal(dim, &xk, &pp) {
                        // the signed distance to the projection: `n . g` where it is orthogonal
                        let gn = pg.g[0] * pg.n[0] + pg.g[1] * pg.n[1] + pg.g[2] * pg.n[2];
                        let d = (pg.g[0] * pg.g[0] + pg.g[1] * pg.g[1] + pg.g[2] * pg.g[2]).sqrt();
                        let (g_n, m) = if d > 0.0 {
                            let s = if gn < 0.0 { -1.0 } else { 1.0 };
                            (s * d, pg.g.map(|c| s * c / d))
                        } else {
                            (0.0, pg.n)
                        };
                        self.pts[q] = Some(MPoint {
                            le,
                            n: pg.n,
                            m,
                            nl_vals: pg.basis,
                            nl: pg.n_nodes,
                            g_n,
                        });
                    }
                    continue;
                }
                // beyond the partner's end: open by the distance to its closest point there, so
                // that the gap does not jump where the point passes the end
                if let Some((le, pp)) = hp.beyond_partner(points[q].edge) {
                    if let Some(pg) = gap_and_normal(dim, &xk, &pp) {
                        let d = (pg.g[0] * pg.g[0] + pg.g[1] * pg.g[1] + pg.g[2] * pg.g[2]).sqrt();
                        if d > 0.0 {
                            self.pts[q] = Some(MPoint {
                                le,
                                n: pg.g.map(|c| c / d),
                                m: pg.g.map(|c| c / d),
                                nl_vals: pg.basis,
                                nl: pg.n_nodes,
                                g_n: d,
                            });
                        }
                    }
                }
            }
        }
        self.gq.clear();
        self.gq.resize(points.len(), 0.0);
        self.area.clear();
        self.area.resize(points.len(), (0.0, [[0.0; 3]; 2]));
        for oe in all {
            let x = hp.geo.pos[hp.k].of(oe.e as usize);
            for q in oe.first..oe.first + oe.n {
                self.gq[q] = self.pts[q].map_or(hp.pair.search_distance, |p| p.g_n);
                self.area[q] = area_element(dim, oe.basis(q).1, x);
            }
        }
        let n_cp = self.w.len();
        self.g.clear();
        self.g.resize(n_cp, 0.0);
        self.w.fill(0.0);
        for (i, oe) in all.iter().enumerate() {
            let (cps, phi) = (&self.elem_cps[i], &self.phi[i]);
            for q in oe.first..oe.first + oe.n {
                let c = points[q].w * self.area[q].0;
                let j = q - oe.first;
                for (&a, &f) in cps.iter().zip(&phi[j * cps.len()..(j + 1) * cps.len()]) {
                    self.g[a as usize] += f * c * self.gq[q];
                    self.w[a as usize] += f * c;
                }
            }
        }
        self.p.clear();
        self.p.resize(n_cp, 0.0);
        self.active.clear();
        self.active.resize(n_cp, false);
        self.touch = hp.touch;
        if self.mean {
            self.pq.clear();
            self.pq.resize(points.len(), 0.0);
            for (i, oe) in all.iter().enumerate() {
                let (cps, phi) = (&self.elem_cps[i], &self.phi[i]);
                for q in oe.first..oe.first + oe.n {
                    let Some(mp) = &self.pts[q] else { continue };
                    if mp.g_n > hp.touch {
                        continue;
                    }
                    self.pq[q] = -eps_n * mp.g_n;
                    let c = points[q].w * self.area[q].0;
                    let j = q - oe.first;
                    for (&a, &f) in cps.iter().zip(&phi[j * cps.len()..(j + 1) * cps.len()]) {
                        self.p[a as usize] += f * c * self.pq[q];
                        if f > 0.0 {
                            self.active[a as usize] = true;
                        }
                    }
                }
            }
        }
        for a in 0..n_cp {
            if self.mean {
                if self.w[a] > 0.0 {
                    self.g[a] /= self.w[a];
                    self.p[a] /= self.w[a];
                } else {
                    self.g[a] = f64::INFINITY;
                }
                continue;
            }
            if self.w[a] > 0.0 {
                self.g[a] /= self.w[a];
                let lambda = self.lambda[a];
                if self.g[a] <= lambda / eps_n + hp.touch {
                    self.active[a] = true;
                    self.p[a] = lambda - eps_n * self.g[a];
                }
            } else {
                self.g[a] = f64::INFINITY;
            }
        }
        self.d.clear();
        self.d.resize(n_cp, None);
    }

    /// Replaces the weight functions of element `i` (own, then halo) at its points
    /// [n_points][n_weight nodes] (points moved onto new segments).
    pub(crate) fn set_weights(&mut self, i: usize, phi: Vec<f64>) {
        self.phi[i] = phi;
    }

    /// The weight functions at point `j` (of the element's points) of element `i`.
    fn weights(&self, i: usize, j: usize) -> &[f64] {
        let n = self.elem_cps[i].len();
        &self.phi[i][j * n..(j + 1) * n]
    }

    /// The pressure at point `j` (of the element's points) of own element `i`.
    pub(super) fn pressure(&self, i: usize, j: usize) -> f64 {
        self.elem_cps[i]
            .iter()
            .zip(self.weights(i, j))
            .map(|(&a, &phi)| phi * self.p[a as usize])
            .sum()
    }

    /// In a Jacobian evaluation, after the points of own element `i` (`oe`; their friction
    /// states of this evaluation in `points`): the variation of its control points' pressures,
    /// `eps_n / W_A G_A (x) D_A` for each active `A`, into the element's blocks.
    pub(super) fn end_element(
        &mut self,
        hp: &HalfPass,
        i: usize,
        all: &[&OwnElem],
        points: &[QPoint],
        eps_n: f64,
        work: &mut Work,
    ) {
        let dim = hp.geo.dim;
        let oe = all[i];
        let nk = oe.N.len() / oe.n;
        let rows = nk * dim;
        // one-pass: the master element's rows carry the opposite force, `-c N^l t`
        let one_pass = hp.pair.formulation.one_pass() && hp.l.is_some();
        let mut G = [0.0; 3 * MAX_FACE_NODES];
        for b in 0..self.elem_cps[i].len() {
            let a = self.elem_cps[i][b] as usize;
            if !self.active[a] {
                continue;
            }
            G[..rows].fill(0.0);
            work.g_master.clear();
            let mut any = false;
            for q in oe.first..oe.first + oe.n {
                let Some(mp) = self.pts[q].as_ref() else {
                    continue;
                };
                let N = oe.basis(q).0;
                let c = self.weights(i, q - oe.first)[b] * points[q].w * self.area[q].0;
                // d t / d p: the normal, plus the slip direction where the point slips (its
                // tangential traction `mu p s` scales with the interpolated pressure)
                let qp = &points[q];
                let t = if qp.slip == SlipState::Slip && qp.p_n > 0.0 {
                    [0, 1, 2].map(|k| mp.n[k] + qp.t_t[k] / qp.p_n)
                } else {
                    mp.n
                };
                for a2 in 0..nk {
                    for k in 0..dim {
                        G[a2 * dim + k] += c * N[a2] * t[k];
                    }
                }
                if one_pass && mp.nl > 0 {
                    let im = match work.g_master.iter().position(|(le, ..)| *le == mp.le) {
                        Some(im) => im,
                        None => {
                            work.g_master
                                .push((mp.le, mp.nl * dim, [0.0; 3 * MAX_FACE_NODES]));
                            work.g_master.len() - 1
                        }
                    };
                    let gm = &mut work.g_master[im].2;
                    for b2 in 0..mp.nl {
                        for k in 0..dim {
                            gm[b2 * dim + k] -= c * mp.nl_vals[b2] * t[k];
                        }
                    }
                }
                any = true;
            }
            if !any {
                continue;
            }
            if self.d[a].is_none() {
                self.d[a] = Some(self.columns(a, all, points, dim, eps_n));
            }
            let f = eps_n / self.w[a];
            let g_master = std::mem::take(&mut work.g_master);
            for (key, vals) in self.d[a].as_ref().expect("built above") {
                // one-pass: the partner of another element's point only, whose rows this
                // element's residual does not reach
                let key = &match BlockKey::decode(*key) {
                    BlockKey::Partner(le) if one_pass && !partner_of(oe, points, le) => {
                        BlockKey::Reach(le).encode()
                    }
                    _ => *key,
                };
                let (ncols, off) = if let BlockKey::Own(_) = BlockKey::decode(*key) {
                    (vals.len(), 0)
                } else {
                    (rows + vals.len(), rows)
                };
                for &(le, nrows, ref gm) in &g_master {
                    let ic = cross_slot(work, le, *key, nrows * vals.len());
                    let kb = &mut work.cross[ic].2;
                    for r in 0..nrows {
                        let gr = f * gm[r];
                        if gr == 0.0 {
                            continue;
                        }
                        let row = &mut kb[r * vals.len()..(r + 1) * vals.len()];
                        for (v, &d) in row.iter_mut().zip(vals) {
                            *v += gr * d;
                        }
                    }
                }
                // one-pass: a partner block holds the partner's rows below the own ones
                let nrows = if one_pass && matches!(BlockKey::decode(*key), BlockKey::Partner(_)) {
                    ncols
                } else {
                    rows
                };
                let ib = block_slot(&mut work.blocks, &mut work.n_used, *key, nrows * ncols);
                let kb = &mut work.blocks[ib].1;
                for r in 0..rows {
                    let gr = f * G[r];
                    if gr == 0.0 {
                        continue;
                    }
                    let row = &mut kb[r * ncols + off..r * ncols + off + vals.len()];
                    for (v, &d) in row.iter_mut().zip(vals) {
                        *v += gr * d;
                    }
                }
            }
            work.g_master = g_master;
        }
    }

    /// Bytes of the net's arrays (weights per point, supports, per-node and per-point state;
    /// the Jacobian columns built in an evaluation not counted).
    pub(crate) fn heap_bytes(&self) -> usize {
        use std::mem::size_of;
        let nested = |v: &Vec<Vec<u32>>| v.iter().map(|x| x.len() * 4 + 24).sum::<usize>();
        nested(&self.elem_cps)
            + nested(&self.support)
            + nested(&self.near)
            + self.phi.iter().map(|x| x.len() * 8 + 24).sum::<usize>()
            + (self.w.len() + self.lambda.len() + self.lambda_committed.len()) * 8
            + (self.g.len() + self.p.len() + self.gq.len()) * 8
            + self.node.len() * 4
            + self.own.len()
            + self.active.len()
            + self.pts.len() * size_of::<Option<MPoint>>()
            + self.area.len() * size_of::<(f64, [[f64; 3]; 2])>()
    }

    /// The weighted gaps `g_A` of the last evaluation (`INFINITY` where `W_A` is 0).
    #[cfg(test)]
    pub(crate) fn gaps(&self) -> &[f64] {
        &self.g
    }

    /// Whether control point `a` belongs to an element this rank integrates.
    pub(crate) fn is_own(&self, a: usize) -> bool {
        self.own[a]
    }

    /// Augmented Lagrangian: the largest violation of the contact conditions at this rank's
    /// control points at the last evaluation, a penetration `-g_A` or the opening `g_A` of a
    /// control point that still carries pressure.
    pub(crate) fn violation(&self) -> f64 {
        (0..self.w.len())
            .filter(|&a| self.own[a] && self.w[a] > 0.0)
            .map(|a| {
                if self.p[a] > 0.0 {
                    self.g[a].abs()
                } else {
                    (-self.g[a]).max(0.0)
                }
            })
            .fold(0.0, f64::max)
    }

    /// Augmented Lagrangian: every multiplier becomes its control point's pressure at the last
    /// evaluation.
    pub(crate) fn augment(&mut self) {
        for (l, &p) in self.lambda.iter_mut().zip(&self.p) {
            *l = p.max(0.0);
        }
    }

    /// `D_A` of control point `a`: per own-surface element of its support (key
    /// [`BlockKey::Own`]) and per partner element of its points, the column values.
    fn columns(
        &self,
        a: usize,
        all: &[&OwnElem],
        points: &[QPoint],
        dim: usize,
        eps_n: f64,
    ) -> Columns {
        let mut out: Columns = Vec::new();
        for &j in &self.support[a] {
            let oe = all[j as usize];
            let cps = &self.elem_cps[j as usize];
            let own_key = BlockKey::Own(oe.e).encode();
            let nk = oe.N.len() / oe.n;
            let io = piece(&mut out, own_key, nk * dim);
            let m = dim - 1;
            for q in oe.first..oe.first + oe.n {
                // (an unused segment slot)
                if points[q].w == 0.0 {
                    continue;
                }
                let (N, dN) = oe.basis(q);
                let phi = self.weights(j as usize, q - oe.first);
                // every entry of the element's list that is `a` (a collapsed control point repeats)
                let fw = cps
                    .iter()
                    .zip(phi)
                    .filter(|(&c, _)| c as usize == a)
                    .map(|(_, &f)| f)
                    .sum::<f64>()
                    * points[q].w;
                let (J, t) = &self.area[q];
                // the area's variation, dJ = sum_b dJ/dx_b . du_b
                let dj = dj_dx(dim, t, *J);
                // `mean`: W_A dp_A = sum R w [(p_q - p_A) dJ + J dp_q], dp_q = -eps_n H_q dg_q,
                // carried as D_A = -W_A dp_A / eps_n
                let ca = if self.mean {
                    fw * (self.p[a] - self.pq[q]) / eps_n
                } else {
                    fw * (self.gq[q] - self.g[a])
                };
                let own = &mut out[io].1;
                for b in 0..nk {
                    for k in 0..dim {
                        let dJ: f64 = (0..m).map(|i| dN[b * m + i] * dj[i][k]).sum();
                        own[b * dim + k] += ca * dJ;
                    }
                }
                let Some(mp) = &self.pts[q] else { continue };
                if self.mean && mp.g_n > self.touch {
                    continue;
                }
                let c = fw * J;
                for b in 0..nk {
                    for k in 0..dim {
                        own[b * dim + k] += c * mp.m[k] * N[b];
                    }
                }
                if mp.nl > 0 {
                    let ip = piece(&mut out, mp.le, mp.nl * dim);
                    let part = &mut out[ip].1;
                    for b in 0..mp.nl {
                        for k in 0..dim {
                            part[b * dim + k] -= c * mp.m[k] * mp.nl_vals[b];
                        }
                    }
                }
            }
        }
        out
    }
}

/// The slot of the one-pass cross block of master element `le`'s rows and block key `key`'s
/// columns, zeroed to `len` entries when it is new for this element.
pub(super) fn cross_slot(work: &mut Work, le: u32, key: u32, len: usize) -> usize {
    let n = work.n_cross;
    if let Some(i) = work.cross[..n]
        .iter()
        .position(|(l, k, _)| *l == le && *k == key)
    {
        return i;
    }
    if n == work.cross.len() {
        work.cross.push((le, key, Vec::new()));
    }
    let (l, k, buf) = &mut work.cross[n];
    (*l, *k) = (le, key);
    buf.clear();
    buf.resize(len, 0.0);
    work.n_cross += 1;
    n
}

/// Whether partner element `le` is the partner (or the closest element beyond the surface's end)
/// of a point of `oe`: the blocks whose rows the element's residual reaches.
fn partner_of(oe: &OwnElem, points: &[QPoint], le: u32) -> bool {
    points[oe.first..oe.first + oe.n]
        .iter()
        .any(|qp| qp.current.iter().chain(&qp.edge).any(|p| p.elem == le))
}

/// The index of the piece keyed `key` in `out`, added with `len` zeros if new.
fn piece(out: &mut Columns, key: u32, len: usize) -> usize {
    if let Some(i) = out.iter().position(|(k, _)| *k == key) {
        return i;
    }
    out.push((key, vec![0.0; len]));
    out.len() - 1
}

/// The current area element `J` of a point (basis derivatives `dN` [n][m], current nodes `x`
/// [n][dim]) and its tangent vectors.
fn area_element(dim: usize, dN: &[f64], x: &[f64]) -> (f64, [[f64; 3]; 2]) {
    let m = dim - 1;
    let mut a = [[0.0; 3]; 2];
    for (b, row) in x.chunks_exact(dim).enumerate() {
        for i in 0..m {
            for c in 0..dim {
                a[i][c] += dN[b * m + i] * row[c];
            }
        }
    }
    let nu = raw_normal(dim, &a);
    ((nu[0] * nu[0] + nu[1] * nu[1] + nu[2] * nu[2]).sqrt(), a)
}

/// `dJ / da_i` [m][3] of the area element `J` with tangent vectors `a`: 2D `a_1 / J`; 3D
/// `a_2 x nu` and `nu x a_1` (`nu` the unit normal), so `dJ = sum_i dJ/da_i . da_i`.
fn dj_dx(dim: usize, a: &[[f64; 3]; 2], J: f64) -> [[f64; 3]; 2] {
    if dim == 2 {
        return [a[0].map(|c| c / J), [0.0; 3]];
    }
    let nu = raw_normal(dim, a).map(|c| c / J);
    let cross = |u: &[f64; 3], v: &[f64; 3]| {
        [
            u[1] * v[2] - u[2] * v[1],
            u[2] * v[0] - u[0] * v[2],
            u[0] * v[1] - u[1] * v[0],
        ]
    };
    [cross(&a[1], &nu), cross(&nu, &a[0])]
}

/// The traction of a point under the pressure `p` of the control points, held fixed:
/// `t = p n`, `dt/dn = p I` (its variation through the pressure is
/// [`MortarNet::end_element`]'s).
pub(super) fn pressure_traction(p: f64, n: &[f64; 3]) -> Traction {
    if p == 0.0 {
        return Traction::ZERO;
    }
    let mut out = Traction::ZERO;
    for i in 0..3 {
        out.t[i] = p * n[i];
        out.dt_dn[4 * i] = p;
    }
    out
}
