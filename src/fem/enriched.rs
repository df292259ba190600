//! Bases of the enriched contact elements of Corbett & Sauer 2014 (sections 3.1 and 3.6): the
//! NURBS-enriched Q1Np / Q1Np.t of eq. (17) in 2D and 3D, and the Lagrange (Q1C2) and Hermite (Q1CH)
//! enrichments of Sauer 2011. Everything returns values and reference-coordinate derivatives; the
//! total-Lagrangian kernel maps them to the current configuration.
//!
//! Conventions (paper Fig. 1): parent element [-1,1]^dim, enriched face `eta = -1` in 2D and
//! `zeta = -1` in 3D. Node order of eq. (17):
//! - 2D Q1Np: the `n_s = p+1` surface control points in increasing `xi`, then the bulk nodes at
//!   (xi,eta) = (+1,+1) and (-1,+1). Positive Jacobian needs the body on the left of the surface
//!   when it is traversed in increasing `xi`.
//! - 3D Q1Np: the `(p+1)(q+1)` control points of face `zeta = -1` (`xi` fastest), then the bulk
//!   nodes at `zeta = +1` in the order (xi,eta) = (-1,-1), (1,-1), (1,1), (-1,1).
//!
//! Each `dN` is [n_nodes][dim] with `dN[a*dim + k] = dN_a / d(xi_k)`.
#![allow(clippy::needless_range_loop)] // index loops mirror the equations
use crate::geometry::bezier::{element_basis_1d, element_basis_2d, extraction_1d, kron_extraction};
use crate::geometry::nurbs::{NurbsCurve, NurbsSurface};
use crate::geometry::{GeometryError, MAX_ORDER};
use thiserror::Error;

/// Errors building enriched element data.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum EnrichedError {
    #[error(transparent)]
    Geometry(#[from] GeometryError),
    #[error("enriched element: {what} has {found} entries, expected {expected}")]
    BadSize {
        what: &'static str,
        expected: usize,
        found: usize,
    },
    #[error("enriched element: order {p} is out of range 1..={max}")]
    BadOrder { p: usize, max: usize },
    #[error("enriched element: weight {index} must be positive and finite, found {value}")]
    BadWeight { index: usize, value: f64 },
    #[error("spatial dimension {dim} is not supported (use 2 or 3)")]
    BadDimension { dim: usize },
}

/// Reference basis of one enriched cell (which of the bases below it takes, with its data).
#[derive(Debug, Clone, PartialEq)]
pub enum EnrichedBasis {
    /// Q1Np / Q1Np.t (eq. 17), 2D or 3D.
    Nurbs(EnrichedElementData),
    /// Q1C2: quadratic Lagrange surface (nodes at xi = -1, 0, 1).
    C2,
    /// Q1CH: cubic Hermite surface; `h` = half the face length in reference arc length.
    Hermite {
        /// `ds/dxi` of the face.
        h: f64,
    },
}

/// Per-element NURBS data of a Q1Np element: plain data after Bezier extraction.
#[derive(Debug, Clone, PartialEq)]
pub struct EnrichedElementData {
    /// order along xi
    pub p: usize,
    /// order along eta (3D); 0 in 2D
    pub q: usize,
    /// Bezier extraction operator `C_e`, row-major [n_s][n_s]; 3D: `C_v (x) C_u`
    pub extraction: Vec<f64>,
    /// weights of the element's control points: [n_s]
    pub weights: Vec<f64>,
    /// patch indices of the element's control points in eq. (17) order: [n_s]
    pub ctrl_ids: Vec<usize>,
}

fn check_weights(w: &[f64]) -> Result<(), EnrichedError> {
    match w
        .iter()
        .enumerate()
        .find(|(_, w)| !(w.is_finite() && **w > 0.0))
    {
        Some((index, &value)) => Err(EnrichedError::BadWeight { index, value }),
        None => Ok(()),
    }
}

impl EnrichedElementData {
    /// 2D element data; `extraction`: [p+1][p+1], `weights`, `ctrl_ids`: [p+1].
    pub fn new_2d(
        p: usize,
        extraction: Vec<f64>,
        weights: Vec<f64>,
        ctrl_ids: Vec<usize>,
    ) -> Result<Self, EnrichedError> {
        Self::new(p, 0, extraction, weights, ctrl_ids)
    }

