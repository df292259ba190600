//! Generic total Lagrangian displacement kernel shared by every element family.
//!
//! A family only supplies its reference-derivative table `dN/dxi` at its quadrature points; [`TlElement::new`]
//! maps it once to `dN/dX` and `w dV`. Per Newton iteration the kernel computes, with `F = I + sum_a u_a (x) dN_a/dX`,
//! `r_(a i) = sum_qp P_iJ dN_a/dX_J wdV` and `K_(a i)(b k) = sum_qp dN_a/dX_J A_iJkL dN_b/dX_L wdV`.
//! The dimension is a const generic inside, so the quadrature-point loop runs on stack arrays without allocation.
//!
//! The residual is `int P : grad_X N dV` over the reference configuration, so a small-strain law that returns
//! `P = sigma(sym(F - I))` with constant `A` ([`crate::material::LinearElastic`]) gives exactly the
//! geometrically linear weak form `int sigma : grad N dV` (`sigma` symmetric) with a `u`-independent tangent.

use super::ElementError;
use crate::material::neo_hookean::trace_and_von_mises;
use crate::material::{ConstitutiveLaw, Material};

/// One element's precomputed geometry for the total Lagrangian kernel.
#[derive(Debug, Clone, PartialEq)]
#[allow(non_snake_case)]
pub struct TlElement {
    pub n_nodes: usize,
    pub dim: usize,
    /// [n_qp][n_nodes][dim] material gradients `dN_a/dX_J`.
    pub dNdX: Vec<f64>,
    /// [n_qp] quadrature weight times reference Jacobian.
    pub wdV: Vec<f64>,
}

fn check_len(what: &'static str, got: usize, expected: usize) -> Result<(), ElementError> {
    if got != expected {
        return Err(ElementError::WrongLength {
            what,
            expected,
            got,
        });
    }
    Ok(())
}

/// `F = I + sum_a u_a (x) dN_a/dX` at one quadrature point, stride `D` in a 9-array.
#[allow(non_snake_case)]
#[inline(always)]
fn deformation_gradient<const D: usize>(dN: &[f64], u_e: &[f64]) -> [f64; 9] {
    let mut F = [0.0; 9];
    for i in 0..D {
        F[i * D + i] = 1.0;
    }
    for (ua, dNa) in u_e.chunks_exact(D).zip(dN.chunks_exact(D)) {
        for i in 0..D {
            for j in 0..D {
                F[i * D + j] += ua[i] * dNa[j];
            }
        }
    }
    F
}

impl TlElement {
    /// Map reference derivatives to the reference configuration.
    /// `X_e`: [n_nodes][dim] nodal coordinates, `dN_ref`: [n_qp][n_nodes][dim] `dN_a/dxi_J`, `q_weights`: [n_qp].
    #[allow(non_snake_case)]
    pub fn new(
        dim: usize,
        X_e: &[f64],
        dN_ref: &[f64],
        q_weights: &[f64],
    ) -> Result<Self, ElementError> {
        if dim != 2 && dim != 3 {
            return Err(ElementError::UnsupportedDimension { dim });
        }
        let n_nodes = X_e.len() / dim;
        check_len("X_e", X_e.len(), n_nodes * dim)?;
        let n_qp = q_weights.len();
        check_len("dN_ref", dN_ref.len(), n_qp * n_nodes * dim)?;
        let mut dNdX = vec![0.0; n_qp * n_nodes * dim];
        let mut wdV = vec![0.0; n_qp];
        for qp in 0..n_qp {
            let dN = &dN_ref[qp * n_nodes * dim..(qp + 1) * n_nodes * dim];
            // Jac_iJ = dX_i/dxi_J
            let mut Jac = nalgebra::Matrix3::<f64>::identity();
            for i in 0..dim {
                for j in 0..dim {
                    Jac[(i, j)] = (0..n_nodes)
                        .map(|a| X_e[a * dim + i] * dN[a * dim + j])
                        .sum();
                }
            }
            let detJ = Jac.determinant();
            // also rejects NaN coordinates
            if detJ.is_nan() || detJ <= 0.0 {
                return Err(ElementError::NonPositiveReferenceJacobian { qp, detJ });
            }
            let Jinv = Jac
                .try_inverse()
                .ok_or(ElementError::NonPositiveReferenceJacobian { qp, detJ })?;
            let out = &mut dNdX[qp * n_nodes * dim..(qp + 1) * n_nodes * dim];
            for a in 0..n_nodes {
                for i in 0..dim {
                    out[a * dim + i] = (0..dim).map(|j| dN[a * dim + j] * Jinv[(j, i)]).sum();
                }
            }
            wdV[qp] = q_weights[qp] * detJ;
        }
        Ok(Self {
            n_nodes,
            dim,
            dNdX,
            wdV,
        })
    }

