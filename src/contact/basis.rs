//! Interpolation of one contact-surface element along its face (Corbett & Sauer 2014, sections 3.1
//! and 3.4): `x(xi) = sum_a N_a(xi) x_a` over the face's nodes, with first and second derivatives
//! with respect to the `m` surface parameters `xi` in [-1,1]^m (m = 1 in 2D, 2 in 3D).
//!
//! The face functions are the element shape functions restricted to the enriched face (`eta = -1`
//! in 2D, `zeta = -1` in 3D, see [`crate::fem::enriched`]): for Q1Np / Q1Np.t the rational element
//! basis `R_e = W_e C_e B / W` of eq. (16), i.e. the first `n_s` functions of eq. (17).
//!
//! Array shapes: `N` [n_nodes], `dN` [n_nodes][m] with `dN[a*m + i] = dN_a/dxi_i`, `ddN`
//! [n_nodes][m][m] with `ddN[a*m*m + i*m + j] = d2N_a/dxi_i dxi_j`.
#![allow(clippy::needless_range_loop)] // index loops mirror the equations
use crate::fem::enriched::{EnrichedBasis, EnrichedElementData};
use crate::geometry::bezier::bernstein2;
use crate::geometry::MAX_ORDER;

/// How one contact-surface element interpolates its face: x(xi) = sum_a N_a(xi) x_a over the face's nodes.
/// `m` = number of surface parameters: 1 in 2D, 2 in 3D. Parameter domain [-1,1]^m.
#[derive(Debug, Clone, PartialEq)]
pub enum FaceBasis {
    /// 2D linear segment (Q1C1 face): nodes at xi = -1, +1.
    Line2,
    /// 3D bilinear quad (Q1C1 hex face): nodes at (xi,eta) = (-1,-1), (1,-1), (1,1), (-1,1).
    Quad4,
    /// Q1Np / Q1Np.t face after Bezier extraction: the NURBS data of the enriched cell
    /// ([`EnrichedElementData`]; `q == 0` means 2D curve, else 3D surface). Nodes: the `n_s`
    /// surface control points in the order of eq. (17) (xi fastest in 3D), i.e. the first `n_s`
    /// nodes of the enriched cell.
    Nurbs(EnrichedElementData),
    /// Q1C2 face: quadratic Lagrange, nodes at xi = -1, 0, 1.
    Lagrange2,
    /// Q1CH face: cubic Hermite; nodes: positions at xi=-1, +1, then tangents dx/ds at xi=-1, +1;
    /// `h` = ds/dxi (so the tangent functions are the Hermite slope functions times h), exactly as
    /// [`crate::fem::enriched::q1ch_2d`] at eta = -1.
    Hermite { h: f64 },
}

impl From<&EnrichedBasis> for FaceBasis {
    /// The face basis of an enriched element: its basis restricted to the enriched face.
    fn from(b: &EnrichedBasis) -> FaceBasis {
        match b {
            EnrichedBasis::Nurbs(d) => FaceBasis::Nurbs(d.clone()),
            EnrichedBasis::C2 => FaceBasis::Lagrange2,
            EnrichedBasis::Hermite { h } => FaceBasis::Hermite { h: *h },
        }
    }
}

/// Corner signs of the bilinear quad, in node order.
const QUAD4_CORNERS: [(f64, f64); 4] = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)];

impl FaceBasis {
    /// Number of face nodes (Nurbs: `n_s = (p+1)(q+1)`).
    pub fn n_nodes(&self) -> usize {
        match self {
            FaceBasis::Line2 => 2,
            FaceBasis::Quad4 => 4,
            FaceBasis::Nurbs(d) => d.n_surface(),
            FaceBasis::Lagrange2 => 3,
            FaceBasis::Hermite { .. } => 4,
        }
    }

    /// Number of surface parameters m (1 or 2).
    pub fn n_params(&self) -> usize {
        match self {
            FaceBasis::Quad4 => 2,
            FaceBasis::Nurbs(d) if d.q > 0 => 2,
            _ => 1,
        }
    }

