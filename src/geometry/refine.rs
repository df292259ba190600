//! Refinement of NURBS curves and surfaces (Corbett & Sauer 2014, sections 2.2.1 and 3.3).
//!
//! Everything acts on homogeneous control points `(w x, w)`, so the rational geometry and its
//! parametrisation are unchanged. Knot insertion is Piegl & Tiller A5.4. Order elevation is done by
//! exact collocation: the elevated spline space (each distinct knot repeated once more per step)
//! contains the original spline, so interpolating the homogeneous curve at the Greville abscissae
//! of the elevated knot vector (Schoenberg-Whitney holds there) reproduces it exactly up to round-off.
#![allow(clippy::needless_range_loop)] // index loops mirror the equations
use crate::geometry::bspline::basis_funs;
use crate::geometry::knots::KnotVector;
use crate::geometry::nurbs::{NurbsCurve, NurbsSurface};
use crate::geometry::{GeometryError, MAX_ORDER};
use nalgebra::DMatrix;

fn check_pw(kv: &KnotVector, pw: &[f64], d: usize) -> Result<(), GeometryError> {
    let expected = kv.n_basis() * d;
    if pw.len() != expected {
        return Err(GeometryError::LengthMismatch {
            what: "homogeneous control points",
            expected,
            found: pw.len(),
        });
    }
    Ok(())
}

/// Inserts the sorted knots `X` (P&T A5.4). `pw`: [n][d] homogeneous points. Returns the new knot
/// vector and points. Each value must lie strictly inside the domain and stay at multiplicity <= p.
#[allow(non_snake_case)]
pub fn refine_knot_vector(
    kv: &KnotVector,
    pw: &[f64],
    d: usize,
    X: &[f64],
) -> Result<(KnotVector, Vec<f64>), GeometryError> {
    if X.is_empty() {
        return Ok((kv.clone(), pw.to_vec()));
    }
    check_pw(kv, pw, d)?;
    let p = kv.degree();
    let U = kv.knots();
    for (i, &x) in X.iter().enumerate() {
        if !(x > kv.first() && x < kv.last()) {
            return Err(GeometryError::BadParameter {
                name: "inserted knot",
                value: x,
                reason: "not strictly inside the parameter domain",
            });
        }
        let m = kv.multiplicity(x) + X.iter().filter(|&&y| y == x).count();
        if m > p {
            return Err(GeometryError::InteriorMultiplicity {
                value: x,
                found: m,
                p,
            });
        }
        if i > 0 && x < X[i - 1] {
            return Err(GeometryError::BadParameter {
                name: "inserted knot",
                value: x,
                reason: "inserted knots must be sorted",
            });
        }
    }
    let n = kv.n_basis() - 1;
    let m = n + p + 1;
    let r = X.len() - 1;
    let a = kv.find_span(X[0]);
    let b = kv.find_span(X[r]) + 1;
    let mut Qw = vec![0.0; (n + r + 2) * d];
    let mut Ub = vec![0.0; m + r + 2];
    let cp = |dst: &mut [f64], j: usize, src: &[f64], i: usize| {
        dst[j * d..(j + 1) * d].copy_from_slice(&src[i * d..(i + 1) * d])
    };
    for j in 0..=a - p {
        cp(&mut Qw, j, pw, j);
    }
    for j in b - 1..=n {
        cp(&mut Qw, j + r + 1, pw, j);
    }
    Ub[..=a].copy_from_slice(&U[..=a]);
    for j in b + p..=m {
        Ub[j + r + 1] = U[j];
    }
    let mut i = b + p - 1;
    let mut k = b + p + r;
    for j in (0..=r).rev() {
        while X[j] <= U[i] && i > a {
            cp(&mut Qw, k - p - 1, pw, i - p - 1);
            Ub[k] = U[i];
            k -= 1;
            i -= 1;
        }
        for c in 0..d {
            Qw[(k - p - 1) * d + c] = Qw[(k - p) * d + c];
        }
        for l in 1..=p {
            let ind = k - p + l;
            let alfa = Ub[k + l] - X[j];
            for c in 0..d {
                Qw[(ind - 1) * d + c] = if alfa.abs() == 0.0 {
                    Qw[ind * d + c]
                } else {
                    let al = alfa / (Ub[k + l] - U[i - p + l]);
                    al * Qw[(ind - 1) * d + c] + (1.0 - al) * Qw[ind * d + c]
                };
            }
        }
        Ub[k] = X[j];
        k -= 1;
    }
    Ok((KnotVector::new(p, Ub)?, Qw))
}

