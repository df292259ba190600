//! Compressible Neo-Hookean material, eq. (21) of Corbett & Sauer 2014:
//! `W = mu/2 (tr C - 3 - 2 ln J) + Lambda/2 (ln J)^2`,
//! `P = mu (F - F^-T) + Lambda ln J F^-T`,
//! `sigma = Lambda/J ln J I + mu/J (F F^T - I)`.
//!
//! In 2D the state is plane strain: `F` is the in-plane 2x2 block and `F33 = 1`, so `tr C` gains `+1`, `J` is the
//! 2x2 determinant, `P` and `A` are the in-plane blocks and `sigma_33 = Lambda/J ln J` is returned by [`NeoHookean::cauchy`].
//!
//! Tensors are flat row-major: `F`, `P`: `[D][D]` (`F[i*D+J] = F_iJ`); the tangent
//! `A[(i*D+J)*D*D + k*D+L] = dP_iJ/dF_kL`: `[D][D][D][D]`.

use super::{ConstitutiveLaw, MaterialError};

/// Compressible Neo-Hookean law with Lame parameters `mu` (shear modulus) and `lambda` (`Lambda` of eq. 21).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NeoHookean {
    pub mu: f64,
    pub lambda: f64,
}

/// Determinant and inverse of a `D x D` row-major matrix stored with stride `D` in a 9-array.
#[allow(non_snake_case)]
#[inline(always)]
fn det_inv<const D: usize>(F: &[f64]) -> (f64, [f64; 9]) {
    let mut inv = [0.0; 9];
    if D == 2 {
        let det = F[0] * F[3] - F[1] * F[2];
        let r = 1.0 / det;
        inv[0] = F[3] * r;
        inv[1] = -F[1] * r;
        inv[2] = -F[2] * r;
        inv[3] = F[0] * r;
        (det, inv)
    } else {
        let c00 = F[4] * F[8] - F[5] * F[7];
        let c01 = F[5] * F[6] - F[3] * F[8];
        let c02 = F[3] * F[7] - F[4] * F[6];
        let det = F[0] * c00 + F[1] * c01 + F[2] * c02;
        let r = 1.0 / det;
        inv[0] = c00 * r;
        inv[1] = (F[2] * F[7] - F[1] * F[8]) * r;
        inv[2] = (F[1] * F[5] - F[2] * F[4]) * r;
        inv[3] = c01 * r;
        inv[4] = (F[0] * F[8] - F[2] * F[6]) * r;
        inv[5] = (F[2] * F[3] - F[0] * F[5]) * r;
        inv[6] = c02 * r;
        inv[7] = (F[1] * F[6] - F[0] * F[7]) * r;
        inv[8] = (F[0] * F[4] - F[1] * F[3]) * r;
        (det, inv)
    }
}

impl NeoHookean {
    /// Lame parameters from Young's modulus and Poisson's ratio: `mu = E/(2(1+nu))`, `Lambda = 2 mu nu/(1-2 nu)`.
    #[allow(non_snake_case)]
    pub fn from_young_poisson(E: f64, nu: f64) -> Result<Self, MaterialError> {
        if !(E.is_finite() && E > 0.0) {
            return Err(MaterialError::InvalidYoungsModulus { young: E });
        }
        if !(nu.is_finite() && nu > -1.0 && nu < 0.5) {
            return Err(MaterialError::InvalidPoissonRatio { poisson: nu });
        }
        let mu = E / (2.0 * (1.0 + nu));
        Ok(Self {
            mu,
            lambda: 2.0 * mu * nu / (1.0 - 2.0 * nu),
        })
    }

    pub(super) fn check(
        dim: usize,
        what: &'static str,
        got: usize,
        power: u32,
    ) -> Result<(), MaterialError> {
        if dim != 2 && dim != 3 {
            return Err(MaterialError::UnsupportedDimension { dim });
        }
        let expected = dim.pow(power);
        if got != expected {
            return Err(MaterialError::WrongLength {
                what,
                dim,
                expected,
                got,
            });
        }
        Ok(())
    }

    /// Stored energy per reference volume `W(F)`; `F`: `[dim][dim]`.
    #[allow(non_snake_case)]
    pub fn energy(&self, dim: usize, F: &[f64]) -> Result<f64, MaterialError> {
        Self::check(dim, "F", F.len(), 2)?;
        let (J, _) = if dim == 2 {
            det_inv::<2>(F)
        } else {
            det_inv::<3>(F)
        };
        if J.is_nan() || J <= 0.0 {
            return Err(MaterialError::NonPositiveJacobian { J });
        }
        // plane strain: F33 = 1 contributes 1 to tr C
        let trC = F.iter().map(|f| f * f).sum::<f64>() + if dim == 2 { 1.0 } else { 0.0 };
        let lnJ = J.ln();
        Ok(0.5 * self.mu * (trC - 3.0 - 2.0 * lnJ) + 0.5 * self.lambda * lnJ * lnJ)
    }