    /// Values N [n_nodes], first derivatives dN [n_nodes][m] (`dN[a*m+i] = dN_a/dxi_i`), second
    /// derivatives ddN [n_nodes][m][m] (`ddN[a*m*m + i*m + j] = d2N_a/dxi_i dxi_j`) at xi [m].
    /// Slices may be longer than needed. Does not allocate.
    #[allow(non_snake_case)]
    pub fn eval(&self, xi: &[f64], N: &mut [f64], dN: &mut [f64], ddN: &mut [f64]) {
        let (n, m) = (self.n_nodes(), self.n_params());
        assert!(
            xi.len() >= m && N.len() >= n && dN.len() >= n * m && ddN.len() >= n * m * m,
            "FaceBasis::eval: xi [{m}], N [{n}], dN [{n}][{m}], ddN [{n}][{m}][{m}] required"
        );
        match self {
            FaceBasis::Line2 => {
                let x = xi[0];
                N[0] = 0.5 * (1.0 - x);
                N[1] = 0.5 * (1.0 + x);
                dN[0] = -0.5;
                dN[1] = 0.5;
                ddN[..2].fill(0.0);
            }
            FaceBasis::Quad4 => {
                let (x, e) = (xi[0], xi[1]);
                for (a, (xa, ea)) in QUAD4_CORNERS.into_iter().enumerate() {
                    let (fx, fe) = (1.0 + xa * x, 1.0 + ea * e);
                    N[a] = 0.25 * fx * fe;
                    dN[2 * a] = 0.25 * xa * fe;
                    dN[2 * a + 1] = 0.25 * fx * ea;
                    let cross = 0.25 * xa * ea;
                    ddN[4 * a..4 * a + 4].copy_from_slice(&[0.0, cross, cross, 0.0]);
                }
            }
            FaceBasis::Nurbs(d) if d.q == 0 => nurbs_curve(d, xi[0], N, dN, ddN),
            FaceBasis::Nurbs(d) => nurbs_surface(d, xi[0], xi[1], N, dN, ddN),
            FaceBasis::Lagrange2 => {
                let x = xi[0];
                N[..3].copy_from_slice(&[0.5 * x * (x - 1.0), 1.0 - x * x, 0.5 * x * (x + 1.0)]);
                dN[..3].copy_from_slice(&[x - 0.5, -2.0 * x, x + 0.5]);
                ddN[..3].copy_from_slice(&[1.0, -2.0, 1.0]);
            }
            FaceBasis::Hermite { h } => {
                let (h, x) = (*h, xi[0]);
                let (x2, x3) = (x * x, x * x * x);
                N[..4].copy_from_slice(&[
                    0.25 * (2.0 - 3.0 * x + x3),
                    0.25 * (2.0 + 3.0 * x - x3),
                    0.25 * h * (1.0 - x - x2 + x3),
                    0.25 * h * (-1.0 - x + x2 + x3),
                ]);
                dN[..4].copy_from_slice(&[
                    0.75 * (x2 - 1.0),
                    0.75 * (1.0 - x2),
                    0.25 * h * (-1.0 - 2.0 * x + 3.0 * x2),
                    0.25 * h * (-1.0 + 2.0 * x + 3.0 * x2),
                ]);
                ddN[..4].copy_from_slice(&[
                    1.5 * x,
                    -1.5 * x,
                    0.25 * h * (-2.0 + 6.0 * x),
                    0.25 * h * (2.0 + 6.0 * x),
                ]);
            }
        }
    }

    /// Gauss points per surface direction for the contact integral (section 3.4 of the paper):
    /// Line2 -> [2], Quad4 -> [2,2], Nurbs -> [p+1] or [p+1, q+1] (p, q are the element's actual
    /// orders), Lagrange2 -> [3], Hermite -> [4].
    pub fn quadrature_counts(&self) -> Vec<usize> {
        match self {
            FaceBasis::Line2 => vec![2],
            FaceBasis::Quad4 => vec![2, 2],
            FaceBasis::Nurbs(d) if d.q == 0 => vec![d.p + 1],
            FaceBasis::Nurbs(d) => vec![d.p + 1, d.q + 1],
            FaceBasis::Lagrange2 => vec![3],
            FaceBasis::Hermite { .. } => vec![4],
        }
    }
}

