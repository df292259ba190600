//! Shared helpers of the material tests: a reproducible generator of deformation gradients and the
//! central-difference check that `P = dW/dF` and `A = dP/dF`, for any [`ConstitutiveLaw`].
#![allow(non_snake_case)]

use super::ConstitutiveLaw;

/// Small deterministic generator so the tests are reproducible without extra crates.
pub(crate) struct Lcg(pub u64);

impl Lcg {
    /// Uniform in [-1, 1).
    pub(crate) fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((self.0 >> 11) as f64) / ((1u64 << 53) as f64) * 2.0 - 1.0
    }
}

/// `I + 0.3 * (uniform in [-1, 1))` per entry, row-major `[dim][dim]`.
pub(crate) fn random_F(dim: usize, rng: &mut Lcg) -> Vec<f64> {
    (0..dim * dim)
        .map(|p| if p % (dim + 1) == 0 { 1.0 } else { 0.0 } + 0.3 * rng.next())
        .collect()
}

pub(crate) fn max_abs(v: &[f64]) -> f64 {
    v.iter().fold(0.0f64, |m, x| m.max(x.abs()))
}

/// At five random `F` per dimension (2 and 3): `P` against central differences of `energy` and `A`
/// against central differences of `P`, both to 1e-6 relative; returns the tangents checked, so a
/// caller can assert more of them (e.g. symmetry).
pub(crate) fn check_stress_and_tangent<L: ConstitutiveLaw>(
    m: &L,
    energy: impl Fn(&L, usize, &[f64]) -> f64,
    seed: u64,
) -> Vec<(usize, Vec<f64>)> {
    let mut rng = Lcg(seed);
    let mut tangents = Vec::new();
    for dim in [2usize, 3] {
        for _ in 0..5 {
            let F = random_F(dim, &mut rng);
            let n = dim * dim;
            let mut P = vec![0.0; n];
            let mut A = vec![0.0; n * n];
            m.pk1_tangent(dim, &F, &mut P, &mut A).unwrap();
            let h = 1e-6;
            let mut P_fd = vec![0.0; n];
            let mut A_fd = vec![0.0; n * n];
            for kl in 0..n {
                let mut Fp = F.clone();
                let mut Fm = F.clone();
                Fp[kl] += h;
                Fm[kl] -= h;
                P_fd[kl] = (energy(m, dim, &Fp) - energy(m, dim, &Fm)) / (2.0 * h);
                let mut Pp = vec![0.0; n];
                let mut Pm = vec![0.0; n];
                m.pk1(dim, &Fp, &mut Pp).unwrap();
                m.pk1(dim, &Fm, &mut Pm).unwrap();
                for ij in 0..n {
                    A_fd[ij * n + kl] = (Pp[ij] - Pm[ij]) / (2.0 * h);
                }
            }
            let eP: Vec<f64> = P.iter().zip(&P_fd).map(|(a, b)| a - b).collect();
            let eA: Vec<f64> = A.iter().zip(&A_fd).map(|(a, b)| a - b).collect();
            assert!(
                max_abs(&eP) < 1e-6 * max_abs(&P),
                "dim {dim}: P error {}",
                max_abs(&eP)
            );
            assert!(
                max_abs(&eA) < 1e-6 * max_abs(&A),
                "dim {dim}: A error {}",
                max_abs(&eA)
            );
            tangents.push((dim, A));
        }
    }
    tangents
}