/// Elevates the order by `t` (each distinct knot gains `t` repeats). `pw`: [n][d] homogeneous.
#[allow(non_snake_case)]
pub fn elevate_degree(
    kv: &KnotVector,
    pw: &[f64],
    d: usize,
    t: usize,
) -> Result<(KnotVector, Vec<f64>), GeometryError> {
    check_pw(kv, pw, d)?;
    if t == 0 {
        return Ok((kv.clone(), pw.to_vec()));
    }
    let p = kv.degree();
    let q = p + t;
    if q > MAX_ORDER {
        return Err(GeometryError::OrderOutOfRange {
            p: q,
            max: MAX_ORDER,
        });
    }
    let mut knots = Vec::new();
    for (u, m) in kv.unique_with_multiplicity() {
        knots.extend(std::iter::repeat_n(u, m + t));
    }
    let kq = KnotVector::new(q, knots)?;
    let nq = kq.n_basis();
    let Uq = kq.knots();
    let mut A = DMatrix::<f64>::zeros(nq, nq);
    let mut rhs = DMatrix::<f64>::zeros(nq, d);
    let mut Nq = [0.0; MAX_ORDER + 1];
    let mut Np = [0.0; MAX_ORDER + 1];
    for i in 0..nq {
        let g = Uq[i + 1..=i + q].iter().sum::<f64>() / q as f64; // Greville abscissa
        let sq = kq.find_span(g);
        basis_funs(&kq, sq, g, &mut Nq);
        for j in 0..=q {
            A[(i, sq - q + j)] = Nq[j];
        }
        let sp = kv.find_span(g);
        basis_funs(kv, sp, g, &mut Np);
        for j in 0..=p {
            for c in 0..d {
                rhs[(i, c)] += Np[j] * pw[(sp - p + j) * d + c];
            }
        }
    }
    let sol = A
        .lu()
        .solve(&rhs)
        .ok_or(GeometryError::SingularCollocation)?;
    let mut out = vec![0.0; nq * d];
    for i in 0..nq {
        for c in 0..d {
            out[i * d + c] = sol[(i, c)];
        }
    }
    Ok((kq, out))
}

/// Knots that split every existing non-empty span into `n_sub` equal parts (sorted).
pub fn uniform_split_knots(kv: &KnotVector, n_sub: usize) -> Vec<f64> {
    let u = kv.unique_with_multiplicity();
    let mut x = Vec::new();
    for w in u.windows(2) {
        let (a, b) = (w[0].0, w[1].0);
        for k in 1..n_sub {
            x.push(a + (b - a) * k as f64 / n_sub as f64);
        }
    }
    x
}

fn n_sub_for(kv: &KnotVector, n_el: usize) -> Result<usize, GeometryError> {
    let n0 = kv.n_elements();
    if n_el == 0 || !n_el.is_multiple_of(n0) {
        return Err(GeometryError::BadParameter {
            name: "n_el",
            value: n_el as f64,
            reason: "must be a positive multiple of the number of elements of the base geometry",
        });
    }
    Ok(n_el / n0)
}

impl NurbsCurve {
    /// Inserts the sorted knots `X` (h-refinement).
    #[allow(non_snake_case)]
    pub fn insert_knots(&self, X: &[f64]) -> Result<NurbsCurve, GeometryError> {
        let (kv, pw) = refine_knot_vector(&self.knots, &self.homogeneous(), self.dim + 1, X)?;
        NurbsCurve::from_homogeneous(kv, self.dim, &pw)
    }