    /// Element from already mapped tables (families whose gradients are not plain `J^-1 dN/dxi`, e.g. the
    /// enhanced modes of Q1E4). `dNdX`: [n_qp][n_nodes][dim], `wdV`: [n_qp].
    #[allow(non_snake_case)]
    pub fn from_parts(
        n_nodes: usize,
        dim: usize,
        dNdX: Vec<f64>,
        wdV: Vec<f64>,
    ) -> Result<Self, ElementError> {
        if dim != 2 && dim != 3 {
            return Err(ElementError::UnsupportedDimension { dim });
        }
        check_len("dNdX", dNdX.len(), wdV.len() * n_nodes * dim)?;
        Ok(Self {
            n_nodes,
            dim,
            dNdX,
            wdV,
        })
    }

    pub fn n_qp(&self) -> usize {
        self.wdV.len()
    }

    /// Number of element dofs `n_nodes * dim`.
    pub fn n_dofs(&self) -> usize {
        self.n_nodes * self.dim
    }

    /// Reference volume (area in 2D) of the element.
    pub fn volume(&self) -> f64 {
        self.wdV.iter().sum()
    }

    /// Internal force `r_e` ([n*D]) and, if requested, tangent `k_e` ([(n*D)][(n*D)] row-major) at the nodal
    /// displacements `u_e` ([n][D]). Both outputs are overwritten. An inverted quadrature point gives
    /// [`ElementError::Inverted`].
    pub fn residual_tangent(
        &self,
        mat: &Material,
        u_e: &[f64],
        r_e: &mut [f64],
        k_e: Option<&mut [f64]>,
    ) -> Result<(), ElementError> {
        let nd = self.n_dofs();
        check_len("u_e", u_e.len(), nd)?;
        check_len("r_e", r_e.len(), nd)?;
        if let Some(k) = k_e.as_deref() {
            check_len("k_e", k.len(), nd * nd)?;
        }
        if self.dim == 2 {
            self.residual_tangent_d::<2>(mat, u_e, r_e, k_e)
        } else {
            self.residual_tangent_d::<3>(mat, u_e, r_e, k_e)
        }
    }

