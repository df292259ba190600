//! Q1E4: the 4-mode enhanced assumed strain quadrilateral of Simo & Armero 1992 (plane strain, finite strain).
//!
//! `F = I + Grad u + F~` with the enhanced part `F~_iK = (j0/j(xi)) sum_J alpha_(iJ) xi_J (J0^-1)_JK`, i.e. the
//! parent-domain gradient `[[xi a_00, eta a_01], [xi a_10, eta a_11]]` mapped with the centre Jacobian `J0`
//! (`j0 = det J0`) and scaled by `j0/j`. Since `int (j0/j) xi_J j dxi = 0`, `F~` integrates to zero over the element
//! and the patch test passes. The enhanced field acts like two extra "nodes" (one per parent direction `J`) whose
//! gradient vectors are `g_J = (j0/j) xi_J J0^-T e_J`, so the element is evaluated by the generic
//! [`TlElement`] kernel with 6 nodes; `alpha[J*2 + i] = alpha_(iJ)` are that kernel's dofs 8..12.
//!
//! Per call the local equations `R_alpha(u, alpha) = 0` are solved by Newton from the caller's warm start, then
//! `alpha` is condensed out: `K = K_uu - K_ua K_aa^-1 K_au`, the exact tangent of the condensed residual `r(u)`.

use super::kernel::TlElement;
use super::quad4;
use super::quadrature::tensor_rule;
use super::ElementError;
use crate::material::Material;
use nalgebra::Matrix4;

/// Bound on local Newton iterations for `alpha`.
pub const MAX_LOCAL_ITERATIONS: usize = 25;
/// Local convergence: `|R_alpha| <= LOCAL_TOLERANCE |r_u| + ROUNDOFF_FLOOR (mu + |Lambda|) A_e`; the floor only
/// matters when the element is (nearly) stress free, where `|r_u|` itself is at rounding level.
pub const LOCAL_TOLERANCE: f64 = 1e-12;
const ROUNDOFF_FLOOR: f64 = 1e-14;

/// One Q1E4 element with its precomputed 2x2 Gauss tables (4 corner nodes plus 2 enhanced pseudo-nodes).
#[derive(Debug, Clone, PartialEq)]
pub struct Q1e4Element {
    tl: TlElement,
}

impl Q1e4Element {
    /// Precompute the element from its nodal coordinates `X_e`: [4][2] in quad4 node order.
    #[allow(non_snake_case)]
    pub fn new(X_e: &[f64; 8]) -> Result<Self, ElementError> {
        let rule = tensor_rule(&[2, 2])?;
        let jacobian = |xi: &[f64; 2]| {
            let dN = quad4::shape_derivatives(xi);
            let mut Jac = nalgebra::Matrix2::<f64>::zeros();
            for (a, d) in dN.iter().enumerate() {
                for i in 0..2 {
                    for j in 0..2 {
                        Jac[(i, j)] += X_e[a * 2 + i] * d[j];
                    }
                }
            }
            (dN, Jac)
        };
        let mut dNdX = Vec::with_capacity(rule.n_points() * 12);
        let mut wdV = Vec::with_capacity(rule.n_points());
        let mut js = [0.0; 4];
        let mut Jinvs = [nalgebra::Matrix2::<f64>::zeros(); 4];
        for qp in 0..rule.n_points() {
            let xi = [rule.points[2 * qp], rule.points[2 * qp + 1]];
            let (_, Jac) = jacobian(&xi);
            let detJ = Jac.determinant();
            if detJ.is_nan() || detJ <= 0.0 {
                return Err(ElementError::NonPositiveReferenceJacobian { qp, detJ });
            }
            js[qp] = detJ;
            Jinvs[qp] = Jac
                .try_inverse()
                .ok_or(ElementError::NonPositiveReferenceJacobian { qp, detJ })?;
        }
        // j is linear in (xi, eta) for a bilinear quad, so j0 > 0 whenever all Gauss values are positive
        let (_, J0) = jacobian(&[0.0, 0.0]);
        let j0 = J0.determinant();
        let J0inv = J0
            .try_inverse()
            .ok_or(ElementError::NonPositiveReferenceJacobian { qp: 0, detJ: j0 })?;
        for qp in 0..rule.n_points() {
            let xi = [rule.points[2 * qp], rule.points[2 * qp + 1]];
            let (dN, _) = jacobian(&xi);
            for d in dN.iter() {
                for k in 0..2 {
                    dNdX.push(d[0] * Jinvs[qp][(0, k)] + d[1] * Jinvs[qp][(1, k)]);
                }
            }
            // enhanced pseudo-node J: g_J,K = (j0/j) xi_J (J0^-1)_JK
            let scale = j0 / js[qp];
            for (j, &xj) in xi.iter().enumerate() {
                for k in 0..2 {
                    dNdX.push(scale * xj * J0inv[(j, k)]);
                }
            }
            wdV.push(rule.weights[qp] * js[qp]);
        }
        Ok(Self {
            tl: TlElement::from_parts(6, 2, dNdX, wdV)?,
        })
    }