    /// Elevates the order by `t` (p-refinement).
    pub fn elevate(&self, t: usize) -> Result<NurbsCurve, GeometryError> {
        let (kv, pw) = elevate_degree(&self.knots, &self.homogeneous(), self.dim + 1, t)?;
        NurbsCurve::from_homogeneous(kv, self.dim, &pw)
    }

    /// k-refinement: elevate to order `p`, then split every span so there are `n_el` elements
    /// (`n_el` must be a multiple of the current number of elements).
    pub fn k_refine(&self, p: usize, n_el: usize) -> Result<NurbsCurve, GeometryError> {
        if p < self.degree() {
            return Err(GeometryError::BadParameter {
                name: "p",
                value: p as f64,
                reason: "k-refinement cannot lower the order",
            });
        }
        let n_sub = n_sub_for(&self.knots, n_el)?;
        let e = self.elevate(p - self.degree())?;
        e.insert_knots(&uniform_split_knots(&e.knots, n_sub))
    }

    /// Surface-oriented refinement Q1Np.t of section 3.3: k-refine to `p` with `n_el` elements,
    /// then `t` order elevations (continuity stays C^{p-1}, order p+t).
    pub fn refine_q1np_t(
        &self,
        p: usize,
        t: usize,
        n_el: usize,
    ) -> Result<NurbsCurve, GeometryError> {
        self.k_refine(p, n_el)?.elevate(t)
    }
}

/// Parametric direction of a surface.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Direction {
    U,
    V,
}

impl NurbsSurface {
    /// Applies a 1D homogeneous refinement to every row (U) or column (V) of the control net.
    fn refine_dir<F>(&self, dir: Direction, f: F) -> Result<NurbsSurface, GeometryError>
    where
        F: Fn(&KnotVector, &[f64]) -> Result<(KnotVector, Vec<f64>), GeometryError>,
    {
        let (nu, nv) = self.n_ctrl();
        let hom = |a: usize| {
            [
                self.weights[a] * self.ctrl[3 * a],
                self.weights[a] * self.ctrl[3 * a + 1],
                self.weights[a] * self.ctrl[3 * a + 2],
                self.weights[a],
            ]
        };
        let (n_lines, n_along, kv) = match dir {
            Direction::U => (nv, nu, &self.knots_u),
            Direction::V => (nu, nv, &self.knots_v),
        };
        let idx = |line: usize, k: usize| match dir {
            Direction::U => k + nu * line,
            Direction::V => line + nu * k,
        };
        let mut new_kv = None;
        let mut lines = Vec::with_capacity(n_lines);
        for line in 0..n_lines {
            let pw: Vec<f64> = (0..n_along).flat_map(|k| hom(idx(line, k))).collect();
            let (kv2, pw2) = f(kv, &pw)?;
            new_kv = Some(kv2);
            lines.push(pw2);
        }
        let new_kv = new_kv.ok_or(GeometryError::LengthMismatch {
            what: "control net lines",
            expected: 1,
            found: 0,
        })?;
        let m = new_kv.n_basis();
        let (nu2, nv2) = match dir {
            Direction::U => (m, nv),
            Direction::V => (nu, m),
        };
        let mut ctrl = vec![0.0; 3 * nu2 * nv2];
        let mut weights = vec![0.0; nu2 * nv2];
        for (line, pw) in lines.iter().enumerate() {
            for k in 0..m {
                let a = match dir {
                    Direction::U => k + nu2 * line,
                    Direction::V => line + nu2 * k,
                };
                let w = pw[4 * k + 3];
                weights[a] = w;
                for c in 0..3 {
                    ctrl[3 * a + c] = pw[4 * k + c] / w;
                }
            }
        }
        let (ku, kv2) = match dir {
            Direction::U => (new_kv, self.knots_v.clone()),
            Direction::V => (self.knots_u.clone(), new_kv),
        };
        NurbsSurface::new(ku, kv2, ctrl, weights)
    }