    #[allow(non_snake_case)]
    fn residual_tangent_d<const D: usize>(
        &self,
        mat: &Material,
        u_e: &[f64],
        r_e: &mut [f64],
        mut k_e: Option<&mut [f64]>,
    ) -> Result<(), ElementError> {
        let n = self.n_nodes;
        let nd = n * D;
        r_e.fill(0.0);
        if let Some(k) = k_e.as_deref_mut() {
            k.fill(0.0);
        }
        for (qp, &w) in self.wdV.iter().enumerate() {
            let dN = &self.dNdX[qp * nd..(qp + 1) * nd];
            let F = deformation_gradient::<D>(dN, u_e);
            let mut P = [0.0; 9];
            let mut A = [0.0; 81];
            let want_k = k_e.is_some();
            mat.pk1_impl::<D>(
                &F[..D * D],
                &mut P[..D * D],
                if want_k {
                    Some(&mut A[..D * D * D * D])
                } else {
                    None
                },
            )
            .map_err(|e| ElementError::from_material(qp, e))?;
            for (ra, dNa) in r_e.chunks_exact_mut(D).zip(dN.chunks_exact(D)) {
                for i in 0..D {
                    let mut s = 0.0;
                    for j in 0..D {
                        s += P[i * D + j] * dNa[j];
                    }
                    ra[i] += w * s;
                }
            }
            if let Some(k) = k_e.as_deref_mut() {
                // G_a[i][k][L] = w sum_J dN_a/dX_J A_iJkL, then K_(ai)(bk) = sum_L G_a[i][k][L] dN_b/dX_L;
                // major symmetry of A lets us fill b >= a only
                for a in 0..n {
                    let dNa = &dN[a * D..(a + 1) * D];
                    let mut G = [0.0; 27];
                    for i in 0..D {
                        for kk in 0..D {
                            for l in 0..D {
                                let mut s = 0.0;
                                for j in 0..D {
                                    s += dNa[j] * A[((i * D + j) * D + kk) * D + l];
                                }
                                G[(i * D + kk) * D + l] = w * s;
                            }
                        }
                    }
                    for b in a..n {
                        let dNb = &dN[b * D..(b + 1) * D];
                        for i in 0..D {
                            let row = (a * D + i) * nd + b * D;
                            for kk in 0..D {
                                let mut s = 0.0;
                                for l in 0..D {
                                    s += G[(i * D + kk) * D + l] * dNb[l];
                                }
                                k[row + kk] += s;
                            }
                        }
                    }
                }
            }
        }
        if let Some(k) = k_e {
            for r in 0..nd {
                for c in 0..r {
                    // only blocks with node(r) > node(c) are still empty
                    if r / D > c / D {
                        k[r * nd + c] = k[c * nd + r];
                    }
                }
            }
        }
        Ok(())
    }

    /// Cauchy stress (3x3 row-major) at one quadrature point.
    #[allow(non_snake_case)]
    fn cauchy_at(&self, qp: usize, mat: &Material, u_e: &[f64]) -> Result<[f64; 9], ElementError> {
        let D = self.dim;
        let nd = self.n_dofs();
        let dN = &self.dNdX[qp * nd..(qp + 1) * nd];
        let F = if D == 2 {
            deformation_gradient::<2>(dN, u_e)
        } else {
            deformation_gradient::<3>(dN, u_e)
        };
        let mut s = [0.0; 9];
        mat.cauchy(D, &F[..D * D], &mut s)
            .map_err(|e| ElementError::from_material(qp, e))?;
        Ok(s)
    }

    /// Cauchy stress at every quadrature point, `sigma`: [n_qp][9] (3x3 row-major; plane strain includes `sigma_33`).
    pub fn cauchy_at_qps(
        &self,
        mat: &Material,
        u_e: &[f64],
        sigma: &mut [f64],
    ) -> Result<(), ElementError> {
        check_len("u_e", u_e.len(), self.n_dofs())?;
        check_len("sigma", sigma.len(), 9 * self.n_qp())?;
        for (qp, s) in sigma.chunks_exact_mut(9).enumerate() {
            s.copy_from_slice(&self.cauchy_at(qp, mat, u_e)?);
        }
        Ok(())
    }

    /// Element stress measures `(I1, von Mises)`: the reference-volume weighted averages over the quadrature
    /// points of `I1 = tr sigma` and of the von Mises stress. `I1` is in stress units (not yet divided by `E0`).
    pub fn stress_measures(&self, mat: &Material, u_e: &[f64]) -> Result<(f64, f64), ElementError> {
        check_len("u_e", u_e.len(), self.n_dofs())?;
        let (mut i1, mut vm, mut vol) = (0.0, 0.0, 0.0);
        for (qp, &w) in self.wdV.iter().enumerate() {
            let (t, v) = trace_and_von_mises(&self.cauchy_at(qp, mat, u_e)?);
            i1 += w * t;
            vm += w * v;
            vol += w;
        }
        Ok((i1 / vol, vm / vol))
    }
}

