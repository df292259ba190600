//! Segment-based quadrature of the one-pass weighted gap.
//!
//! A one-pass pair integrates over the slave surface and applies the opposite force to the master
//! element at each point's projection: the master's rows carry `N^l_b(xi_p(xi))`, a function of
//! the slave coordinate with a kink wherever the projection crosses a master element boundary.
//! A Gauss rule over the whole slave element integrates such a kink only approximately, so on
//! non-matching meshes a uniform pressure did not give the master's consistent nodal forces (the
//! non-matching contact patch test failed, with an error that fell only as `n_q^-2.6..-3` with more
//! points). Segmentation splits each slave element at the slave coordinates whose projection is a
//! master element's end, and integrates each segment with the element's own Gauss rule, as
//! segment-based mortar methods do: every integrand is then smooth on its segment.
//!
//! The breakpoints are found at every update (the projections' update of a Newton iteration),
//! before the points are projected, and stay fixed through that update's evaluations, so the
//! tangent (which holds the points' surface coordinates fixed) is the exact derivative of the
//! residual it comes with. A breakpoint is a root of `h(xi) = (x(xi) - y_b) . a_b` on the slave
//! element, `y_b` and `a_b` the position and tangent of a master element's end (both sides of a
//! C0 master's node: the edges of the fan of points that project onto the node), within the
//! search distance and the slave element's own length of `y_b`.
//!
//! In 3D the master's element edges split the slave element's parameter square into convex
//! pieces: each master element's corners are projected onto the slave element's surface (closest
//! point, the surface extended beyond the element), and every piece that an edge between two
//! projected corners crosses is cut along the edge's line. Each piece is then split into
//! quadrilaterals (a triangle is a quadrilateral with two equal corners) that carry the element's
//! tensor Gauss rule through their bilinear map. The edges are straight lines in the slave
//! coordinates: exact where both surfaces are flat (the patch test), otherwise close to the kinks
//! by the surfaces' curvature over an element.
//!
//! Each element holds `slots` segments' (in 3D: quadrilaterals') worth of points (enough for the
//! longest slave element over the shortest master element; more breakpoints than that merge the
//! shortest neighbouring segments, and a 3D element cut into more quadrilaterals keeps its own
//! rule); the points of unused slots have weight 0, are neither projected nor integrated, and
//! carry NaN pressure and gap in the output. Frictionless pairs only: a point's friction anchor is
//! the history of a material point, which moving points do not keep.
#![allow(non_snake_case)]

use super::ContactSystem;
use crate::contact::half_pass::QPoint;
use crate::contact::pair::{GapKind, PairDef, Partner};
use crate::contact::surface::{frame, raw_normal, MAX_FACE_NODES};

/// Samples per element at which the breakpoint functions are evaluated before bisection.
const SAMPLES: usize = 16;

/// Breakpoints that moved less than this (in the slave coordinate) since the points were placed
/// keep them where they are. The tangent holds the points fixed (it omits the breakpoints'
/// motion, whose effect on the residual is of the order of the segments' quadrature error): moving
/// them at every update left Newton converging only linearly once the iterates' changes were
/// small (on the 2D patch test with Q1N2, 11 iterations in a step where held points take 4). A
/// breakpoint held `d` from its kink leaves an error of order `d^2` in the integral: the patch
/// test's pressure stays uniform to 3e-12.
const KEEP: f64 = 1e-4;

/// 3D: a layout that moved more than this in a solve moves its points (between solves), and the
/// load step solves again, for at most `ROUNDS` rounds. Within a solve the points stay: cuts that
/// come and go with the iterates (where a master element's corner sits on a slave element's edge)
/// would otherwise change the residual at every iterate. A layout held `d` from the kinks leaves
/// an error of order `d^2` (the non-matching patch test's pressure stays uniform to 3e-12).
pub(super) const KEEP_3D: f64 = 1e-4;

/// 3D: most segment rounds of a load step.
pub(super) const ROUNDS: usize = 1;

/// Breakpoints closer than this to the element's ends (in the slave coordinate) are dropped: a
/// master node that lies on a slave node, as where meshes share nodes, otherwise comes and goes
/// between updates; the kink it leaves inside the end segment is within `END * h` of the end.
const END: f64 = 1e-4;

/// Distances (in the slave coordinates) below which a piece's corner lies on a cutting line, and
/// two corners are one: a kink moved by `SNAP` leaves an error of order `SNAP^2` in the integral,
/// and pieces whose corners come and go with the projections' round-off would move the points at
/// every update.
const SNAP: f64 = 1e-6;

