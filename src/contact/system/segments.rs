//! Segment-based quadrature of one-pass pairs (weighted or pointwise gap) in 2D and 3D.
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
//! element, `y_b` and `a_b` the position and tangent of a master element's end, within the
//! search distance and the slave element's own length of `y_b`. At a kink of a C0 master's node
//! (unit tangents `u`, `v` from the node into its two elements) the projection's boundaries depend
//! on which side of the corner the point lies: `d . u = 0` where `d . v <= 0` and the same with
//! `u`, `v` swapped (the edges of the fan of points that project onto the node, where the corner is
//! convex towards them), and `d . (u - v) = 0` where both `d . u` and `d . v` are positive (the
//! bisector, where the corner is concave towards them: both facets hold an orthogonal projection
//! and the nearer one is the closest point; the fan's edges cross there and bound nothing).
//!
//! Each element holds `slots` segments' worth of points (enough for the longest slave element over
//! the shortest master element; more breakpoints than that merge the shortest neighbouring
//! segments); the points of unused slots have weight 0, are neither projected nor integrated, and
//! carry NaN pressure and gap in the output. Frictionless pairs only: a point's friction anchor is
//! the history of a material point, which moving points do not keep.
//!
//! 3D (off with `NURBS_CONTACT_SEGMENTS_3D=0`, for comparison): each slave element's square is
//! split into the images of the master elements near it (each master corner mapped to the slave
//! coordinate of its closest point on the bilinear surface through the slave element's corners,
//! straight edges between them, images clipped to the square, the uncovered rest of the square a
//! piece of its own). Each piece, a convex polygon, is fanned into triangles, and neighbouring
//! triangles of the fan that form a convex quadrilateral are one cell: a quadrilateral takes the
//! element's tensor rule on its bilinear map (9 points for Q1N2), a triangle a triangle rule of
//! the element's degree (6 points for Q1N2). An element that one image covers, or whose images do
//! not tile it, keeps its tensor rule. Points are held while every image corner moved less than
//! [`KEEP`], and for the rest of a load factor once an element was placed [`HOLD`] times at it.
//! Each element starts with room for its tensor rule's points; a placement that needs more grows
//! it ([`reserve`]: the pass's points are laid out again, once per update, each element's range
//! moved), so an element holds the most points its placements have needed so far, and the walks
//! over its points visit only those placed (`OwnElem::n`). This passes the 3D non-matching patch test;
//! `docs/formulations.md` has what it costs on Table 4's twist.
#![allow(non_snake_case)]

use super::ContactSystem;
use crate::contact::basis::FaceBasis;
use crate::contact::formulation::Pressure;
use crate::contact::half_pass::QPoint;
use crate::contact::pair::{Law, PairDef, Partner};
use crate::contact::search::Aabb;
use crate::contact::surface::{frame, raw_normal, MAX_FACE_NODES};

/// Samples per element at which the breakpoint functions are evaluated before bisection.
const SAMPLES: usize = 16;

/// 3D: images of master corners that moved less than this (in the slave coordinate) since the
/// element's points were placed keep them where they are (within a load step the points are then
/// held, [`HOLD`]). The tangent holds the points fixed (it omits the breakpoints' motion, whose
/// effect on the residual is of the order of the segments' quadrature error).
const KEEP: f64 = 1e-4;

/// 2D: breakpoints that moved less than this (in the slave coordinate) since the points were
/// placed keep them where they are; the others are placed again at the next update, every
/// residual evaluation included. The tangent holds the points fixed: moving them at every update
/// left Newton converging only linearly once the iterates' changes were small (on the 2D patch
/// test with Q1N2, 11 iterations in a step where held points take 4). A breakpoint held `d` from
/// its kink leaves an error of order `d^2` in its element's integral. The weighted gaps keep
/// [`KEEP`]; the pointwise gap takes [`KEEP_POINTWISE_2D`].
const KEEP_2D: f64 = KEEP;

/// 2D, the pointwise gap: [`KEEP_2D`] of its passes. Measured on the 4-unit slide of ironing
/// (`ci/formulation_matrix.py --rows patch2d,ironing4,ironing8,ironing16 --families Q1C1,Q1N2
/// --forms op/pointwise`, docs/formulations.md "The breakpoints' threshold"): with 1e-4 the cuts
/// of the fan of points projecting onto a faceted master's kinked node moved by 1e-2..3e-2
/// between the evaluations of one Newton iteration, and Newton stalled in the press of Q1C1 on
/// mesh 4 (19 failed iterations, one cutback); with this threshold that run has 4 failed
/// iterations and no cutback, mesh 8 takes 17 % (Q1C1) and 9 % (Q1N2) fewer Newton iterations,
/// and DeltaP_x and DeltaP_y agree to three digits; the patch test's pressure stays uniform to
/// 1.2e-11. The weighted gap with Q1C1 does not take it: its press of ironing mesh 4 then fails
/// at load 0.70 (`tests/weighted_gap.rs` presses to 0.95 without a cutback with [`KEEP`]).
/// Holding the 2D points through a load step and placing them again after it, as 3D does, took
/// more iterations (mesh 4: 2421 against 1492 with Q1C1, 1453 against 1245 with Q1N2).
const KEEP_POINTWISE_2D: f64 = 2e-2;

/// 3D: after a converged solve, elements whose images moved more than this (in the slave
/// coordinate) since their points were placed are placed again and the step solved again
/// (`crate::contact::system::augment`). A kink left `d` inside a segment costs its element's
/// integral an error of order `d^2`. Measured: the one-step press of `tests/iterative.rs` against
/// its cut-back Krylov run differs by 1.7e-6 in displacement (1.4e-3 without the rounds, the points
/// then placed at the undeformed state); Table 4's twist on mesh 2 takes 307 Newton iterations
/// (295 without the rounds, 471 with a threshold of 1e-3, 499 with [`KEEP`]), DeltaP_z the same
/// to four digits.
pub(super) const SETTLE: f64 = 2e-2;

/// Breakpoints closer than this to the element's ends (in the slave coordinate) are dropped: a
/// master node that lies on a slave node, as where meshes share nodes, otherwise comes and goes
/// between updates; the kink it leaves inside the end segment is within `END * h` of the end.
const END: f64 = 1e-4;

/// Tangents into a node's two elements whose sum is shorter than this meet without a kink: the
/// node's breakpoint is where the projection leaves either element (one root for both).
const KINK: f64 = 1e-10;

/// Most segments an element's points can hold.
const MAX_SLOTS: usize = 16;

/// The segment rule of a pass.
#[derive(Debug, Clone)]
pub(crate) struct Segments {
    /// Gauss-Legendre points and weights of one segment on [-1, 1].
    zeta: Vec<f64>,
    wz: Vec<f64>,
    /// Segments per element.
    pub(crate) slots: usize,
    /// The weight functions are the linear parent's corners (`weighted_linear`).
    linear: bool,
    /// 2D: how far (in the slave coordinate) the breakpoints may move before the points are
    /// placed again ([`KEEP_2D`], [`KEEP_POINTWISE_2D`]).
    keep: f64,
    /// Per element (own, then halo): the breakpoints its points are placed on (`None`: not yet
    /// placed).
    placed: Vec<Option<Vec<f64>>>,
    /// 3D: the triangle rule of one piece (barycentric `s`, `t` on the triangle (0,0), (1,0),
    /// (0,1), weight; the weights sum to 1).
    tri: Vec<(f64, f64, f64)>,
    /// 3D: per element (own, then halo), the master elements' images its points are placed on.
    layouts: Vec<Option<Layout>>,
    /// 3D: per element, whether its points are the tensor rule's (no images cut it).
    tensor: Vec<bool>,
    /// 3D: per element, the load factor of its last placement and how often it was placed at it.
    moves: Vec<(f64, u32)>,
}