#[cfg(test)]
#[allow(non_snake_case)]
mod tests {
    use super::*;
    use crate::fem::test_support::*;
    use crate::fem::{hex8, quad4};
    use crate::material::NeoHookean;

    fn mat() -> Material {
        NeoHookean::from_young_poisson(3.0, 0.3).unwrap().into()
    }

    fn check_tangent(el: &TlElement, u: &[f64]) {
        let m = mat();
        let nd = el.n_dofs();
        let mut r = vec![0.0; nd];
        let mut k = vec![0.0; nd * nd];
        el.residual_tangent(&m, u, &mut r, Some(&mut k)).unwrap();
        let k_fd = fd_tangent(nd, u, 1e-6, |v, r| el.residual_tangent(&m, v, r, None));
        let err = max_abs_diff(&k, &k_fd);
        assert!(err < 1e-6 * max_abs(&k), "tangent error {err}");
        // residual-only path agrees with the full path
        let mut r2 = vec![0.0; nd];
        el.residual_tangent(&m, u, &mut r2, None).unwrap();
        assert_eq!(r, r2);
    }

    #[test]
    fn quad4_tangent_matches_finite_differences() {
        let X = [0.0, 0.0, 1.2, 0.1, 1.0, 0.9, -0.1, 1.1];
        let el = quad4::tl_element(&X, 2).unwrap();
        let mut rng = Lcg(3);
        let u: Vec<f64> = (0..8).map(|_| 0.15 * rng.next()).collect();
        check_tangent(&el, &u);
    }

    #[test]
    fn hex8_tangent_matches_finite_differences() {
        let mut rng = Lcg(5);
        let X: Vec<f64> = hex8::NODES
            .iter()
            .flat_map(|n| n.map(|c| 0.5 * c + 0.08 * rng.next()))
            .collect();
        let el = hex8::tl_element(&X, 2).unwrap();
        let u: Vec<f64> = (0..24).map(|_| 0.08 * rng.next()).collect();
        check_tangent(&el, &u);
    }

    #[test]
    fn inverted_element_is_an_error_not_a_panic() {
        let X = [0.0, 0.0, 1.0, 0.0, 1.0, 1.0, 0.0, 1.0];
        let el = quad4::tl_element(&X, 2).unwrap();
        // push node 2 through the opposite corner
        let u = [0.0, 0.0, 0.0, 0.0, -2.0, -2.0, 0.0, 0.0];
        let mut r = [0.0; 8];
        let mut k = [0.0; 64];
        let err = el
            .residual_tangent(&mat(), &u, &mut r, Some(&mut k))
            .unwrap_err();
        assert!(
            matches!(err, ElementError::Inverted { J, .. } if J <= 0.0),
            "{err}"
        );
        assert!(el.stress_measures(&mat(), &u).is_err());
    }

    #[test]
    fn clockwise_reference_element_is_rejected() {
        let X = [0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 1.0, 0.0];
        let err = quad4::tl_element(&X, 2).unwrap_err();
        assert!(matches!(
            err,
            ElementError::NonPositiveReferenceJacobian { qp: 0, detJ } if detJ < 0.0
        ));
        assert!(err.to_string().contains("quadrature point 0"));
        let el = quad4::tl_element(&[0.0, 0.0, 1.0, 0.0, 1.0, 1.0, 0.0, 1.0], 2).unwrap();
        let mut r = [0.0; 6];
        assert!(matches!(
            el.residual_tangent(&mat(), &[0.0; 8], &mut r, None),
            Err(ElementError::WrongLength { what: "r_e", .. })
        ));
    }