/// Rational element basis of a curve element, eq. (16), with two derivatives:
/// `A_a = w_a (C B)_a`, `W = sum A_a`, `R = A/W`, `R' = (A' - R W')/W`,
/// `R'' = (A'' - 2 R' W' - R W'')/W`. `R`, `dR`, `ddR`: [p+1].
#[allow(non_snake_case)]
fn nurbs_curve(d: &EnrichedElementData, xi: f64, R: &mut [f64], dR: &mut [f64], ddR: &mut [f64]) {
    let (p, C, w) = (d.p, &d.extraction, &d.weights);
    let n = p + 1;
    let mut B = [0.0; MAX_ORDER + 1];
    let mut dB = [0.0; MAX_ORDER + 1];
    let mut ddB = [0.0; MAX_ORDER + 1];
    bernstein2(p, xi, &mut B, &mut dB, &mut ddB);
    let (mut W, mut dW, mut ddW) = (0.0, 0.0, 0.0);
    for a in 0..n {
        let row = &C[a * n..(a + 1) * n];
        let (mut A, mut dA, mut ddA) = (0.0, 0.0, 0.0);
        for k in 0..n {
            A += row[k] * B[k];
            dA += row[k] * dB[k];
            ddA += row[k] * ddB[k];
        }
        R[a] = w[a] * A;
        dR[a] = w[a] * dA;
        ddR[a] = w[a] * ddA;
        W += R[a];
        dW += dR[a];
        ddW += ddR[a];
    }
    for a in 0..n {
        R[a] /= W;
        dR[a] = (dR[a] - R[a] * dW) / W;
        ddR[a] = (ddR[a] - 2.0 * dR[a] * dW - R[a] * ddW) / W;
    }
}

/// Rational element basis of a surface element (tensor product of eq. 16) with two derivatives:
/// `R_i = (A_i - R W_i)/W`, `R_ij = (A_ij - R_i W_j - R_j W_i - R W_ij)/W`.
/// `R`: [n_s], `dR`: [n_s][2], `ddR`: [n_s][2][2], `n_s = (p+1)(q+1)`, local `a = i + (p+1) j`.
#[allow(non_snake_case)]
fn nurbs_surface(
    d: &EnrichedElementData,
    xi: f64,
    eta: f64,
    R: &mut [f64],
    dR: &mut [f64],
    ddR: &mut [f64],
) {
    let n = (d.p + 1) * (d.q + 1);
    let (W, dW, ddW) = nurbs_surface_numerators(d, xi, eta, R, dR, ddR);
    // the quotient rule, one array at a time and the same operations per entry as
    // `R_ij = (A_ij - R_i W_j - R_j W_i - R W_ij)/W`: independent divisions in contiguous runs,
    // which the compiler can pair (the divisions bound this function)
    for r in R[..n].iter_mut() {
        *r /= W;
    }
    for (d, &r) in dR[..2 * n].chunks_exact_mut(2).zip(&R[..n]) {
        d[0] = (d[0] - r * dW[0]) / W;
        d[1] = (d[1] - r * dW[1]) / W;
    }
    for ((dd, d), &r) in ddR[..4 * n]
        .chunks_exact_mut(4)
        .zip(dR[..2 * n].chunks_exact(2))
        .zip(&R[..n])
    {
        let (a01, ri) = (dd[1], [d[0], d[1]]);
        let mixed = (a01 - ri[0] * dW[1] - ri[1] * dW[0] - r * ddW[1]) / W;
        dd[0] = (dd[0] - ri[0] * dW[0] - ri[0] * dW[0] - r * ddW[0]) / W;
        dd[1] = mixed;
        dd[2] = mixed;
        dd[3] = (dd[3] - ri[1] * dW[1] - ri[1] * dW[1] - r * ddW[2]) / W;
    }
}

