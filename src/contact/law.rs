//! Pointwise contact laws (Corbett & Sauer 2014, eqs. 5-7): a gap vector `g` and the partner's unit
//! normal `n` go in, a traction and its derivatives come out. Nothing here knows about meshes,
//! projections or quadrature; `crate::contact::kernel` chains these derivatives with those of the
//! gap and normal.
//!
//! Vectors are `[f64; 3]` and matrices row-major `[f64; 9]` (`m[3 i + j] = d t_i / d x_j`); a 2D
//! problem uses the leading 2 components and the upper-left 2x2 block (the rest stays zero).
#![allow(clippy::needless_range_loop)] // index loops mirror the equations

/// A traction and its derivatives with respect to the gap vector and the normal.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Traction {
    /// The traction `t` [3].
    pub t: [f64; 3],
    /// `d t_i / d g_j`, row-major [3][3].
    pub dt_dg: [f64; 9],
    /// `d t_i / d n_j`, row-major [3][3].
    pub dt_dn: [f64; 9],
}

impl Traction {
    /// No traction (inactive point).
    pub const ZERO: Traction = Traction {
        t: [0.0; 3],
        dt_dg: [0.0; 9],
        dt_dn: [0.0; 9],
    };

    /// True when the traction and its derivatives all vanish.
    pub fn is_zero(&self) -> bool {
        self.t
            .iter()
            .chain(&self.dt_dg)
            .chain(&self.dt_dn)
            .all(|&v| v == 0.0)
    }
}