/// 3D: the master elements whose images cut a slave element, with their corners' images in the
/// slave coordinates (after snapping).
type Layout = Vec<(u32, [[f64; 2]; 4])>;

impl Segments {
    /// Points per element at set-up: in 2D room for every segment, in 3D the tensor rule's (an
    /// element grows when a placement needs more, [`reserve`]).
    pub(crate) fn per_element(&self) -> usize {
        if self.tri.is_empty() {
            self.slots * self.zeta.len()
        } else {
            self.zeta.len() * self.zeta.len()
        }
    }

    /// Whether the pass is integrated over 3D segments (its elements' point counts vary).
    pub(crate) fn three_d(&self) -> bool {
        !self.tri.is_empty()
    }

    /// 3D: the points a placement on `cells` takes (`None`: the tensor rule).
    fn points_on(&self, cells: Option<&[Cell]>) -> usize {
        let tensor = self.zeta.len() * self.zeta.len();
        cells.map_or(tensor, |cs| {
            cs.iter()
                .map(|c| if c.len() == 3 { self.tri.len() } else { tensor })
                .sum()
        })
    }

    /// 3D: the most points a placement can take (every triangle of the most the pass allows).
    pub(crate) fn most_points(&self) -> usize {
        (self.slots * self.tri.len()).max(self.zeta.len() * self.zeta.len())
    }
}

/// Gives element `i` (own, then halo) of `ps` room for at least `n` points for each `(i, n)` of
/// `need`: where one has less, the pass's points (and the partner bases stored at them) are laid
/// out again in element order, each element's range moved and the grown ones padded with unused
/// points (weight 0, no state); the points keep their state and order. Elements never shrink.
pub(crate) fn reserve(ps: &mut crate::contact::half_pass::Pass, need: &[(usize, usize)]) {
    let mut want: Vec<usize> = ps.elems.iter().chain(&ps.halo).map(|o| o.slots).collect();
    let mut grows = false;
    for &(i, n) in need {
        if n > want[i] {
            want[i] = n;
            grows = true;
        }
    }
    if !grows {
        return;
    }
    let total: usize = want.iter().sum();
    let old = std::mem::take(&mut ps.points);
    let mut old_bases = std::mem::take(&mut ps.bases);
    let keep_bases = !old_bases.is_empty();
    let mut points = Vec::with_capacity(total);
    let mut bases = Vec::with_capacity(if keep_bases { total } else { 0 });
    for (oe, &n) in ps.elems.iter_mut().chain(ps.halo.iter_mut()).zip(&want) {
        let first = points.len();
        points.extend_from_slice(&old[oe.first..oe.first + oe.slots]);
        points.resize(first + n, QPoint::default());
        if keep_bases {
            for q in oe.first..oe.first + oe.slots {
                bases.push(old_bases.get_mut(q).map(std::mem::take).unwrap_or_default());
            }
            bases.resize(first + n, Default::default());
        }
        oe.first = first;
        oe.slots = n;
    }
    ps.points = points;
    ps.bases = bases;
}

/// Whether a pair's pass is integrated over segments: one-pass, frictionless, against another
/// surface, with a weighted gap (2D, and 3D unless switched off) or, in 2D, with the pointwise
/// gap under the plain penalty law. An augmented pointwise pair keeps a multiplier per material
/// point and the cohesive law a pairing and damage per material point, which points that move
/// onto new segments would not keep (van der Waals pairs keep the element's rule too: not
/// measured with segments). In 3D the pointwise gap is
/// not segmented: over the master elements' images it passes the 3D patch test (spread 1.3e-11
/// with Q1C1, 1.8e-11 with Q1N2), but with Q1C1 Table 4's twist on mesh 8 then stalls in the
/// press (steps cut to 2e-4 of the load by load 0.88, up to 256 Newton iterations each), as the
/// one-pass weighted gaps do there.
pub(crate) fn segmented(def: &PairDef, dim: usize, partner: &Partner) -> bool {
    let pressure = match def.formulation.pressure {
        Pressure::Pointwise => {
            dim == 2
                && def.formulation.augmented().is_none()
                && matches!(def.formulation.law, Law::Penalty { .. })
        }
        p => p.is_nodal() && (dim == 2 || segments_3d()),
    };
    pressure
        && def.formulation.one_pass()
        && def.friction.is_none()
        && matches!(partner, Partner::Surface(_))
}