/// The numerators of [`nurbs_surface`]'s quotients: `w_a A_a` into `R`, `w_a A_a,i` into `dR`,
/// `w_a A_a,ij` into `ddR` ([xx, xe, -, ee] per function), and the sums `W`, `W_i`, `W_ij`
/// ([xx, xe, ee]).
#[allow(non_snake_case)]
fn nurbs_surface_numerators(
    d: &EnrichedElementData,
    xi: f64,
    eta: f64,
    R: &mut [f64],
    dR: &mut [f64],
    ddR: &mut [f64],
) -> (f64, [f64; 2], [f64; 3]) {
    let (p, q, C, w) = (d.p, d.q, &d.extraction, &d.weights);
    let (wu, wv) = (p + 1, q + 1);
    let n = wu * wv;
    let mut Bu = [0.0; MAX_ORDER + 1];
    let mut dBu = [0.0; MAX_ORDER + 1];
    let mut ddBu = [0.0; MAX_ORDER + 1];
    let mut Bv = [0.0; MAX_ORDER + 1];
    let mut dBv = [0.0; MAX_ORDER + 1];
    let mut ddBv = [0.0; MAX_ORDER + 1];
    bernstein2(p, xi, &mut Bu, &mut dBu, &mut ddBu);
    bernstein2(q, eta, &mut Bv, &mut dBv, &mut ddBv);
    // C = C_v (x) C_u: the univariate extracted B-splines N_u = C_u B_u and N_v = C_v B_v give
    // A_(i,j) = N_u,i N_v,j, (p+1)^2 + (q+1)^2 products instead of (p+1)^2 (q+1)^2 per function.
    // C_u and C_v are read off C up to a scale fixed by the entry of the last functions
    // (C_u[p][p] C_v[q][q] > 0: the last function of an element is positive at its right end).
    let last = p + wu * q;
    let c0 = C[last * n + last];
    let (mut nu, mut dnu, mut ddnu) = (
        [0.0; MAX_ORDER + 1],
        [0.0; MAX_ORDER + 1],
        [0.0; MAX_ORDER + 1],
    );
    let (mut nv, mut dnv, mut ddnv) = (
        [0.0; MAX_ORDER + 1],
        [0.0; MAX_ORDER + 1],
        [0.0; MAX_ORDER + 1],
    );
    let tensor = c0 != 0.0;
    if tensor {
        for i in 0..wu {
            let row = &C[(i + wu * q) * n..];
            for r in 0..wu {
                let c = row[r + wu * q] / c0;
                nu[i] += c * Bu[r];
                dnu[i] += c * dBu[r];
                ddnu[i] += c * ddBu[r];
            }
        }
        for j in 0..wv {
            let row = &C[(p + wu * j) * n..];
            for s in 0..wv {
                let c = row[p + wu * s];
                nv[j] += c * Bv[s];
                dnv[j] += c * dBv[s];
                ddnv[j] += c * ddBv[s];
            }
        }
    }
    // W, W_i, W_ij (symmetric: [xx, xe, ee])
    let (mut W, mut dW, mut ddW) = (0.0, [0.0; 2], [0.0; 3]);
    for a in 0..n {
        let (mut A, mut dA, mut ddA) = (0.0, [0.0; 2], [0.0; 3]);
        if tensor {
            let (i, j) = (a % wu, a / wu);
            A = nu[i] * nv[j];
            dA = [dnu[i] * nv[j], nu[i] * dnv[j]];
            ddA = [ddnu[i] * nv[j], dnu[i] * dnv[j], nu[i] * ddnv[j]];
        } else {
            let row = &C[a * n..(a + 1) * n];
            for s in 0..wv {
                for r in 0..wu {
                    let c = row[r + wu * s];
                    if c != 0.0 {
                        A += c * Bu[r] * Bv[s];
                        dA[0] += c * dBu[r] * Bv[s];
                        dA[1] += c * Bu[r] * dBv[s];
                        ddA[0] += c * ddBu[r] * Bv[s];
                        ddA[1] += c * dBu[r] * dBv[s];
                        ddA[2] += c * Bu[r] * ddBv[s];
                    }
                }
            }
        }
        R[a] = w[a] * A;
        W += R[a];
        for i in 0..2 {
            dR[2 * a + i] = w[a] * dA[i];
            dW[i] += dR[2 * a + i];
        }
        for k in 0..3 {
            ddW[k] += w[a] * ddA[k];
        }
        ddR[4 * a] = w[a] * ddA[0];
        ddR[4 * a + 1] = w[a] * ddA[1];
        ddR[4 * a + 3] = w[a] * ddA[2];
    }
    (W, dW, ddW)
}

#[cfg(test)]
#[allow(non_snake_case)]
mod tests {
    use super::*;
    use crate::fem::enriched::{q1c2_2d, q1ch_2d, q1np_2d, q1np_3d};
    use crate::geometry::conics::{circular_arc, hemisphere_surface, line_segment};
    use crate::geometry::nurbs::NurbsSurface;
    use crate::geometry::refine::Direction;
    use std::f64::consts::PI;

    /// Hemisphere refinements (p, t, extra order along u): p = q = 2, 3, Q1N2.1, and p != q.
    const SURFACE_CASES: [(usize, usize, usize); 4] = [(2, 0, 0), (3, 0, 0), (2, 1, 0), (2, 0, 1)];