fn dot(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn norm(a: &[f64; 3]) -> f64 {
    dot(a, a).sqrt()
}

/// Penalty law, eq. (5): `t = -eps_n g_n n` for `g_n = g . n < 0`, zero otherwise (a current traction).
/// A point touching within `touch` (`g_n <= touch`, a round-off tolerance) counts as active: its
/// traction is (nearly) zero but its stiffness is not, so Newton's first iteration from surfaces that
/// just touch (a patch test, an indenter placed on a block) already sees the contact instead of
/// passing through it where round-off left `g_n = +1e-16`.
pub fn penalty(eps_n: f64, touch: f64, g: &[f64; 3], n: &[f64; 3]) -> Traction {
    let g_n = dot(g, n);
    if g_n > touch {
        return Traction::ZERO;
    }
    let mut out = Traction::ZERO;
    for i in 0..3 {
        out.t[i] = -eps_n * g_n * n[i];
        for j in 0..3 {
            // d(g.n)/dg_j = n_j ; d(g.n)/dn_j = g_j ; d n_i/d n_j = delta_ij
            out.dt_dg[3 * i + j] = -eps_n * n[i] * n[j];
            out.dt_dn[3 * i + j] = -eps_n * (g[j] * n[i] + if i == j { g_n } else { 0.0 });
        }
    }
    out
}

/// The augmented Lagrangian form of [`penalty`]: `t = <lambda - eps_n g_n> n` with the point's
/// multiplier `lambda >= 0` (a pressure, fixed during a Newton solve). Active where
/// `g_n <= lambda / eps_n + touch`. With `lambda = 0` it is [`penalty`].
pub fn penalty_augmented(
    eps_n: f64,
    lambda: f64,
    touch: f64,
    g: &[f64; 3],
    n: &[f64; 3],
) -> Traction {
    let g_n = dot(g, n);
    if g_n > lambda / eps_n + touch {
        return Traction::ZERO;
    }
    let p = lambda - eps_n * g_n;
    let mut out = Traction::ZERO;
    for i in 0..3 {
        out.t[i] = p * n[i];
        for j in 0..3 {
            out.dt_dg[3 * i + j] = -eps_n * n[i] * n[j];
            out.dt_dn[3 * i + j] = -eps_n * g[j] * n[i] + if i == j { p } else { 0.0 };
        }
    }
    out
}

/// Quadratic penalty against penetration: `t = eps_n g_n^2 n` where `g_n = g . n < 0`, zero
/// otherwise. Its traction and tangent are continuous at `g_n = 0`, so a bonded interface that sits
/// at `g_n = 0` (the cohesive law's material pairing) has no kink there (`eps_n` in force per
/// length^4 in 3D, per length^3 in 2D).
pub fn penalty_quadratic(eps_n: f64, g: &[f64; 3], n: &[f64; 3]) -> Traction {
    let g_n = dot(g, n);
    if g_n >= 0.0 {
        return Traction::ZERO;
    }
    let mut out = Traction::ZERO;
    for i in 0..3 {
        out.t[i] = eps_n * g_n * g_n * n[i];
        for j in 0..3 {
            out.dt_dg[3 * i + j] = 2.0 * eps_n * g_n * n[i] * n[j];
            out.dt_dn[3 * i + j] =
                eps_n * (2.0 * g_n * g[j] * n[i] + if i == j { g_n * g_n } else { 0.0 });
        }
    }
    out
}

/// Magnitude of the van der Waals traction, eq. (6), and its derivative in `r = |g|`:
/// `T_c(r) = A_H / (2 pi r0^3) [ (r0/r)^9 / 45 - (r0/r)^3 / 3 ]`; it vanishes where
/// `(r0/r)^6 = 15`, the equilibrium spacing `r_eq = 15^(-1/6) r0`.
pub fn van_der_waals_magnitude(a_h: f64, r0: f64, r: f64) -> (f64, f64) {
    let c = a_h / (2.0 * std::f64::consts::PI * r0.powi(3));
    let s = r0 / r;
    let (s3, s9) = (s.powi(3), s.powi(9));
    let tc = c * (s9 / 45.0 - s3 / 3.0);
    // d s / d r = -s / r
    let dtc = c * (-(9.0 / 45.0) * s9 + s3) / r;
    (tc, dtc)
}

/// Equilibrium distance of eq. (6), where the van der Waals traction vanishes: `15^(-1/6) r0`.
pub fn van_der_waals_equilibrium(r0: f64) -> f64 {
    r0 * 15f64.powf(-1.0 / 6.0)
}

/// Van der Waals adhesion, eq. (6): `T = T_c(|g|) n` (a reference traction).
pub fn van_der_waals(a_h: f64, r0: f64, g: &[f64; 3], n: &[f64; 3]) -> Traction {
    let r = norm(g);
    if r == 0.0 {
        return Traction::ZERO;
    }
    let (tc, dtc) = van_der_waals_magnitude(a_h, r0, r);
    let mut out = Traction::ZERO;
    for i in 0..3 {
        out.t[i] = tc * n[i];
        for j in 0..3 {
            out.dt_dg[3 * i + j] = dtc * n[i] * g[j] / r;
            out.dt_dn[3 * i + j] = if i == j { tc } else { 0.0 };
        }
    }
    out
}

/// Exponential cohesive zone, eq. (7): `T = -T0 (|g0|/g_0) exp(1 - |g0|/g_0) g0/|g0|`
/// `= -(T0/g_0) exp(1 - |g0|/g_0) g0` (a reference traction; `g0` is the gap to the material point
/// paired in the reference configuration, so no normal enters).
pub fn cohesive(t0: f64, g_0: f64, g0: &[f64; 3]) -> Traction {
    let r = norm(g0);
    let e = (1.0 - r / g_0).exp();
    let c = -t0 / g_0 * e;
    let mut out = Traction::ZERO;
    for i in 0..3 {
        out.t[i] = c * g0[i];
        for j in 0..3 {
            // d(c g_i)/d g_j = c delta_ij + g_i dc/dr g_j/r, dc/dr = -c/g_0
            let radial = if r > 0.0 {
                -c / g_0 * g0[i] * g0[j] / r
            } else {
                0.0
            };
            out.dt_dg[3 * i + j] = if i == j { c } else { 0.0 } + radial;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Central differences of a law's traction in g and in n, against its derivatives.
    fn check(f: &dyn Fn(&[f64; 3], &[f64; 3]) -> Traction, g: [f64; 3], n: [f64; 3], tol: f64) {
        let base = f(&g, &n);
        let h = 1e-6;
        for j in 0..3 {
            for (which, d_an) in [(0, &base.dt_dg), (1, &base.dt_dn)] {
                let (mut gp, mut gm, mut np, mut nm) = (g, g, n, n);
                if which == 0 {
                    gp[j] += h;
                    gm[j] -= h;
                } else {
                    np[j] += h;
                    nm[j] -= h;
                }
                let (tp, tm) = (f(&gp, &np).t, f(&gm, &nm).t);
                for i in 0..3 {
                    let fd = (tp[i] - tm[i]) / (2.0 * h);
                    let an = d_an[3 * i + j];
                    assert!(
                        (fd - an).abs() <= tol * (1.0 + an.abs()),
                        "d t_{i}/d {}_{j}: fd {fd} analytic {an}",
                        if which == 0 { "g" } else { "n" }
                    );
                }
            }
        }
    }

    fn unit(v: [f64; 3]) -> [f64; 3] {
        let l = norm(&v);
        [v[0] / l, v[1] / l, v[2] / l]
    }

    #[test]
    fn quadratic_penalty_derivatives_match_central_differences_and_vanish_at_contact() {
        let n = unit([0.3, -0.2, 0.9]);
        check(
            &|g, n| penalty_quadratic(50.0, g, n),
            [0.01, 0.02, -0.03],
            n,
            1e-6,
        );
        // open: nothing; just touching: traction and tangent both zero (no kink)
        assert_eq!(penalty_quadratic(50.0, &[0.0, 0.0, 0.1], &n).t, [0.0; 3]);
        let t = penalty_quadratic(50.0, &[0.0; 3], &n);
        assert!(t.t.iter().chain(&t.dt_dg).all(|&v| v == 0.0));
        // penetrating by d: pushed out along n with eps d^2
        let d = 0.02;
        let t = penalty_quadratic(50.0, &[-d * n[0], -d * n[1], -d * n[2]], &n);
        assert!((dot(&t.t, &n) - 50.0 * d * d).abs() < 1e-15);
    }

    #[test]
    fn penalty_derivatives_match_central_differences() {
        let n = unit([0.3, -0.2, 0.9]);
        check(
            &|g, n| penalty(1e3, 0.0, g, n),
            [0.01, -0.02, -0.05],
            n,
            1e-6,
        );
        // open gap: no traction, no derivatives
        assert!(penalty(1e3, 1e-12, &[0.0, 0.0, 0.1], &[0.0, 0.0, 1.0]).is_zero());
        // touching within the tolerance: no traction, but stiffness
        let t = penalty(1e3, 1e-12, &[0.0, 0.0, 1e-16], &[0.0, 0.0, 1.0]);
        assert!(t.t[2].abs() < 1e-12 && t.dt_dg[8] == -1e3);
    }

    #[test]
    fn augmented_penalty_derivatives_match_central_differences_and_reduce_to_penalty() {
        let n = unit([0.3, -0.2, 0.9]);
        // open by less than lambda / eps_n: still pressed, by lambda - eps_n g_n
        let g = [0.01, -0.02, 0.03];
        check(&|g, n| penalty_augmented(1e3, 40.0, 0.0, g, n), g, n, 1e-6);
        let t = penalty_augmented(1e3, 40.0, 0.0, &g, &n);
        assert!((dot(&t.t, &n) - (40.0 - 1e3 * dot(&g, &n))).abs() < 1e-12);
        assert!(dot(&t.t, &n) > 0.0);
        // open by more than lambda / eps_n: nothing
        let far = [0.0, 0.0, 0.2];
        assert!(penalty_augmented(1e3, 40.0, 0.0, &far, &n).is_zero());
        // lambda = 0 is the penalty law, bit for bit
        let gp = [0.01, -0.02, -0.05];
        let (a, b) = (
            penalty_augmented(1e3, 0.0, 1e-12, &gp, &n),
            penalty(1e3, 1e-12, &gp, &n),
        );
        assert_eq!(a.t, b.t);
        assert_eq!(a.dt_dg, b.dt_dg);
    }

    #[test]
    fn penalty_pushes_along_the_partner_normal() {
        let t = penalty(100.0, 0.0, &[0.0, -0.01, 0.0], &[0.0, 1.0, 0.0]);
        assert!((t.t[1] - 1.0).abs() < 1e-12 && t.t[0] == 0.0);
    }

    #[test]
    fn van_der_waals_derivatives_match_central_differences() {
        let n = unit([0.1, 1.0, 0.2]);
        for r in [0.3, 0.5, 0.8] {
            let g = [0.02, r, -0.01];
            check(
                &|g, n| van_der_waals(1e-19 / 1e-27 / 1e9, 0.4, g, n),
                g,
                n,
                1e-5,
            );
        }
    }

    #[test]
    fn van_der_waals_vanishes_at_equilibrium_and_attracts_beyond() {
        let r0 = 0.4;
        let r_eq = van_der_waals_equilibrium(r0);
        let (tc, _) = van_der_waals_magnitude(1.0, r0, r_eq);
        assert!(tc.abs() < 1e-12, "T_c(r_eq) = {tc}");
        assert!(van_der_waals_magnitude(1.0, r0, 1.2 * r_eq).0 < 0.0);
        assert!(van_der_waals_magnitude(1.0, r0, 0.9 * r_eq).0 > 0.0);
    }

    #[test]
    fn cohesive_derivatives_match_central_differences() {
        for g in [[0.01, 0.02, 0.0], [0.03, -0.06, 0.04], [-0.2, 0.1, 0.05]] {
            check(&|g, _| cohesive(0.2, 0.05, g), g, [0.0, 0.0, 1.0], 1e-6);
        }
    }

    #[test]
    fn cohesive_peak_traction_is_t0_at_g0() {
        // |T| = T0 (r/g0) exp(1 - r/g0) peaks at r = g0 with value T0
        let t = cohesive(0.2, 0.05, &[0.0, 0.05, 0.0]);
        assert!((t.t[1] + 0.2).abs() < 1e-14, "{:?}", t.t);
        let t2 = cohesive(0.2, 0.05, &[0.0, 0.051, 0.0]);
        assert!(t2.t[1].abs() < 0.2);
    }
}
