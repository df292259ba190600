//! Small-strain (geometrically linear) isotropic linear elasticity, for validation against classical
//! solutions (Hertz contact, beams):
//! `eps = sym(F - I)`, `sigma = lambda tr(eps) I + 2 mu eps`, `W = lambda/2 tr(eps)^2 + mu eps:eps`.
//!
//! The element kernels are total Lagrangian: they take `P(F)` and `A = dP/dF` and assemble
//! `r_a = int P grad_X N_a dV` (see `crate::fem::kernel`). Returning `P = sigma(eps(F))` and the constant
//! `A_iJkL = lambda d_iJ d_kL + mu (d_ik d_JL + d_iL d_Jk)` turns that into the small-strain weak form
//! `int sigma : grad N dV` on the reference configuration, exactly: `sigma` is symmetric, so
//! `sigma : grad N = sigma : sym grad N`, and `r(u)` is linear in `u` with tangent `K` independent of `u`.
//! Hence a rigid rotation by `theta` is *not* stress free: `eps = sym(R - I) = O(theta^2)`.
//!
//! In 2D the state is plane strain (`eps_i3 = 0`): `F`, `P` and `A` are the in-plane blocks, and
//! [`LinearElastic::cauchy`] returns `sigma_33 = lambda tr(eps)`. No `det F > 0` check is made: the
//! linearised theory has no notion of inversion.
//!
//! Tensors are flat row-major as in [`super::neo_hookean`]: `F`, `P`: `[D][D]`, `A`: `[D][D][D][D]`.

use super::neo_hookean::NeoHookean;
use super::{ConstitutiveLaw, MaterialError};

/// Isotropic Hooke law with Lame parameters `mu` (shear modulus) and `lambda`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LinearElastic {
    pub mu: f64,
    pub lambda: f64,
}

/// Small strain `eps = sym(F - I)` and its trace, stride `D` in a 9-array.
#[allow(non_snake_case)]
#[inline(always)]
fn small_strain<const D: usize>(F: &[f64]) -> ([f64; 9], f64) {
    let mut eps = [0.0; 9];
    let mut tr = 0.0;
    for i in 0..D {
        for j in 0..D {
            let d = if i == j { 1.0 } else { 0.0 };
            eps[i * D + j] = 0.5 * (F[i * D + j] + F[j * D + i]) - d;
        }
        tr += eps[i * D + i];
    }
    (eps, tr)
}

impl LinearElastic {
    /// Lame parameters from Young's modulus and Poisson's ratio: `mu = E/(2(1+nu))`, `lambda = 2 mu nu/(1-2 nu)`;
    /// the same checks (`E > 0`, `-1 < nu < 0.5`) as [`NeoHookean::from_young_poisson`].
    #[allow(non_snake_case)]
    pub fn from_young_poisson(E: f64, nu: f64) -> Result<Self, MaterialError> {
        let NeoHookean { mu, lambda } = NeoHookean::from_young_poisson(E, nu)?;
        Ok(Self { mu, lambda })
    }

    /// Stored energy per reference volume `W = lambda/2 tr(eps)^2 + mu eps:eps`; `F`: `[dim][dim]`.
    #[allow(non_snake_case)]
    pub fn energy(&self, dim: usize, F: &[f64]) -> Result<f64, MaterialError> {
        NeoHookean::check(dim, "F", F.len(), 2)?;
        let (eps, tr) = if dim == 2 {
            small_strain::<2>(F)
        } else {
            small_strain::<3>(F)
        };
        let ee: f64 = eps[..dim * dim].iter().map(|e| e * e).sum();
        Ok(0.5 * self.lambda * tr * tr + self.mu * ee)
    }

    /// Cauchy stress `sigma = lambda tr(eps) I + 2 mu eps` (equal to `P`), always 3x3 row-major; in plane strain
    /// `sigma_33 = lambda tr(eps)` and the out-of-plane shears are zero.
    #[allow(non_snake_case)]
    pub fn cauchy(&self, dim: usize, F: &[f64], sigma: &mut [f64; 9]) -> Result<(), MaterialError> {
        NeoHookean::check(dim, "F", F.len(), 2)?;
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
        self.pk1_impl::<3>(&F3, sigma, None)
    }
}

impl ConstitutiveLaw for LinearElastic {
    /// Specialised stress (and tangent) evaluation; slices have exactly the sizes checked by the callers.
    /// Never fails; the `Result` matches [`NeoHookean`]'s signature.
    #[allow(non_snake_case)]
    #[inline(always)]
    fn pk1_impl<const D: usize>(
        &self,
        F: &[f64],
        P: &mut [f64],
        A: Option<&mut [f64]>,
    ) -> Result<(), MaterialError> {
        let (eps, tr) = small_strain::<D>(F);
        for i in 0..D {
            for j in 0..D {
                let d = if i == j { 1.0 } else { 0.0 };
                P[i * D + j] = self.lambda * tr * d + 2.0 * self.mu * eps[i * D + j];
            }
        }
        if let Some(A) = A {
            let delta = |a: usize, b: usize| if a == b { 1.0 } else { 0.0 };
            for i in 0..D {
                for j in 0..D {
                    for k in 0..D {
                        for l in 0..D {
                            A[((i * D + j) * D + k) * D + l] = self.lambda
                                * delta(i, j)
                                * delta(k, l)
                                + self.mu * (delta(i, k) * delta(j, l) + delta(i, l) * delta(j, k));
                        }
                    }
                }
            }
        }
        Ok(())
    }
}