/// Most segments an element's points can hold (2D).
const MAX_SLOTS: usize = 16;

/// Most quadrilaterals an element's points can hold (3D).
const MAX_SLOTS_3D: usize = 36;

/// The segment rule of a pass.
#[derive(Debug, Clone)]
pub(crate) struct Segments {
    /// Gauss-Legendre points and weights of one segment on [-1, 1] (in 3D per direction of a
    /// quadrilateral).
    zeta: Vec<f64>,
    wz: Vec<f64>,
    /// Surface dimension (1: curves in 2D, 2: surfaces in 3D).
    m: usize,
    /// Segments per element.
    pub(crate) slots: usize,
    /// The weight functions are the linear parent's corners (`mortar_linear`).
    linear: bool,
    /// Per element (own, then halo): the breakpoints its points are placed on, in 3D the
    /// quadrilaterals' corners (`None`: not yet placed).
    placed: Vec<Option<Vec<f64>>>,
    /// 3D elements cut into more quadrilaterals than `slots` (they keep their own rule).
    pub(crate) overflow: usize,
    /// 3D: per element, the layout of the last update where it moved by more than `KEEP` (its
    /// points move onto it between solves, [`ContactSystem::place_pending`]), and the largest
    /// such move.
    pending: Vec<Option<Vec<f64>>>,
    moved: f64,
    /// 3D: pieces of each master element edge (straight in the slave coordinates), about half
    /// the smallest slave element each (at most 8).
    sub: usize,
}

impl Segments {
    /// Points per segment (quadrilateral).
    fn per_slot(&self) -> usize {
        self.zeta.len().pow(self.m as u32)
    }

    /// Points per element.
    pub(crate) fn per_element(&self) -> usize {
        self.slots * self.per_slot()
    }
}

/// Whether a pair's pass is integrated over segments: one-pass, a weighted gap, frictionless,
/// against another surface.
pub(crate) fn segmented(def: &PairDef, _dim: usize, partner: &Partner) -> bool {
    def.one_pass
        && def.friction.is_none()
        && matches!(
            def.gap,
            GapKind::Mortar | GapKind::MortarLinear | GapKind::MortarMean
        )
        && matches!(partner, Partner::Surface(_))
}

impl ContactSystem {
    /// The segment rule of surface `k` integrated against surface `l` with `n_g` Gauss points per
    /// segment: enough slots for the longest slave element over the shortest master element.
    pub(super) fn segment_rule(&self, k: usize, l: usize, n_g: usize, linear: bool) -> Segments {
        let dim = self.dim;
        let dist = |a: &[f64; 3], b: &[f64; 3]| {
            (0..dim).map(|c| (b[c] - a[c]).powi(2)).sum::<f64>().sqrt()
        };
        // an element's chords between the midpoints of opposite sides (in 2D its ends)
        let chords = |s: usize| -> Vec<(f64, f64)> {
            let surf = &self.surfaces[s];
            (0..surf.elements.len())
                .map(|e| {
                    let el = &surf.elements[e];
                    let x = self.pos[s].of(e);
                    let at = |xi: [f64; 2]| frame(el, dim, x, &xi).0;
                    let h0 = dist(&at([-1.0, 0.0]), &at([1.0, 0.0]));
                    if dim == 2 {
                        (h0, h0)
                    } else {
                        let h1 = dist(&at([0.0, -1.0]), &at([0.0, 1.0]));
                        (h0.max(h1), h0.min(h1))
                    }
                })
                .collect()
        };
        let (own, partner) = (chords(k), chords(l));
        let longest = own.iter().map(|c| c.0).fold(0.0, f64::max);
        let shortest = partner
            .iter()
            .map(|c| c.1)
            .filter(|&h| h > 0.0)
            .fold(f64::INFINITY, f64::min);
        let smallest_own = own
            .iter()
            .map(|c| c.1)
            .filter(|&h| h > 0.0)
            .fold(f64::INFINITY, f64::min);
        let longest_partner = partner.iter().map(|c| c.0).fold(0.0, f64::max);
        let sub = if smallest_own.is_finite() {
            (2.0 * longest_partner / smallest_own)
                .ceil()
                .clamp(1.0, 8.0) as usize
        } else {
            1
        };
        let ratio = if shortest.is_finite() {
            longest / shortest
        } else {
            1.0
        };
        // a slave element meets at most ceil(ratio) + 1 master nodes, each two breakpoints where
        // the master is C0 (the edges of its fan); the master's elements may shorten by half
        // in 3D: a slave element meets about (ceil(1.5 ratio) + 1)^2 master elements, the pieces
        // of a straight cut are quadrilaterals, those of slanted ones also triangles and
        // pentagons (one or two quadrilaterals each)
        let slots = if dim == 2 {
            (2.0 * (1.5 * ratio).ceil() + 3.0).min(MAX_SLOTS as f64) as usize
        } else {
            (((1.5 * ratio).ceil() + 2.0).powi(2)).min(MAX_SLOTS_3D as f64) as usize
        };
        let (zeta, wz) =
            crate::fem::quadrature::gauss_legendre(n_g).expect("a rule of at least one point");
        Segments {
            zeta,
            wz,
            m: dim - 1,
            slots,
            linear,
            placed: Vec::new(),
            overflow: 0,
            pending: Vec::new(),
            moved: 0.0,
            sub,
        }
    }