impl ContactSystem {
    /// The segment rule of surface `k` integrated against surface `l` with `n_g` Gauss points per
    /// segment: enough slots for the longest slave element over the shortest master element.
    pub(super) fn segment_rule(
        &self,
        k: usize,
        l: usize,
        n_g: usize,
        pressure: &Pressure,
    ) -> Segments {
        let linear = pressure.linear_parent();
        let keep = match pressure {
            Pressure::Pointwise => KEEP_POINTWISE_2D,
            _ => KEEP_2D,
        };
        let chord = |s: usize| -> Vec<f64> {
            let surf = &self.surfaces[s];
            (0..surf.elements.len())
                .map(|e| {
                    let el = &surf.elements[e];
                    let x = self.pos[s].of(e);
                    let a = frame(el, self.dim, x, &[-1.0, 0.0]).0;
                    let b = frame(el, self.dim, x, &[1.0, 0.0]).0;
                    (0..self.dim)
                        .map(|c| (b[c] - a[c]).powi(2))
                        .sum::<f64>()
                        .sqrt()
                })
                .collect()
        };
        let longest = chord(k).into_iter().fold(0.0, f64::max);
        let shortest = chord(l)
            .into_iter()
            .filter(|&h| h > 0.0)
            .fold(f64::INFINITY, f64::min);
        let ratio = if shortest.is_finite() {
            longest / shortest
        } else {
            1.0
        };
        // a slave element meets at most ceil(ratio) + 1 master nodes, each two breakpoints where
        // the master is C0 (the edges of its fan); the master's elements may shorten by half
        let slots = (2.0 * (1.5 * ratio).ceil() + 3.0).min(MAX_SLOTS as f64) as usize;
        let (zeta, wz) =
            crate::fem::quadrature::gauss_legendre(n_g).expect("a rule of at least one point");
        if self.dim == 3 {
            // a slave element meets at most r^2 master elements, each piece a few triangles
            let r = (1.5 * ratio).ceil() + 1.0;
            let slots = (4.0 * r * r).min(MAX_TRIANGLES as f64) as usize;
            let tri = triangle_rule(n_g);
            return Segments {
                zeta,
                wz,
                slots,
                linear,
                keep: KEEP,
                placed: Vec::new(),
                tri,
                layouts: Vec::new(),
                tensor: Vec::new(),
                moves: Vec::new(),
            };
        }
        Segments {
            zeta,
            wz,
            slots,
            linear,
            keep,
            placed: Vec::new(),
            tri: Vec::new(),
            layouts: Vec::new(),
            tensor: Vec::new(),
            moves: Vec::new(),
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
                seg.layouts.resize(n_all, None);
                seg.tensor.resize(n_all, true);
                seg.moves.resize(n_all, (f64::NAN, 0));
                let boxed = self.boxed_in_grid(l);
                // 3D: the elements placed again (index, element, cells, images), placed after the
                // loop once every element has the room its cells need
                let mut placing: Vec<(usize, usize, Option<Vec<Cell>>, Layout)> = Vec::new();
                for i in 0..n_all {
                    if self.dim == 3 {
                        let e = {
                            let ps = &self.pairs[pi].passes[si];
                            ps.elems.get(i).unwrap_or_else(|| &ps.halo[i - n_own]).e as usize
                        };
                        // held for the rest of this load factor: nothing to compute
                        if seg.moves[i].0 == self.lambda
                            && seg.moves[i].1 >= HOLD
                            && seg.layouts[i].is_some()
                        {
                            continue;
                        }
                        let (layout, tris) = self.pieces(k, e, l, dist, seg.slots, boxed);
                        let old = seg.layouts[i].as_ref();
                        let mv = old.map_or(-1.0, |p| layout_move(p, &layout));
                        // no corner moved more than KEEP, or the tensor rule then and now (the
                        // same points)
                        let kept =
                            old.is_some() && (mv <= KEEP || (seg.tensor[i] && tris.is_none()));
                        let lam = self.lambda;
                        if !kept {
                            if seg.moves[i].0 == lam {
                                seg.moves[i].1 += 1;
                            } else {
                                seg.moves[i] = (lam, 1);
                            }
                        }
                        if !kept && std::env::var_os("NURBS_CONTACT_DEBUG_SEGMENTS").is_some() {
                            eprintln!("seg3d: load {} element {e} placed again: {} images (was {:?}), moved {mv:e}, {} triangles; {:?} -> {:?}", self.lambda, layout.len(), old.map(|p| p.len()), tris.as_ref().map_or(0, |t| t.iter().map(|c| c.len() - 2).sum::<usize>()), old.map(|p| p.iter().map(|x| x.0).collect::<Vec<_>>()), layout.iter().map(|x| x.0).collect::<Vec<_>>());
                        }
                        if !kept {
                            placing.push((i, e, tris, layout));
                        }
                        continue;
                    }
                    let e = {
                        let ps = &self.pairs[pi].passes[si];
                        ps.elems.get(i).unwrap_or_else(|| &ps.halo[i - n_own]).e as usize
                    };
                    let mut cuts = self.breakpoints(k, e, l, dist);
                    if cuts.len() + 1 > seg.slots {
                        merge_segments(&mut cuts, seg.slots);
                    }
                    let kept = seg.placed[i].as_ref().is_some_and(|p| {
                        p.len() == cuts.len()
                            && p.iter().zip(&cuts).all(|(a, b)| (a - b).abs() <= seg.keep)
                    });
                    if !kept {
                        self.place_points(pi, si, i, e, &cuts, &seg, region.as_ref());
                        seg.placed[i] = Some(cuts);
                    }
                }
                if !placing.is_empty() {
                    let need: Vec<(usize, usize)> = placing
                        .iter()
                        .map(|(i, _, cells, _)| (*i, seg.points_on(cells.as_deref())))
                        .collect();
                    reserve(&mut self.pairs[pi].passes[si], &need);
                }
                for (i, e, cells, layout) in placing {
                    self.place_points3(pi, si, i, e, cells.as_deref(), &seg, region.as_ref());
                    seg.layouts[i] = Some(layout);
                    seg.tensor[i] = cells.is_none();
                }
                self.pairs[pi].passes[si].segments = Some(seg);
            }
        }
    }

    /// 3D: per pair, how far the points of its segmented passes lie from where the current
    /// positions would place them: the largest move of a master corner's image (in the slave
    /// coordinate) since its element was placed, infinite where the images changed; 0 for pairs
    /// without 3D segments. Empty when no pass is integrated over 3D segments.
    pub(super) fn segment_drift(&self) -> Vec<f64> {
        let three_d = |ps: &crate::contact::half_pass::Pass| {
            ps.segments.as_ref().is_some_and(|s| !s.tri.is_empty())
        };
        if !self.pairs.iter().flat_map(|p| &p.passes).any(three_d) {
            return Vec::new();
        }
        self.pairs
            .iter()
            .map(|pair| {
                let mut drift = 0.0f64;
                for ps in pair.passes.iter().filter(|ps| three_d(ps)) {
                    let (Some(seg), Partner::Surface(l)) = (&ps.segments, &ps.partner) else {
                        continue;
                    };
                    let n_own = ps.elems.len();
                    let boxed = self.boxed_in_grid(*l);
                    for (i, old) in seg.layouts.iter().enumerate() {
                        let Some(old) = old else { continue };
                        let e = ps.elems.get(i).unwrap_or_else(|| &ps.halo[i - n_own]).e;
                        let (now, tris) = self.pieces(
                            ps.k,
                            e as usize,
                            *l,
                            pair.def.search_distance,
                            seg.slots,
                            boxed,
                        );
                        // the tensor rule then and now: the same points, whatever the images
                        let mv = match (seg.tensor[i], tris.is_none()) {
                            (true, true) => 0.0,
                            _ => layout_move(old, &now),
                        };
                        if mv > KEEP && std::env::var_os("NURBS_CONTACT_DEBUG_SEGMENTS").is_some() {
                            eprintln!(
                                "seg3d drift: element {e} moved {mv:e}: {:?} -> {:?}",
                                old, now
                            );
                        }
                        drift = drift.max(mv);
                    }
                }
                drift
            })
            .collect()
    }

    /// 3D: the points of every element of the segmented passes of the pairs whose `drift`
    /// exceeds [`SETTLE`] are placed again at the next update (the element's hold is released).
    pub(super) fn release_segments(&mut self, drift: &[f64]) {
        for (pair, &d) in self.pairs.iter_mut().zip(drift) {
            if d <= SETTLE {
                continue;
            }
            for ps in &mut pair.passes {
                if let Some(seg) = ps.segments.as_mut() {
                    for m in &mut seg.moves {
                        m.1 = 0;
                    }
                }
            }
            // the next update at the same state places them (it would return at once)
            self.last_update = None;
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
        // the roots of `(x(t) - y_b) . dir` on the element within `reach` of `y_b` where `keep`
        // holds at the root
        let mut roots = |yb: &[f64; 3], dir: &[f64; 3], keep: &dyn Fn(&[f64; 3]) -> bool| {
            let h = |x: &[f64; 3]| (0..dim).map(|c| (x[c] - yb[c]) * dir[c]).sum::<f64>();
            let near = |x: &[f64; 3]| {
                (0..dim).map(|c| (x[c] - yb[c]).powi(2)).sum::<f64>().sqrt() <= reach
            };
            for w in samples.windows(2) {
                let ((mut t0, xa), (mut t1, xb)) = (w[0], w[1]);
                let (mut h0, h1) = (h(&xa), h(&xb));
                if h0 == 0.0 {
                    if near(&xa) && keep(&xa) {
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
                let x = at(t);
                if near(&x) && keep(&x) {
                    cuts.push(t);
                }
            }
        };
        for &f in &partners {
            let elf = &self.surfaces[l].elements[f as usize];
            let yf = self.pos[l].of(f as usize);
            for (side, end) in [(0usize, -1.0), (1, 1.0)] {
                let (yb, a, _) = frame(elf, dim, yf, &[end, 0.0]);
                // `u`: the unit tangent from the node into `f`; `v`: into the neighbour across
                // the node, where this rank has it
                let u = unit(a[0], -end);
                let v = elf.neighbours[side].and_then(|(f2, s2, _)| {
                    let f2 = f2 as usize;
                    if !self.pos[l].has(f2) {
                        return None;
                    }
                    let end2 = if s2 == 0 { -1.0 } else { 1.0 };
                    let el2 = &self.surfaces[l].elements[f2];
                    let (_, a2, _) = frame(el2, dim, self.pos[l].of(f2), &[end2, 0.0]);
                    Some(unit(a2[0], -end2))
                });
                match v.filter(|v| kinked(&u, v)) {
                    // a kink of a C0 master: a point projects into `f` where `d . u > 0`, into
                    // the neighbour where `d . v > 0`, onto the node where neither holds (the
                    // fan of a corner convex towards the point), and where both hold onto the
                    // nearer of the two, `f` where `d . (u - v) > 0` (the bisector of a corner
                    // concave towards the point, where the fan's edges cross and are no boundary)
                    Some(v) => {
                        let dot = |x: &[f64; 3], w: &[f64; 3]| {
                            (0..dim).map(|c| (x[c] - yb[c]) * w[c]).sum::<f64>()
                        };
                        roots(&yb, &u, &|x| dot(x, &v) <= 0.0);
                        let b = [0, 1, 2].map(|c| u[c] - v[c]);
                        roots(&yb, &b, &|x| dot(x, &u) > 0.0);
                    }
                    // a smooth node, or the surface's end: where the projection leaves `f`
                    None => roots(&yb, &a[0], &|_| true),
                }
            }
        }
        cuts.retain(|&t| t.abs() < 1.0 - END);
        cuts.sort_by(|a, b| a.total_cmp(b));
        cuts.dedup_by(|a, b| (*a - *b).abs() < 1e-9);
        cuts
    }

    /// Moves the points of element `i` (own, then halo) of pass `si` of pair `pi` onto the
    /// segments between `cuts`: surface coordinates, weights, reference area, the element's basis
    /// at them and the weighted gap's weight functions. A point keeps the reference position it
    /// was set up with (the output grid's), so its output displacement leads to where it is now.
    #[allow(clippy::too_many_arguments)]
    fn place_points(
        &mut self,
        pi: usize,
        si: usize,
        i: usize,
        e: usize,
        cuts: &[f64],
        seg: &Segments,
        region: Option<&crate::contact::search::Aabb>,
    ) {
        let mut ends = Vec::with_capacity(cuts.len() + 2);
        ends.push(-1.0);
        ends.extend_from_slice(cuts);
        ends.push(1.0);
        let per = seg.per_element();
        let mut pts: Vec<([f64; 2], f64)> = Vec::with_capacity(per);
        for s in ends.windows(2) {
            let (a, b) = (s[0], s[1]);
            for (z, w) in seg.zeta.iter().zip(&seg.wz) {
                pts.push(([0.5 * (a + b) + 0.5 * (b - a) * z, 0.0], 0.5 * (b - a) * w));
            }
        }
        self.write_points(pi, si, i, e, pts, seg, region);
    }

    /// 3D: the pieces of element `e` of surface `k` against surface `l`: the images of the master
    /// elements near it in its coordinates (each master corner mapped to the slave coordinate of
    /// its closest point on the bilinear surface through the element's corners, straight edges
    /// between them, corners within
    /// [`SNAP`] of the element's sides moved onto them), clipped to the element's square, and the
    /// part of the square no image covers; every piece split into triangles. `None`: the element's
    /// own tensor rule (one image covers it, or the images do not tile it).
    /// `boxed`: [`Self::boxed_in_grid`] of `l`.
    #[allow(clippy::type_complexity)]
    #[allow(clippy::too_many_arguments)]
    fn pieces(
        &self,
        k: usize,
        e: usize,
        l: usize,
        dist: f64,
        slots: usize,
        boxed: bool,
    ) -> (Layout, Option<Vec<Cell>>) {
        let dim = self.dim;
        let el = &self.surfaces[k].elements[e];
        let xe = self.pos[k].of(e);
        // the master elements whose control points' box meets the element's, grown by the search
        // distance and half the element's size (a master whose image misses the element is
        // clipped away, so the set does not decide the layout)
        let (mut lo, mut hi) = points_box(xe, dim);
        let size = (0..dim)
            .map(|c| (hi[c] - lo[c]).powi(2))
            .sum::<f64>()
            .sqrt();
        for c in 0..dim {
            lo[c] -= dist + 0.5 * size;
            hi[c] += dist + 0.5 * size;
        }
        let partners = self.near_masters(l, &lo, &hi, boxed);
        // the corners' images are taken on the bilinear surface through the element's corners,
        // defined far beyond the element (a curved element's own map, extrapolated, is not: the
        // images of distant master corners did not converge and jumped between iterates)
        let xc: [[f64; 3]; 4] = QUAD_CORNERS.map(|(s, t)| frame(el, dim, xe, &[s, t]).0);
        let surf = |xi: &[f64; 2]| -> ([f64; 3], [[f64; 3]; 2]) {
            let mut p = [0.0; 3];
            let mut a = [[0.0; 3]; 2];
            for (c, (s, t)) in QUAD_CORNERS.into_iter().enumerate() {
                let (fs, ft) = (1.0 + s * xi[0], 1.0 + t * xi[1]);
                for k in 0..3 {
                    p[k] += 0.25 * fs * ft * xc[c][k];
                    a[0][k] += 0.25 * s * ft * xc[c][k];
                    a[1][k] += 0.25 * fs * t * xc[c][k];
                }
            }
            (p, a)
        };
        // the slave coordinate of the closest point of `y` on that surface (Gauss-Newton)
        let image = |y: &[f64; 3]| -> Option<[f64; 2]> {
            let mut xi = [0.0f64; 2];
            for _ in 0..50 {
                let (p, a) = surf(&xi);
                let r = [0, 1, 2].map(|c| y[c] - p[c]);
                let d = |u: &[f64; 3], v: &[f64; 3]| u[0] * v[0] + u[1] * v[1] + u[2] * v[2];
                let (m00, m01, m11) = (d(&a[0], &a[0]), d(&a[0], &a[1]), d(&a[1], &a[1]));
                let (b0, b1) = (d(&a[0], &r), d(&a[1], &r));
                let det = m00 * m11 - m01 * m01;
                if det.abs() <= 1e-300 {
                    return None;
                }
                let dx = [(m11 * b0 - m01 * b1) / det, (m00 * b1 - m01 * b0) / det];
                xi = [
                    (xi[0] + dx[0]).clamp(-4.0, 4.0),
                    (xi[1] + dx[1]).clamp(-4.0, 4.0),
                ];
                if dx[0].abs().max(dx[1].abs()) < 1e-14 {
                    return Some(xi);
                }
            }
            Some(xi)
        };
        let mut cache: Vec<(u32, Option<[f64; 2]>)> = Vec::new();
        let mut layout: Layout = Vec::new();
        let square = vec![[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]];
        let mut pieces: Vec<Vec<[f64; 2]>> = Vec::new();
        let mut quads: Vec<[[f64; 2]; 4]> = Vec::new();
        for &f in &partners {
            let elf = &self.surfaces[l].elements[f as usize];
            let yf = self.pos[l].of(f as usize);
            let mut q = [[0.0; 2]; 4];
            let mut ok = true;
            for (c, (s, t)) in QUAD_CORNERS.into_iter().enumerate() {
                let node = elf.corners[c];
                let im = match cache.iter().find(|(n, _)| *n == node) {
                    Some(&(_, im)) => im,
                    None => {
                        let y = frame(elf, dim, yf, &[s, t]).0;
                        let im = image(&y).map(|v| v.map(snapped));
                        cache.push((node, im));
                        im
                    }
                };
                match im {
                    Some(v) => q[c] = v,
                    None => ok = false,
                }
            }
            if !ok {
                continue;
            }
            if signed_area(&q) < 0.0 {
                q.reverse();
            }
            let clip = clip_convex(&q, &square);
            if signed_area(&clip) <= AREA_TOL {
                continue;
            }
            layout.push((f, q));
            quads.push(q);
            pieces.push(clip);
        }
        let covered: f64 = pieces.iter().map(|p| signed_area(p)).sum();
        if covered > 4.0 + 1e-9 {
            return (layout, None);
        }
        if covered < 4.0 - 1e-9 {
            // the part of the square no image covers: split off the outside of every image
            let mut rest = vec![square.clone()];
            for q in &quads {
                if !convex(q) {
                    return (layout, None);
                }
                let mut next = Vec::new();
                for p in rest {
                    let mut inside = p;
                    for c in 0..4 {
                        let (a, b) = (q[c], q[(c + 1) % 4]);
                        let (out, inn) = split(&inside, &a, &b);
                        if signed_area(&out) > AREA_TOL {
                            next.push(out);
                        }
                        inside = inn;
                        if inside.len() < 3 {
                            break;
                        }
                    }
                }
                rest = next;
            }
            pieces.extend(rest);
            let total: f64 = pieces.iter().map(|p| signed_area(p)).sum();
            if (total - 4.0).abs() > 1e-9 {
                return (layout, None);
            }
        }
        if pieces.len() == 1 && (signed_area(&pieces[0]) - 4.0).abs() <= 1e-12 {
            return (layout, None);
        }
        let mut n_tris = 0;
        let mut cells = Vec::new();
        for p in &pieces {
            let fan: Vec<[[f64; 2]; 3]> = (1..p.len().saturating_sub(1))
                .map(|j| [p[0], p[j], p[j + 1]])
                .filter(|t| signed_area(t) > AREA_TOL)
                .collect();
            n_tris += fan.len();
            cells.extend(cells_of(&fan));
        }
        if n_tris > slots {
            return (layout, None);
        }
        (layout, Some(cells))
    }

    /// Whether the search grid's box of every element of surface `l` holds the box of its nodes
    /// (bilinear and NURBS faces: their grid box is that box, grown by the search distance; the
    /// other faces' boxes are sampled).
    fn boxed_in_grid(&self, l: usize) -> bool {
        self.surfaces[l]
            .elements
            .iter()
            .all(|el| matches!(el.basis, FaceBasis::Nurbs(_) | FaceBasis::Quad4))
    }

    /// 3D: the elements of surface `l` with positions on this rank whose nodes' box meets the box
    /// `lo`..`hi`, ascending: the search grid's elements whose box meets it, where `l` has a grid
    /// at the current positions and `boxed` ([`Self::boxed_in_grid`]) holds, each tested as
    /// [`Self::near_masters_by_test`] does; otherwise that test on every element. The same set
    /// either way.
    pub(crate) fn near_masters(
        &self,
        l: usize,
        lo: &[f64; 3],
        hi: &[f64; 3],
        boxed: bool,
    ) -> Vec<u32> {
        let Some(grid) = self.grids[l].as_ref().filter(|_| boxed) else {
            return self.near_masters_by_test(l, lo, hi);
        };
        let mut out = Vec::new();
        grid.meeting(&Aabb { lo: *lo, hi: *hi }, &mut out);
        out.retain(|&f| self.meets_box(l, f as usize, lo, hi));
        out
    }

    /// [`Self::near_masters`] by testing every element of `l`.
    pub(crate) fn near_masters_by_test(&self, l: usize, lo: &[f64; 3], hi: &[f64; 3]) -> Vec<u32> {
        (0..self.surfaces[l].elements.len())
            .filter(|&f| self.meets_box(l, f, lo, hi))
            .map(|f| f as u32)
            .collect()
    }

    /// Whether this rank holds the positions of element `f` of surface `l` and their box meets
    /// `lo`..`hi`.
    fn meets_box(&self, l: usize, f: usize, lo: &[f64; 3], hi: &[f64; 3]) -> bool {
        let dim = self.dim;
        if !self.pos[l].has(f) {
            return false;
        }
        let (a, b) = points_box(self.pos[l].of(f), dim);
        (0..dim).all(|c| a[c] <= hi[c] && b[c] >= lo[c])
    }

    /// 3D: moves the points of element `i` (own, then halo) of pass `si` of pair `pi` onto the
    /// triangles `tris` (`None`: the element's tensor rule), as [`Self::place_points`].
    #[allow(clippy::too_many_arguments)]
    fn place_points3(
        &mut self,
        pi: usize,
        si: usize,
        i: usize,
        e: usize,
        tris: Option<&[Cell]>,
        seg: &Segments,
        region: Option<&crate::contact::search::Aabb>,
    ) {
        let per = seg.per_element();
        let mut pts: Vec<([f64; 2], f64)> = Vec::with_capacity(per);
        match tris {
            None => {
                for (z0, w0) in seg.zeta.iter().zip(&seg.wz) {
                    for (z1, w1) in seg.zeta.iter().zip(&seg.wz) {
                        pts.push(([*z0, *z1], w0 * w1));
                    }
                }
            }
            Some(cells) => {
                for c in cells {
                    cell_points(c, seg, &mut pts);
                }
            }
        }
        self.write_points(pi, si, i, e, pts, seg, region);
    }

    /// Moves the points of element `i` (element `e` of its surface) of pass `si` of pair `pi` to
    /// `pts` (surface coordinates and weights; the element's remaining slots get weight 0; it has
    /// room for them, [`reserve`]): their
    /// basis, reference Jacobian and the weighted gap's weight functions with them.
    #[allow(clippy::too_many_arguments)]
    fn write_points(
        &mut self,
        pi: usize,
        si: usize,
        i: usize,
        e: usize,
        mut pts: Vec<([f64; 2], f64)>,
        seg: &Segments,
        region: Option<&crate::contact::search::Aabb>,
    ) {
        let dim = self.dim;
        let m = dim - 1;
        let k = self.pairs[pi].passes[si].k;
        let el = &self.surfaces[k].elements[e];
        let nk = el.basis.n_nodes();
        let Xe: Vec<f64> = self.slots[k][e]
            .iter()
            .flat_map(|&t| self.X[t as usize * dim..(t as usize + 1) * dim].to_vec())
            .collect();
        // at least one point, so that the element's basis arrays keep their shape
        if pts.is_empty() {
            pts.push(([0.0, 0.0], 0.0));
        }
        let used = pts.len();
        let (mut N, mut dN, mut ddN) = (
            [0.0; MAX_FACE_NODES],
            [0.0; 2 * MAX_FACE_NODES],
            [0.0; 4 * MAX_FACE_NODES],
        );
        let mut bN = vec![0.0; used * nk];
        let mut bdN = vec![0.0; used * nk * m];
        let mut phi = Vec::with_capacity(used * nk);
        let ps = &mut self.pairs[pi].passes[si];
        let n_own = ps.elems.len();
        let (first, per) = {
            let oe = ps.elems.get(i).unwrap_or_else(|| &ps.halo[i - n_own]);
            (oe.first, oe.slots)
        };
        debug_assert!(used <= per, "{used} points in {per} slots");
        for (j, &(xi, w)) in pts.iter().enumerate() {
            el.basis.eval(&xi[..m], &mut N, &mut dN, &mut ddN);
            bN[j * nk..(j + 1) * nk].copy_from_slice(&N[..nk]);
            bdN[j * nk * m..(j + 1) * nk * m].copy_from_slice(&dN[..nk * m]);
            let [x, y] = xi;
            match (seg.linear, m) {
                (true, 1) => phi.extend([0.5 * (1.0 - x), 0.5 * (1.0 + x)]),
                (true, _) => phi.extend([
                    0.25 * (1.0 - x) * (1.0 - y),
                    0.25 * (1.0 + x) * (1.0 - y),
                    0.25 * (1.0 + x) * (1.0 + y),
                    0.25 * (1.0 - x) * (1.0 + y),
                ]),
                (false, _) => phi.extend_from_slice(&N[..nk]),
            }
            let (xr, a, _) = frame(el, dim, &Xe, &xi);
            let nu = raw_normal(dim, &a);
            let outside = region.is_some_and(|b| !b.contains(&xr[..dim]));
            let qp: &mut QPoint = &mut ps.points[first + j];
            qp.xi = xi;
            qp.w = if outside { 0.0 } else { w };
            qp.J0 = (nu[0] * nu[0] + nu[1] * nu[1] + nu[2] * nu[2]).sqrt();
        }
        // the slots after the used points: weight 0, no partner, outside the element's range
        for qp in &mut ps.points[first + used..first + per] {
            qp.w = 0.0;
            (qp.current, qp.edge) = (None, None);
        }
        let oe = if i < n_own {
            &mut ps.elems[i]
        } else {
            &mut ps.halo[i - n_own]
        };
        oe.n = used;
        oe.N = bN;
        oe.dN = bdN;
        if let Some(net) = ps.mortar.as_mut() {
            net.set_weights(i, phi);
        }
    }
}

/// The box of the points `x` [n][dim] (unused axes empty).
fn points_box(x: &[f64], dim: usize) -> ([f64; 3], [f64; 3]) {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in x.chunks_exact(dim) {
        for c in 0..dim {
            lo[c] = lo[c].min(p[c]);
            hi[c] = hi[c].max(p[c]);
        }
    }
    (lo, hi)
}

/// 3D: a cell of a piece's rule: a triangle (the triangle rule) or a convex quadrilateral (the
/// element's tensor rule on its bilinear map), its corners counter-clockwise.
type Cell = Vec<[f64; 2]>;

/// 3D: the cells of a convex piece from its fan of triangles `(p0, p_j, p_j+1)`: each two
/// neighbouring triangles that share an edge form a quadrilateral, a last odd one stays a
/// triangle. A quadrilateral's tensor rule (`n_g^2` points, of degree `2 n_g - 1` in each
/// direction) integrates on the bilinear map what the triangle rule integrates on its two
/// triangles (degree `2 n_g - 2` for `n_g >= 3`, 2 for `n_g <= 2`) with fewer points: 9 against
/// 12 for `n_g = 3`, 4 against 6 for `n_g = 2`.
fn cells_of(fan: &[[[f64; 2]; 3]]) -> Vec<Cell> {
    let mut out = Vec::with_capacity(fan.len());
    let mut j = 0;
    while j < fan.len() {
        if let Some(b) = fan.get(j + 1) {
            let a = &fan[j];
            let q = [a[0], a[1], a[2], b[2]];
            if a[0] == b[0] && a[2] == b[1] && convex(&q) {
                out.push(q.to_vec());
                j += 2;
                continue;
            }
        }
        out.push(fan[j].to_vec());
        j += 1;
    }
    out
}

/// 3D: the points of cell `c` (surface coordinates and weights) appended to `pts`: the triangle
/// rule on a triangle, the `n_g x n_g` Gauss rule on the bilinear map of a quadrilateral.
fn cell_points(c: &[[f64; 2]], seg: &Segments, pts: &mut Vec<([f64; 2], f64)>) {
    if c.len() == 3 {
        let area = signed_area(c);
        for &(s, r, w) in &seg.tri {
            let xi = [0, 1].map(|k| c[0][k] + s * (c[1][k] - c[0][k]) + r * (c[2][k] - c[0][k]));
            pts.push((xi, w * area));
        }
        return;
    }
    for (u, wu) in seg.zeta.iter().zip(&seg.wz) {
        for (v, wv) in seg.zeta.iter().zip(&seg.wz) {
            let mut xi = [0.0; 2];
            let mut J = [[0.0; 2]; 2];
            for (k, (s, t)) in QUAD_CORNERS.into_iter().enumerate() {
                let (fs, ft) = (1.0 + s * u, 1.0 + t * v);
                for d in 0..2 {
                    xi[d] += 0.25 * fs * ft * c[k][d];
                    J[d][0] += 0.25 * s * ft * c[k][d];
                    J[d][1] += 0.25 * fs * t * c[k][d];
                }
            }
            let det = J[0][0] * J[1][1] - J[0][1] * J[1][0];
            pts.push((xi, wu * wv * det));
        }
    }
}

/// 3D: the largest move of a master corner's image between two layouts of an element (infinite
/// where their master elements differ).
fn layout_move(a: &Layout, b: &Layout) -> f64 {
    if a.len() != b.len() || a.iter().zip(b).any(|(x, y)| x.0 != y.0) {
        return f64::INFINITY;
    }
    a.iter()
        .zip(b)
        .flat_map(|(x, y)| {
            x.1.iter()
                .zip(&y.1)
                .map(|(u, v)| (u[0] - v[0]).abs().max((u[1] - v[1]).abs()))
        })
        .fold(0.0, f64::max)
}

/// 3D: the corners of a quadrilateral element in side order.
const QUAD_CORNERS: [(f64, f64); 4] = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)];