    fn refined_hemisphere(s: &NurbsSurface, p: usize, t: usize, du: usize) -> NurbsSurface {
        let r = s.refine_q1np_t(p, t, 4).unwrap();
        if du == 0 {
            r
        } else {
            r.elevate(Direction::U, du).unwrap()
        }
    }

    /// Elements of refined real geometry: a 2D NURBS curve per (p, t), p = 1..4, t = 0..2 (p = 1: a
    /// line with perturbed weights; p >= 2: a circular arc), and 3D hemisphere elements, p = q = 2, 3.
    fn nurbs_faces() -> Vec<FaceBasis> {
        let mut out = Vec::new();
        let arc = circular_arc([0.3, -0.2], 1.7, 0.2, 0.2 + 0.8 * PI).unwrap(); // 2 segments
        let line = line_segment(&[0.0, 0.0], &[2.0, 0.5]).unwrap();
        for p in 1..=4 {
            for t in 0..=2 {
                let c = if p == 1 {
                    let mut c = line.refine_q1np_t(1, t, 3).unwrap();
                    c.weights
                        .iter_mut()
                        .enumerate()
                        .for_each(|(i, w)| *w = 1.0 + 0.4 * (1.3 * i as f64).sin().abs());
                    c
                } else {
                    arc.refine_q1np_t(p, t, 4).unwrap()
                };
                let els = EnrichedElementData::elements_from_curve(&c).unwrap();
                assert_eq!((els[0].p, els[0].q), (p + t, 0));
                out.extend(
                    [&els[0], &els[1], &els[els.len() - 1]].map(|d| FaceBasis::Nurbs(d.clone())),
                );
            }
        }
        let s = hemisphere_surface([0.0, 0.0, 1.0], 1.3).unwrap();
        for (p, t, du) in SURFACE_CASES {
            let r = refined_hemisphere(&s, p, t, du);
            let els = EnrichedElementData::elements_from_surface(&r).unwrap();
            assert_eq!((els[0].p, els[0].q), (p + t + du, p + t));
            out.extend([&els[0], &els[5], &els[10]].map(|d| FaceBasis::Nurbs(d.clone())));
        }
        // the data must include rational weights, else the quotient rule is untested
        assert!(out.iter().all(|f| match f {
            FaceBasis::Nurbs(d) => d.weights.iter().any(|&w| (w - 1.0).abs() > 1e-3),
            _ => true,
        }));
        out
    }

    fn all_faces() -> Vec<FaceBasis> {
        let mut out = vec![
            FaceBasis::Line2,
            FaceBasis::Quad4,
            FaceBasis::Lagrange2,
            FaceBasis::Hermite { h: 0.7 },
        ];
        out.extend(nurbs_faces());
        out
    }

    /// Deterministic pseudo-random points in [-1,1]^m (plus the corners).
    fn points(m: usize) -> Vec<Vec<f64>> {
        let mut state: u64 = 0x9e37_79b9_7f4a_7c15;
        let mut next = || {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            2.0 * ((state >> 11) as f64 / (1u64 << 53) as f64) - 1.0
        };
        let mut out: Vec<Vec<f64>> = (0..8).map(|_| (0..m).map(|_| next()).collect()).collect();
        out.push(vec![-1.0; m]);
        out.push(vec![1.0; m]);
        out
    }

    struct Eval {
        N: Vec<f64>,
        dN: Vec<f64>,
        ddN: Vec<f64>,
    }

    fn eval(f: &FaceBasis, xi: &[f64]) -> Eval {
        // buffers deliberately longer than needed
        let (n, m) = (f.n_nodes() + 2, f.n_params());
        let mut e = Eval {
            N: vec![f64::NAN; n],
            dN: vec![f64::NAN; n * m],
            ddN: vec![f64::NAN; n * m * m],
        };
        f.eval(xi, &mut e.N, &mut e.dN, &mut e.ddN);
        e
    }