    /// Splits every element of the segmented passes at its breakpoints on the current positions
    /// and moves its points onto the segments (their basis, weights and weight functions with them).
    pub(super) fn segment_all(&mut self) {
        for pi in 0..self.pairs.len() {
            for si in 0..self.pairs[pi].passes.len() {
                let Some(mut seg) = self.pairs[pi].passes[si].segments.take() else {
                    continue;
                };
                let Partner::Surface(l) = self.pairs[pi].passes[si].partner else {
                    self.pairs[pi].passes[si].segments = Some(seg);
                    continue;
                };
                let dist = self.pairs[pi].def.search_distance;
                let region = self.pairs[pi].def.region;
                self.ensure_grid(l, dist);
                let k = self.pairs[pi].passes[si].k;
                let n_own = self.pairs[pi].passes[si].elems.len();
                let n_all = n_own + self.pairs[pi].passes[si].halo.len();
                seg.placed.resize(n_all, None);
                seg.pending.clear();
                seg.pending.resize(n_all, None);
                seg.moved = 0.0;
                for i in 0..n_all {
                    let e = self.pairs[pi].passes[si].elem(i).e as usize;
                    let layout = if self.dim == 2 {
                        let mut cuts = self.breakpoints(k, e, l, dist);
                        if cuts.len() + 1 > seg.slots {
                            merge_segments(&mut cuts, seg.slots);
                        }
                        cuts
                    } else {
                        let mut quads = self.quadrilaterals(k, e, l, dist, seg.sub);
                        if quads.len() > seg.slots {
                            seg.overflow += 1;
                            quads = vec![SQUARE];
                        }
                        quads.iter().flatten().flatten().copied().collect()
                    };
                    let moved = seg.placed[i].as_ref().map(|p| layout_move(p, &layout));
                    let keep = if seg.m == 1 { KEEP } else { KEEP_3D };
                    match moved {
                        Some(d) if d <= keep => {}
                        // 3D: the points stay where they are through the solve; the move is
                        // reported for the rounds after it
                        Some(d) if seg.m == 2 => {
                            seg.moved = seg.moved.max(d);
                            seg.pending[i] = Some(layout);
                        }
                        _ => {
                            self.place_points(pi, si, i, e, &layout, &seg, region.as_ref());
                            seg.placed[i] = Some(layout);
                        }
                    }
                }
                self.pairs[pi].passes[si].segments = Some(seg);
            }
        }
    }

    /// 3D: per pair, the largest move of a layout since its points were placed, at the last
    /// update (0 for pairs without 3D segments).
    pub(super) fn segment_moves(&self) -> Vec<f64> {
        self.pairs
            .iter()
            .map(|pair| {
                pair.passes
                    .iter()
                    .filter_map(|ps| ps.segments.as_ref())
                    .map(|s| s.moved)
                    .fold(0.0, f64::max)
            })
            .collect()
    }

    /// Whether a pass is integrated over 3D segments (whose points move between solves only).
    pub(super) fn has_segment_rounds(&self) -> bool {
        self.pairs.iter().any(|p| {
            p.passes
                .iter()
                .any(|ps| ps.segments.as_ref().is_some_and(|s| s.m == 2))
        })
    }