    /// Reference area of the element.
    pub fn area(&self) -> f64 {
        self.tl.volume()
    }

    fn extended(u_e: &[f64; 8], alpha: &[f64; 4]) -> [f64; 12] {
        let mut u = [0.0; 12];
        u[..8].copy_from_slice(u_e);
        u[8..].copy_from_slice(alpha);
        u
    }

    /// Condensed residual `r_e` ([8]) and tangent `k_e` ([8][8] row-major) at `u_e` ([4][2]). `alpha` ([4]) is the
    /// warm start on entry and the converged enhanced parameters on success; on error it is left unchanged.
    pub fn residual_tangent(
        &self,
        mat: &Material,
        u_e: &[f64; 8],
        alpha: &mut [f64; 4],
        r_e: &mut [f64; 8],
        k_e: Option<&mut [f64; 64]>,
    ) -> Result<(), ElementError> {
        let mut a = *alpha;
        let mut r = [0.0; 12];
        let mut k = [0.0; 144];
        let floor = ROUNDOFF_FLOOR * (mat.mu() + mat.lambda().abs()) * self.area();
        let mut residual = f64::NAN;
        let mut tolerance = f64::NAN;
        for it in 0..=MAX_LOCAL_ITERATIONS {
            self.tl
                .residual_tangent(mat, &Self::extended(u_e, &a), &mut r, Some(&mut k))?;
            residual = r[8..].iter().map(|x| x * x).sum::<f64>().sqrt();
            let r_u = r[..8].iter().map(|x| x * x).sum::<f64>().sqrt();
            tolerance = LOCAL_TOLERANCE * r_u + floor;
            let k_aa_inv = Matrix4::from_fn(|p, q| k[(8 + p) * 12 + 8 + q])
                .try_inverse()
                .ok_or(ElementError::SingularEnhancedTangent)?;
            if !residual.is_finite() {
                break;
            }
            if residual <= tolerance {
                r_e.copy_from_slice(&r[..8]);
                if let Some(k_e) = k_e {
                    // K = K_uu - K_ua K_aa^-1 K_au
                    let mut kinv_au = [0.0; 32];
                    for s in 0..4 {
                        for q in 0..8 {
                            kinv_au[s * 8 + q] =
                                (0..4).map(|t| k_aa_inv[(s, t)] * k[(8 + t) * 12 + q]).sum();
                        }
                    }
                    for p in 0..8 {
                        for q in 0..8 {
                            let c: f64 =
                                (0..4).map(|s| k[p * 12 + 8 + s] * kinv_au[s * 8 + q]).sum();
                            k_e[p * 8 + q] = k[p * 12 + q] - c;
                        }
                    }
                }
                *alpha = a;
                return Ok(());
            }
            if it == MAX_LOCAL_ITERATIONS {
                break;
            }
            for (s, a_s) in a.iter_mut().enumerate() {
                *a_s -= (0..4).map(|t| k_aa_inv[(s, t)] * r[8 + t]).sum::<f64>();
            }
        }
        Err(ElementError::EnhancedNotConverged {
            iterations: MAX_LOCAL_ITERATIONS,
            residual,
            tolerance,
        })
    }