/// 3D: pieces and triangles of at most this area (in the slave coordinates) are empty.
const AREA_TOL: f64 = 1e-14;

/// 3D: most triangles an element's points can hold.
const MAX_TRIANGLES: usize = 64;

/// 3D: an element placed this often at one load factor keeps its points for the rest of it. Once
/// (at the load step's first evaluation, its predicted start): the tangent, which holds the
/// points, is then the residual's exact derivative through the step, and Newton converges as
/// without segments (Table 4's twist on mesh 2: 295 iterations against 322 when an element could
/// be placed again at the step's first iterate, and 242 without segments; on mesh 4, 333 against
/// 331 without). The kinks lie where the step's start put them, off by the step's motion,
/// which leaves an error of the order of its square (the patch test, whose bodies do not slide,
/// stays uniform to 3e-12).
const HOLD: u32 = 1;

/// 3D: images of master corners within this of a slave element's side (in its coordinate) lie on
/// it, so that a master edge along a slave edge leaves no sliver.
const SNAP: f64 = 1e-3;

/// Whether one-pass weighted gaps are integrated over segments in 3D: yes, unless
/// `NURBS_CONTACT_SEGMENTS_3D=0` (a measurement switch: the element's own rule across the master's
/// element edges, as the one-pass pointwise gap).
fn segments_3d() -> bool {
    std::env::var_os("NURBS_CONTACT_SEGMENTS_3D").is_none_or(|v| v != "0")
}

