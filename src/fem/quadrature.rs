//! Gauss-Legendre quadrature on `[-1, 1]` and tensor-product rules on `[-1, 1]^d` with a different point count
//! per direction (the NURBS-enriched elements use `p+1` points along the surface and 2 through the thickness).

use super::ElementError;

/// Points and weights of a quadrature rule on the reference cell.
#[derive(Debug, Clone, PartialEq)]
pub struct QuadratureRule {
    /// Spatial dimension of the points.
    pub dim: usize,
    /// [n_qp][dim]
    pub points: Vec<f64>,
    /// [n_qp]
    pub weights: Vec<f64>,
}

impl QuadratureRule {
    pub fn n_points(&self) -> usize {
        self.weights.len()
    }
}

/// Gauss-Legendre points (ascending) and weights for `n >= 1` points, exact for polynomials of degree `2n - 1`.
/// Roots of `P_n` by Newton from Chebyshev-like initial guesses, mirrored so the rule is exactly symmetric.
pub fn gauss_legendre(n: usize) -> Result<(Vec<f64>, Vec<f64>), ElementError> {
    if n == 0 {
        return Err(ElementError::InvalidPointCount { n });
    }
    let mut x = vec![0.0; n];
    let mut w = vec![0.0; n];
    // (P_n(t), P_n'(t)) by the three-term recurrence
    let legendre = |t: f64| {
        let (mut p0, mut p1) = (1.0, t);
        for k in 2..=n {
            let p2 = ((2 * k - 1) as f64 * t * p1 - (k - 1) as f64 * p0) / k as f64;
            p0 = p1;
            p1 = p2;
        }
        let dp = if n == 1 {
            1.0
        } else {
            n as f64 * (t * p1 - p0) / (t * t - 1.0)
        };
        (p1, dp)
    };
    for i in 0..n.div_ceil(2) {
        let mut t = (std::f64::consts::PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
        let mut converged = false;
        for _ in 0..100 {
            let (p, dp) = legendre(t);
            let dt = p / dp;
            t -= dt;
            if dt.abs() <= 1e-16 {
                converged = true;
                break;
            }
        }
        if !converged {
            // Newton may stall one ulp away from the root; accept if the residual is at rounding level
            let (p, _) = legendre(t);
            if p.is_nan() || p.abs() >= 1e-13 {
                return Err(ElementError::QuadratureNotConverged { n });
            }
        }
        if 2 * i + 1 == n {
            t = 0.0;
        }
        let (_, dp) = legendre(t);
        let wi = 2.0 / ((1.0 - t * t) * dp * dp);
        x[n - 1 - i] = t;
        x[i] = -t;
        w[n - 1 - i] = wi;
        w[i] = wi;
    }
    Ok((x, w))
}

/// Tensor-product Gauss-Legendre rule with `counts[d]` points in direction `d` (1 to 3 directions).
/// Point ordering: the first direction runs fastest, `qp = i0 + n0 * (i1 + n1 * i2)`.
pub fn tensor_rule(counts: &[usize]) -> Result<QuadratureRule, ElementError> {
    let dim = counts.len();
    if !(1..=3).contains(&dim) {
        return Err(ElementError::UnsupportedDimension { dim });
    }
    let rules = counts
        .iter()
        .map(|&n| gauss_legendre(n))
        .collect::<Result<Vec<_>, _>>()?;
    let n_qp: usize = counts.iter().product();
    let mut points = Vec::with_capacity(n_qp * dim);
    let mut weights = Vec::with_capacity(n_qp);
    for q in 0..n_qp {
        let mut rest = q;
        let mut w = 1.0;
        for (d, (x, wd)) in rules.iter().enumerate() {
            let i = rest % counts[d];
            rest /= counts[d];
            points.push(x[i]);
            w *= wd[i];
        }
        weights.push(w);
    }
    Ok(QuadratureRule {
        dim,
        points,
        weights,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gauss_legendre_integrates_degree_2n_minus_1_exactly() {
        for n in 1..=20 {
            let (x, w) = gauss_legendre(n).unwrap();
            for deg in 0..2 * n {
                let q: f64 = x.iter().zip(&w).map(|(x, w)| w * x.powi(deg as i32)).sum();
                let exact = if deg % 2 == 1 {
                    0.0
                } else {
                    2.0 / (deg as f64 + 1.0)
                };
                assert!((q - exact).abs() < 2e-15, "n {n} deg {deg}: {q} vs {exact}");
            }
            assert!(
                x.windows(2).all(|p| p[0] < p[1]),
                "n {n}: points not ascending"
            );
        }
    }

    #[test]
    fn gauss_legendre_matches_closed_forms() {
        let (x, w) = gauss_legendre(2).unwrap();
        assert!((x[1] - 1.0 / 3f64.sqrt()).abs() < 2e-16 && (w[0] - 1.0).abs() < 1e-15);
        let (x, w) = gauss_legendre(3).unwrap();
        assert!((x[2] - 0.6f64.sqrt()).abs() < 1e-15 && x[1] == 0.0);
        assert!((w[1] - 8.0 / 9.0).abs() < 1e-15 && (w[0] - 5.0 / 9.0).abs() < 1e-15);
        let (x, _) = gauss_legendre(64).unwrap();
        assert!(x.iter().all(|t| t.abs() < 1.0));
    }

    #[test]
    fn tensor_rule_has_anisotropic_counts_and_exact_moments() {
        let r = tensor_rule(&[3, 2]).unwrap();
        assert_eq!(r.n_points(), 6);
        assert_eq!(r.points.len(), 12);
        // x^4 y^2 over [-1,1]^2 = (2/5)(2/3)
        let q: f64 = (0..6)
            .map(|i| r.weights[i] * r.points[2 * i].powi(4) * r.points[2 * i + 1].powi(2))
            .sum();
        assert!((q - 4.0 / 15.0).abs() < 1e-15);
        // first direction runs fastest
        assert_eq!(r.points[1], r.points[3]);
        let r3 = tensor_rule(&[2, 1, 4]).unwrap();
        assert!((r3.weights.iter().sum::<f64>() - 8.0).abs() < 1e-14);
    }

    #[test]
    fn zero_points_or_bad_dimension_is_an_error() {
        assert_eq!(
            gauss_legendre(0).unwrap_err(),
            ElementError::InvalidPointCount { n: 0 }
        );
        assert!(tensor_rule(&[2, 0]).is_err());
        assert!(tensor_rule(&[]).is_err());
        assert!(tensor_rule(&[2, 2, 2, 2]).is_err());
    }
}
