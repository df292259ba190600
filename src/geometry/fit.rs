//! Smooth spline fits of an exact curve or surface (`enriched_geometry = "smooth"`): a polynomial
//! B-spline of order `p` with single interior knots (C^{p-1} everywhere), fitted in least squares to
//! many points of the exact geometry with its ends interpolated, and the largest geometric distance
//! between fit and exact geometry.
//!
//! Why this fit:
//! - **Least squares, ends interpolated**: interpolating only the `n_el + 1` mesh nodes leaves
//!   `p - 1` free conditions (end derivatives, a choice that pollutes the end elements), while a
//!   least-squares fit on `p + 3` Gauss points per span approximates the L2 projection, whose error
//!   is O(h^{p+1}) on a smooth curve, distributed evenly instead of concentrated at the ends; the
//!   two end points stay exact so the surface keeps its corners on the mesh (and a collapsed edge
//!   of a degenerate patch stays collapsed: the fit reproduces a constant row exactly).
//! - **Unit weights**: with single knots a circle is not exactly representable by any NURBS of the
//!   family, so weights would buy nothing but a non-linear fit; a polynomial B-spline is a linear
//!   least-squares problem.
//! - **Parametrised by arc length** (the caller passes the exact geometry as a function of the fit's
//!   parameter): the exact rational arcs are only C^1 in their own parameter at their joints, so a
//!   C^{p-1} fit in that parameter would lose its order there for p >= 3; in arc length a circle is
//!   analytic. The span boundaries are the mesh nodes' arc-length parameters, so each enriched
//!   element keeps its linear face.
#![allow(clippy::needless_range_loop)] // index loops mirror the equations
use crate::geometry::bspline::basis_funs;
use crate::geometry::knots::KnotVector;
use crate::geometry::nurbs::{NurbsCurve, NurbsSurface};
use crate::geometry::{GeometryError, MAX_ORDER};
use nalgebra::DMatrix;

/// Gauss points per span of the least-squares fit, beyond `p`: `p + 3` points per span.
const EXTRA_POINTS: usize = 3;

fn gauss(n: usize) -> Result<(Vec<f64>, Vec<f64>), GeometryError> {
    crate::fem::quadrature::gauss_legendre(n).map_err(|_| GeometryError::BadParameter {
        name: "n",
        value: n as f64,
        reason: "no Gauss rule",
    })
}

/// Open knot vector of order `p` on `[0, 1]` with single interior knots at `breaks` (the interior
/// span boundaries, strictly increasing in (0, 1)).
pub fn single_knots(p: usize, breaks: &[f64]) -> Result<KnotVector, GeometryError> {
    let mut k = vec![0.0; p + 1];
    k.extend_from_slice(breaks);
    k.extend(std::iter::repeat_n(1.0, p + 1));
    let kv = KnotVector::new(p, k)?;
    if kv.n_elements() != breaks.len() + 1 {
        return Err(GeometryError::BadParameter {
            name: "breaks",
            value: breaks.len() as f64,
            reason: "span boundaries must be distinct and inside (0, 1)",
        });
    }
    Ok(kv)
}

/// Sample parameters of the fit on `kv`: 0, `p + 3` Gauss points per span, 1.
pub fn sample_params(kv: &KnotVector) -> Result<Vec<f64>, GeometryError> {
    let (x, _) = gauss(kv.degree() + EXTRA_POINTS)?;
    let u = kv.unique_with_multiplicity();
    let mut s = vec![kv.first()];
    for w in u.windows(2) {
        let (a, b) = (w[0].0, w[1].0);
        s.extend(x.iter().map(|&xi| 0.5 * (a + b) + 0.5 * (b - a) * xi));
    }
    s.push(kv.last());
    Ok(s)
}