    /// 3D: moves the points of pair `pi`'s elements whose layouts moved at the last update onto
    /// them (between two solves of a load step).
    pub(super) fn place_pending(&mut self, pi: usize) {
        // the moved points are projected at the next update, also at the same positions
        self.last_update = None;
        for si in 0..self.pairs[pi].passes.len() {
            let Some(mut seg) = self.pairs[pi].passes[si].segments.take() else {
                continue;
            };
            let region = self.pairs[pi].def.region;
            for i in 0..seg.pending.len() {
                if let Some(layout) = seg.pending[i].take() {
                    let e = self.pairs[pi].passes[si].elem(i).e as usize;
                    self.place_points(pi, si, i, e, &layout, &seg, region.as_ref());
                    seg.placed[i] = Some(layout);
                }
            }
            seg.moved = 0.0;
            self.pairs[pi].passes[si].segments = Some(seg);
        }
    }

    /// The interior breakpoints (sorted slave coordinates in (-1, 1)) of element `e` of surface
    /// `k` against surface `l`.
    fn breakpoints(&mut self, k: usize, e: usize, l: usize, dist: f64) -> Vec<f64> {
        let dim = self.dim;
        let el = &self.surfaces[k].elements[e];
        let xe = self.pos[k].of(e);
        let at = |t: f64| frame(el, dim, xe, &[t, 0.0]).0;
        let samples: [(f64, [f64; 3]); SAMPLES + 1] = std::array::from_fn(|j| {
            let t = -1.0 + 2.0 * j as f64 / SAMPLES as f64;
            (t, at(t))
        });
        let (x0, x1) = (samples[0].1, samples[SAMPLES].1);
        let length = (0..dim)
            .map(|c| (x1[c] - x0[c]).powi(2))
            .sum::<f64>()
            .sqrt();
        let reach = dist.min(length);
        let grid = self.grids[l].as_ref().expect("built by the caller");
        let mut cand = std::mem::take(&mut self.cand);
        let mut partners: Vec<u32> = Vec::new();
        for (_, x) in &samples {
            grid.candidates(&x[..dim], &mut cand);
            partners.extend_from_slice(&cand);
        }
        self.cand = cand;
        partners.sort_unstable();
        partners.dedup();
        let mut cuts = Vec::new();
        for &f in &partners {
            let elf = &self.surfaces[l].elements[f as usize];
            let yf = self.pos[l].of(f as usize);
            for end in [-1.0, 1.0] {
                let (yb, a, _) = frame(elf, dim, yf, &[end, 0.0]);
                let h = |x: &[f64; 3]| (0..dim).map(|c| (x[c] - yb[c]) * a[0][c]).sum::<f64>();
                let near = |x: &[f64; 3]| {
                    (0..dim).map(|c| (x[c] - yb[c]).powi(2)).sum::<f64>().sqrt() <= reach
                };
                for w in samples.windows(2) {
                    let ((mut t0, xa), (mut t1, xb)) = (w[0], w[1]);
                    let (mut h0, h1) = (h(&xa), h(&xb));
                    if h0 == 0.0 {
                        if near(&xa) {
                            cuts.push(t0);
                        }
                        continue;
                    }
                    if h0 * h1 >= 0.0 {
                        continue;
                    }
                    // bisection to round-off in the coordinate
                    while t1 - t0 > 4.0 * f64::EPSILON {
                        let tm = 0.5 * (t0 + t1);
                        if tm <= t0 || tm >= t1 {
                            break;
                        }
                        let hm = h(&at(tm));
                        if hm == 0.0 {
                            (t0, t1) = (tm, tm);
                            break;
                        }
                        if (hm < 0.0) == (h0 < 0.0) {
                            (t0, h0) = (tm, hm);
                        } else {
                            t1 = tm;
                        }
                    }
                    let t = 0.5 * (t0 + t1);
                    if near(&at(t)) {
                        cuts.push(t);
                    }
                }
            }
        }
        cuts.retain(|&t| t.abs() < 1.0 - END);
        cuts.sort_by(|a, b| a.total_cmp(b));
        cuts.dedup_by(|a, b| (*a - *b).abs() < 1e-9);
        cuts
    }