    /// 3D element data; `n_s = (p+1)(q+1)`, `extraction`: [n_s][n_s], `weights`, `ctrl_ids`: [n_s].
    pub fn new_3d(
        p: usize,
        q: usize,
        extraction: Vec<f64>,
        weights: Vec<f64>,
        ctrl_ids: Vec<usize>,
    ) -> Result<Self, EnrichedError> {
        if q == 0 {
            return Err(EnrichedError::BadOrder {
                p: q,
                max: MAX_ORDER,
            });
        }
        Self::new(p, q, extraction, weights, ctrl_ids)
    }

    fn new(
        p: usize,
        q: usize,
        extraction: Vec<f64>,
        weights: Vec<f64>,
        ctrl_ids: Vec<usize>,
    ) -> Result<Self, EnrichedError> {
        for o in [p, q.max(1)] {
            if o == 0 || o > MAX_ORDER {
                return Err(EnrichedError::BadOrder {
                    p: o,
                    max: MAX_ORDER,
                });
            }
        }
        let n_s = (p + 1) * (q + 1);
        if extraction.len() != n_s * n_s {
            return Err(EnrichedError::BadSize {
                what: "extraction operator",
                expected: n_s * n_s,
                found: extraction.len(),
            });
        }
        if weights.len() != n_s {
            return Err(EnrichedError::BadSize {
                what: "weights",
                expected: n_s,
                found: weights.len(),
            });
        }
        if ctrl_ids.len() != n_s {
            return Err(EnrichedError::BadSize {
                what: "control point ids",
                expected: n_s,
                found: ctrl_ids.len(),
            });
        }
        check_weights(&weights)?;
        Ok(EnrichedElementData {
            p,
            q,
            extraction,
            weights,
            ctrl_ids,
        })
    }

    /// Data of every element of a NURBS curve, in knot order (element e covers the e-th knot span).
    pub fn elements_from_curve(curve: &NurbsCurve) -> Result<Vec<Self>, EnrichedError> {
        let p = curve.degree();
        let ex = extraction_1d(&curve.knots);
        (0..ex.n_el())
            .map(|e| {
                let ids: Vec<usize> = (ex.spans[e] - p..=ex.spans[e]).collect();
                let w = ids.iter().map(|&i| curve.weights[i]).collect();
                Self::new_2d(p, ex.op(e).to_vec(), w, ids)
            })
            .collect()
    }

    /// Data of every element of a NURBS surface; element `e_u + n_el_u * e_v`.
    pub fn elements_from_surface(s: &NurbsSurface) -> Result<Vec<Self>, EnrichedError> {
        let (p, q) = (s.knots_u.degree(), s.knots_v.degree());
        let n_u = s.knots_u.n_basis();
        let (exu, exv) = (extraction_1d(&s.knots_u), extraction_1d(&s.knots_v));
        let mut out = Vec::with_capacity(exu.n_el() * exv.n_el());
        for ev in 0..exv.n_el() {
            for eu in 0..exu.n_el() {
                let (fu, fv) = (exu.spans[eu] - p, exv.spans[ev] - q);
                let ids: Vec<usize> = (0..=q)
                    .flat_map(|j| (0..=p).map(move |i| (fu + i) + n_u * (fv + j)))
                    .collect();
                let w = ids.iter().map(|&i| s.weights[i]).collect();
                out.push(Self::new_3d(
                    p,
                    q,
                    kron_extraction(p, exu.op(eu), q, exv.op(ev)),
                    w,
                    ids,
                )?);
            }
        }
        Ok(out)
    }

    /// Number of surface control points `n_s`.
    pub fn n_surface(&self) -> usize {
        (self.p + 1) * (self.q + 1)
    }

    /// Total element nodes: `n_s + 2` in 2D, `n_s + 4` in 3D.
    pub fn n_nodes(&self) -> usize {
        self.n_surface() + if self.q == 0 { 2 } else { 4 }
    }
}