    /// Inserts sorted knots `X` in direction `dir`.
    #[allow(non_snake_case)]
    pub fn insert_knots(&self, dir: Direction, X: &[f64]) -> Result<NurbsSurface, GeometryError> {
        self.refine_dir(dir, |kv, pw| refine_knot_vector(kv, pw, 4, X))
    }

    /// Elevates the order by `t` in direction `dir`.
    pub fn elevate(&self, dir: Direction, t: usize) -> Result<NurbsSurface, GeometryError> {
        self.refine_dir(dir, |kv, pw| elevate_degree(kv, pw, 4, t))
    }

    /// k-refinement to order `p` with `n_el` elements in each direction.
    pub fn k_refine(&self, p: usize, n_el: usize) -> Result<NurbsSurface, GeometryError> {
        let mut s = self.clone();
        for dir in [Direction::U, Direction::V] {
            let kv = match dir {
                Direction::U => &s.knots_u,
                Direction::V => &s.knots_v,
            };
            if p < kv.degree() {
                return Err(GeometryError::BadParameter {
                    name: "p",
                    value: p as f64,
                    reason: "k-refinement cannot lower the order",
                });
            }
            let n_sub = n_sub_for(kv, n_el)?;
            let t = p - kv.degree();
            let e = s.elevate(dir, t)?;
            let x = uniform_split_knots(
                match dir {
                    Direction::U => &e.knots_u,
                    Direction::V => &e.knots_v,
                },
                n_sub,
            );
            s = e.insert_knots(dir, &x)?;
        }
        Ok(s)
    }

    /// Surface-oriented refinement Q1Np.t (section 3.3) in both directions.
    pub fn refine_q1np_t(
        &self,
        p: usize,
        t: usize,
        n_el: usize,
    ) -> Result<NurbsSurface, GeometryError> {
        self.k_refine(p, n_el)?
            .elevate(Direction::U, t)?
            .elevate(Direction::V, t)
    }
}

#[cfg(test)]
#[allow(non_snake_case)]
mod tests {
    use super::*;

    fn wavy_curve(p: usize, dim: usize) -> NurbsCurve {
        let mut k = vec![0.0; p + 1];
        k.extend([0.2, 0.45, 0.8]);
        if p >= 2 {
            k.push(0.45);
            k.sort_by(f64::total_cmp);
        }
        k.extend(vec![1.0; p + 1]);
        let kv = KnotVector::new(p, k).unwrap();
        let n = kv.n_basis();
        let ctrl: Vec<f64> = (0..n)
            .flat_map(|a| {
                [a as f64, (a as f64 * 1.3).sin(), (a as f64 * 0.4).cos()]
                    .into_iter()
                    .take(dim)
            })
            .collect();
        let weights: Vec<f64> = (0..n).map(|a| 1.0 + 0.5 * (a as f64 * 0.9).cos()).collect();
        NurbsCurve::new(kv, dim, ctrl, weights).unwrap()
    }

    fn max_dev(a: &NurbsCurve, b: &NurbsCurve) -> f64 {
        (0..=2000)
            .map(|s| {
                let u = s as f64 / 2000.0;
                let (x, y) = (a.point(u), b.point(u));
                (0..3).map(|c| (x[c] - y[c]).abs()).fold(0.0, f64::max)
            })
            .fold(0.0, f64::max)
    }

    #[test]
    fn knot_insertion_leaves_geometry_unchanged() {
        for p in 1..=4 {
            for dim in [2, 3] {
                let c = wavy_curve(p, dim);
                let x: &[f64] = if p >= 2 {
                    &[0.1, 0.46, 0.5, 0.5, 0.93]
                } else {
                    &[0.1, 0.3, 0.5, 0.93, 0.95]
                };
                let r = c.insert_knots(x).unwrap();
                assert_eq!(r.n_ctrl(), c.n_ctrl() + 5);
                assert!(max_dev(&c, &r) < 1e-12, "p={p}");
            }
        }
    }