    /// Cauchy stress at the 4 Gauss points, [4][9], for converged `alpha`.
    pub fn cauchy_at_qps(
        &self,
        mat: &Material,
        u_e: &[f64; 8],
        alpha: &[f64; 4],
        sigma: &mut [f64; 36],
    ) -> Result<(), ElementError> {
        self.tl
            .cauchy_at_qps(mat, &Self::extended(u_e, alpha), sigma)
    }

    /// `(I1, von Mises)` area-weighted averages over the Gauss points (as [`TlElement::stress_measures`]),
    /// using the enhanced `F`; `alpha` must be the converged value from [`Self::residual_tangent`].
    pub fn stress_measures(
        &self,
        mat: &Material,
        u_e: &[f64; 8],
        alpha: &[f64; 4],
    ) -> Result<(f64, f64), ElementError> {
        self.tl.stress_measures(mat, &Self::extended(u_e, alpha))
    }
}

/// One-shot form of [`Q1e4Element::residual_tangent`] that rebuilds the element tables from `X_e` ([4][2]);
/// prefer storing a [`Q1e4Element`] per element in loops.
#[allow(non_snake_case)]
pub fn q1e4_residual_tangent(
    X_e: &[f64; 8],
    u_e: &[f64; 8],
    alpha: &mut [f64; 4],
    mat: &Material,
    r_e: &mut [f64; 8],
    k_e: Option<&mut [f64; 64]>,
) -> Result<(), ElementError> {
    Q1e4Element::new(X_e)?.residual_tangent(mat, u_e, alpha, r_e, k_e)
}

/// One-shot form of [`Q1e4Element::stress_measures`].
#[allow(non_snake_case)]
pub fn q1e4_stress_measures(
    X_e: &[f64; 8],
    u_e: &[f64; 8],
    alpha: &[f64; 4],
    mat: &Material,
) -> Result<(f64, f64), ElementError> {
    Q1e4Element::new(X_e)?.stress_measures(mat, u_e, alpha)
}

#[cfg(test)]
#[allow(non_snake_case)]
mod tests {
    use super::*;
    use crate::fem::test_support::*;
    use crate::material::{LinearElastic, NeoHookean};
    use nalgebra::DMatrix;

    fn mat() -> Material {
        NeoHookean::from_young_poisson(3.0, 0.3).unwrap().into()
    }

    const X_DISTORTED: [f64; 8] = [0.0, 0.0, 1.2, 0.1, 1.0, 0.9, -0.1, 1.1];

    #[test]
    fn q1e4_condensed_tangent_matches_finite_differences() {
        let m = mat();
        let el = Q1e4Element::new(&X_DISTORTED).unwrap();
        let mut rng = Lcg(3);
        let u: [f64; 8] = std::array::from_fn(|_| 0.15 * rng.next());
        let mut alpha = [0.0; 4];
        let mut r = [0.0; 8];
        let mut k = [0.0; 64];
        el.residual_tangent(&m, &u, &mut alpha, &mut r, Some(&mut k))
            .unwrap();
        // a non-trivial enhanced state is being condensed
        assert!(max_abs(&alpha) > 1e-3, "alpha = {alpha:?}");
        let k_fd = fd_tangent(8, &u, 1e-6, |v, rv| {
            let mut a = alpha;
            let v: &[f64; 8] = v.try_into().unwrap();
            let rv: &mut [f64; 8] = rv.try_into().unwrap();
            el.residual_tangent(&m, v, &mut a, rv, None)
        });
        let err = max_abs_diff(&k, &k_fd);
        assert!(err < 1e-6 * max_abs(&k), "tangent error {err}");
        // the one-shot form gives the same result
        let (mut a2, mut r2) = ([0.0; 4], [0.0; 8]);
        q1e4_residual_tangent(&X_DISTORTED, &u, &mut a2, &m, &mut r2, None).unwrap();
        assert!(max_abs_diff(&r, &r2) < 1e-12 * max_abs(&r));
    }