/// `z` moved onto -1 or 1 where it lies within [`SNAP`] of it.
fn snapped(z: f64) -> f64 {
    if (z - 1.0).abs() <= SNAP {
        1.0
    } else if (z + 1.0).abs() <= SNAP {
        -1.0
    } else {
        z
    }
}

/// The signed area of a polygon (positive counter-clockwise).
fn signed_area(p: &[[f64; 2]]) -> f64 {
    let n = p.len();
    if n < 3 {
        return 0.0;
    }
    0.5 * (0..n)
        .map(|i| {
            let (a, b) = (p[i], p[(i + 1) % n]);
            a[0] * b[1] - a[1] * b[0]
        })
        .sum::<f64>()
}

/// Whether the counter-clockwise quadrilateral `q` is convex.
fn convex(q: &[[f64; 2]; 4]) -> bool {
    (0..4).all(|i| {
        let (a, b, c) = (q[i], q[(i + 1) % 4], q[(i + 2) % 4]);
        (b[0] - a[0]) * (c[1] - b[1]) - (b[1] - a[1]) * (c[0] - b[0]) >= 0.0
    })
}

/// The parts of the convex polygon `p` right of (outside) and left of (inside) the line `a -> b`.
fn split(p: &[[f64; 2]], a: &[f64; 2], b: &[f64; 2]) -> (Vec<[f64; 2]>, Vec<[f64; 2]>) {
    let side = |x: &[f64; 2]| (b[0] - a[0]) * (x[1] - a[1]) - (b[1] - a[1]) * (x[0] - a[0]);
    let (mut out, mut inn) = (Vec::new(), Vec::new());
    let n = p.len();
    for i in 0..n {
        let (x, y) = (p[i], p[(i + 1) % n]);
        let (sx, sy) = (side(&x), side(&y));
        if sx >= 0.0 {
            inn.push(x);
        }
        if sx <= 0.0 {
            out.push(x);
        }
        if (sx > 0.0 && sy < 0.0) || (sx < 0.0 && sy > 0.0) {
            let t = sx / (sx - sy);
            let z = [x[0] + t * (y[0] - x[0]), x[1] + t * (y[1] - x[1])];
            inn.push(z);
            out.push(z);
        }
    }
    (out, inn)
}