    /// Solve a mesh with every boundary node on `u = H X` and check that the interior reproduces `H X` and
    /// every quadrature point carries the constant stress of `F = I + H`.
    fn patch_test(mesh: &Mesh, H: &[f64]) {
        let m = mat();
        let D = mesh.dim;
        let els = tl_elements(mesh);
        let exact: Vec<f64> = affine(mesh, H);
        let fixed: Vec<(usize, f64)> = boundary_dofs(mesh)
            .into_iter()
            .map(|d| (d, exact[d]))
            .collect();
        let mut u = vec![0.0; exact.len()];
        newton_solve(&fixed, &vec![0.0; u.len()], &mut u, |u, r, k| {
            assemble(mesh, &els, &m, u, r, k)
        })
        .unwrap();
        let scale = max_abs(&exact);
        assert!(max_abs_diff(&u, &exact) < 1e-10 * scale);
        let mut F = vec![0.0; D * D];
        for i in 0..D {
            for j in 0..D {
                F[i * D + j] = H[i * D + j] + if i == j { 1.0 } else { 0.0 };
            }
        }
        let mut s_exact = [0.0; 9];
        m.cauchy(D, &F, &mut s_exact).unwrap();
        for (e, el) in els.iter().enumerate() {
            let mut s = vec![0.0; 9 * el.n_qp()];
            el.cauchy_at_qps(&m, &gather(mesh, e, &u), &mut s).unwrap();
            for sq in s.chunks_exact(9) {
                assert!(max_abs_diff(sq, &s_exact) < 1e-10 * max_abs(&s_exact));
            }
        }
    }

    #[test]
    fn quad4_patch_test_on_distorted_mesh_is_exact() {
        patch_test(&quad_mesh(3, 3, 1.0, 1.0, 0.25), &[0.2, -0.1, 0.15, -0.12]);
    }

    #[test]
    fn hex8_patch_test_on_distorted_mesh_is_exact() {
        patch_test(
            &hex_mesh(2, 2, 2, 1.0, 0.2),
            &[0.1, -0.05, 0.08, 0.03, -0.12, 0.02, -0.07, 0.06, 0.15],
        );
    }

    fn uniaxial_tension(mesh: &Mesh, la: f64) {
        let m = mat();
        let D = mesh.dim;
        let lt = lateral_stretch(&m, D, la);
        let els = tl_elements(mesh);
        // symmetry planes X_d = 0 and the pulled face X_0 = L; the lateral faces are free
        let lx = mesh
            .coords
            .chunks_exact(D)
            .map(|x| x[0])
            .fold(0.0, f64::max);
        let mut u = vec![0.0; mesh.coords.len()];
        let f_ext = vec![0.0; u.len()];
        let n_steps = 3;
        for step in 1..=n_steps {
            let stretch = 1.0 + (la - 1.0) * step as f64 / n_steps as f64;
            let mut fixed = vec![];
            for (a, x) in mesh.coords.chunks_exact(D).enumerate() {
                for (d, xd) in x.iter().enumerate() {
                    if xd.abs() < 1e-12 {
                        fixed.push((a * D + d, 0.0));
                    }
                }
                if (x[0] - lx).abs() < 1e-12 {
                    fixed.push((a * D, (stretch - 1.0) * lx));
                }
            }
            newton_solve(&fixed, &f_ext, &mut u, |u, r, k| {
                assemble(mesh, &els, &m, u, r, k)
            })
            .unwrap();
        }
        let J = la * lt.powi(D as i32 - 1);
        let s11 = (m.lambda() * J.ln() + m.mu() * (la * la - 1.0)) / J;
        let s33 = if D == 2 { m.lambda() * J.ln() / J } else { 0.0 };
        let mut s_exact = [0.0; 9];
        s_exact[0] = s11;
        s_exact[8] = s33;
        for (a, x) in mesh.coords.chunks_exact(D).enumerate() {
            assert!((u[a * D] - (la - 1.0) * x[0]).abs() < 1e-10 * la);
            for d in 1..D {
                assert!((u[a * D + d] - (lt - 1.0) * x[d]).abs() < 1e-10 * la);
            }
        }
        for (e, el) in els.iter().enumerate() {
            let mut s = vec![0.0; 9 * el.n_qp()];
            el.cauchy_at_qps(&m, &gather(mesh, e, &u), &mut s).unwrap();
            for sq in s.chunks_exact(9) {
                assert!(
                    max_abs_diff(sq, &s_exact) < 1e-10 * s11,
                    "{sq:?} vs {s_exact:?}"
                );
            }
        }
    }