    /// With the small-strain law the enhanced equations are linear too: the local solve converges from any
    /// warm start, `alpha` is linear in `u`, and the condensed residual is `K u` with a constant `K`.
    #[test]
    fn q1e4_with_linear_elastic_is_linear_in_u() {
        let m: Material = LinearElastic::from_young_poisson(3.0, 0.3).unwrap().into();
        let el = Q1e4Element::new(&X_DISTORTED).unwrap();
        let mut rng = Lcg(13);
        let u1: [f64; 8] = std::array::from_fn(|_| 0.3 * rng.next());
        let u2: [f64; 8] = std::array::from_fn(|_| 0.3 * rng.next());
        let eval = |u: &[f64; 8]| {
            let mut alpha = [0.05, -0.1, 0.2, 0.07];
            let (mut r, mut k) = ([0.0; 8], [0.0; 64]);
            el.residual_tangent(&m, u, &mut alpha, &mut r, Some(&mut k))
                .unwrap();
            (alpha, r, k)
        };
        let (a1, r1, k1) = eval(&u1);
        let (a2, _, k2) = eval(&u2);
        let (a12, _, _) = eval(&std::array::from_fn(|p| u1[p] + 2.0 * u2[p]));
        assert!(max_abs(&a1) > 1e-3, "alpha = {a1:?}");
        let a_lin: Vec<f64> = (0..4).map(|s| a1[s] + 2.0 * a2[s]).collect();
        assert!(max_abs_diff(&a12, &a_lin) < 1e-12 * max_abs(&a12));
        assert!(max_abs_diff(&k1, &k2) < 1e-13 * max_abs(&k1));
        let ku: Vec<f64> = (0..8)
            .map(|p| (0..8).map(|q| k1[p * 8 + q] * u1[q]).sum())
            .collect();
        assert!(max_abs_diff(&r1, &ku) < 1e-12 * max_abs(&r1), "r != K u");
    }

    #[test]
    fn q1e4_rigid_rotation_is_stress_free_with_zero_alpha() {
        let m = mat();
        let el = Q1e4Element::new(&X_DISTORTED).unwrap();
        let u: [f64; 8] = std::array::from_fn(|p| {
            let (x, y) = (X_DISTORTED[p / 2 * 2], X_DISTORTED[p / 2 * 2 + 1]);
            // 90 degree rotation: (x, y) -> (-y, x)
            if p % 2 == 0 {
                -y - x
            } else {
                x - y
            }
        });
        let mut alpha = [0.01, -0.02, 0.03, 0.0];
        let mut r = [0.0; 8];
        el.residual_tangent(&m, &u, &mut alpha, &mut r, None)
            .unwrap();
        assert!(max_abs(&r) < 1e-13, "r = {r:?}");
        assert!(max_abs(&alpha) < 1e-13, "alpha = {alpha:?}");
        let (i1, vm) = el.stress_measures(&m, &u, &alpha).unwrap();
        assert!(i1.abs() < 1e-13 && vm.abs() < 1e-13);
    }

    #[test]
    fn q1e4_inverted_element_is_an_error_and_keeps_alpha() {
        let m = mat();
        let el = Q1e4Element::new(&[0.0, 0.0, 1.0, 0.0, 1.0, 1.0, 0.0, 1.0]).unwrap();
        let u = [0.0, 0.0, 0.0, 0.0, -2.0, -2.0, 0.0, 0.0];
        let mut alpha = [0.1, 0.2, 0.3, 0.4];
        let mut r = [0.0; 8];
        let err = el
            .residual_tangent(&m, &u, &mut alpha, &mut r, None)
            .unwrap_err();
        assert!(matches!(err, ElementError::Inverted { .. }), "{err}");
        assert_eq!(alpha, [0.1, 0.2, 0.3, 0.4]);
        assert!(matches!(
            Q1e4Element::new(&[0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 1.0, 0.0]),
            Err(ElementError::NonPositiveReferenceJacobian { .. })
        ));
    }