    /// Cauchy stress of eq. (21), always 3x3 row-major; in plane strain `sigma_33 = Lambda/J ln J` and the
    /// out-of-plane shears are zero.
    #[allow(non_snake_case)]
    pub fn cauchy(&self, dim: usize, F: &[f64], sigma: &mut [f64; 9]) -> Result<(), MaterialError> {
        Self::check(dim, "F", F.len(), 2)?;
        let mut F3 = [0.0; 9];
        if dim == 2 {
            F3[0] = F[0];
            F3[1] = F[1];
            F3[3] = F[2];
            F3[4] = F[3];
            F3[8] = 1.0;
        } else {
            F3.copy_from_slice(F);
        }
        let (J, _) = det_inv::<3>(&F3);
        if J.is_nan() || J <= 0.0 {
            return Err(MaterialError::NonPositiveJacobian { J });
        }
        let vol = self.lambda * J.ln() / J;
        let s = self.mu / J;
        for i in 0..3 {
            for j in 0..3 {
                let b_ij: f64 = (0..3).map(|k| F3[i * 3 + k] * F3[j * 3 + k]).sum();
                let d = if i == j { 1.0 } else { 0.0 };
                sigma[i * 3 + j] = vol * d + s * (b_ij - d);
            }
        }
        Ok(())
    }
}

impl ConstitutiveLaw for NeoHookean {
    /// `P = mu (F - F^-T) + Lambda ln J F^-T` and its tangent; fails with
    /// [`MaterialError::NonPositiveJacobian`] when `det F <= 0`.
    #[allow(non_snake_case)]
    #[inline(always)]
    fn pk1_impl<const D: usize>(
        &self,
        F: &[f64],
        P: &mut [f64],
        A: Option<&mut [f64]>,
    ) -> Result<(), MaterialError> {
        let (J, Finv) = det_inv::<D>(F);
        if J.is_nan() || J <= 0.0 {
            return Err(MaterialError::NonPositiveJacobian { J });
        }
        let lnJ = J.ln();
        let c = self.lambda * lnJ - self.mu;
        // (F^-T)_iJ = Finv_Ji
        for i in 0..D {
            for j in 0..D {
                P[i * D + j] = self.mu * F[i * D + j] + c * Finv[j * D + i];
            }
        }
        if let Some(A) = A {
            // d ln J/dF_kL = Finv_Lk, d Finv_Ji/dF_kL = -Finv_Jk Finv_Li
            for i in 0..D {
                for j in 0..D {
                    let fji = Finv[j * D + i];
                    for k in 0..D {
                        let fjk = Finv[j * D + k];
                        for l in 0..D {
                            let id = if i == k && j == l { self.mu } else { 0.0 };
                            A[((i * D + j) * D + k) * D + l] = id
                                + self.lambda * fji * Finv[l * D + k]
                                - c * Finv[l * D + i] * fjk;
                        }
                    }
                }
            }
        }
        Ok(())
    }
}

/// Trace and von Mises equivalent of a 3x3 row-major Cauchy stress.
pub fn trace_and_von_mises(sigma: &[f64; 9]) -> (f64, f64) {
    let (s11, s22, s33) = (sigma[0], sigma[4], sigma[8]);
    let s12 = 0.5 * (sigma[1] + sigma[3]);
    let s23 = 0.5 * (sigma[5] + sigma[7]);
    let s13 = 0.5 * (sigma[2] + sigma[6]);
    let vm2 = 0.5 * ((s11 - s22).powi(2) + (s22 - s33).powi(2) + (s33 - s11).powi(2))
        + 3.0 * (s12 * s12 + s23 * s23 + s13 * s13);
    (s11 + s22 + s33, vm2.max(0.0).sqrt())
}

#[cfg(test)]
#[allow(non_snake_case)]
mod tests {
    use super::*;

    use crate::material::test_support::{check_stress_and_tangent, max_abs, random_F, Lcg};

    fn mat() -> NeoHookean {
        NeoHookean::from_young_poisson(3.0, 0.3).unwrap()
    }

    #[test]
    fn pk1_is_energy_derivative_and_tangent_is_pk1_derivative() {
        let checked = check_stress_and_tangent(&mat(), |m, d, F| m.energy(d, F).unwrap(), 7);
        assert_eq!(checked.len(), 10);
    }