/// The linear map `L` [n_basis][K] from values at the sample parameters `s` [K] (first = start,
/// last = end of the knot vector) to control values: the least-squares fit with both ends
/// interpolated (control values 0 and n-1 are the first and last sample).
pub fn fit_operator(kv: &KnotVector, s: &[f64]) -> Result<DMatrix<f64>, GeometryError> {
    let (n, k, p) = (kv.n_basis(), s.len(), kv.degree());
    if s.len() < n || s[0] != kv.first() || s[k - 1] != kv.last() {
        return Err(GeometryError::BadParameter {
            name: "samples",
            value: s.len() as f64,
            reason: "need at least one sample per control point, from the first to the last knot",
        });
    }
    let mut b = DMatrix::zeros(k, n);
    let mut nb = [0.0; MAX_ORDER + 1];
    for (r, &u) in s.iter().enumerate() {
        let span = kv.find_span(u);
        basis_funs(kv, span, u, &mut nb[..=p]);
        for j in 0..=p {
            b[(r, span - p + j)] = nb[j];
        }
    }
    let mut l = DMatrix::zeros(n, k);
    l[(0, 0)] = 1.0;
    l[(n - 1, k - 1)] = 1.0;
    if n > 2 {
        // interior unknowns: minimise |B_i P_i - (X - b_0 x_0 - b_last x_last)|
        let bi = b.columns(1, n - 2).into_owned();
        let m = bi.transpose() * &bi;
        let chol = m.cholesky().ok_or(GeometryError::SingularCollocation)?;
        // rhs operator: R = I - b_0 e_0^T - b_last e_last^T  [K][K], applied implicitly
        let mut rhs = bi.transpose(); // [n-2][K]
        for i in 0..n - 2 {
            let (c0, c1) = (
                (0..k).map(|r| bi[(r, i)] * b[(r, 0)]).sum::<f64>(),
                (0..k).map(|r| bi[(r, i)] * b[(r, n - 1)]).sum::<f64>(),
            );
            rhs[(i, 0)] -= c0;
            rhs[(i, k - 1)] -= c1;
        }
        let inner = chol.solve(&rhs);
        l.rows_mut(1, n - 2).copy_from(&inner);
    }
    Ok(l)
}

/// Fits a polynomial B-spline of order `p` with single interior knots at `breaks` to the curve
/// `exact(s)` [dim], `s` in [0, 1] (see the module docs).
pub fn fit_curve(
    p: usize,
    breaks: &[f64],
    dim: usize,
    exact: &dyn Fn(f64) -> [f64; 3],
) -> Result<NurbsCurve, GeometryError> {
    let kv = single_knots(p, breaks)?;
    let s = sample_params(&kv)?;
    let l = fit_operator(&kv, &s)?;
    let x: Vec<[f64; 3]> = s.iter().map(|&u| exact(u)).collect();
    let n = kv.n_basis();
    let mut ctrl = vec![0.0; n * dim];
    for a in 0..n {
        for (r, xr) in x.iter().enumerate() {
            for c in 0..dim {
                ctrl[a * dim + c] += l[(a, r)] * xr[c];
            }
        }
    }
    NurbsCurve::new(kv, dim, ctrl, vec![1.0; n])
}

/// Tensor-product fit of order `p` in both directions with single interior knots at `breaks_u`,
/// `breaks_v` to the surface `exact(map_u(s), map_v(t))`, (s, t) in [0, 1]^2 (the maps turn the
/// fit's parameters into the exact surface's, e.g. by arc length): the 1D fit applied along both
/// directions (`P = L_u X L_v^T`), so every boundary row is the 1D fit of its boundary curve and a
/// boundary curve collapsed to a point stays that point.
pub fn fit_surface(
    p: usize,
    breaks_u: &[f64],
    breaks_v: &[f64],
    map_u: &dyn Fn(f64) -> f64,
    map_v: &dyn Fn(f64) -> f64,
    exact: &dyn Fn(f64, f64) -> [f64; 3],
) -> Result<NurbsSurface, GeometryError> {
    let (ku, kv) = (single_knots(p, breaks_u)?, single_knots(p, breaks_v)?);
    let (su, sv) = (sample_params(&ku)?, sample_params(&kv)?);
    let (lu, lv) = (fit_operator(&ku, &su)?, fit_operator(&kv, &sv)?);
    let (nu, nv) = (ku.n_basis(), kv.n_basis());
    let (mu, mv): (Vec<f64>, Vec<f64>) = (
        su.iter().map(|&s| map_u(s)).collect(),
        sv.iter().map(|&t| map_v(t)).collect(),
    );
    let x: Vec<[f64; 3]> = (0..sv.len())
        .flat_map(|j| {
            let v = mv[j];
            mu.iter().map(move |&u| (u, v))
        })
        .map(|(u, v)| exact(u, v))
        .collect();
    let mut ctrl = vec![0.0; 3 * nu * nv];
    for c in 0..3 {
        let x = DMatrix::from_fn(su.len(), sv.len(), |i, j| x[i + su.len() * j][c]);
        let pc = &lu * x * lv.transpose(); // [nu][nv]
        for j in 0..nv {
            for i in 0..nu {
                ctrl[3 * (i + nu * j) + c] = pc[(i, j)];
            }
        }
    }
    NurbsSurface::new(ku, kv, ctrl, vec![1.0; nu * nv])
}

