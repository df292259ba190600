//! Segment-based quadrature of the one-pass weighted gap in 2D.
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
#![allow(non_snake_case)]

use super::ContactSystem;
use crate::contact::half_pass::QPoint;
use crate::contact::pair::{PairDef, Partner};
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
    /// Per element (own, then halo): the breakpoints its points are placed on (`None`: not yet
    /// placed).
    placed: Vec<Option<Vec<f64>>>,
}

impl Segments {
    /// Points per element.
    pub(crate) fn per_element(&self) -> usize {
        self.slots * self.zeta.len()
    }
}

/// Whether a pair's pass is integrated over segments: one-pass, a weighted gap, frictionless, 2D,
/// against another surface.
pub(crate) fn segmented(def: &PairDef, dim: usize, partner: &Partner) -> bool {
    dim == 2
        && def.formulation.one_pass()
        && def.friction.is_none()
        && def.formulation.pressure.is_nodal()
        && matches!(partner, Partner::Surface(_))
}

impl ContactSystem {
    /// The segment rule of surface `k` integrated against surface `l` with `n_g` Gauss points per
    /// segment: enough slots for the longest slave element over the shortest master element.
    pub(super) fn segment_rule(&self, k: usize, l: usize, n_g: usize, linear: bool) -> Segments {
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
        Segments {
            zeta,
            wz,
            slots,
            linear,
            placed: Vec::new(),
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
                for i in 0..n_all {
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
                            && p.iter().zip(&cuts).all(|(a, b)| (a - b).abs() <= KEEP)
                    });
                    if !kept {
                        self.place_points(pi, si, i, e, &cuts, &seg, region.as_ref());
                        seg.placed[i] = Some(cuts);
                    }
                }
                self.pairs[pi].passes[si].segments = Some(seg);
            }
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
        let dim = self.dim;
        let m = dim - 1;
        let k = self.pairs[pi].passes[si].k;
        let el = &self.surfaces[k].elements[e];
        let nk = el.basis.n_nodes();
        let Xe: Vec<f64> = self.slots[k][e]
            .iter()
            .flat_map(|&t| self.X[t as usize * dim..(t as usize + 1) * dim].to_vec())
            .collect();
        let mut ends = Vec::with_capacity(cuts.len() + 2);
        ends.push(-1.0);
        ends.extend_from_slice(cuts);
        ends.push(1.0);
        let n_g = seg.zeta.len();
        let per = seg.per_element();
        let (mut N, mut dN, mut ddN) = (
            [0.0; MAX_FACE_NODES],
            [0.0; 2 * MAX_FACE_NODES],
            [0.0; 4 * MAX_FACE_NODES],
        );
        let mut bN = vec![0.0; per * nk];
        let mut bdN = vec![0.0; per * nk * m];
        let mut phi = Vec::with_capacity(per * nk);
        let mut pts: Vec<(f64, f64)> = Vec::with_capacity(per);
        for s in ends.windows(2) {
            let (a, b) = (s[0], s[1]);
            for (z, w) in seg.zeta.iter().zip(&seg.wz) {
                pts.push((0.5 * (a + b) + 0.5 * (b - a) * z, 0.5 * (b - a) * w));
            }
        }
        pts.resize(per, (0.0, 0.0));
        let ps = &mut self.pairs[pi].passes[si];
        let n_own = ps.elems.len();
        let first = ps.elems.get(i).unwrap_or_else(|| &ps.halo[i - n_own]).first;
        for (j, &(t, w)) in pts.iter().enumerate() {
            let xi = [t, 0.0];
            el.basis.eval(&xi[..m], &mut N, &mut dN, &mut ddN);
            bN[j * nk..(j + 1) * nk].copy_from_slice(&N[..nk]);
            bdN[j * nk * m..(j + 1) * nk * m].copy_from_slice(&dN[..nk * m]);
            if seg.linear {
                phi.extend([0.5 * (1.0 - t), 0.5 * (1.0 + t)]);
            } else {
                phi.extend_from_slice(&N[..nk]);
            }
            let (xr, a, _) = frame(el, dim, &Xe, &xi);
            let nu = raw_normal(dim, &a);
            let outside = region.is_some_and(|b| !b.contains(&xr[..dim]));
            let qp: &mut QPoint = &mut ps.points[first + j];
            qp.xi = xi;
            qp.w = if outside || j >= (ends.len() - 1) * n_g {
                0.0
            } else {
                w
            };
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