    #[test]
    fn plane_strain_uniaxial_tension_matches_analytic_neo_hookean() {
        uniaxial_tension(&quad_mesh(2, 2, 2.0, 1.0, 0.2), 1.4);
    }

    #[test]
    fn hex8_uniaxial_tension_matches_analytic_neo_hookean() {
        uniaxial_tension(&hex_mesh(2, 2, 2, 1.0, 0.2), 1.4);
    }

    fn simple_shear(mesh: &Mesh, gamma: f64) {
        let m = mat();
        let D = mesh.dim;
        let els = tl_elements(mesh);
        let mut u = vec![0.0; mesh.coords.len()];
        let n_steps = 4;
        for step in 1..=n_steps {
            let mut H = vec![0.0; D * D];
            H[1] = gamma * step as f64 / n_steps as f64;
            let exact = affine(mesh, &H);
            let fixed: Vec<(usize, f64)> = boundary_dofs(mesh)
                .into_iter()
                .map(|d| (d, exact[d]))
                .collect();
            newton_solve(&fixed, &vec![0.0; u.len()], &mut u, |u, r, k| {
                assemble(mesh, &els, &m, u, r, k)
            })
            .unwrap();
        }
        // J = 1: sigma = mu (b - I), b = [[1 + g^2, g, 0], [g, 1, 0], [0, 0, 1]]
        let mut s_exact = [0.0; 9];
        s_exact[0] = m.mu() * gamma * gamma;
        s_exact[1] = m.mu() * gamma;
        s_exact[3] = m.mu() * gamma;
        for (e, el) in els.iter().enumerate() {
            let mut s = vec![0.0; 9 * el.n_qp()];
            el.cauchy_at_qps(&m, &gather(mesh, e, &u), &mut s).unwrap();
            for sq in s.chunks_exact(9) {
                assert!(
                    max_abs_diff(sq, &s_exact) < 1e-10 * m.mu() * gamma,
                    "{sq:?}"
                );
            }
            let (i1, vm) = el.stress_measures(&m, &gather(mesh, e, &u)).unwrap();
            assert!((i1 - m.mu() * gamma * gamma).abs() < 1e-10);
            let (_, vm_exact) = trace_and_von_mises(&s_exact);
            assert!((vm - vm_exact).abs() < 1e-10);
        }
    }

    #[test]
    fn plane_strain_simple_shear_matches_analytic_neo_hookean() {
        simple_shear(&quad_mesh(3, 3, 1.0, 1.0, 0.25), 0.5);
    }

    #[test]
    fn hex8_simple_shear_matches_analytic_neo_hookean() {
        simple_shear(&hex_mesh(2, 2, 2, 1.0, 0.2), 0.5);
    }
}

#[cfg(test)]
#[allow(non_snake_case)]
mod linear_elastic_tests {
    use super::*;
    use crate::fem::test_support::*;
    use crate::fem::{hex8, quad4};
    use crate::material::LinearElastic;

    fn mat() -> Material {
        LinearElastic::from_young_poisson(3.0, 0.3).unwrap().into()
    }