/// The C^2 cubic B-spline through the points `q` [n+1][dim] at the increasing parameters `t`
/// [n+1] (from 0 to 1), with single interior knots at `t` and Bessel end conditions: the end
/// tangents are those of the parabola through the first (last) three points. A smooth reference
/// curve for a curved face set whose exact geometry is unknown (e.g. a Gmsh boundary).
#[allow(non_snake_case)]
pub fn interpolate_cubic(
    q: &[[f64; 3]],
    t: &[f64],
    dim: usize,
) -> Result<NurbsCurve, GeometryError> {
    let n = q.len() - 1;
    if n < 2 || t.len() != n + 1 {
        return Err(GeometryError::BadParameter {
            name: "points",
            value: q.len() as f64,
            reason: "need at least 3 points, one parameter each",
        });
    }
    let kv = single_knots(3, &t[1..n])?;
    let m = kv.n_basis(); // n + 3
    let mut a = DMatrix::zeros(m, m);
    let mut d = [0.0; 2 * (MAX_ORDER + 1)];
    for (i, &u) in t.iter().enumerate() {
        let span = kv.find_span(u);
        crate::geometry::bspline::ders_basis_funs(&kv, span, u, 1, &mut d);
        for j in 0..4 {
            a[(i, span - 3 + j)] = d[j];
        }
        // derivative rows for the two ends
        if i == 0 || i == n {
            let row = if i == 0 { n + 1 } else { n + 2 };
            for j in 0..4 {
                a[(row, span - 3 + j)] = d[4 + j];
            }
        }
    }
    // derivative of the parabola through three points at the first of them (dt to the others)
    let parabola = |x0: [f64; 3], x1: [f64; 3], x2: [f64; 3], h1: f64, h2: f64| -> [f64; 3] {
        let mut out = [0.0; 3];
        for c in 0..3 {
            let (d1, d2) = ((x1[c] - x0[c]) / h1, (x2[c] - x0[c]) / h2);
            // p(s) = x0 + b s + c s^2 through (h1, x1), (h2, x2): b = (d1 h2 - d2 h1) / (h2 - h1)
            out[c] = (d1 * h2 - d2 * h1) / (h2 - h1);
        }
        out
    };
    let d0 = parabola(q[0], q[1], q[2], t[1] - t[0], t[2] - t[0]);
    let dn = parabola(q[n], q[n - 1], q[n - 2], t[n - 1] - t[n], t[n - 2] - t[n]);
    let lu = a.lu();
    let mut ctrl = vec![0.0; m * dim];
    for c in 0..dim {
        let mut rhs = nalgebra::DVector::zeros(m);
        for i in 0..=n {
            rhs[i] = q[i][c];
        }
        rhs[n + 1] = d0[c];
        rhs[n + 2] = dn[c];
        let x = lu.solve(&rhs).ok_or(GeometryError::SingularCollocation)?;
        for k in 0..m {
            ctrl[k * dim + c] = x[k];
        }
    }
    NurbsCurve::new(kv, dim, ctrl, vec![1.0; m])
}

/// Arc length along a parametrised curve with speed `|dC/du|` on `[0, 1]`, smooth between the
/// `breaks` (e.g. the exact curve's C^0 knots): cumulative length by 20-point Gauss rules on four
/// sub-intervals per piece (round-off for the rational arcs), and its inverse by bisection.
pub struct ArcLength<'a> {
    speed: &'a dyn Fn(f64) -> f64,
    /// Sub-interval ends [m + 1], from 0 to 1.
    ends: Vec<f64>,
    /// Length up to each end [m + 1].
    cum: Vec<f64>,
    x: Vec<f64>,
    w: Vec<f64>,
}