#[cfg(test)]
#[allow(non_snake_case)]
mod tests {
    use super::*;

    use crate::material::test_support::{check_stress_and_tangent, max_abs};

    fn mat() -> LinearElastic {
        LinearElastic::from_young_poisson(3.0, 0.3).unwrap()
    }

    /// Hooke's law written out for a symmetric 3x3 strain.
    fn hooke(m: &LinearElastic, eps: &[f64; 9]) -> [f64; 9] {
        let tr = eps[0] + eps[4] + eps[8];
        std::array::from_fn(|p| {
            let d = if p % 4 == 0 { 1.0 } else { 0.0 };
            m.lambda * tr * d + 2.0 * m.mu * eps[p]
        })
    }

    #[test]
    fn lame_parameters_and_validation_follow_neo_hookean() {
        let m = LinearElastic::from_young_poisson(2.6, 0.3).unwrap();
        assert!((m.mu - 1.0).abs() < 1e-15);
        assert!((m.lambda - 1.5).abs() < 1e-14);
        assert!(matches!(
            LinearElastic::from_young_poisson(0.0, 0.3),
            Err(MaterialError::InvalidYoungsModulus { .. })
        ));
        assert!(matches!(
            LinearElastic::from_young_poisson(1.0, 0.5),
            Err(MaterialError::InvalidPoissonRatio { .. })
        ));
    }

    #[test]
    fn pk1_is_energy_derivative_and_tangent_is_pk1_derivative() {
        let checked = check_stress_and_tangent(&mat(), |m, d, F| m.energy(d, F).unwrap(), 7);
        assert_eq!(checked.len(), 10);
        // the kernel fills only half of K: A must have major symmetry
        for (dim, A) in checked {
            let n = dim * dim;
            for ij in 0..n {
                for kl in 0..n {
                    assert_eq!(A[ij * n + kl], A[kl * n + ij]);
                }
            }
        }
    }

    #[test]
    fn pk1_is_hooke_stress_of_the_symmetric_part_of_grad_u() {
        let m = mat();
        let eps = [1e-3, 2e-4, -3e-4, 2e-4, -5e-4, 1e-4, -3e-4, 1e-4, 7e-4];
        // a skew part (infinitesimal rotation) adds nothing
        let w = [0.0, 4e-3, -1e-3, -4e-3, 0.0, 2e-3, 1e-3, -2e-3, 0.0];
        let F: [f64; 9] =
            std::array::from_fn(|p| if p % 4 == 0 { 1.0 } else { 0.0 } + eps[p] + w[p]);
        let expected = hooke(&m, &eps);
        let mut P = [0.0; 9];
        m.pk1(3, &F, &mut P).unwrap();
        let mut s = [0.0; 9];
        m.cauchy(3, &F, &mut s).unwrap();
        for p in 0..9 {
            assert!(
                (P[p] - expected[p]).abs() < 1e-15,
                "P = {P:?}, Hooke {expected:?}"
            );
            assert_eq!(s[p], P[p], "Cauchy stress is P itself");
        }
        // uniaxial stress in 3D: eps = diag(e, -nu e, -nu e) gives sigma = diag(E e, 0, 0)
        let (E, nu, e) = (3.0, 0.3, 1e-3);
        let F = [
            1.0 + e,
            0.0,
            0.0,
            0.0,
            1.0 - nu * e,
            0.0,
            0.0,
            0.0,
            1.0 - nu * e,
        ];
        m.pk1(3, &F, &mut P).unwrap();
        assert!(
            (P[0] - E * e).abs() < 1e-15 && max_abs(&P[1..]) < 1e-15,
            "{P:?}"
        );
        // plane strain: sigma_33 = lambda tr(eps); eps = diag(e, -nu/(1-nu) e) makes sigma_22 = 0 and
        // sigma_11 = E/(1 - nu^2) e
        let e22 = -nu / (1.0 - nu) * e;
        let F2 = [1.0 + e, 3e-4, 3e-4, 1.0 + e22];
        let mut P2 = [0.0; 4];
        m.pk1(2, &F2, &mut P2).unwrap();
        let s2 = hooke(&m, &[e, 3e-4, 0.0, 3e-4, e22, 0.0, 0.0, 0.0, 0.0]);
        assert!((P2[0] - E / (1.0 - nu * nu) * e).abs() < 1e-15, "{P2:?}");
        assert!(P2[3].abs() < 1e-15, "{P2:?}");
        assert!((P2[1] - 2.0 * m.mu * 3e-4).abs() < 1e-15 && P2[1] == P2[2]);
        m.cauchy(2, &F2, &mut s).unwrap();
        for p in 0..9 {
            assert!((s[p] - s2[p]).abs() < 1e-15, "sigma = {s:?}, Hooke {s2:?}");
        }
        assert!((s[8] - m.lambda * (e + e22)).abs() < 1e-15);
        assert!(s[2] == 0.0 && s[5] == 0.0 && s[6] == 0.0 && s[7] == 0.0);
    }

