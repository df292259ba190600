//! Cox-de Boor B-spline basis and derivatives, eq. (10)-(11) of Corbett & Sauer 2014
//! (Piegl & Tiller A2.2 and A2.3). Only the `p+1` functions non-zero on a span are computed.
#![allow(clippy::needless_range_loop)] // index loops mirror the equations
use crate::geometry::knots::KnotVector;
use crate::geometry::MAX_ORDER;

/// The `p+1` non-zero basis functions `N_{span-p..=span}(u)` into `N` (P&T A2.2). `N`: [p+1].
#[allow(non_snake_case)]
pub fn basis_funs(kv: &KnotVector, span: usize, u: f64, N: &mut [f64]) {
    let p = kv.degree();
    let U = kv.knots();
    let mut left = [0.0; MAX_ORDER + 1];
    let mut right = [0.0; MAX_ORDER + 1];
    N[0] = 1.0;
    for j in 1..=p {
        left[j] = u - U[span + 1 - j];
        right[j] = U[span + j] - u;
        let mut saved = 0.0;
        for r in 0..j {
            let temp = N[r] / (right[r + 1] + left[j - r]);
            N[r] = saved + right[r + 1] * temp;
            saved = left[j - r] * temp;
        }
        N[j] = saved;
    }
}

/// Basis functions and derivatives up to order `n_der` (P&T A2.3). `ders`: [n_der+1][p+1],
/// row k holds the k-th derivatives of `N_{span-p..=span}` with respect to `u`.
#[allow(non_snake_case)]
pub fn ders_basis_funs(kv: &KnotVector, span: usize, u: f64, n_der: usize, ders: &mut [f64]) {
    let p = kv.degree();
    let U = kv.knots();
    let w = p + 1;
    let mut ndu = [[0.0; MAX_ORDER + 1]; MAX_ORDER + 1];
    let mut left = [0.0; MAX_ORDER + 1];
    let mut right = [0.0; MAX_ORDER + 1];
    ndu[0][0] = 1.0;
    for j in 1..=p {
        left[j] = u - U[span + 1 - j];
        right[j] = U[span + j] - u;
        let mut saved = 0.0;
        for r in 0..j {
            // lower triangle holds knot differences
            ndu[j][r] = right[r + 1] + left[j - r];
            let temp = ndu[r][j - 1] / ndu[j][r];
            ndu[r][j] = saved + right[r + 1] * temp;
            saved = left[j - r] * temp;
        }
        ndu[j][j] = saved;
    }
    for j in 0..=p {
        ders[j] = ndu[j][p];
    }
    let mut a = [[0.0; MAX_ORDER + 1]; 2];
    for r in 0..=p {
        let (mut s1, mut s2) = (0usize, 1usize);
        a[0][0] = 1.0;
        for k in 1..=n_der {
            let mut d = 0.0;
            let rk = r as isize - k as isize;
            let pk = p as isize - k as isize;
            if r >= k {
                a[s2][0] = a[s1][0] / ndu[(pk + 1) as usize][rk as usize];
                d = a[s2][0] * ndu[rk as usize][pk as usize];
            }
            let j1: isize = if rk >= -1 { 1 } else { -rk };
            let j2: isize = if (r as isize - 1) <= pk {
                k as isize - 1
            } else {
                p as isize - r as isize
            };
            let mut j = j1;
            while j <= j2 {
                let ju = j as usize;
                a[s2][ju] = (a[s1][ju] - a[s1][ju - 1]) / ndu[(pk + 1) as usize][(rk + j) as usize];
                d += a[s2][ju] * ndu[(rk + j) as usize][pk as usize];
                j += 1;
            }
            if r as isize <= pk {
                a[s2][k] = -a[s1][k - 1] / ndu[(pk + 1) as usize][r];
                d += a[s2][k] * ndu[r][pk as usize];
            }
            ders[k * w + r] = d;
            std::mem::swap(&mut s1, &mut s2);
        }
    }
    let mut fac = p as f64;
    for k in 1..=n_der {
        for j in 0..=p {
            ders[k * w + j] *= fac;
        }
        fac *= (p as isize - k as isize) as f64;
    }
}

#[cfg(test)]
#[allow(non_snake_case)]
mod tests {
    use super::*;

    fn test_vectors() -> Vec<KnotVector> {
        let mut out = Vec::new();
        for p in 1..=4 {
            for t in 0..=3 {
                let q = p + t;
                // non-uniform interior knots with multiplicity t+1 (<= q)
                let mut k = vec![0.0; q + 1];
                for (i, u) in [0.13, 0.4, 0.41, 0.77].iter().enumerate() {
                    let m = if i % 2 == 0 { t + 1 } else { 1 };
                    k.extend(std::iter::repeat_n(*u, m));
                }
                k.extend(std::iter::repeat_n(1.0, q + 1));
                out.push(KnotVector::new(q, k).unwrap());
            }
        }
        out
    }

    #[test]
    fn bspline_basis_is_nonnegative_partition_of_unity() {
        for kv in test_vectors() {
            let p = kv.degree();
            let mut N = vec![0.0; p + 1];
            for s in 0..=500 {
                let u = s as f64 / 500.0;
                basis_funs(&kv, kv.find_span(u), u, &mut N);
                let sum: f64 = N.iter().sum();
                assert!((sum - 1.0).abs() < 1e-14, "p={p} u={u} sum={sum}");
                assert!(N.iter().all(|&v| v >= -1e-15), "p={p} u={u} {N:?}");
            }
        }
    }

    #[test]
    fn bspline_derivatives_match_central_differences() {
        for kv in test_vectors() {
            let p = kv.degree();
            let mut d = vec![0.0; 2 * (p + 1)];
            let (mut Np, mut Nm) = (vec![0.0; p + 1], vec![0.0; p + 1]);
            let h = 1e-6;
            for s in 0..200 {
                let u = (s as f64 + 0.37) / 200.0;
                let span = kv.find_span(u);
                // stay inside the span so the FD stencil sees one polynomial piece
                let U = kv.knots();
                if u - h <= U[span] || u + h >= U[span + 1] {
                    continue;
                }
                ders_basis_funs(&kv, span, u, 1, &mut d);
                basis_funs(&kv, span, u + h, &mut Np);
                basis_funs(&kv, span, u - h, &mut Nm);
                let mut N0 = vec![0.0; p + 1];
                basis_funs(&kv, span, u, &mut N0);
                for j in 0..=p {
                    assert!((d[j] - N0[j]).abs() < 1e-15);
                    let fd = (Np[j] - Nm[j]) / (2.0 * h);
                    assert!(
                        (d[p + 1 + j] - fd).abs() < 1e-6 * (1.0 + fd.abs()),
                        "p={p} j={j}"
                    );
                }
            }
        }
    }
}