impl<'a> ArcLength<'a> {
    /// Tabulates the length; `breaks` are interior points in (0, 1) where the speed may be
    /// non-smooth.
    pub fn new(speed: &'a dyn Fn(f64) -> f64, breaks: &[f64]) -> Result<Self, GeometryError> {
        let (x, w) = gauss(20)?;
        let mut pieces = vec![0.0];
        pieces.extend(breaks.iter().copied().filter(|&b| b > 0.0 && b < 1.0));
        pieces.push(1.0);
        let mut ends = vec![0.0];
        for q in pieces.windows(2) {
            for k in 1..=4 {
                ends.push(q[0] + (q[1] - q[0]) * k as f64 / 4.0);
            }
        }
        let mut a = ArcLength {
            speed,
            ends,
            cum: vec![0.0],
            x,
            w,
        };
        for i in 1..a.ends.len() {
            let l = a.cum[i - 1] + a.integral(a.ends[i - 1], a.ends[i]);
            a.cum.push(l);
        }
        if !(a.total() > 0.0 && a.total().is_finite()) {
            return Err(GeometryError::BadParameter {
                name: "arc length",
                value: a.total(),
                reason: "the curve must have a positive finite length",
            });
        }
        Ok(a)
    }

    fn integral(&self, a: f64, b: f64) -> f64 {
        let h = 0.5 * (b - a);
        self.x
            .iter()
            .zip(&self.w)
            .map(|(&xi, &wi)| wi * (self.speed)(0.5 * (a + b) + h * xi))
            .sum::<f64>()
            * h
    }

    /// Total length.
    pub fn total(&self) -> f64 {
        self.cum[self.cum.len() - 1]
    }

    /// Length from 0 to `u`.
    pub fn length_to(&self, u: f64) -> f64 {
        let u = u.clamp(0.0, 1.0);
        let i = self
            .ends
            .partition_point(|&e| e <= u)
            .clamp(1, self.ends.len() - 1)
            - 1;
        self.cum[i] + self.integral(self.ends[i], u)
    }

