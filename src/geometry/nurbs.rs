//! Rational basis, eq. (12)-(14), and NURBS curves and tensor-product surfaces, eq. (15)
//! of Corbett & Sauer 2014.
#![allow(clippy::needless_range_loop)] // index loops mirror the equations
use crate::geometry::bspline::ders_basis_funs;
use crate::geometry::knots::KnotVector;
use crate::geometry::{GeometryError, MAX_ORDER};

/// Rational basis `R_A = w_A N_A / W` (eq. 13) and its first derivative for the `p+1` functions
/// `A = span-p..=span`. `w`: all weights [n]; `R`, `dR`: [p+1]. Returns `span`.
#[allow(non_snake_case)]
pub fn rational_basis(kv: &KnotVector, w: &[f64], u: f64, R: &mut [f64], dR: &mut [f64]) -> usize {
    let p = kv.degree();
    let span = kv.find_span(u);
    let mut d = [0.0; 2 * (MAX_ORDER + 1)];
    ders_basis_funs(kv, span, u, 1, &mut d);
    let (mut W, mut dW) = (0.0, 0.0); // eq. (12)
    for j in 0..=p {
        let wa = w[span - p + j];
        W += wa * d[j];
        dW += wa * d[p + 1 + j];
    }
    for j in 0..=p {
        let wa = w[span - p + j];
        R[j] = wa * d[j] / W;
        dR[j] = wa * (d[p + 1 + j] * W - d[j] * dW) / (W * W);
    }
    span
}

fn check_net(ctrl: &[f64], weights: &[f64], n: usize, dim: usize) -> Result<(), GeometryError> {
    if weights.len() != n {
        return Err(GeometryError::LengthMismatch {
            what: "weights",
            expected: n,
            found: weights.len(),
        });
    }
    if ctrl.len() != n * dim {
        return Err(GeometryError::LengthMismatch {
            what: "control points",
            expected: n * dim,
            found: ctrl.len(),
        });
    }
    if let Some((index, &value)) = weights
        .iter()
        .enumerate()
        .find(|(_, w)| !(w.is_finite() && **w > 0.0))
    {
        return Err(GeometryError::BadWeight { index, value });
    }
    if let Some((index, &value)) = ctrl.iter().enumerate().find(|(_, x)| !x.is_finite()) {
        return Err(GeometryError::NonFiniteControlPoint { index, value });
    }
    Ok(())
}

/// A NURBS curve of order `p = knots.degree()` in 2D or 3D.
#[derive(Debug, Clone, PartialEq)]
pub struct NurbsCurve {
    pub knots: KnotVector,
    /// spatial dimension, 2 or 3
    pub dim: usize,
    /// [n][dim]
    pub ctrl: Vec<f64>,
    /// [n]
    pub weights: Vec<f64>,
}

impl NurbsCurve {
    /// Validates sizes, weights (positive) and coordinates (finite).
    pub fn new(
        knots: KnotVector,
        dim: usize,
        ctrl: Vec<f64>,
        weights: Vec<f64>,
    ) -> Result<Self, GeometryError> {
        if dim != 2 && dim != 3 {
            return Err(GeometryError::BadDimension { dim });
        }
        check_net(&ctrl, &weights, knots.n_basis(), dim)?;
        Ok(NurbsCurve {
            knots,
            dim,
            ctrl,
            weights,
        })
    }

    /// Order p.
    pub fn degree(&self) -> usize {
        self.knots.degree()
    }
    /// Number of control points.
    pub fn n_ctrl(&self) -> usize {
        self.weights.len()
    }
    /// Control point `a` (unused third coordinate is 0 in 2D).
    pub fn ctrl_point(&self, a: usize) -> [f64; 3] {
        let mut x = [0.0; 3];
        x[..self.dim].copy_from_slice(&self.ctrl[a * self.dim..(a + 1) * self.dim]);
        x
    }

    /// Point `S(u)` and tangent `dS/du` (eq. 15); third component 0 in 2D.
    #[allow(non_snake_case)]
    pub fn eval(&self, u: f64) -> ([f64; 3], [f64; 3]) {
        let p = self.degree();
        let (mut R, mut dR) = ([0.0; MAX_ORDER + 1], [0.0; MAX_ORDER + 1]);
        let span = rational_basis(&self.knots, &self.weights, u, &mut R, &mut dR);
        let (mut x, mut dx) = ([0.0; 3], [0.0; 3]);
        for j in 0..=p {
            let a = span - p + j;
            for c in 0..self.dim {
                x[c] += R[j] * self.ctrl[a * self.dim + c];
                dx[c] += dR[j] * self.ctrl[a * self.dim + c];
            }
        }
        (x, dx)
    }