    /// The quadrilaterals that the edges of surface `l`'s elements cut element `e` of surface `k`
    /// (3D) into, in its parameter square.
    fn quadrilaterals(
        &mut self,
        k: usize,
        e: usize,
        l: usize,
        dist: f64,
        sub: usize,
    ) -> Vec<[[f64; 2]; 4]> {
        const N_S: usize = 4;
        let el = &self.surfaces[k].elements[e];
        let xe = self.pos[k].of(e);
        // the element's centre and the radius of its corners about it: master points farther
        // than that and the search distance are not projected
        let centre = frame(el, 3, xe, &[0.0; 2]).0;
        let radius = SQUARE
            .iter()
            .map(|c| {
                let x = frame(el, 3, xe, c).0;
                (0..3)
                    .map(|d| (x[d] - centre[d]).powi(2))
                    .sum::<f64>()
                    .sqrt()
            })
            .fold(0.0, f64::max);
        let grid = self.grids[l].as_ref().expect("built by the caller");
        let mut cand = std::mem::take(&mut self.cand);
        let mut partners: Vec<u32> = Vec::new();
        for i in 0..=N_S {
            for j in 0..=N_S {
                let xi = [
                    -1.0 + 2.0 * i as f64 / N_S as f64,
                    -1.0 + 2.0 * j as f64 / N_S as f64,
                ];
                grid.candidates(&frame(el, 3, xe, &xi).0, &mut cand);
                partners.extend_from_slice(&cand);
            }
        }
        self.cand = cand;
        partners.sort_unstable();
        partners.dedup();
        let mut pieces = vec![SQUARE.to_vec()];
        for &f in &partners {
            let elf = &self.surfaces[l].elements[f as usize];
            let yf = self.pos[l].of(f as usize);
            for c in 0..4 {
                let (p, q) = (SQUARE[c], SQUARE[(c + 1) % 4]);
                // the edge's points, each where the slave surface meets the master's normal line
                let mut prev: Option<([f64; 2], bool)> = None;
                for j in 0..=sub {
                    let f = j as f64 / sub as f64;
                    let eta = [p[0] + f * (q[0] - p[0]), p[1] + f * (q[1] - p[1])];
                    let (y, a, _) = frame(elf, 3, yf, &eta);
                    let start = prev.map_or([0.0; 2], |(xi, _)| xi);
                    let far = (0..3)
                        .map(|d| (y[d] - centre[d]).powi(2))
                        .sum::<f64>()
                        .sqrt()
                        > radius + dist;
                    let here = if far {
                        None
                    } else {
                        along_normal(el, xe, &y, &a, start)
                    };
                    let here = here.map(|xi| {
                        let x = frame(el, 3, xe, &xi).0;
                        let g = (0..3).map(|c| (x[c] - y[c]).powi(2)).sum::<f64>().sqrt();
                        (xi, g <= dist && xi[0].abs().max(xi[1].abs()) <= 1.5)
                    });
                    if let (Some((a0, n0)), Some((a1, n1))) = (prev, here) {
                        if n0 || n1 {
                            cut_pieces(&mut pieces, a0, a1);
                        }
                    }
                    prev = here;
                }
            }
        }
        // the same pieces in the same order at every update: each from its corner first along a
        // generic direction, in that direction's order of their centroids
        let key = |v: &[f64; 2]| 0.754_877_666_2 * v[0] + 0.569_840_290_9 * v[1];
        pieces.retain(|p| p.len() >= 3 && area2(p).abs() > 1e-12);
        for p in pieces.iter_mut() {
            let first = (0..p.len())
                .min_by(|&a, &b| key(&p[a]).total_cmp(&key(&p[b])))
                .unwrap_or(0);
            p.rotate_left(first);
        }
        let centre = |p: &Vec<[f64; 2]>| p.iter().map(key).sum::<f64>() / p.len() as f64;
        pieces.sort_by(|a, b| centre(a).total_cmp(&centre(b)));
        let mut quads = Vec::with_capacity(pieces.len());
        for p in &pieces {
            fan_quadrilaterals(p, &mut quads);
        }
        quads
    }