    /// Parameter `u` whose length from 0 is the fraction `f` of the total.
    pub fn param_at(&self, f: f64) -> f64 {
        let target = f.clamp(0.0, 1.0) * self.total();
        let (mut a, mut b) = (0.0, 1.0);
        while b - a > 4.0 * f64::EPSILON {
            let m = 0.5 * (a + b);
            if self.length_to(m) < target {
                a = m;
            } else {
                b = m;
            }
        }
        0.5 * (a + b)
    }
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Distance from `x` to the curve `c`, by Gauss-Newton from the parameter `u0` (a nearby foot
/// point: the fit and the exact curve are close), clamped to the curve's domain.
pub fn distance_to_curve(c: &NurbsCurve, x: [f64; 3], u0: f64) -> f64 {
    let (lo, hi) = (c.knots.first(), c.knots.last());
    let mut u = u0.clamp(lo, hi);
    for _ in 0..50 {
        let (y, d) = c.eval(u);
        let du = dot(sub(x, y), d) / dot(d, d);
        let un = (u + du).clamp(lo, hi);
        let step = (un - u).abs();
        u = un;
        if step <= 1e-15 {
            break;
        }
    }
    let r = sub(x, c.point(u));
    dot(r, r).sqrt()
}

/// Distance from `x` to the surface `s`, by Gauss-Newton from `(u0, v0)` (regularised where a
/// derivative vanishes, e.g. on a collapsed edge), clamped to the domain.
pub fn distance_to_surface(s: &NurbsSurface, x: [f64; 3], u0: f64, v0: f64) -> f64 {
    let (ul, uh) = (s.knots_u.first(), s.knots_u.last());
    let (vl, vh) = (s.knots_v.first(), s.knots_v.last());
    let (mut u, mut v) = (u0.clamp(ul, uh), v0.clamp(vl, vh));
    for _ in 0..100 {
        let (y, su, sv) = s.eval(u, v);
        let r = sub(x, y);
        let (a, b, d) = (dot(su, su), dot(su, sv), dot(sv, sv));
        let eps = 1e-14 * (a + d);
        let (a, d) = (a + eps, d + eps);
        let (f, g) = (dot(su, r), dot(sv, r));
        let det = a * d - b * b;
        if det.is_nan() || det <= 0.0 {
            break;
        }
        let (du, dv) = ((d * f - b * g) / det, (a * g - b * f) / det);
        let (un, vn) = ((u + du).clamp(ul, uh), (v + dv).clamp(vl, vh));
        let step = (un - u).abs().max((vn - v).abs());
        (u, v) = (un, vn);
        if step <= 1e-15 {
            break;
        }
    }
    let r = sub(x, s.point(u, v));
    dot(r, r).sqrt()
}

#[cfg(test)]
#[allow(non_snake_case)]
mod tests {
    use super::*;
    use crate::geometry::conics::lower_half_circle;

    #[test]
    fn fit_reproduces_splines_of_its_space_and_interpolates_the_ends() {
        // a cubic polynomial curve lies in every space of order >= 3: the fit returns it
        for p in 3..=5 {
            let breaks = [0.2, 0.45, 0.5, 0.8];
            let f = |s: f64| [1.0 + s - 2.0 * s * s * s, 0.3 * s * s - s, 0.0];
            let c = fit_curve(p, &breaks, 2, &f).unwrap();
            for k in 0..=50 {
                let s = k as f64 / 50.0;
                let (x, y) = (c.point(s), f(s));
                assert!(dist(x, y) < 1e-12, "p={p} s={s}: {x:?} vs {y:?}");
            }
            // a non-polynomial curve: ends exact, interior approximate
            let g = |s: f64| [s.sin(), (3.0 * s).cos(), 0.0];
            let c = fit_curve(p, &breaks, 2, &g).unwrap();
            assert!(dist(c.point(0.0), g(0.0)) < 1e-15);
            assert!(dist(c.point(1.0), g(1.0)) < 1e-15);
            assert!(dist(c.point(0.3), g(0.3)) > 0.0);
        }
    }

    fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
        let r = sub(a, b);
        dot(r, r).sqrt()
    }

    #[test]
    fn arc_length_of_a_rational_half_circle_is_its_angle() {
        let c = lower_half_circle([0.3, -0.2], 2.0).unwrap();
        let speed = |u: f64| {
            let (_, d) = c.eval(u);
            dot(d, d).sqrt()
        };
        let a = ArcLength::new(&speed, &[0.5]).unwrap();
        assert!((a.total() - 2.0 * std::f64::consts::PI).abs() < 1e-13);
        // the rational quarter arcs are symmetric: half the length at the joint
        assert!((a.param_at(0.5) - 0.5).abs() < 1e-13);
        for f in [0.1, 0.37, 0.9] {
            let u = a.param_at(f);
            assert!((a.length_to(u) / a.total() - f).abs() < 1e-13, "f={f}");
        }
    }

    #[test]
    fn cubic_interpolant_passes_through_its_points_and_reproduces_a_cubic() {
        // points of a cubic polynomial curve at uneven parameters: Bessel ends are exact for a
        // parabola, the interpolant of a cubic is then close; for a parabola it is exact
        let t = [0.0, 0.1, 0.35, 0.5, 0.8, 1.0];
        let f = |s: f64| [1.0 + 2.0 * s - s * s, 0.5 * s * s - s, 0.0];
        let q: Vec<[f64; 3]> = t.iter().map(|&s| f(s)).collect();
        let c = interpolate_cubic(&q, &t, 2).unwrap();
        for k in 0..=40 {
            let s = k as f64 / 40.0;
            assert!(dist(c.point(s), f(s)) < 1e-12, "s={s}");
        }
        let g = |s: f64| [(2.0 * s).cos(), (2.0 * s).sin(), 0.0];
        let q: Vec<[f64; 3]> = t.iter().map(|&s| g(s)).collect();
        let c = interpolate_cubic(&q, &t, 2).unwrap();
        for (&s, x) in t.iter().zip(&q) {
            assert!(dist(c.point(s), *x) < 1e-13, "through point {s}");
        }
        // measured: largest error 4.6e-3 for steps of up to 0.6 rad on the unit circle
        let worst = (0..=100)
            .map(|k| dist(c.point(k as f64 / 100.0), g(k as f64 / 100.0)))
            .fold(0.0, f64::max);
        assert!(worst < 6e-3 && worst > 1e-4, "{worst:e}");
        assert_eq!(c.knots.min_interior_continuity(), 2);
    }

    #[test]
    fn distance_to_a_circle_is_radial() {
        let c = lower_half_circle([0.0, 0.0], 1.0).unwrap();
        for (x, d) in [
            ([0.0, -1.3, 0.0], 0.3),
            ([0.5, -0.5, 0.0], 1.0 - 0.5f64.sqrt()),
        ] {
            let got = distance_to_curve(&c, x, 0.3);
            assert!((got - d).abs() < 1e-12, "{got} vs {d}");
        }
    }
}
