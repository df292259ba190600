//! Bernstein basis on [-1,1], Bezier extraction (Borden et al. 2011, algorithm 1) and the element
//! basis `R_e = W_e C_e B_e / W` of eq. (16) of Corbett & Sauer 2014.
//!
//! Convention: `C_e` is row-major [p+1][p+1] with `N_{first+i}(xi) = sum_k C_e[i][k] B_k(xi)`,
//! where `first = span - p` is the global index of the element's first basis function.
//! Surfaces: local function `a = i + (p+1) j` (xi fastest), `C_e = C_v (x) C_u`.
#![allow(clippy::needless_range_loop)] // index loops mirror the equations
use crate::geometry::knots::KnotVector;
use crate::geometry::MAX_ORDER;

/// Bernstein polynomials of order `p` on [-1,1] and their derivatives. `B`, `dB`: [p+1].
#[allow(non_snake_case)]
pub fn bernstein(p: usize, xi: f64, B: &mut [f64], dB: &mut [f64]) {
    let s = 0.5 * (1.0 + xi);
    let r = 1.0 - s;
    // build order p-1 by the de Casteljau triangle, then the derivative from it
    B[0] = 1.0;
    for j in 1..p {
        let mut saved = 0.0;
        for k in 0..j {
            let tmp = B[k];
            B[k] = saved + r * tmp;
            saved = s * tmp;
        }
        B[j] = saved;
    }
    if p == 0 {
        dB[0] = 0.0;
        return;
    }
    // d/dxi B_k^p = p/2 (B_{k-1}^{p-1} - B_k^{p-1})
    let half_p = 0.5 * p as f64;
    for k in 0..=p {
        let lo = if k >= 1 { B[k - 1] } else { 0.0 };
        let hi = if k < p { B[k] } else { 0.0 };
        dB[k] = half_p * (lo - hi);
    }
    let mut saved = 0.0;
    for k in 0..p {
        let tmp = B[k];
        B[k] = saved + r * tmp;
        saved = s * tmp;
    }
    B[p] = saved;
}

/// Bernstein polynomials of order `p` on [-1,1] with first and second derivatives.
/// `B`, `dB`, `ddB`: [p+1]. The second derivative is the derivative of `dB` of order `p-1`:
/// `d2/dxi2 B_k^p = p/2 (dB_{k-1}^{p-1} - dB_k^{p-1})`.
#[allow(non_snake_case)]
pub fn bernstein2(p: usize, xi: f64, B: &mut [f64], dB: &mut [f64], ddB: &mut [f64]) {
    bernstein(p, xi, B, dB);
    ddB[..=p].fill(0.0);
    if p < 2 {
        return;
    }
    let (mut b, mut db) = ([0.0; MAX_ORDER + 1], [0.0; MAX_ORDER + 1]);
    bernstein(p - 1, xi, &mut b, &mut db);
    let half_p = 0.5 * p as f64;
    for k in 0..=p {
        let lo = if k >= 1 { db[k - 1] } else { 0.0 };
        let hi = if k < p { db[k] } else { 0.0 };
        ddB[k] = half_p * (lo - hi);
    }
}

/// Bezier extraction operators of a 1D knot vector.
#[derive(Debug, Clone, PartialEq)]
pub struct Extraction1d {
    pub p: usize,
    /// [n_el][p+1][p+1], row-major per element
    pub ops: Vec<f64>,
    /// knot span index of each element: [n_el]; its functions are `span-p..=span`
    pub spans: Vec<usize>,
    /// parameter interval `(u_a, u_b)` of each element: [n_el]
    pub intervals: Vec<(f64, f64)>,
}

impl Extraction1d {
    /// Number of elements.
    pub fn n_el(&self) -> usize {
        self.spans.len()
    }
    /// `C_e` of element `e`, [p+1][p+1].
    pub fn op(&self, e: usize) -> &[f64] {
        let m = (self.p + 1) * (self.p + 1);
        &self.ops[e * m..(e + 1) * m]
    }
}