/// Q1Np basis of eq. (17) in 2D. `N`: [p+3], `dN`: [p+3][2].
#[allow(non_snake_case)]
pub fn q1np_2d(data: &EnrichedElementData, xi: f64, eta: f64, N: &mut [f64], dN: &mut [f64]) {
    let n_s = data.p + 1;
    assert!(
        data.q == 0 && N.len() >= n_s + 2 && dN.len() >= 2 * (n_s + 2),
        "q1np_2d: 2D data and buffers [p+3], [p+3][2] required"
    );
    let (mut R, mut dR) = ([0.0; MAX_ORDER + 1], [0.0; MAX_ORDER + 1]);
    element_basis_1d(data.p, &data.extraction, &data.weights, xi, &mut R, &mut dR); // eq. (16)
    let (lo, hi) = (0.5 * (1.0 - eta), 0.5 * (1.0 + eta));
    for a in 0..n_s {
        N[a] = R[a] * lo;
        dN[2 * a] = dR[a] * lo;
        dN[2 * a + 1] = -0.5 * R[a];
    }
    let (a, b) = (n_s, n_s + 1);
    N[a] = 0.5 * (1.0 + xi) * hi; // node (+1,+1)
    dN[2 * a] = 0.5 * hi;
    dN[2 * a + 1] = 0.25 * (1.0 + xi);
    N[b] = 0.5 * (1.0 - xi) * hi; // node (-1,+1)
    dN[2 * b] = -0.5 * hi;
    dN[2 * b + 1] = 0.25 * (1.0 - xi);
}

/// Q1Np basis in 3D (section 3.1). `N`: [n_s+4], `dN`: [n_s+4][3].
#[allow(non_snake_case)]
pub fn q1np_3d(
    data: &EnrichedElementData,
    xi: f64,
    eta: f64,
    zeta: f64,
    N: &mut [f64],
    dN: &mut [f64],
) {
    let n_s = data.n_surface();
    assert!(
        data.q > 0 && N.len() >= n_s + 4 && dN.len() >= 3 * (n_s + 4),
        "q1np_3d: 3D data and buffers [n_s+4], [n_s+4][3] required"
    );
    // R and dR/d(xi,eta) go straight into the caller's buffers, then get the zeta factor
    element_basis_2d(
        data.p,
        data.q,
        &data.extraction,
        &data.weights,
        xi,
        eta,
        &mut N[..n_s],
        &mut dN[..2 * n_s],
    );
    let lo = 0.5 * (1.0 - zeta);
    for a in (0..n_s).rev() {
        let (r, rx, re) = (N[a], dN[2 * a], dN[2 * a + 1]);
        N[a] = r * lo;
        dN[3 * a] = rx * lo;
        dN[3 * a + 1] = re * lo;
        dN[3 * a + 2] = -0.5 * r;
    }
    for (k, (xa, ea)) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)]
        .into_iter()
        .enumerate()
    {
        let a = n_s + k;
        let (fx, fe, fz) = (1.0 + xa * xi, 1.0 + ea * eta, 1.0 + zeta);
        N[a] = 0.125 * fx * fe * fz;
        dN[3 * a] = 0.125 * xa * fe * fz;
        dN[3 * a + 1] = 0.125 * fx * ea * fz;
        dN[3 * a + 2] = 0.125 * fx * fe;
    }
}

/// Bilinear Q1C1 basis, nodes (-1,-1), (1,-1), (1,1), (-1,1). `N`: [4], `dN`: [4][2].
#[allow(non_snake_case)]
pub fn q1c1_2d(xi: f64, eta: f64, N: &mut [f64], dN: &mut [f64]) {
    for (a, (xa, ea)) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)]
        .into_iter()
        .enumerate()
    {
        N[a] = 0.25 * (1.0 + xa * xi) * (1.0 + ea * eta);
        dN[2 * a] = 0.25 * xa * (1.0 + ea * eta);
        dN[2 * a + 1] = 0.25 * (1.0 + xa * xi) * ea;
    }
}

/// Q1C2 basis (Sauer 2011): quadratic Lagrange along `eta = -1` with surface nodes at
/// xi = -1, 0, 1, linear through the thickness; then bulk nodes (1,1), (-1,1). `N`: [5], `dN`: [5][2].
#[allow(non_snake_case)]
pub fn q1c2_2d(xi: f64, eta: f64, N: &mut [f64], dN: &mut [f64]) {
    let L = [0.5 * xi * (xi - 1.0), 1.0 - xi * xi, 0.5 * xi * (xi + 1.0)];
    let dL = [xi - 0.5, -2.0 * xi, xi + 0.5];
    let (lo, hi) = (0.5 * (1.0 - eta), 0.5 * (1.0 + eta));
    for a in 0..3 {
        N[a] = L[a] * lo;
        dN[2 * a] = dL[a] * lo;
        dN[2 * a + 1] = -0.5 * L[a];
    }
    N[3] = 0.5 * (1.0 + xi) * hi;
    dN[6] = 0.5 * hi;
    dN[7] = 0.25 * (1.0 + xi);
    N[4] = 0.5 * (1.0 - xi) * hi;
    dN[8] = -0.5 * hi;
    dN[9] = 0.25 * (1.0 - xi);
}