    /// Point `S(u)`.
    pub fn point(&self, u: f64) -> [f64; 3] {
        self.eval(u).0
    }

    /// Homogeneous control points `(w x, w)`: [n][dim+1].
    pub fn homogeneous(&self) -> Vec<f64> {
        let d = self.dim;
        let mut pw = Vec::with_capacity(self.n_ctrl() * (d + 1));
        for (a, &w) in self.weights.iter().enumerate() {
            pw.extend(self.ctrl[a * d..(a + 1) * d].iter().map(|x| w * x));
            pw.push(w);
        }
        pw
    }

    /// Rebuilds a curve from homogeneous control points [n][dim+1].
    pub fn from_homogeneous(
        knots: KnotVector,
        dim: usize,
        pw: &[f64],
    ) -> Result<Self, GeometryError> {
        let n = pw.len() / (dim + 1);
        let mut ctrl = Vec::with_capacity(n * dim);
        let mut weights = Vec::with_capacity(n);
        for a in 0..n {
            let w = pw[a * (dim + 1) + dim];
            weights.push(w);
            ctrl.extend(pw[a * (dim + 1)..a * (dim + 1) + dim].iter().map(|x| x / w));
        }
        NurbsCurve::new(knots, dim, ctrl, weights)
    }
}

/// A tensor-product NURBS surface in 3D. Control net index `a = i + n_u * j` (u fastest).
#[derive(Debug, Clone, PartialEq)]
pub struct NurbsSurface {
    pub knots_u: KnotVector,
    pub knots_v: KnotVector,
    /// [n_v][n_u][3]
    pub ctrl: Vec<f64>,
    /// [n_v][n_u]
    pub weights: Vec<f64>,
}

impl NurbsSurface {
    /// Validates sizes, weights and coordinates.
    pub fn new(
        knots_u: KnotVector,
        knots_v: KnotVector,
        ctrl: Vec<f64>,
        weights: Vec<f64>,
    ) -> Result<Self, GeometryError> {
        check_net(&ctrl, &weights, knots_u.n_basis() * knots_v.n_basis(), 3)?;
        Ok(NurbsSurface {
            knots_u,
            knots_v,
            ctrl,
            weights,
        })
    }

    /// (n_u, n_v)
    pub fn n_ctrl(&self) -> (usize, usize) {
        (self.knots_u.n_basis(), self.knots_v.n_basis())
    }

    /// Point `S(u,v)` and first derivatives `S_u`, `S_v`.
    #[allow(non_snake_case)]
    pub fn eval(&self, u: f64, v: f64) -> ([f64; 3], [f64; 3], [f64; 3]) {
        let (p, q) = (self.knots_u.degree(), self.knots_v.degree());
        let n_u = self.knots_u.n_basis();
        let (su, sv) = (self.knots_u.find_span(u), self.knots_v.find_span(v));
        let mut Nu = [0.0; 2 * (MAX_ORDER + 1)];
        let mut Nv = [0.0; 2 * (MAX_ORDER + 1)];
        ders_basis_funs(&self.knots_u, su, u, 1, &mut Nu);
        ders_basis_funs(&self.knots_v, sv, v, 1, &mut Nv);
        // homogeneous sums: A = sum N w P, W = sum N w, and their u/v derivatives
        let (mut A, mut Au, mut Av) = ([0.0; 3], [0.0; 3], [0.0; 3]);
        let (mut W, mut Wu, mut Wv) = (0.0, 0.0, 0.0);
        for j in 0..=q {
            for i in 0..=p {
                let a = (su - p + i) + n_u * (sv - q + j);
                let w = self.weights[a];
                let (n, nu, nv) = (
                    Nu[i] * Nv[j] * w,
                    Nu[p + 1 + i] * Nv[j] * w,
                    Nu[i] * Nv[q + 1 + j] * w,
                );
                W += n;
                Wu += nu;
                Wv += nv;
                for c in 0..3 {
                    let x = self.ctrl[3 * a + c];
                    A[c] += n * x;
                    Au[c] += nu * x;
                    Av[c] += nv * x;
                }
            }
        }
        let (mut S, mut Su, mut Sv) = ([0.0; 3], [0.0; 3], [0.0; 3]);
        for c in 0..3 {
            S[c] = A[c] / W;
            Su[c] = (Au[c] - Wu * S[c]) / W;
            Sv[c] = (Av[c] - Wv * S[c]) / W;
        }
        (S, Su, Sv)
    }