/// Bezier extraction operators of every element (Borden et al. 2011, algorithm 1).
#[allow(non_snake_case)]
pub fn extraction_1d(kv: &KnotVector) -> Extraction1d {
    let p = kv.degree();
    let U = kv.knots();
    let m = U.len();
    let w = p + 1;
    let n_el = kv.n_elements();
    let identity = |c: &mut [f64]| {
        c.iter_mut().for_each(|x| *x = 0.0);
        (0..w).for_each(|i| c[i * w + i] = 1.0);
    };
    let mut ops = vec![0.0; (n_el + 1) * w * w];
    identity(&mut ops[..w * w]);
    let mut alphas = [0.0; MAX_ORDER + 1];
    let (mut a, mut b) = (p, p + 1);
    let mut nb = 0;
    while b < m - 1 {
        identity(&mut ops[(nb + 1) * w * w..(nb + 2) * w * w]);
        let i = b;
        while b < m - 1 && U[b + 1] == U[b] {
            b += 1;
        }
        let mult = b - i + 1;
        if mult < p {
            let numer = U[b] - U[a];
            for j in (mult + 1..=p).rev() {
                alphas[j - mult - 1] = numer / (U[a + j] - U[a]);
            }
            let r = p - mult;
            for j in 1..=r {
                let save = r - j; // 0-based
                let s = mult + j;
                let (cur, next) = ops[nb * w * w..(nb + 2) * w * w].split_at_mut(w * w);
                for k in (s..=p).rev() {
                    let alpha = alphas[k - s];
                    for row in 0..w {
                        cur[row * w + k] =
                            alpha * cur[row * w + k] + (1.0 - alpha) * cur[row * w + k - 1];
                    }
                }
                if b < m - 1 {
                    for l in 0..=j {
                        next[(save + l) * w + save] = cur[(p - j + l) * w + p];
                    }
                }
            }
        }
        nb += 1;
        if b < m - 1 {
            a = b;
            b += 1;
        }
    }
    ops.truncate(n_el * w * w);
    let spans = kv.element_spans();
    let intervals = spans.iter().map(|&s| (U[s], U[s + 1])).collect();
    Extraction1d {
        p,
        ops,
        spans,
        intervals,
    }
}

/// Tensor-product extraction operator `C = C_v (x) C_u`: [(p+1)(q+1)][(p+1)(q+1)], row `i + (p+1) j`,
/// column `r + (p+1) s`, entry `C_u[i][r] C_v[j][s]`.
#[allow(non_snake_case)]
pub fn kron_extraction(p: usize, Cu: &[f64], q: usize, Cv: &[f64]) -> Vec<f64> {
    let (wu, wv) = (p + 1, q + 1);
    let n = wu * wv;
    let mut C = vec![0.0; n * n];
    for j in 0..wv {
        for i in 0..wu {
            for s in 0..wv {
                for r in 0..wu {
                    C[(i + wu * j) * n + (r + wu * s)] = Cu[i * wu + r] * Cv[j * wv + s];
                }
            }
        }
    }
    C
}

/// Element rational basis of eq. (16), `R_e = W_e C_e B / W`, and `dR_e/dxi` on [-1,1].
/// `C`: [p+1][p+1], `w`: [p+1]; `R`, `dR`: [p+1].
#[allow(non_snake_case)]
pub fn element_basis_1d(p: usize, C: &[f64], w: &[f64], xi: f64, R: &mut [f64], dR: &mut [f64]) {
    let w1 = p + 1;
    let (mut B, mut dB) = ([0.0; MAX_ORDER + 1], [0.0; MAX_ORDER + 1]);
    bernstein(p, xi, &mut B, &mut dB);
    let (mut W, mut dW) = (0.0, 0.0);
    for i in 0..w1 {
        let row = &C[i * w1..(i + 1) * w1];
        let n: f64 = row.iter().zip(&B[..w1]).map(|(c, b)| c * b).sum();
        let dn: f64 = row.iter().zip(&dB[..w1]).map(|(c, b)| c * b).sum();
        R[i] = w[i] * n;
        dR[i] = w[i] * dn;
        W += R[i];
        dW += dR[i];
    }
    for i in 0..w1 {
        dR[i] = (dR[i] - R[i] * dW / W) / W;
        R[i] /= W;
    }
}