    /// The quotient rule of `nurbs_surface` as it was written before its loops were split (entry
    /// by entry, each function's derivatives right after its value).
    fn quotient_entrywise(
        n: usize,
        W: f64,
        dW: [f64; 2],
        ddW: [f64; 3],
        R: &mut [f64],
        dR: &mut [f64],
        ddR: &mut [f64],
    ) {
        let ddW = [[ddW[0], ddW[1]], [ddW[1], ddW[2]]];
        for a in 0..n {
            R[a] /= W;
            for i in 0..2 {
                dR[2 * a + i] = (dR[2 * a + i] - R[a] * dW[i]) / W;
            }
            let Ri = [dR[2 * a], dR[2 * a + 1]];
            for i in 0..2 {
                for j in i..2 {
                    let Aij = ddR[4 * a + 2 * i + j];
                    ddR[4 * a + 2 * i + j] =
                        (Aij - Ri[i] * dW[j] - Ri[j] * dW[i] - R[a] * ddW[i][j]) / W;
                }
            }
            ddR[4 * a + 2] = ddR[4 * a + 1];
        }
    }

    #[test]
    fn nurbs_surface_is_bit_identical_to_the_entrywise_quotient_rule() {
        // the same numerators and sums, divided entry by entry as before: the same bits
        let mut checked = 0;
        for f in nurbs_faces() {
            let FaceBasis::Nurbs(d) = &f else { continue };
            if d.q == 0 {
                continue;
            }
            let n = f.n_nodes();
            for x in points(2) {
                let e = eval(&f, &x);
                let (mut R, mut dR, mut ddR) = (vec![0.0; n], vec![0.0; 2 * n], vec![0.0; 4 * n]);
                let (W, dW, ddW) =
                    nurbs_surface_numerators(d, x[0], x[1], &mut R, &mut dR, &mut ddR);
                quotient_entrywise(n, W, dW, ddW, &mut R, &mut dR, &mut ddR);
                let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                assert_eq!(bits(&e.N[..n]), bits(&R), "{f:?} at {x:?}");
                assert_eq!(bits(&e.dN[..2 * n]), bits(&dR), "{f:?} at {x:?}");
                assert_eq!(bits(&e.ddN[..4 * n]), bits(&ddR), "{f:?} at {x:?}");
                checked += 1;
            }
        }
        assert!(checked >= 40, "{checked}");
    }

    #[test]
    fn n_nodes_params_and_quadrature_counts() {
        assert_eq!(
            (FaceBasis::Line2.n_nodes(), FaceBasis::Line2.n_params()),
            (2, 1)
        );
        assert_eq!(
            (FaceBasis::Quad4.n_nodes(), FaceBasis::Quad4.n_params()),
            (4, 2)
        );
        assert_eq!(
            (
                FaceBasis::Lagrange2.n_nodes(),
                FaceBasis::Lagrange2.n_params()
            ),
            (3, 1)
        );
        let herm = FaceBasis::Hermite { h: 1.0 };
        assert_eq!((herm.n_nodes(), herm.n_params()), (4, 1));
        assert_eq!(FaceBasis::Line2.quadrature_counts(), vec![2]);
        assert_eq!(FaceBasis::Quad4.quadrature_counts(), vec![2, 2]);
        assert_eq!(FaceBasis::Lagrange2.quadrature_counts(), vec![3]);
        assert_eq!(herm.quadrature_counts(), vec![4]);
        let c = circular_arc([0.0, 0.0], 1.0, 0.0, 0.5 * PI).unwrap();
        let d =
            EnrichedElementData::elements_from_curve(&c.refine_q1np_t(2, 1, 2).unwrap()).unwrap();
        let f = FaceBasis::Nurbs(d[0].clone());
        assert_eq!(
            (f.n_nodes(), f.n_params(), f.quadrature_counts()),
            (4, 1, vec![4])
        );
        let s = hemisphere_surface([0.0; 3], 1.0)
            .unwrap()
            .refine_q1np_t(3, 0, 2)
            .unwrap();
        let d = EnrichedElementData::elements_from_surface(&s).unwrap();
        let f = FaceBasis::Nurbs(d[0].clone());
        assert_eq!(
            (f.n_nodes(), f.n_params(), f.quadrature_counts()),
            (16, 2, vec![4, 4])
        );
        let s = s.elevate(Direction::V, 1).unwrap(); // p = 3, q = 4
        let d = EnrichedElementData::elements_from_surface(&s).unwrap();
        let f = FaceBasis::Nurbs(d[0].clone());
        assert_eq!(
            (f.n_nodes(), f.n_params(), f.quadrature_counts()),
            (20, 2, vec![4, 5])
        );
    }