    /// The residual is linear in `u`: `r(u) = K u` with the same `K` at every `u`, which also matches
    /// finite differences.
    fn check_linear(el: &TlElement, rng: &mut Lcg, amp: f64) {
        let m = mat();
        let nd = el.n_dofs();
        let u1: Vec<f64> = (0..nd).map(|_| amp * rng.next()).collect();
        let u2: Vec<f64> = (0..nd).map(|_| amp * rng.next()).collect();
        let (mut r1, mut k1) = (vec![0.0; nd], vec![0.0; nd * nd]);
        let (mut r2, mut k2) = (vec![0.0; nd], vec![0.0; nd * nd]);
        el.residual_tangent(&m, &u1, &mut r1, Some(&mut k1))
            .unwrap();
        el.residual_tangent(&m, &u2, &mut r2, Some(&mut k2))
            .unwrap();
        assert!(max_abs_diff(&k1, &k2) < 1e-14 * max_abs(&k1));
        let ku: Vec<f64> = (0..nd)
            .map(|p| (0..nd).map(|q| k1[p * nd + q] * u1[q]).sum())
            .collect();
        assert!(max_abs_diff(&r1, &ku) < 1e-13 * max_abs(&r1), "r != K u");
        let k_fd = fd_tangent(nd, &u1, 1e-6, |v, r| el.residual_tangent(&m, v, r, None));
        assert!(max_abs_diff(&k1, &k_fd) < 1e-7 * max_abs(&k1));
    }

    #[test]
    fn linear_elastic_residual_is_k_times_u_on_quad4_and_hex8() {
        let mut rng = Lcg(9);
        let X = [0.0, 0.0, 1.2, 0.1, 1.0, 0.9, -0.1, 1.1];
        check_linear(&quad4::tl_element(&X, 2).unwrap(), &mut rng, 0.5);
        let X: Vec<f64> = hex8::NODES
            .iter()
            .flat_map(|n| n.map(|c| 0.5 * c + 0.08 * rng.next()))
            .collect();
        check_linear(&hex8::tl_element(&X, 2).unwrap(), &mut rng, 0.5);
    }

    /// Affine `u = H X` with a non-symmetric `H` on the boundary: one Newton iteration reproduces it, and every
    /// quadrature point carries Hooke's stress of `sym H` (the skew part of `H` is stress free).
    #[test]
    fn linear_elastic_patch_test_converges_in_one_iteration() {
        let m = mat();
        for (mesh, H) in [
            (
                quad_mesh(3, 3, 1.0, 1.0, 0.25),
                vec![0.02, -0.05, 0.09, -0.01],
            ),
            (
                hex_mesh(2, 2, 2, 1.0, 0.2),
                vec![0.01, -0.05, 0.08, 0.03, -0.02, 0.02, -0.07, 0.06, 0.015],
            ),
        ] {
            let D = mesh.dim;
            let els = tl_elements(&mesh);
            let exact = affine(&mesh, &H);
            let fixed: Vec<(usize, f64)> = boundary_dofs(&mesh)
                .into_iter()
                .map(|d| (d, exact[d]))
                .collect();
            let mut u = vec![0.0; exact.len()];
            let its = newton_solve(&fixed, &vec![0.0; u.len()], &mut u, |u, r, k| {
                assemble(&mesh, &els, &m, u, r, k)
            })
            .unwrap();
            assert_eq!(its, 1, "dim {D}: a linear problem takes one Newton step");
            assert!(max_abs_diff(&u, &exact) < 1e-12 * max_abs(&exact));
            let mut eps = [0.0; 9];
            for i in 0..D {
                for j in 0..D {
                    eps[i * 3 + j] = 0.5 * (H[i * D + j] + H[j * D + i]);
                }
            }
            let tr = eps[0] + eps[4] + eps[8];
            let s_exact: [f64; 9] = std::array::from_fn(|p| {
                m.lambda() * tr * if p % 4 == 0 { 1.0 } else { 0.0 } + 2.0 * m.mu() * eps[p]
            });
            for (e, el) in els.iter().enumerate() {
                let mut s = vec![0.0; 9 * el.n_qp()];
                el.cauchy_at_qps(&m, &gather(&mesh, e, &u), &mut s).unwrap();
                for sq in s.chunks_exact(9) {
                    assert!(
                        max_abs_diff(sq, &s_exact) < 1e-11 * max_abs(&s_exact),
                        "{sq:?} vs {s_exact:?}"
                    );
                }
            }
        }
    }
}