/// Q1CH basis (Sauer 2011; docs/theory/formulation.md): cubic Hermite along `eta = -1`. Pseudo-node order:
/// positions at xi = -1, +1; tangents `dx/ds` (w.r.t. reference arc length s) at xi = -1, +1; bulk
/// nodes (1,1), (-1,1). A tangent's basis function is the Hermite slope function times `h`, the
/// element half-length in reference arc length (`ds/dxi = h`), so `x = sum_a N_a x_a` holds with
/// tangents entered as `x_a = dx/ds`. `N`: [6], `dN`: [6][2].
#[allow(non_snake_case)]
pub fn q1ch_2d(h: f64, xi: f64, eta: f64, N: &mut [f64], dN: &mut [f64]) {
    let (x2, x3) = (xi * xi, xi * xi * xi);
    let H = [
        0.25 * (2.0 - 3.0 * xi + x3),
        0.25 * (2.0 + 3.0 * xi - x3),
        0.25 * h * (1.0 - xi - x2 + x3),
        0.25 * h * (-1.0 - xi + x2 + x3),
    ];
    let dH = [
        0.75 * (x2 - 1.0),
        0.75 * (1.0 - x2),
        0.25 * h * (-1.0 - 2.0 * xi + 3.0 * x2),
        0.25 * h * (-1.0 + 2.0 * xi + 3.0 * x2),
    ];
    let (lo, hi) = (0.5 * (1.0 - eta), 0.5 * (1.0 + eta));
    for a in 0..4 {
        N[a] = H[a] * lo;
        dN[2 * a] = dH[a] * lo;
        dN[2 * a + 1] = -0.5 * H[a];
    }
    N[4] = 0.5 * (1.0 + xi) * hi;
    dN[8] = 0.5 * hi;
    dN[9] = 0.25 * (1.0 + xi);
    N[5] = 0.5 * (1.0 - xi) * hi;
    dN[10] = -0.5 * hi;
    dN[11] = 0.25 * (1.0 - xi);
}

/// Gauss point counts of section 3.4 for a Q1Np.t element of actual order `p+t`:
/// (contact surface, volume) = (`(p+t+1)^(dim-1)`, `2 (p+t+1)^(dim-1)`), i.e. `p+t+1` points per
/// NURBS direction and 2 through the thickness.
pub fn quadrature_counts(p: usize, t: usize, dim: usize) -> Result<(usize, usize), EnrichedError> {
    let n = p + t + 1;
    match dim {
        2 => Ok((n, 2 * n)),
        3 => Ok((n * n, 2 * n * n)),
        _ => Err(EnrichedError::BadDimension { dim }),
    }
}

#[cfg(test)]
#[allow(non_snake_case)]
mod tests {
    use super::*;
    use crate::geometry::bezier::extraction_1d;
    use crate::geometry::conics::{hemisphere_surface, lower_half_circle, refined_curve};
    use crate::geometry::nurbs::rational_basis;

    const GRID: [f64; 7] = [-1.0, -0.77, -0.31, 0.0, 0.42, 0.9, 1.0];

    /// Checks partition of unity (eq. 18), non-negativity (eq. 19, here on the whole element) and
    /// derivatives against central differences for a basis `f(x, N, dN)` with `n` functions.
    fn check_basis<F: Fn(&[f64], &mut [f64], &mut [f64])>(
        f: F,
        n: usize,
        dim: usize,
        pts: &[Vec<f64>],
        nonneg: bool,
    ) {
        let (mut N, mut dN) = (vec![0.0; n], vec![0.0; n * dim]);
        let (mut Np, mut Nm, mut tmp) = (vec![0.0; n], vec![0.0; n], vec![0.0; n * dim]);
        let h = 1e-6;
        for x in pts {
            f(x, &mut N, &mut dN);
            assert!((N.iter().sum::<f64>() - 1.0).abs() < 1e-14, "sum at {x:?}");
            if nonneg {
                assert!(N.iter().all(|&v| v >= -1e-15), "negative at {x:?}: {N:?}");
            }
            for k in 0..dim {
                let (mut xp, mut xm) = (x.clone(), x.clone());
                xp[k] += h;
                xm[k] -= h;
                f(&xp, &mut Np, &mut tmp);
                f(&xm, &mut Nm, &mut tmp);
                for a in 0..n {
                    let fd = (Np[a] - Nm[a]) / (2.0 * h);
                    assert!(
                        (dN[a * dim + k] - fd).abs() < 1e-7 * (1.0 + fd.abs()),
                        "a={a} k={k} at {x:?}"
                    );
                }
            }
        }
    }