    /// Newton solve of a quad mesh of Q1E4 elements; returns the converged enhanced parameters.
    fn solve_q1e4(
        mesh: &Mesh,
        m: &Material,
        fixed: &[(usize, f64)],
        f_ext: &[f64],
        u: &mut [f64],
    ) -> Vec<[f64; 4]> {
        let els: Vec<Q1e4Element> = (0..mesh.elems.len())
            .map(|e| Q1e4Element::new(&element_coords(mesh, e).try_into().unwrap()).unwrap())
            .collect();
        let mut alphas = vec![[0.0; 4]; els.len()];
        newton_solve(fixed, f_ext, u, |u, r, k: &mut DMatrix<f64>| {
            for (e, el) in els.iter().enumerate() {
                let u_e: [f64; 8] = gather(mesh, e, u).try_into().unwrap();
                let (mut r_e, mut k_e) = ([0.0; 8], [0.0; 64]);
                el.residual_tangent(m, &u_e, &mut alphas[e], &mut r_e, Some(&mut k_e))?;
                scatter(mesh, e, &r_e, &k_e, r, k);
            }
            Ok(())
        })
        .unwrap();
        alphas
    }

    #[test]
    fn q1e4_patch_test_on_distorted_mesh_is_exact_with_vanishing_alpha() {
        let m = mat();
        let mesh = quad_mesh(3, 3, 1.0, 1.0, 0.25);
        let H = [0.2, -0.1, 0.15, -0.12];
        let exact = affine(&mesh, &H);
        let fixed: Vec<(usize, f64)> = boundary_dofs(&mesh)
            .into_iter()
            .map(|d| (d, exact[d]))
            .collect();
        let mut u = vec![0.0; exact.len()];
        let alphas = solve_q1e4(&mesh, &m, &fixed, &vec![0.0; u.len()], &mut u);
        assert!(max_abs_diff(&u, &exact) < 1e-10 * max_abs(&exact));
        let F = [1.2, -0.1, 0.15, 0.88];
        let mut s_exact = [0.0; 9];
        m.cauchy(2, &F, &mut s_exact).unwrap();
        for (e, a) in alphas.iter().enumerate() {
            assert!(max_abs(a) < 1e-10, "element {e}: alpha = {a:?}");
            let el = Q1e4Element::new(&element_coords(&mesh, e).try_into().unwrap()).unwrap();
            let mut s = [0.0; 36];
            el.cauchy_at_qps(&m, &gather(&mesh, e, &u).try_into().unwrap(), a, &mut s)
                .unwrap();
            for sq in s.chunks_exact(9) {
                assert!(max_abs_diff(sq, &s_exact) < 1e-10 * max_abs(&s_exact));
            }
        }
    }