/// Element rational basis of a surface element (tensor product of eq. 16) and its derivatives.
/// `C`: [(p+1)(q+1)][(p+1)(q+1)] (see [`kron_extraction`]), `w`: [(p+1)(q+1)];
/// `R`: [(p+1)(q+1)], `dR`: [(p+1)(q+1)][2] (d/dxi, d/deta).
#[allow(non_snake_case)]
#[allow(clippy::too_many_arguments)]
pub fn element_basis_2d(
    p: usize,
    q: usize,
    C: &[f64],
    w: &[f64],
    xi: f64,
    eta: f64,
    R: &mut [f64],
    dR: &mut [f64],
) {
    let (wu, wv) = (p + 1, q + 1);
    let n = wu * wv;
    let (mut Bu, mut dBu) = ([0.0; MAX_ORDER + 1], [0.0; MAX_ORDER + 1]);
    let (mut Bv, mut dBv) = ([0.0; MAX_ORDER + 1], [0.0; MAX_ORDER + 1]);
    bernstein(p, xi, &mut Bu, &mut dBu);
    bernstein(q, eta, &mut Bv, &mut dBv);
    let (mut W, mut Wx, mut We) = (0.0, 0.0, 0.0);
    for a in 0..n {
        let row = &C[a * n..(a + 1) * n];
        let (mut b, mut bx, mut be) = (0.0, 0.0, 0.0);
        for s in 0..wv {
            for r in 0..wu {
                let c = row[r + wu * s];
                if c != 0.0 {
                    b += c * Bu[r] * Bv[s];
                    bx += c * dBu[r] * Bv[s];
                    be += c * Bu[r] * dBv[s];
                }
            }
        }
        R[a] = w[a] * b;
        dR[2 * a] = w[a] * bx;
        dR[2 * a + 1] = w[a] * be;
        W += R[a];
        Wx += dR[2 * a];
        We += dR[2 * a + 1];
    }
    for a in 0..n {
        R[a] /= W;
        dR[2 * a] = (dR[2 * a] - R[a] * Wx) / W;
        dR[2 * a + 1] = (dR[2 * a + 1] - R[a] * We) / W;
    }
}

#[cfg(test)]
#[allow(non_snake_case)]
mod tests {
    use super::*;
    use crate::geometry::bspline::ders_basis_funs;

    fn kvs() -> Vec<KnotVector> {
        let mut out = Vec::new();
        for p in 1..=4 {
            for t in 0..=3 {
                let q = p + t;
                let mut k = vec![-1.0; q + 1];
                for (i, u) in [-0.5, 0.1, 0.2, 0.75].iter().enumerate() {
                    k.extend(std::iter::repeat_n(*u, if i % 2 == 1 { t + 1 } else { 1 }));
                }
                k.extend(vec![2.0; q + 1]);
                out.push(KnotVector::new(q, k).unwrap());
            }
        }
        out
    }

    #[test]
    #[allow(non_snake_case)]
    fn bernstein_is_partition_of_unity_with_fd_derivatives() {
        for p in 1..=8 {
            let (mut B, mut dB) = (vec![0.0; p + 1], vec![0.0; p + 1]);
            let (mut Bp, mut Bm, mut tmp) = (vec![0.0; p + 1], vec![0.0; p + 1], vec![0.0; p + 1]);
            for s in 0..=40 {
                let xi = -1.0 + s as f64 / 20.0;
                bernstein(p, xi, &mut B, &mut dB);
                assert!((B.iter().sum::<f64>() - 1.0).abs() < 1e-14);
                assert!(B.iter().all(|&b| b >= 0.0));
                let h = 1e-6;
                bernstein(p, xi + h, &mut Bp, &mut tmp);
                bernstein(p, xi - h, &mut Bm, &mut tmp);
                for k in 0..=p {
                    assert!(
                        (dB[k] - (Bp[k] - Bm[k]) / (2.0 * h)).abs() < 1e-7,
                        "p={p} k={k}"
                    );
                }
            }
        }
    }