    fn grid(dim: usize) -> Vec<Vec<f64>> {
        let mut out = Vec::new();
        for &a in &GRID {
            for &b in &GRID {
                if dim == 2 {
                    out.push(vec![a, b]);
                } else {
                    for &c in &GRID[..4] {
                        out.push(vec![a, b, c]);
                    }
                }
            }
        }
        out
    }

    #[test]
    fn q1np_t_2d_basis_is_nonnegative_partition_of_unity_with_fd_derivatives() {
        let half = lower_half_circle([0.0, 1.0], 1.0).unwrap();
        for p in 2..=4 {
            for t in 0..=3 {
                let c = refined_curve(&half, p, t, 6).unwrap();
                let els = EnrichedElementData::elements_from_curve(&c).unwrap();
                assert_eq!(els.len(), 6);
                for el in [&els[0], &els[2], &els[5]] {
                    assert_eq!(el.n_nodes(), p + t + 3);
                    check_basis(
                        |x, N, dN| q1np_2d(el, x[0], x[1], N, dN),
                        p + t + 3,
                        2,
                        &grid(2),
                        true,
                    );
                }
            }
        }
        // p = 1 (k-refined line with non-unit weights)
        let line = crate::geometry::conics::line_segment(&[0.0, 0.0], &[2.0, 0.5]).unwrap();
        for t in 0..=3 {
            let mut c = refined_curve(&line, 1, t, 4).unwrap();
            c.weights
                .iter_mut()
                .enumerate()
                .for_each(|(i, w)| *w = 1.0 + 0.3 * (i as f64).sin().abs());
            for el in EnrichedElementData::elements_from_curve(&c).unwrap() {
                check_basis(
                    |x, N, dN| q1np_2d(&el, x[0], x[1], N, dN),
                    t + 4,
                    2,
                    &grid(2),
                    true,
                );
            }
        }
    }

    #[test]
    fn q1np_surface_basis_equals_patch_nurbs_basis() {
        // the element basis on eta = -1 (eq. 16) must equal the patch basis (eq. 13) of the same functions
        let half = lower_half_circle([0.0, 0.0], 2.0).unwrap();
        for (p, t) in [(2, 0), (3, 0), (2, 2), (3, 3)] {
            let c = refined_curve(&half, p, t, 4).unwrap();
            let q = p + t;
            let (mut R, mut dR) = (vec![0.0; q + 1], vec![0.0; q + 1]);
            let (mut N, mut dN) = (vec![0.0; q + 3], vec![0.0; 2 * (q + 3)]);
            let spans = c.knots.element_spans();
            for (e, el) in EnrichedElementData::elements_from_curve(&c)
                .unwrap()
                .iter()
                .enumerate()
            {
                let (ua, ub) = (c.knots.knots()[spans[e]], c.knots.knots()[spans[e] + 1]);
                for &xi in &GRID[1..6] {
                    let u = 0.5 * (ua + ub) + 0.5 * xi * (ub - ua);
                    let span = rational_basis(&c.knots, &c.weights, u, &mut R, &mut dR);
                    assert_eq!(span, spans[e]);
                    q1np_2d(el, xi, -1.0, &mut N, &mut dN);
                    for a in 0..=q {
                        assert_eq!(el.ctrl_ids[a], span - q + a);
                        assert!((N[a] - R[a]).abs() < 1e-14);
                        assert!((dN[2 * a] - dR[a] * 0.5 * (ub - ua)).abs() < 1e-12);
                    }
                    assert_eq!((N[q + 1], N[q + 2]), (0.0, 0.0));
                }
            }
        }
    }