    #[test]
    fn partition_of_unity_and_zero_derivative_sums_for_every_variant() {
        for f in all_faces() {
            let (n, m) = (f.n_nodes(), f.n_params());
            // Hermite: only the position functions sum to one
            let sum_over = if matches!(f, FaceBasis::Hermite { .. }) {
                2
            } else {
                n
            };
            for x in points(m) {
                let e = eval(&f, &x);
                let s: f64 = e.N[..sum_over].iter().sum();
                assert!((s - 1.0).abs() < 1e-13, "{f:?} at {x:?}: sum N = {s}");
                for i in 0..m {
                    let s: f64 = (0..sum_over).map(|a| e.dN[a * m + i]).sum();
                    assert!(s.abs() < 1e-11, "{f:?} at {x:?}: sum dN_{i} = {s}");
                    for j in 0..m {
                        let s: f64 = (0..sum_over).map(|a| e.ddN[a * m * m + i * m + j]).sum();
                        assert!(s.abs() < 1e-10, "{f:?} at {x:?}: sum ddN_{i}{j} = {s}");
                    }
                }
                // the output is fully written (no NaN from the buffers left)
                assert!(e.N[..n]
                    .iter()
                    .chain(&e.dN[..n * m])
                    .chain(&e.ddN[..n * m * m])
                    .all(|v| v.is_finite()));
            }
        }
    }