/// The polygon `p` clipped to the convex counter-clockwise polygon `window` (Sutherland-Hodgman).
fn clip_convex(p: &[[f64; 2]], window: &[[f64; 2]]) -> Vec<[f64; 2]> {
    let mut out = p.to_vec();
    for i in 0..window.len() {
        if out.len() < 3 {
            return Vec::new();
        }
        out = split(&out, &window[i], &window[(i + 1) % window.len()]).1;
    }
    out
}

/// A triangle rule (barycentric `s`, `t`, weights summing to 1) for `n_g` Gauss points per
/// direction of the element: degree 2 (3 points) for `n_g <= 2`, degree 4 (6 points) for 3,
/// otherwise the collapsed `n_g x n_g` Gauss rule (degree `2 n_g - 2`).
fn triangle_rule(n_g: usize) -> Vec<(f64, f64, f64)> {
    if n_g <= 2 {
        let (a, b) = (1.0 / 6.0, 2.0 / 3.0);
        return vec![(a, a, 1.0 / 3.0), (b, a, 1.0 / 3.0), (a, b, 1.0 / 3.0)];
    }
    if n_g == 3 {
        let (a, wa) = (0.445_948_490_915_965, 0.223_381_589_678_011);
        let (b, wb) = (0.091_576_213_509_771, 0.109_951_743_655_322);
        return vec![
            (a, a, wa),
            (1.0 - 2.0 * a, a, wa),
            (a, 1.0 - 2.0 * a, wa),
            (b, b, wb),
            (1.0 - 2.0 * b, b, wb),
            (b, 1.0 - 2.0 * b, wb),
        ];
    }
    let (z, w) = crate::fem::quadrature::gauss_legendre(n_g).expect("a rule of at least one point");
    let mut out = Vec::new();
    for (zu, wu) in z.iter().zip(&w) {
        for (zv, wv) in z.iter().zip(&w) {
            let s = 0.5 * (1.0 + zu);
            let t = (1.0 - s) * 0.5 * (1.0 + zv);
            out.push((s, t, 0.5 * wu * wv * (1.0 - s)));
        }
    }
    out
}