    #[test]
    fn q1np_3d_basis_is_nonnegative_partition_of_unity_and_maps_the_sphere() {
        let s = hemisphere_surface([0.0, 0.0, 1.0], 1.0).unwrap();
        for (p, t) in [(2, 0), (2, 1), (3, 0)] {
            let r = s.refine_q1np_t(p, t, 4).unwrap();
            let els = EnrichedElementData::elements_from_surface(&r).unwrap();
            assert_eq!(els.len(), 16);
            let n = (p + t + 1) * (p + t + 1) + 4;
            for el in [&els[0], &els[5], &els[15]] {
                assert_eq!(el.n_nodes(), n);
                check_basis(
                    |x, N, dN| q1np_3d(el, x[0], x[1], x[2], N, dN),
                    n,
                    3,
                    &grid(3),
                    true,
                );
                // on zeta = -1 the surface nodes reproduce the exact sphere
                let (mut N, mut dN) = (vec![0.0; n], vec![0.0; 3 * n]);
                for &xi in &GRID {
                    for &eta in &GRID {
                        q1np_3d(el, xi, eta, -1.0, &mut N, &mut dN);
                        let mut x = [0.0; 3];
                        for (a, &id) in el.ctrl_ids.iter().enumerate() {
                            for c in 0..3 {
                                x[c] += N[a] * r.ctrl[3 * id + c];
                            }
                        }
                        let rad = (x[0] * x[0] + x[1] * x[1] + (x[2] - 1.0) * (x[2] - 1.0)).sqrt();
                        assert!((rad - 1.0).abs() < 1e-13);
                    }
                }
            }
        }
    }

    fn det3(J: &[[f64; 3]; 3]) -> f64 {
        J[0][0] * (J[1][1] * J[2][2] - J[1][2] * J[2][1])
            - J[0][1] * (J[1][0] * J[2][2] - J[1][2] * J[2][0])
            + J[0][2] * (J[1][0] * J[2][1] - J[1][1] * J[2][0])
    }

    #[test]
    fn q1np_shell_elements_on_hollow_hemisphere_have_positive_jacobian() {
        let (outer, inner) =
            crate::geometry::conics::hollow_hemisphere([0.0; 3], 1.0, 1.0 / 3.0).unwrap();
        let (outer, inner) = (
            outer.refine_q1np_t(2, 1, 4).unwrap(),
            inner.refine_q1np_t(2, 1, 4).unwrap(),
        );
        let els = EnrichedElementData::elements_from_surface(&outer).unwrap();
        let (iu, iv) = (
            extraction_1d(&outer.knots_u).intervals,
            extraction_1d(&outer.knots_v).intervals,
        );
        let n = els[0].n_nodes();
        let (mut N, mut dN) = (vec![0.0; n], vec![0.0; 3 * n]);
        let (gp, _) = crate::fem::quadrature::gauss_legendre(4).unwrap();
        for (e, el) in els.iter().enumerate() {
            let ((ua, ub), (va, vb)) = (iu[e % iu.len()], iv[e / iu.len()]);
            let mut X: Vec<[f64; 3]> = el
                .ctrl_ids
                .iter()
                .map(|&id| {
                    [
                        outer.ctrl[3 * id],
                        outer.ctrl[3 * id + 1],
                        outer.ctrl[3 * id + 2],
                    ]
                })
                .collect();
            X.extend([(ua, va), (ub, va), (ub, vb), (ua, vb)].map(|(u, v)| inner.point(u, v)));
            for &xi in &gp {
                for &eta in &gp {
                    for zeta in [-0.57, 0.57] {
                        q1np_3d(el, xi, eta, zeta, &mut N, &mut dN);
                        let mut J = [[0.0; 3]; 3];
                        for a in 0..n {
                            for i in 0..3 {
                                for k in 0..3 {
                                    J[i][k] += X[a][i] * dN[3 * a + k];
                                }
                            }
                        }
                        assert!(det3(&J) > 0.0, "element {e} at ({xi},{eta},{zeta})");
                    }
                }
            }
        }
    }

    #[test]
    fn q1n1_with_unit_weights_equals_q1c1() {
        let el =
            EnrichedElementData::new_2d(1, vec![1.0, 0.0, 0.0, 1.0], vec![1.0, 1.0], vec![0, 1])
                .unwrap();
        let (mut N, mut dN, mut M, mut dM) = ([0.0; 4], [0.0; 8], [0.0; 4], [0.0; 8]);
        for x in grid(2) {
            q1np_2d(&el, x[0], x[1], &mut N, &mut dN);
            q1c1_2d(x[0], x[1], &mut M, &mut dM);
            for a in 0..4 {
                assert!((N[a] - M[a]).abs() < 1e-16, "{x:?}");
                assert!(
                    (dN[2 * a] - dM[2 * a]).abs() < 1e-16
                        && (dN[2 * a + 1] - dM[2 * a + 1]).abs() < 1e-16
                );
            }
        }
    }