    #[test]
    fn q1e4_plane_strain_uniaxial_tension_matches_analytic_neo_hookean() {
        let m = mat();
        let mesh = quad_mesh(2, 2, 2.0, 1.0, 0.2);
        let (la, lx) = (1.4, 2.0);
        let lt = lateral_stretch(&m, 2, la);
        let mut u = vec![0.0; mesh.coords.len()];
        let mut alphas = vec![];
        for step in 1..=3 {
            let stretch = 1.0 + (la - 1.0) * step as f64 / 3.0;
            let mut fixed = vec![];
            for (a, x) in mesh.coords.chunks_exact(2).enumerate() {
                for (d, xd) in x.iter().enumerate() {
                    if xd.abs() < 1e-12 {
                        fixed.push((a * 2 + d, 0.0));
                    }
                }
                if (x[0] - lx).abs() < 1e-12 {
                    fixed.push((a * 2, (stretch - 1.0) * lx));
                }
            }
            alphas = solve_q1e4(&mesh, &m, &fixed, &vec![0.0; u.len()], &mut u);
        }
        let J = la * lt;
        let s11 = (m.lambda() * J.ln() + m.mu() * (la * la - 1.0)) / J;
        for (a, x) in mesh.coords.chunks_exact(2).enumerate() {
            assert!((u[2 * a] - (la - 1.0) * x[0]).abs() < 1e-10);
            assert!((u[2 * a + 1] - (lt - 1.0) * x[1]).abs() < 1e-10);
        }
        for (e, a) in alphas.iter().enumerate() {
            assert!(max_abs(a) < 1e-10, "element {e}: alpha = {a:?}");
            let el = Q1e4Element::new(&element_coords(&mesh, e).try_into().unwrap()).unwrap();
            let (i1, vm) = el
                .stress_measures(&m, &gather(&mesh, e, &u).try_into().unwrap(), a)
                .unwrap();
            // sigma = diag(s11, 0, Lambda ln J / J) in plane strain
            let s33 = m.lambda() * J.ln() / J;
            assert!((i1 - (s11 + s33)).abs() < 1e-10 * s11);
            let vm_exact = (s11 * s11 + s33 * s33 - s11 * s33).sqrt();
            assert!((vm - vm_exact).abs() < 1e-10 * s11);
        }
    }

    /// Tip deflection of a 4x1-element cantilever (L = 10, h = 1) under a small end moment, over the
    /// Euler-Bernoulli value `M L^2 / (2 E' I)` (plane strain `E' = E/(1 - nu^2)`).
    fn bending_ratio(enhanced: bool) -> f64 {
        let (E, nu) = (3.0, 0.3);
        let m: Material = NeoHookean::from_young_poisson(E, nu).unwrap().into();
        let (L, h) = (10.0, 1.0);
        let mesh = quad_mesh(4, 1, L, h, 0.0);
        let n = mesh.n_nodes() * 2;
        // left end: u_x = 0 on both nodes, u_y = 0 at the bottom node, so Poisson contraction stays free
        let fixed = [(0, 0.0), (1, 0.0), (5 * 2, 0.0)];
        // couple of consistent nodal forces for a linear bending stress: +F at the top, -F at the bottom tip node
        let F = 1e-5;
        let mut f_ext = vec![0.0; n];
        f_ext[4 * 2] = -F;
        f_ext[9 * 2] = F;
        let mut u = vec![0.0; n];
        if enhanced {
            solve_q1e4(&mesh, &m, &fixed, &f_ext, &mut u);
        } else {
            let els = tl_elements(&mesh);
            newton_solve(&fixed, &f_ext, &mut u, |u, r, k| {
                assemble(&mesh, &els, &m, u, r, k)
            })
            .unwrap();
        }
        let tip = 0.5 * (u[4 * 2 + 1] + u[9 * 2 + 1]);
        let M = F * h;
        let exact = M * L * L / (2.0 * E / (1.0 - nu * nu) * h.powi(3) / 12.0);
        // the top fibre is stretched, so the beam bends downwards
        -tip / exact
    }

    #[test]
    fn q1e4_is_much_softer_in_bending_than_q4() {
        let q1e4 = bending_ratio(true);
        let q4 = bending_ratio(false);
        eprintln!("bending ratios: Q1E4 {q1e4}, Q4 {q4}");
        // EAS is exact for pure bending of rectangles (up to the tiny geometric nonlinearity); Q4 shear-locks
        assert!(
            (q1e4 - 1.0).abs() < 1e-3,
            "Q1E4 tip / Euler-Bernoulli = {q1e4}"
        );
        assert!(q4 < 0.5, "Q4 tip / Euler-Bernoulli = {q4}");
        assert!(q1e4 / q4 > 2.0, "Q1E4 {q1e4} vs Q4 {q4}");
    }
}