    #[test]
    fn cauchy_equals_p_f_transpose_over_j() {
        let m = mat();
        let mut rng = Lcg(11);
        for dim in [2usize, 3] {
            let F = random_F(dim, &mut rng);
            let mut P = vec![0.0; dim * dim];
            m.pk1(dim, &F, &mut P).unwrap();
            let J = if dim == 2 {
                det_inv::<2>(&F).0
            } else {
                det_inv::<3>(&F).0
            };
            let mut s = [0.0; 9];
            m.cauchy(dim, &F, &mut s).unwrap();
            for i in 0..dim {
                for j in 0..dim {
                    let pft: f64 = (0..dim)
                        .map(|k| P[i * dim + k] * F[j * dim + k])
                        .sum::<f64>()
                        / J;
                    assert!((s[i * 3 + j] - pft).abs() < 1e-12 * (1.0 + pft.abs()));
                }
            }
            if dim == 2 {
                // plane strain: P_33 = Lambda ln J (F33 = 1), sigma_33 = P_33 / J
                assert!((s[8] - m.lambda * J.ln() / J).abs() < 1e-14);
                assert!(s[2] == 0.0 && s[5] == 0.0 && s[6] == 0.0 && s[7] == 0.0);
            }
        }
    }

    #[test]
    fn stress_vanishes_at_identity_and_rotations() {
        let m = mat();
        let angles = [0.0, 0.3, std::f64::consts::FRAC_PI_2, 2.5];
        for &t in &angles {
            let (c, s) = (f64::cos(t), f64::sin(t));
            let F2 = [c, -s, s, c];
            // rotation about an oblique axis via Rodrigues' formula
            let a = [1.0 / 3f64.sqrt(); 3];
            let mut F3 = [0.0; 9];
            for i in 0..3 {
                for j in 0..3 {
                    let d = if i == j { 1.0 } else { 0.0 };
                    let eps = match (i, j) {
                        (0, 1) => -a[2],
                        (1, 0) => a[2],
                        (0, 2) => a[1],
                        (2, 0) => -a[1],
                        (1, 2) => -a[0],
                        (2, 1) => a[0],
                        _ => 0.0,
                    };
                    F3[i * 3 + j] = c * d + s * eps + (1.0 - c) * a[i] * a[j];
                }
            }
            for (dim, F) in [(2usize, &F2[..]), (3, &F3[..])] {
                let mut P = vec![0.0; dim * dim];
                m.pk1(dim, F, &mut P).unwrap();
                let mut sig = [0.0; 9];
                m.cauchy(dim, F, &mut sig).unwrap();
                assert!(max_abs(&P) < 1e-14, "angle {t} dim {dim}: P = {P:?}");
                assert!(
                    max_abs(&sig) < 1e-14,
                    "angle {t} dim {dim}: sigma = {sig:?}"
                );
                assert!(m.energy(dim, F).unwrap().abs() < 1e-14);
            }
        }
    }

    #[test]
    fn non_positive_jacobian_is_an_error() {
        let m = mat();
        let mut P = [0.0; 4];
        let mut A = [0.0; 16];
        let F = [-1.0, 0.0, 0.0, 1.0];
        let err = m.pk1_tangent(2, &F, &mut P, &mut A).unwrap_err();
        assert_eq!(err, MaterialError::NonPositiveJacobian { J: -1.0 });
        assert!(err.to_string().contains("-1"));
        let F3 = [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0];
        assert!(matches!(
            m.energy(3, &F3),
            Err(MaterialError::NonPositiveJacobian { .. })
        ));
        let mut s = [0.0; 9];
        assert!(m.cauchy(3, &F3, &mut s).is_err());
        assert!(matches!(
            m.pk1(4, &F3, &mut P),
            Err(MaterialError::UnsupportedDimension { dim: 4 })
        ));
        assert!(matches!(
            m.pk1(3, &F3, &mut P),
            Err(MaterialError::WrongLength { what: "P", .. })
        ));
    }

    #[test]
    fn from_young_poisson_validates_and_converts() {
        let m = NeoHookean::from_young_poisson(2.6, 0.3).unwrap();
        assert!((m.mu - 1.0).abs() < 1e-15);
        assert!((m.lambda - 1.5).abs() < 1e-14);
        let e = NeoHookean::from_young_poisson(-1.0, 0.3).unwrap_err();
        assert!(e.to_string().contains("-1"));
        let e = NeoHookean::from_young_poisson(1.0, 0.5).unwrap_err();
        assert!(e.to_string().contains("0.5"));
        assert!(NeoHookean::from_young_poisson(f64::NAN, 0.3).is_err());
        assert!(NeoHookean::from_young_poisson(1.0, -1.0).is_err());
    }

    #[test]
    fn von_mises_of_uniaxial_stress_is_its_magnitude() {
        let s = [2.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
        let (tr, vm) = trace_and_von_mises(&s);
        assert_eq!(tr, 2.0);
        assert!((vm - 2.0).abs() < 1e-15);
        let shear = [0.0, 1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0];
        assert!((trace_and_von_mises(&shear).1 - 3f64.sqrt()).abs() < 1e-15);
    }
}