    #[test]
    fn q1c2_basis_is_interpolatory_partition_of_unity_with_fd_derivatives() {
        check_basis(|x, N, dN| q1c2_2d(x[0], x[1], N, dN), 5, 2, &grid(2), false);
        let nodes = [
            (-1.0, -1.0),
            (0.0, -1.0),
            (1.0, -1.0),
            (1.0, 1.0),
            (-1.0, 1.0),
        ];
        let (mut N, mut dN) = ([0.0; 5], [0.0; 10]);
        for (b, &(x, e)) in nodes.iter().enumerate() {
            q1c2_2d(x, e, &mut N, &mut dN);
            for a in 0..5 {
                assert_eq!(N[a], if a == b { 1.0 } else { 0.0 });
            }
        }
    }

    #[test]
    fn q1ch_reproduces_cubic_surface_with_arc_length_tangents() {
        // derivatives by FD; positions + bulk sum to one (tangent functions carry no constant part)
        let h = 0.7;
        let (mut N, mut dN) = ([0.0; 6], [0.0; 12]);
        let (mut Np, mut Nm, mut tmp) = ([0.0; 6], [0.0; 6], [0.0; 12]);
        for x in grid(2) {
            q1ch_2d(h, x[0], x[1], &mut N, &mut dN);
            let s = N[0] + N[1] + N[4] + N[5];
            assert!((s - 1.0).abs() < 1e-14);
            for k in 0..2 {
                let (mut xp, mut xm) = (x.clone(), x.clone());
                xp[k] += 1e-6;
                xm[k] -= 1e-6;
                q1ch_2d(h, xp[0], xp[1], &mut Np, &mut tmp);
                q1ch_2d(h, xm[0], xm[1], &mut Nm, &mut tmp);
                for a in 0..6 {
                    assert!((dN[2 * a + k] - (Np[a] - Nm[a]) / 2e-6).abs() < 1e-7);
                }
            }
        }
        // a cubic in arc length s = h (xi + 1) on the face is reproduced exactly
        let g = |s: f64| 0.3 - 1.2 * s + 0.5 * s * s - 0.25 * s * s * s;
        let dg = |s: f64| -1.2 + s - 0.75 * s * s;
        let vals = [g(0.0), g(2.0 * h), dg(0.0), dg(2.0 * h), 7.0, -3.0];
        for &xi in &GRID {
            q1ch_2d(h, xi, -1.0, &mut N, &mut dN);
            let x: f64 = N.iter().zip(&vals).map(|(n, v)| n * v).sum();
            assert!((x - g(h * (xi + 1.0))).abs() < 1e-14);
        }
    }

    #[test]
    fn quadrature_counts_follow_section_3_4() {
        assert_eq!(quadrature_counts(2, 0, 2).unwrap(), (3, 6));
        assert_eq!(quadrature_counts(2, 1, 2).unwrap(), (4, 8));
        assert_eq!(quadrature_counts(3, 0, 3).unwrap(), (16, 32));
        assert!(matches!(
            quadrature_counts(2, 0, 4),
            Err(EnrichedError::BadDimension { dim: 4 })
        ));
    }

    #[test]
    fn enriched_data_rejects_bad_sizes_and_weights() {
        assert!(matches!(
            EnrichedElementData::new_2d(2, vec![0.0; 8], vec![1.0; 3], vec![0, 1, 2]),
            Err(EnrichedError::BadSize {
                what: "extraction operator",
                expected: 9,
                found: 8
            })
        ));
        assert!(matches!(
            EnrichedElementData::new_2d(1, vec![1.0, 0.0, 0.0, 1.0], vec![1.0, 0.0], vec![0, 1]),
            Err(EnrichedError::BadWeight { index: 1, .. })
        ));
        assert!(matches!(
            EnrichedElementData::new_3d(1, 0, vec![], vec![], vec![]),
            Err(EnrichedError::BadOrder { .. })
        ));
    }
}