    /// Moves the points of element `i` (own, then halo) of pass `si` of pair `pi` onto `layout`
    /// (its breakpoints, or its quadrilaterals' corners; the element's other points get weight
    /// 0): surface
    /// coordinates, weights, reference area, the element's basis at them and the weighted gap's
    /// weight functions. A point keeps the reference position it was set up with (the output
    /// grid's), so its output displacement leads to where it is now.
    #[allow(clippy::too_many_arguments)]
    fn place_points(
        &mut self,
        pi: usize,
        si: usize,
        i: usize,
        e: usize,
        layout: &[f64],
        seg: &Segments,
        region: Option<&crate::contact::search::Aabb>,
    ) {
        let pts = if seg.m == 1 {
            segment_points(layout, seg)
        } else {
            quad_points(layout, seg)
        };
        let dim = self.dim;
        let m = dim - 1;
        let k = self.pairs[pi].passes[si].k;
        let el = &self.surfaces[k].elements[e];
        let nk = el.basis.n_nodes();
        let Xe: Vec<f64> = self.slots[k][e]
            .iter()
            .flat_map(|&t| self.X[t as usize * dim..(t as usize + 1) * dim].to_vec())
            .collect();
        let per = seg.per_element();
        let (mut N, mut dN, mut ddN) = (
            [0.0; MAX_FACE_NODES],
            [0.0; 2 * MAX_FACE_NODES],
            [0.0; 4 * MAX_FACE_NODES],
        );
        let mut bN = vec![0.0; per * nk];
        let mut bdN = vec![0.0; per * nk * m];
        let mut phi = Vec::with_capacity(per * nk);
        let used = pts.len().min(per);
        let ps = &mut self.pairs[pi].passes[si];
        let n_own = ps.elems.len();
        let first = ps.elems.get(i).unwrap_or_else(|| &ps.halo[i - n_own]).first;
        for j in 0..per {
            let (xi, w) = if j < used { pts[j] } else { ([0.0; 2], 0.0) };
            let [t, r] = xi;
            el.basis.eval(&xi[..m], &mut N, &mut dN, &mut ddN);
            bN[j * nk..(j + 1) * nk].copy_from_slice(&N[..nk]);
            bdN[j * nk * m..(j + 1) * nk * m].copy_from_slice(&dN[..nk * m]);
            if !seg.linear {
                phi.extend_from_slice(&N[..nk]);
            } else if m == 1 {
                phi.extend([0.5 * (1.0 - t), 0.5 * (1.0 + t)]);
            } else {
                phi.extend([
                    0.25 * (1.0 - t) * (1.0 - r),
                    0.25 * (1.0 + t) * (1.0 - r),
                    0.25 * (1.0 + t) * (1.0 + r),
                    0.25 * (1.0 - t) * (1.0 + r),
                ]);
            }
            let (xr, a, _) = frame(el, dim, &Xe, &xi);
            let nu = raw_normal(dim, &a);
            let outside = region.is_some_and(|b| !b.contains(&xr[..dim]));
            let qp: &mut QPoint = &mut ps.points[first + j];
            qp.xi = xi;
            qp.w = if outside || j >= used { 0.0 } else { w };
            qp.J0 = (nu[0] * nu[0] + nu[1] * nu[1] + nu[2] * nu[2]).sqrt();
        }
        let oe = if i < n_own {
            &mut ps.elems[i]
        } else {
            &mut ps.halo[i - n_own]
        };
        oe.N = bN;
        oe.dN = bdN;
        if let Some(net) = ps.mortar.as_mut() {
            net.set_weights(i, phi);
        }
    }
}

/// The surface coordinates of the point of element `el` (at positions `xe`, 3D; the surface
/// extended beyond the element) that projects onto the partner's point `y` with tangents `a`:
/// `(x(xi) - y) . a_alpha = 0`, the point on the line through `y` along the partner's normal
/// there. Newton from `start`; `None` if it does not settle or leaves the element's neighbourhood.
fn along_normal(
    el: &crate::contact::surface::SurfaceElement,
    xe: &[f64],
    y: &[f64; 3],
    a: &[[f64; 3]; 2],
    start: [f64; 2],
) -> Option<[f64; 2]> {
    let dot = |u: &[f64; 3], v: &[f64; 3]| u[0] * v[0] + u[1] * v[1] + u[2] * v[2];
    let mut xi = start;
    for _ in 0..30 {
        let (x, b, _) = frame(el, 3, xe, &xi);
        let r = [x[0] - y[0], x[1] - y[1], x[2] - y[2]];
        let f = [dot(&r, &a[0]), dot(&r, &a[1])];
        let (j00, j01, j10, j11) = (
            dot(&a[0], &b[0]),
            dot(&a[0], &b[1]),
            dot(&a[1], &b[0]),
            dot(&a[1], &b[1]),
        );
        let det = j00 * j11 - j01 * j10;
        if det.abs() <= 1e-12 * (j00.abs() + j01.abs()) * (j10.abs() + j11.abs()) {
            return None;
        }
        let d = [
            -(j11 * f[0] - j01 * f[1]) / det,
            -(j00 * f[1] - j10 * f[0]) / det,
        ];
        xi = [xi[0] + d[0], xi[1] + d[1]];
        if xi[0].abs().max(xi[1].abs()) > 4.0 {
            return None;
        }
        if d[0].abs().max(d[1].abs()) <= 1e-13 {
            return Some(xi);
        }
    }
    None
}