    /// A rigid rotation `R` by `theta` gives `eps = sym(R - I) = -(1 - cos theta) (I - a a^T)` (3D, axis `a`;
    /// in 2D the in-plane identity): the stress is exactly Hooke's law of that strain, i.e.
    /// `-(1 - cos theta) * (const)` = `O(theta^2)`, not zero. The energy is `O(theta^4)`.
    #[test]
    fn rigid_rotation_gives_second_order_stress() {
        let m = mat();
        let a = [1.0 / 3f64.sqrt(); 3];
        let mut prev: Option<(f64, f64, f64)> = None;
        for &t in &[1e-2, 5e-3] {
            let (c, s) = (f64::cos(t), f64::sin(t));
            // 2D: eps = (c - 1) I_2, sigma_11 = sigma_22 = 2 (lambda + mu) (c - 1), sigma_33 = 2 lambda (c - 1)
            let F2 = [c, -s, s, c];
            let mut P2 = [0.0; 4];
            m.pk1(2, &F2, &mut P2).unwrap();
            let s11 = 2.0 * (m.lambda + m.mu) * (c - 1.0);
            assert!((P2[0] - s11).abs() < 1e-12 * s11.abs(), "{P2:?} vs {s11}");
            assert!((P2[3] - s11).abs() < 1e-12 * s11.abs());
            assert!(P2[1].abs() < 1e-18 && P2[2].abs() < 1e-18, "{P2:?}");
            let mut sig = [0.0; 9];
            m.cauchy(2, &F2, &mut sig).unwrap();
            assert!((sig[8] - 2.0 * m.lambda * (c - 1.0)).abs() < 1e-12 * s11.abs());
            // leading order: sigma_11 = -(lambda + mu) theta^2
            assert!((s11 / (t * t) + (m.lambda + m.mu)).abs() < 1e-4 * (m.lambda + m.mu));

            // 3D, oblique axis (Rodrigues)
            let F3: [f64; 9] = std::array::from_fn(|p| {
                let (i, j) = (p / 3, p % 3);
                let d = if i == j { 1.0 } else { 0.0 };
                let skew = match (i, j) {
                    (0, 1) => -a[2],
                    (1, 0) => a[2],
                    (0, 2) => a[1],
                    (2, 0) => -a[1],
                    (1, 2) => -a[0],
                    (2, 1) => a[0],
                    _ => 0.0,
                };
                c * d + s * skew + (1.0 - c) * a[i] * a[j]
            });
            let eps: [f64; 9] = std::array::from_fn(|p| {
                let (i, j) = (p / 3, p % 3);
                let d = if i == j { 1.0 } else { 0.0 };
                (1.0 - c) * (a[i] * a[j] - d)
            });
            let expected = hooke(&m, &eps);
            let mut P3 = [0.0; 9];
            m.pk1(3, &F3, &mut P3).unwrap();
            let scale = max_abs(&expected);
            assert!(scale > 0.0);
            for p in 0..9 {
                assert!(
                    (P3[p] - expected[p]).abs() < 1e-9 * scale,
                    "theta {t}: P = {P3:?}, expected {expected:?}"
                );
            }
            let norm = max_abs(&P3);
            let w = m.energy(3, &F3).unwrap();
            assert!(w > 0.0);
            if let Some((t0, n0, w0)) = prev {
                // halving theta divides the stress by 4 and the energy by 16
                let r = t0 / t;
                assert!(((n0 / norm) / (r * r) - 1.0).abs() < 1e-4, "{n0} / {norm}");
                assert!(((w0 / w) / r.powi(4) - 1.0).abs() < 1e-4, "{w0} / {w}");
            }
            prev = Some((t, norm, w));
        }
    }

    #[test]
    fn inverted_f_is_not_an_error_and_lengths_are_checked() {
        let m = mat();
        let mut P = [0.0; 4];
        let mut A = [0.0; 16];
        m.pk1_tangent(2, &[-1.0, 0.0, 0.0, 1.0], &mut P, &mut A)
            .unwrap();
        assert!((P[0] - (-2.0) * (m.lambda + 2.0 * m.mu)).abs() < 1e-14);
        let F3 = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];
        assert!(matches!(
            m.pk1(4, &F3, &mut P),
            Err(MaterialError::UnsupportedDimension { dim: 4 })
        ));
        assert!(matches!(
            m.pk1(3, &F3, &mut P),
            Err(MaterialError::WrongLength { what: "P", .. })
        ));
        assert!(matches!(
            m.energy(2, &F3),
            Err(MaterialError::WrongLength { what: "F", .. })
        ));
    }
}