    #[test]
    fn derivatives_match_central_differences_for_every_variant() {
        let h = 1e-5;
        let close = |a: f64, fd: f64| (a - fd).abs() < 1e-7 * (1.0 + fd.abs());
        for f in all_faces() {
            let (n, m) = (f.n_nodes(), f.n_params());
            for x in points(m) {
                let e = eval(&f, &x);
                for k in 0..m {
                    let (mut xp, mut xm) = (x.clone(), x.clone());
                    xp[k] += h;
                    xm[k] -= h;
                    let (ep, em) = (eval(&f, &xp), eval(&f, &xm));
                    for a in 0..n {
                        let fd = (ep.N[a] - em.N[a]) / (2.0 * h);
                        assert!(close(e.dN[a * m + k], fd), "{f:?} dN a={a} k={k} at {x:?}");
                        for i in 0..m {
                            // d/dxi_k of dN_a/dxi_i
                            let fd = (ep.dN[a * m + i] - em.dN[a * m + i]) / (2.0 * h);
                            let dd = e.ddN[a * m * m + i * m + k];
                            assert!(
                                close(dd, fd),
                                "{f:?} ddN a={a} i={i} k={k} at {x:?}: {dd} vs {fd}"
                            );
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn face_basis_equals_element_shape_functions_on_the_face() {
        let mut checked = [0usize; 4];
        for f in all_faces() {
            let m = f.n_params();
            for x in points(m) {
                let e = eval(&f, &x);
                let (mut M, mut dM) = ([0.0; 512], [0.0; 1536]);
                let (n_s, dim) = match &f {
                    FaceBasis::Nurbs(d) if d.q == 0 => {
                        q1np_2d(d, x[0], -1.0, &mut M, &mut dM);
                        checked[0] += 1;
                        (d.n_surface(), 2)
                    }
                    FaceBasis::Nurbs(d) => {
                        q1np_3d(d, x[0], x[1], -1.0, &mut M, &mut dM);
                        checked[1] += 1;
                        (d.n_surface(), 3)
                    }
                    FaceBasis::Lagrange2 => {
                        q1c2_2d(x[0], -1.0, &mut M, &mut dM);
                        checked[2] += 1;
                        (3, 2)
                    }
                    FaceBasis::Hermite { h } => {
                        q1ch_2d(*h, x[0], -1.0, &mut M, &mut dM);
                        checked[3] += 1;
                        (4, 2)
                    }
                    _ => continue,
                };
                for a in 0..n_s {
                    assert!((e.N[a] - M[a]).abs() < 1e-13, "{f:?} N a={a} at {x:?}");
                    for i in 0..m {
                        let (u, v) = (e.dN[a * m + i], dM[a * dim + i]);
                        assert!(
                            (u - v).abs() < 1e-13,
                            "{f:?} dN a={a} i={i} at {x:?}: {u} vs {v}"
                        );
                    }
                }
            }
        }
        assert!(checked.iter().all(|&c| c > 0), "{checked:?}");
    }

    #[test]
    fn nurbs_quarter_circle_face_reproduces_circle_and_curvature() {
        let (c0, r) = ([0.4, -0.7], 2.3);
        let quarter = circular_arc(c0, r, 0.3, 0.3 + 0.5 * PI).unwrap();
        for (p, t, n_el) in [(2, 0, 1), (2, 0, 3), (3, 1, 2), (4, 2, 4)] {
            let c = quarter.refine_q1np_t(p, t, n_el).unwrap();
            for d in EnrichedElementData::elements_from_curve(&c).unwrap() {
                let P: Vec<[f64; 2]> = d
                    .ctrl_ids
                    .iter()
                    .map(|&i| [c.ctrl[2 * i], c.ctrl[2 * i + 1]])
                    .collect();
                let f = FaceBasis::Nurbs(d);
                for s in 0..=20 {
                    let xi = -1.0 + s as f64 / 10.0;
                    let e = eval(&f, &[xi]);
                    let (mut x, mut x1, mut x2) = ([0.0; 2], [0.0; 2], [0.0; 2]);
                    for (a, Pa) in P.iter().enumerate() {
                        for k in 0..2 {
                            x[k] += e.N[a] * Pa[k];
                            x1[k] += e.dN[a] * Pa[k];
                            x2[k] += e.ddN[a] * Pa[k];
                        }
                    }
                    let rad = (x[0] - c0[0]).hypot(x[1] - c0[1]);
                    assert!((rad - r).abs() < 1e-12, "p={p} t={t}: radius {rad}");
                    let speed = x1[0].hypot(x1[1]);
                    let kappa = (x1[0] * x2[1] - x1[1] * x2[0]).abs() / speed.powi(3);
                    assert!(
                        (kappa * r - 1.0).abs() < 1e-10,
                        "p={p} t={t} xi={xi}: kappa = {kappa}"
                    );
                }
            }
        }
    }

    #[test]
    fn nurbs_sphere_face_second_derivatives_satisfy_the_sphere_identity() {
        // |x - c|^2 = r^2 gives x_i . (x - c) = 0 and x_ij . (x - c) = -x_i . x_j (mixed terms too)
        let (c0, r) = ([0.2, -0.1, 1.0], 1.3);
        let s = hemisphere_surface(c0, r).unwrap();
        for (p, t, du) in SURFACE_CASES {
            let sr = refined_hemisphere(&s, p, t, du);
            let els = EnrichedElementData::elements_from_surface(&sr).unwrap();
            for d in [&els[5], &els[6], &els[10]] {
                let P: Vec<[f64; 3]> = d
                    .ctrl_ids
                    .iter()
                    .map(|&i| [sr.ctrl[3 * i], sr.ctrl[3 * i + 1], sr.ctrl[3 * i + 2]])
                    .collect();
                let f = FaceBasis::Nurbs(d.clone());
                for x in points(2) {
                    let e = eval(&f, &x);
                    let mut y = [0.0; 3];
                    let mut yi = [[0.0; 3]; 2];
                    let mut yij = [[[0.0; 3]; 2]; 2];
                    for (a, Pa) in P.iter().enumerate() {
                        for k in 0..3 {
                            y[k] += e.N[a] * (Pa[k] - c0[k]);
                            for i in 0..2 {
                                yi[i][k] += e.dN[2 * a + i] * Pa[k];
                                for j in 0..2 {
                                    yij[i][j][k] += e.ddN[4 * a + 2 * i + j] * Pa[k];
                                }
                            }
                        }
                    }
                    let dot = |u: &[f64; 3], v: &[f64; 3]| u[0] * v[0] + u[1] * v[1] + u[2] * v[2];
                    assert!((dot(&y, &y).sqrt() - r).abs() < 1e-12);
                    for i in 0..2 {
                        assert!(dot(&yi[i], &y).abs() < 1e-11);
                        for j in 0..2 {
                            let lhs = dot(&yij[i][j], &y);
                            let rhs = -dot(&yi[i], &yi[j]);
                            assert!(
                                (lhs - rhs).abs() < 1e-10 * (1.0 + rhs.abs()),
                                "p={p} t={t} ij={i}{j} at {x:?}: {lhs} vs {rhs}"
                            );
                        }
                    }
                }
            }
        }
    }
}