/// How far a layout moved: the largest change of a coordinate, 2 (the size of the parameter
/// square) where the number of breakpoints or quadrilaterals changed.
fn layout_move(old: &[f64], new: &[f64]) -> f64 {
    if old.len() != new.len() {
        return 2.0;
    }
    old.iter()
        .zip(new)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max)
}

/// The parameter square of a 3D element, corners counter-clockwise.
const SQUARE: [[f64; 2]; 4] = [[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]];

/// The points (surface coordinates, weights) of the segments between `cuts` (and -1, 1).
fn segment_points(cuts: &[f64], seg: &Segments) -> Vec<([f64; 2], f64)> {
    let mut ends = Vec::with_capacity(cuts.len() + 2);
    ends.push(-1.0);
    ends.extend_from_slice(cuts);
    ends.push(1.0);
    let mut pts = Vec::with_capacity(seg.per_element());
    for s in ends.windows(2) {
        let (a, b) = (s[0], s[1]);
        for (z, w) in seg.zeta.iter().zip(&seg.wz) {
            pts.push(([0.5 * (a + b) + 0.5 * (b - a) * z, 0.0], 0.5 * (b - a) * w));
        }
    }
    pts
}

/// The points (surface coordinates, weights) of the quadrilaterals whose corners `corners` lists
/// (8 numbers each): the tensor rule mapped by each one's bilinear map.
fn quad_points(corners: &[f64], seg: &Segments) -> Vec<([f64; 2], f64)> {
    let mut pts = Vec::with_capacity(seg.per_element());
    for q in corners.chunks_exact(8) {
        let v = |c: usize| [q[2 * c], q[2 * c + 1]];
        let (v0, v1, v2, v3) = (v(0), v(1), v(2), v(3));
        for (s, ws) in seg.zeta.iter().zip(&seg.wz) {
            for (t, wt) in seg.zeta.iter().zip(&seg.wz) {
                let n = [
                    0.25 * (1.0 - s) * (1.0 - t),
                    0.25 * (1.0 + s) * (1.0 - t),
                    0.25 * (1.0 + s) * (1.0 + t),
                    0.25 * (1.0 - s) * (1.0 + t),
                ];
                let ds = [
                    -0.25 * (1.0 - t),
                    0.25 * (1.0 - t),
                    0.25 * (1.0 + t),
                    -0.25 * (1.0 + t),
                ];
                let dt = [
                    -0.25 * (1.0 - s),
                    -0.25 * (1.0 + s),
                    0.25 * (1.0 + s),
                    0.25 * (1.0 - s),
                ];
                let (mut x, mut xs, mut xt) = ([0.0; 2], [0.0; 2], [0.0; 2]);
                for (c, vc) in [v0, v1, v2, v3].iter().enumerate() {
                    for d in 0..2 {
                        x[d] += n[c] * vc[d];
                        xs[d] += ds[c] * vc[d];
                        xt[d] += dt[c] * vc[d];
                    }
                }
                let det = (xs[0] * xt[1] - xs[1] * xt[0]).abs();
                pts.push((x, ws * wt * det));
            }
        }
    }
    pts
}

/// Twice the signed area of a polygon.
fn area2(p: &[[f64; 2]]) -> f64 {
    (0..p.len())
        .map(|i| {
            let (a, b) = (p[i], p[(i + 1) % p.len()]);
            a[0] * b[1] - a[1] * b[0]
        })
        .sum()
}