    /// Point `S(u,v)`.
    pub fn point(&self, u: f64, v: f64) -> [f64; 3] {
        self.eval(u, v).0
    }

    /// Unit normal `S_u x S_v / |S_u x S_v|`, or `None` where the parametrisation degenerates.
    pub fn normal(&self, u: f64, v: f64) -> Option<[f64; 3]> {
        let (_, a, b) = self.eval(u, v);
        let n = [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ];
        let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        let (la, lb) = (
            a.iter().map(|x| x * x).sum::<f64>().sqrt(),
            b.iter().map(|x| x * x).sum::<f64>().sqrt(),
        );
        // collapsed edge (one tangent vanishes relative to the other) or parallel tangents
        if la <= 1e-10 * lb || lb <= 1e-10 * la || len <= 1e-12 * la * lb || len == 0.0 {
            return None;
        }
        Some([n[0] / len, n[1] / len, n[2] / len])
    }
}

#[cfg(test)]
#[allow(non_snake_case)]
mod tests {
    use super::*;

    fn wavy_curve(p: usize) -> NurbsCurve {
        let kv = KnotVector::new(p, {
            let mut k = vec![0.0; p + 1];
            k.extend([0.3, 0.55, 0.55]);
            k.extend(vec![1.0; p + 1]);
            k
        })
        .unwrap();
        let n = kv.n_basis();
        let ctrl: Vec<f64> = (0..n)
            .flat_map(|a| [a as f64, (a as f64 * 1.3).sin()])
            .collect();
        let weights: Vec<f64> = (0..n).map(|a| 1.0 + 0.4 * (a as f64).cos()).collect();
        NurbsCurve::new(kv, 2, ctrl, weights).unwrap()
    }

    #[test]
    #[allow(non_snake_case)]
    fn nurbs_basis_is_nonnegative_partition_of_unity_with_fd_derivatives() {
        for p in 2..=7 {
            let c = wavy_curve(p);
            let (mut R, mut dR) = (vec![0.0; p + 1], vec![0.0; p + 1]);
            let (mut Rp, mut Rm) = (vec![0.0; p + 1], vec![0.0; p + 1]);
            for s in 0..=300 {
                let u = s as f64 / 300.0;
                let span = rational_basis(&c.knots, &c.weights, u, &mut R, &mut dR);
                assert!((R.iter().sum::<f64>() - 1.0).abs() < 1e-14);
                assert!(R.iter().all(|&r| r >= -1e-15));
                assert!(dR.iter().sum::<f64>().abs() < 1e-10);
                let h = 1e-6;
                let U = c.knots.knots();
                if u - h > U[span] && u + h < U[span + 1] {
                    rational_basis(&c.knots, &c.weights, u + h, &mut Rp, &mut dR.clone());
                    rational_basis(&c.knots, &c.weights, u - h, &mut Rm, &mut dR.clone());
                    for j in 0..=p {
                        let fd = (Rp[j] - Rm[j]) / (2.0 * h);
                        assert!(
                            (dR[j] - fd).abs() < 1e-6 * (1.0 + fd.abs()),
                            "p={p} u={u} j={j}"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn curve_and_surface_rejects_bad_weights_and_sizes() {
        let kv = KnotVector::new(1, vec![0., 0., 1., 1.]).unwrap();
        assert!(matches!(
            NurbsCurve::new(kv.clone(), 2, vec![0.; 4], vec![1., -1.]),
            Err(GeometryError::BadWeight { index: 1, .. })
        ));
        assert!(matches!(
            NurbsCurve::new(kv.clone(), 2, vec![0.; 3], vec![1., 1.]),
            Err(GeometryError::LengthMismatch {
                expected: 4,
                found: 3,
                ..
            })
        ));
        assert!(matches!(
            NurbsCurve::new(kv.clone(), 4, vec![0.; 8], vec![1., 1.]),
            Err(GeometryError::BadDimension { dim: 4 })
        ));
        assert!(matches!(
            NurbsSurface::new(kv.clone(), kv, vec![0.; 11], vec![1.; 4]),
            Err(GeometryError::LengthMismatch { expected: 12, .. })
        ));
    }
}