    #[test]
    #[allow(non_snake_case)]
    fn bernstein2_matches_bernstein_with_fd_second_derivatives() {
        for p in 0..=8 {
            let n = p + 1;
            let (mut B, mut dB, mut ddB) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
            let (mut B1, mut dB1) = (vec![0.0; n], vec![0.0; n]);
            let (mut dBp, mut dBm, mut tmp) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
            for s in 0..=40 {
                let xi = -1.0 + s as f64 / 20.0;
                bernstein2(p, xi, &mut B, &mut dB, &mut ddB);
                bernstein(p, xi, &mut B1, &mut dB1);
                assert_eq!((&B, &dB), (&B1, &dB1), "p={p}");
                assert!(ddB.iter().sum::<f64>().abs() < 1e-12);
                let h = 1e-5;
                bernstein(p, xi + h, &mut tmp, &mut dBp);
                bernstein(p, xi - h, &mut tmp, &mut dBm);
                for k in 0..=p {
                    let fd = (dBp[k] - dBm[k]) / (2.0 * h);
                    assert!((ddB[k] - fd).abs() < 1e-7 * (1.0 + fd.abs()), "p={p} k={k}");
                }
            }
        }
    }

    #[test]
    #[allow(non_snake_case)]
    fn bezier_extraction_equals_cox_de_boor() {
        for kv in kvs() {
            let p = kv.degree();
            let ex = extraction_1d(&kv);
            assert_eq!(ex.n_el(), 5);
            let (mut B, mut dB) = (vec![0.0; p + 1], vec![0.0; p + 1]);
            let mut d = vec![0.0; 2 * (p + 1)];
            let mut max_diff: f64 = 0.0;
            for e in 0..ex.n_el() {
                let (ua, ub) = ex.intervals[e];
                let C = ex.op(e);
                for s in 0..=50 {
                    let xi = -1.0 + s as f64 / 25.0;
                    let u = 0.5 * (ua + ub) + 0.5 * xi * (ub - ua);
                    bernstein(p, xi, &mut B, &mut dB);
                    // evaluate in this element's span (also at its right end)
                    ders_basis_funs(&kv, ex.spans[e], u, 1, &mut d);
                    for i in 0..=p {
                        let n: f64 = (0..=p).map(|k| C[i * (p + 1) + k] * B[k]).sum();
                        let dn: f64 = (0..=p).map(|k| C[i * (p + 1) + k] * dB[k]).sum::<f64>()
                            * 2.0
                            / (ub - ua);
                        max_diff = max_diff.max((n - d[i]).abs());
                        max_diff = max_diff.max((dn - d[p + 1 + i]).abs() * (ub - ua) / 2.0);
                    }
                }
            }
            assert!(max_diff < 1e-13, "p={p}: {max_diff}");
        }
    }

    #[test]
    #[allow(non_snake_case)]
    fn element_basis_2d_is_partition_of_unity_with_fd_derivatives() {
        let kv2 = KnotVector::new(2, vec![0., 0., 0., 0.3, 0.6, 1., 1., 1.]).unwrap();
        let kv3 = KnotVector::new(3, vec![0., 0., 0., 0., 0.5, 1., 1., 1., 1.]).unwrap();
        let (e2, e3) = (extraction_1d(&kv2), extraction_1d(&kv3));
        let C = kron_extraction(2, e2.op(1), 3, e3.op(0));
        let w: Vec<f64> = (0..12)
            .map(|a| 1.0 + 0.3 * (a as f64 * 0.7).sin())
            .collect();
        let (mut R, mut dR) = (vec![0.0; 12], vec![0.0; 24]);
        let (mut Rp, mut Rm, mut tmp) = (vec![0.0; 12], vec![0.0; 12], vec![0.0; 24]);
        let h = 1e-6;
        for (xi, eta) in [(-0.3, 0.2), (0.9, -0.8), (0.0, 0.0), (-1.0, 1.0)] {
            element_basis_2d(2, 3, &C, &w, xi, eta, &mut R, &mut dR);
            assert!((R.iter().sum::<f64>() - 1.0).abs() < 1e-14);
            assert!(R.iter().all(|&r| r >= -1e-15));
            for dir in 0..2 {
                let (dx, de) = if dir == 0 { (h, 0.0) } else { (0.0, h) };
                element_basis_2d(2, 3, &C, &w, xi + dx, eta + de, &mut Rp, &mut tmp);
                element_basis_2d(2, 3, &C, &w, xi - dx, eta - de, &mut Rm, &mut tmp);
                for a in 0..12 {
                    assert!((dR[2 * a + dir] - (Rp[a] - Rm[a]) / (2.0 * h)).abs() < 1e-7);
                }
            }
        }
    }
}