/// Cuts every convex piece that the segment from `a` to `b` crosses along the segment's line.
/// Cuts that would leave a sliver thinner than `END`, or that the segment does not reach by more
/// than `END`, are not made.
fn cut_pieces(pieces: &mut Vec<Vec<[f64; 2]>>, a: [f64; 2], b: [f64; 2]) {
    let d = [b[0] - a[0], b[1] - a[1]];
    let len = d[0].hypot(d[1]);
    if len <= END {
        return;
    }
    let (u, n) = ([d[0] / len, d[1] / len], [-d[1] / len, d[0] / len]);
    let side = |v: &[f64; 2]| n[0] * (v[0] - a[0]) + n[1] * (v[1] - a[1]);
    let along = |v: &[f64; 2]| u[0] * (v[0] - a[0]) + u[1] * (v[1] - a[1]);
    let mut out = Vec::with_capacity(pieces.len() + 2);
    for p in pieces.drain(..) {
        // corners within round-off of the line lie on it: the pieces' corner counts then do not
        // flip between updates with the round-off of the projections
        let s: Vec<f64> = p
            .iter()
            .map(|v| {
                let d = side(v);
                if d.abs() <= SNAP {
                    0.0
                } else {
                    d
                }
            })
            .collect();
        let (lo, hi) = s
            .iter()
            .fold((0.0f64, 0.0f64), |(l, h), &v| (l.min(v), h.max(v)));
        if lo > -END || hi < END {
            out.push(p);
            continue;
        }
        let (mut left, mut right) = (Vec::with_capacity(p.len() + 1), Vec::new());
        let mut chord = (f64::INFINITY, f64::NEG_INFINITY);
        for i in 0..p.len() {
            let j = (i + 1) % p.len();
            let (si, sj) = (s[i], s[j]);
            if si >= 0.0 {
                left.push(p[i]);
            }
            if si <= 0.0 {
                right.push(p[i]);
            }
            if si == 0.0 {
                let t = along(&p[i]);
                chord = (chord.0.min(t), chord.1.max(t));
            }
            if (si > 0.0 && sj < 0.0) || (si < 0.0 && sj > 0.0) {
                let f = si / (si - sj);
                let x = [
                    p[i][0] + f * (p[j][0] - p[i][0]),
                    p[i][1] + f * (p[j][1] - p[i][1]),
                ];
                left.push(x);
                right.push(x);
                let t = along(&x);
                chord = (chord.0.min(t), chord.1.max(t));
            }
        }
        // the segment reaches into the piece along the chord of its line through it
        if chord.1.min(len) - chord.0.max(0.0) <= END {
            out.push(p);
            continue;
        }
        for q in [left, right] {
            let mut q: Vec<[f64; 2]> = q;
            q.dedup_by(|a, b| (a[0] - b[0]).hypot(a[1] - b[1]) <= SNAP);
            if q.len() > 1
                && (q[0][0] - q[q.len() - 1][0]).hypot(q[0][1] - q[q.len() - 1][1]) <= SNAP
            {
                q.pop();
            }
            out.push(q);
        }
    }
    *pieces = out;
}

/// Splits a convex polygon into quadrilaterals (a fan from its first corner; a remaining triangle
/// is a quadrilateral with its last two corners equal).
fn fan_quadrilaterals(p: &[[f64; 2]], out: &mut Vec<[[f64; 2]; 4]>) {
    let mut i = 1;
    while i + 1 < p.len() {
        if i + 2 < p.len() {
            out.push([p[0], p[i], p[i + 1], p[i + 2]]);
            i += 2;
        } else {
            out.push([p[0], p[i], p[i + 1], p[i + 1]]);
            i += 1;
        }
    }
}

/// Merges the pair of neighbouring segments between `cuts` (and -1, 1) whose union is shortest
/// until at most `slots` segments remain.
fn merge_segments(cuts: &mut Vec<f64>, slots: usize) {
    while cuts.len() + 1 > slots && !cuts.is_empty() {
        let mut best = (f64::INFINITY, 0);
        for j in 0..cuts.len() {
            let lo = if j == 0 { -1.0 } else { cuts[j - 1] };
            let hi = if j + 1 < cuts.len() { cuts[j + 1] } else { 1.0 };
            if hi - lo < best.0 {
                best = (hi - lo, j);
            }
        }
        cuts.remove(best.1);
    }
}

#[cfg(test)]
mod tests {
    use super::merge_segments;

    #[test]
    fn merging_removes_the_cut_between_the_shortest_pair() {
        let mut cuts = vec![-0.5, 0.0, 0.1, 0.6];
        merge_segments(&mut cuts, 4);
        // segments [-1,-.5] [-.5,0] [0,.1] [.1,.6] [.6,1]: removing a cut joins its two neighbours,
        // lengths 1.0, 0.6, 0.6, 0.9: the first shortest union goes, the cut 0.0
        assert_eq!(cuts, vec![-0.5, 0.1, 0.6]);
        merge_segments(&mut cuts, 1);
        assert!(cuts.is_empty());
    }
}