/// `a / |a|` times `s`.
fn unit(a: [f64; 3], s: f64) -> [f64; 3] {
    let l = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
    a.map(|c| s * c / l)
}

/// Whether the unit tangents `u`, `v` from a node into its two elements leave a kink there (they
/// are opposite at a smooth node).
fn kinked(u: &[f64; 3], v: &[f64; 3]) -> bool {
    let s = [0, 1, 2].map(|c| u[c] + v[c]);
    (s[0] * s[0] + s[1] * s[1] + s[2] * s[2]).sqrt() > KINK
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
    use super::{
        cell_points, cells_of, clip_convex, merge_segments, points_box, signed_area, triangle_rule,
        Segments,
    };

    #[test]
    fn a_one_pass_pointwise_pair_is_segmented_in_2d_under_the_plain_penalty_only() {
        use crate::contact::formulation::{Enforcement, Formulation, Passes, Pressure};
        use crate::contact::pair::{Augmented, Friction, Law, PairDef, Partner};
        let def = |passes, law, enforcement, friction| PairDef {
            name: "p".into(),
            formulation: Formulation {
                passes,
                pressure: Pressure::Pointwise,
                enforcement,
                law,
            },
            passes: vec![(0, Partner::Surface(1))],
            search_distance: 1.0,
            moment_point: [0.0; 3],
            debonded: None,
            region: None,
            friction,
        };
        let penalty = Law::Penalty { eps_n: 10.0 };
        let plain = def(Passes::OnePass, penalty, Enforcement::Penalty, None);
        let surface = Partner::Surface(1);
        assert!(super::segmented(&plain, 2, &surface));
        assert!(!super::segmented(&plain, 3, &surface), "3D");
        let cohesive = Law::Cohesive {
            t0: 1.0,
            g0: 0.1,
            eps_n: 10.0,
            quadratic: false,
        };
        let friction = Friction {
            mu: 0.3,
            eps_t: 10.0,
            stages: Vec::new(),
        };
        for (what, d) in [
            (
                "two half-passes",
                def(Passes::TwoHalfPass, penalty, Enforcement::Penalty, None),
            ),
            (
                "cohesive",
                def(Passes::OnePass, cohesive, Enforcement::Penalty, None),
            ),
            (
                "van der Waals",
                def(
                    Passes::OnePass,
                    Law::VanDerWaals { a_h: 1.0, r0: 0.1 },
                    Enforcement::Penalty,
                    None,
                ),
            ),
            (
                "augmented",
                def(
                    Passes::OnePass,
                    penalty,
                    Enforcement::Augmented(Augmented { tol: 1e-6, max: 5 }),
                    None,
                ),
            ),
            (
                "friction",
                def(
                    Passes::OnePass,
                    penalty,
                    Enforcement::Penalty,
                    Some(friction.clone()),
                ),
            ),
        ] {
            assert!(!super::segmented(&d, 2, &surface), "{what}");
        }
    }

    #[test]
    fn triangle_rules_integrate_their_degree_exactly() {
        // int over the triangle (0,0), (1,0), (0,1) of s^a t^b = a! b! / (a + b + 2)!
        let fact = |n: u32| (1..=n).map(f64::from).product::<f64>();
        for (n_g, degree) in [(2, 2), (3, 4), (4, 6)] {
            let rule = triangle_rule(n_g);
            for a in 0..=degree {
                for b in 0..=degree - a {
                    let exact = fact(a) * fact(b) / fact(a + b + 2);
                    let got: f64 = rule
                        .iter()
                        .map(|&(s, t, w)| 0.5 * w * s.powi(a as i32) * t.powi(b as i32))
                        .sum();
                    assert!(
                        (got - exact).abs() < 1e-14,
                        "n_g {n_g}: s^{a} t^{b}: {got} against {exact}"
                    );
                }
            }
        }
    }

    #[test]
    fn a_pieces_cells_integrate_what_its_triangles_do_with_fewer_points() {
        // a convex pentagon, fanned from its first corner into three triangles: one quadrilateral
        // and one triangle
        let p = [
            [-0.9, -0.8],
            [0.7, -1.0],
            [1.0, 0.2],
            [0.3, 0.9],
            [-0.8, 0.6],
        ];
        let fan: Vec<[[f64; 2]; 3]> = (1..p.len() - 1).map(|j| [p[0], p[j], p[j + 1]]).collect();
        let cells = cells_of(&fan);
        assert_eq!(
            cells.iter().map(|c| c.len()).collect::<Vec<_>>(),
            vec![4, 3]
        );
        for (n_g, degree) in [(2, 2), (3, 4)] {
            let (zeta, wz) = crate::fem::quadrature::gauss_legendre(n_g).unwrap();
            let seg = Segments {
                zeta,
                wz,
                slots: 8,
                linear: false,
                keep: super::KEEP,
                placed: Vec::new(),
                tri: triangle_rule(n_g),
                layouts: Vec::new(),
                tensor: Vec::new(),
                moves: Vec::new(),
            };
            let (mut by_cells, mut by_tris) = (Vec::new(), Vec::new());
            for c in &cells {
                cell_points(c, &seg, &mut by_cells);
            }
            for t in &fan {
                cell_points(t, &seg, &mut by_tris);
            }
            assert!(
                by_cells.len() < by_tris.len(),
                "n_g {n_g}: {} points",
                by_cells.len()
            );
            let area: f64 = fan.iter().map(|t| signed_area(t)).sum();
            assert!((area - signed_area(&p)).abs() < 1e-14);
            for a in 0..=degree {
                for b in 0..=degree - a {
                    let f = |pts: &[([f64; 2], f64)]| -> f64 {
                        pts.iter()
                            .map(|(x, w)| w * x[0].powi(a) * x[1].powi(b))
                            .sum()
                    };
                    let (got, exact) = (f(&by_cells), f(&by_tris));
                    assert!(
                        (got - exact).abs() < 1e-14,
                        "n_g {n_g}: x^{a} y^{b}: {got} against {exact}"
                    );
                }
            }
        }
    }

    #[test]
    fn clipping_a_diamond_to_the_square_cuts_off_its_corners() {
        let r = 2f64.sqrt();
        let diamond = [[r, 0.0], [0.0, r], [-r, 0.0], [0.0, -r]];
        let square = [[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]];
        let clip = clip_convex(&diamond, &square);
        // an octagon: the square less four corner triangles with legs 2 - sqrt 2
        assert_eq!(clip.len(), 8);
        let expected = 4.0 - 2.0 * (2.0 - r).powi(2);
        assert!((signed_area(&clip) - expected).abs() < 1e-14);
        // a polygon apart from the square leaves nothing
        let apart = [[2.0, 2.0], [3.0, 2.0], [3.0, 3.0], [2.0, 3.0]];
        assert!(clip_convex(&apart, &square).len() < 3);
    }

    /// A hemispherical shell on a box: its outer surface against the box's top, whose finer
    /// elements cut the shell's.
    const SHELL_ON_BOX: &str = r#"
[case]
name = "near"
dim = 3
[meshes.lower]
generator = "box"
origin = [-1.0, -1.0, -1.0]
size = [2.0, 2.0, 1.0]
divisions = [5, 5, 1]
[meshes.shell]
generator = "hemisphere_nurbs"
center = [0.0, 0.0, 1.0]
outer_radius = 1.0
thickness = 0.3333333333333333
n_surface = 4
n_thickness = 1
[bodies.lower]
mesh = "lower"
element = "Q1N2"
enriched_surface = "zmax"
[bodies.lower.material]
model = "neo_hookean"
E = 1.0
nu = 0.3
[bodies.shell]
mesh = "shell"
element = "Q1N2"
enriched_surface = "outer"
[bodies.shell.material]
model = "neo_hookean"
E = 5.0
nu = 0.3
[[contact]]
surfaces = ["shell.outer", "lower.zmax"]
law = "penalty"
eps_n = 1.0
[[stages]]
name = "s"
steps = 1
"#;

    #[test]
    fn an_element_whose_cells_need_more_points_than_it_had_is_grown_and_integrates_exactly() {
        let mut h = crate::contact::tests::Harness::new(SHELL_ON_BOX);
        let n = h.n();
        h.eval(&vec![0.0; n], false);
        let sys = &h.sys;
        let (mut grown, mut checked) = (0, 0);
        for ps in sys.pairs.iter().flat_map(|p| &p.passes) {
            let Some(seg) = ps.segments.as_ref().filter(|s| s.three_d()) else {
                continue;
            };
            let per = seg.per_element();
            // the ranges tile the points in element order, each within its room
            let mut next = 0;
            for oe in ps.elems.iter().chain(&ps.halo) {
                assert_eq!(oe.first, next, "element {}", oe.e);
                assert!(oe.n <= oe.slots && oe.slots >= per, "element {}", oe.e);
                next += oe.slots;
            }
            assert_eq!(next, ps.points.len());
            for oe in ps.elems.iter().chain(&ps.halo) {
                grown += (oe.n > per) as usize;
                // the placed points integrate the element's square [-1, 1]^2: its area and
                // x^a y^b (degree 4: every cell's rule is exact to it for Q1N2) exactly
                let pts = &ps.points[oe.first..oe.first + oe.n];
                for (a, b) in [(0, 0), (2, 0), (0, 2), (2, 2), (4, 0), (1, 1), (3, 1)] {
                    let moment = |k: i32| {
                        if k % 2 == 1 {
                            0.0
                        } else {
                            2.0 / f64::from(k + 1)
                        }
                    };
                    let exact = moment(a) * moment(b);
                    let got: f64 = pts
                        .iter()
                        .map(|q| q.w * q.xi[0].powi(a) * q.xi[1].powi(b))
                        .sum();
                    assert!(
                        (got - exact).abs() < 1e-12,
                        "element {} ({} points): x^{a} y^{b} {got} against {exact}",
                        oe.e,
                        oe.n
                    );
                }
                // the rest of its room is unused
                for q in &ps.points[oe.first + oe.n..oe.first + oe.slots] {
                    assert_eq!(q.w, 0.0, "element {}", oe.e);
                }
                checked += 1;
            }
        }
        assert!(checked > 10, "{checked} elements checked");
        assert!(grown > 0, "no element placed more than its set-up points");
        // a fresh system given the checkpoint rows gets the grown elements' room back
        let rows = h.sys.export_points();
        let mut fresh = crate::contact::tests::Harness::new(SHELL_ON_BOX);
        fresh.sys.import_points(&rows).unwrap();
        let slots = |sys: &crate::contact::ContactSystem| -> Vec<usize> {
            sys.pairs
                .iter()
                .flat_map(|p| &p.passes)
                .flat_map(|ps| ps.elems.iter().map(|o| o.slots))
                .collect()
        };
        assert_eq!(slots(&fresh.sys), slots(&h.sys));
    }

    #[test]
    fn the_grid_finds_the_master_elements_near_a_slave_element_that_testing_every_one_finds() {
        use crate::contact::pair::Partner;
        let mut h = crate::contact::tests::Harness::new(SHELL_ON_BOX);
        let n = h.n();
        h.eval(&vec![0.0; n], false);
        let sys = &mut h.sys;
        let (mut compared, mut proper) = (0, 0);
        let mut sizes = std::collections::BTreeSet::new();
        for pi in 0..sys.pairs.len() {
            for si in 0..sys.pairs[pi].passes.len() {
                let (k, Partner::Surface(l)) = (
                    sys.pairs[pi].passes[si].k,
                    sys.pairs[pi].passes[si].partner.clone(),
                ) else {
                    continue;
                };
                sys.ensure_grid(l, sys.pairs[pi].def.search_distance);
                assert!(sys.boxed_in_grid(l));
                let n_l = sys.surfaces[l].elements.len();
                for e in 0..sys.surfaces[k].elements.len() {
                    let (lo0, hi0) = points_box(sys.pos[k].of(e), 3);
                    for grow in [-0.3, 0.0, 0.05, 0.3, 1.0, 3.0] {
                        let lo = lo0.map(|v| v - grow);
                        let hi = hi0.map(|v| v + grow);
                        let by_grid = sys.near_masters(l, &lo, &hi, true);
                        let by_test = sys.near_masters_by_test(l, &lo, &hi);
                        assert_eq!(by_grid, by_test, "element {e}, grown by {grow}");
                        compared += 1;
                        proper += (!by_test.is_empty() && by_test.len() < n_l) as usize;
                        // the sets differ between the boxes: a grid query that missed or added
                        // elements would be told apart
                        sizes.insert(by_test.len());
                    }
                }
            }
        }
        assert!(compared > 50, "{compared} boxes compared");
        assert!(proper > 10, "{proper} sets neither empty nor every element");
        assert!(sizes.len() > 3, "set sizes {sizes:?}");
    }

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