    #[test]
    fn knot_insertion_rejects_knot_outside_domain() {
        let c = wavy_curve(2, 2);
        assert!(matches!(
            c.insert_knots(&[1.0]),
            Err(GeometryError::BadParameter { .. })
        ));
        assert!(matches!(
            c.insert_knots(&[0.45]),
            Err(GeometryError::InteriorMultiplicity { found: 3, .. })
        ));
        assert!(matches!(
            c.insert_knots(&[0.6, 0.6, 0.6, 0.6]),
            Err(GeometryError::InteriorMultiplicity { found: 4, .. })
        ));
        assert!(matches!(
            c.insert_knots(&[0.7, 0.6]),
            Err(GeometryError::BadParameter { .. })
        ));
        let kv = c.knots.clone();
        assert!(matches!(
            refine_knot_vector(&kv, &[0.0; 5], 3, &[0.5]),
            Err(GeometryError::LengthMismatch { .. })
        ));
        assert!(matches!(
            elevate_degree(&kv, &[0.0; 5], 3, 1),
            Err(GeometryError::LengthMismatch { .. })
        ));
    }

    #[test]
    fn order_elevation_leaves_geometry_unchanged_and_raises_multiplicity() {
        for p in 1..=4 {
            for t in 1..=3 {
                let c = wavy_curve(p, 2);
                let e = c.elevate(t).unwrap();
                assert_eq!(e.degree(), p + t);
                assert_eq!(e.knots.multiplicity(0.2), 1 + t);
                assert_eq!(e.knots.multiplicity(0.45), c.knots.multiplicity(0.45) + t);
                assert!(max_dev(&c, &e) < 1e-12, "p={p} t={t}: {}", max_dev(&c, &e));
            }
        }
    }

    #[test]
    fn k_and_surface_oriented_refinement_leave_geometry_unchanged() {
        let line = KnotVector::new(2, vec![0., 0., 0., 1., 1., 1.]).unwrap();
        let c =
            NurbsCurve::new(line, 2, vec![0., 0., 1., 2., 3., 0.5], vec![1., 0.6, 1.3]).unwrap();
        for p in 2..=4 {
            for t in 0..=3 {
                let r = c.refine_q1np_t(p, t, 6).unwrap();
                assert_eq!(r.degree(), p + t);
                assert_eq!(r.knots.n_elements(), 6);
                assert_eq!(r.knots.min_interior_continuity(), p - 1);
                assert!(max_dev(&c, &r) < 1e-12, "p={p} t={t}");
            }
        }
        assert!(matches!(
            c.k_refine(1, 4),
            Err(GeometryError::BadParameter { name: "p", .. })
        ));
        assert!(matches!(
            c.k_refine(3, 0),
            Err(GeometryError::BadParameter { name: "n_el", .. })
        ));
    }

    #[test]
    fn surface_refinement_leaves_geometry_unchanged() {
        let ku = KnotVector::new(2, vec![0., 0., 0., 0.5, 1., 1., 1.]).unwrap();
        let kv = KnotVector::new(1, vec![0., 0., 1., 1.]).unwrap();
        let (nu, nv) = (4, 2);
        let mut ctrl = Vec::new();
        let mut w = Vec::new();
        for j in 0..nv {
            for i in 0..nu {
                ctrl.extend([i as f64, j as f64 * 1.5, ((i + 2 * j) as f64).sin()]);
                w.push(1.0 + 0.2 * ((i * j + i) as f64).cos());
            }
        }
        let s = NurbsSurface::new(ku, kv, ctrl, w).unwrap();
        let r = s.refine_q1np_t(2, 1, 4).unwrap();
        assert_eq!((r.knots_u.degree(), r.knots_v.degree()), (3, 3));
        let mut dev: f64 = 0.0;
        for a in 0..=40 {
            for b in 0..=40 {
                let (u, v) = (a as f64 / 40.0, b as f64 / 40.0);
                let (x, y) = (s.point(u, v), r.point(u, v));
                dev = dev.max((0..3).map(|c| (x[c] - y[c]).abs()).fold(0.0, f64::max));
            }
        }
        assert!(dev < 1e-12, "{dev}");
    }
}
