//! Trilinear 8-node hexahedron (Q1C1 in 3D).
//!
//! Reference nodes: the `zeta = -1` face (-1,-1), (1,-1), (1,1), (-1,1) as nodes 0-3, then the same at
//! `zeta = +1` as nodes 4-7, so `N_a = (1 + xi xi_a)(1 + eta eta_a)(1 + zeta zeta_a)/8`.
//! Local faces, node order counter-clockwise seen from outside (outward normal by the right-hand rule):
//! face 0: `zeta = -1` (0,3,2,1); face 1: `zeta = +1` (4,5,6,7); face 2: `eta = -1` (0,1,5,4);
//! face 3: `xi = +1` (1,2,6,5); face 4: `eta = +1` (2,3,7,6); face 5: `xi = -1` (3,0,4,7).

use super::kernel::TlElement;
use super::quadrature::tensor_rule;
use super::ElementError;

/// [8][3] reference coordinates of the nodes.
pub const NODES: [[f64; 3]; 8] = [
    [-1.0, -1.0, -1.0],
    [1.0, -1.0, -1.0],
    [1.0, 1.0, -1.0],
    [-1.0, 1.0, -1.0],
    [-1.0, -1.0, 1.0],
    [1.0, -1.0, 1.0],
    [1.0, 1.0, 1.0],
    [-1.0, 1.0, 1.0],
];

/// [6][4] local nodes of each face, counter-clockwise seen from outside.
pub const FACES: [[usize; 4]; 6] = [
    [0, 3, 2, 1],
    [4, 5, 6, 7],
    [0, 1, 5, 4],
    [1, 2, 6, 5],
    [2, 3, 7, 6],
    [3, 0, 4, 7],
];

/// Shape functions `N_a(xi)`, [8].
pub fn shape_functions(xi: &[f64; 3]) -> [f64; 8] {
    NODES.map(|n| 0.125 * (1.0 + xi[0] * n[0]) * (1.0 + xi[1] * n[1]) * (1.0 + xi[2] * n[2]))
}

/// Reference derivatives `dN_a/dxi_J`, [8][3].
pub fn shape_derivatives(xi: &[f64; 3]) -> [[f64; 3]; 8] {
    NODES.map(|n| {
        let f = [1.0 + xi[0] * n[0], 1.0 + xi[1] * n[1], 1.0 + xi[2] * n[2]];
        [
            0.125 * n[0] * f[1] * f[2],
            0.125 * n[1] * f[0] * f[2],
            0.125 * n[2] * f[0] * f[1],
        ]
    })
}

/// Reference-derivative table at the given points (`points`: [n_qp][3]) -> [n_qp][8][3].
pub fn derivative_table(points: &[f64]) -> Vec<f64> {
    points
        .chunks_exact(3)
        .flat_map(|p| shape_derivatives(&[p[0], p[1], p[2]]).into_iter().flatten())
        .collect()
}

/// Total Lagrangian kernel of one element with an `n_gauss^3` rule; `X_e`: [8][3] nodal coordinates.
#[allow(non_snake_case)]
pub fn tl_element(X_e: &[f64], n_gauss: usize) -> Result<TlElement, ElementError> {
    let rule = tensor_rule(&[n_gauss, n_gauss, n_gauss])?;
    TlElement::new(3, X_e, &derivative_table(&rule.points), &rule.weights)
}

#[cfg(test)]
#[allow(non_snake_case)]
mod tests {
    use super::*;

    #[test]
    fn hex8_basis_is_kronecker_and_partition_of_unity() {
        for (a, n) in NODES.iter().enumerate() {
            let N = shape_functions(n);
            for (b, v) in N.iter().enumerate() {
                assert_eq!(*v, if a == b { 1.0 } else { 0.0 });
            }
        }
        let xi = [0.3, -0.7, 0.1];
        assert!((shape_functions(&xi).iter().sum::<f64>() - 1.0).abs() < 1e-15);
        let dN = shape_derivatives(&xi);
        for j in 0..3 {
            assert!(dN.iter().map(|d| d[j]).sum::<f64>().abs() < 1e-15);
        }
    }

    #[test]
    fn hex8_derivatives_match_finite_differences() {
        let xi = [0.21, -0.43, 0.77];
        let dN = shape_derivatives(&xi);
        let h = 1e-7;
        for j in 0..3 {
            let (mut p, mut m) = (xi, xi);
            p[j] += h;
            m[j] -= h;
            let (Np, Nm) = (shape_functions(&p), shape_functions(&m));
            for a in 0..8 {
                assert!((dN[a][j] - (Np[a] - Nm[a]) / (2.0 * h)).abs() < 1e-9);
            }
        }
    }

    #[test]
    fn hex8_faces_are_planar_with_outward_normals() {
        for (f, face) in FACES.iter().enumerate() {
            let p = face.map(|a| NODES[a]);
            let u = [p[1][0] - p[0][0], p[1][1] - p[0][1], p[1][2] - p[0][2]];
            let v = [p[3][0] - p[0][0], p[3][1] - p[0][1], p[3][2] - p[0][2]];
            let n = [
                u[1] * v[2] - u[2] * v[1],
                u[2] * v[0] - u[0] * v[2],
                u[0] * v[1] - u[1] * v[0],
            ];
            let c: [f64; 3] = std::array::from_fn(|d| p.iter().map(|q| q[d]).sum::<f64>() / 4.0);
            // the face centre is the unit outward direction; n must be parallel to it
            let dot = n[0] * c[0] + n[1] * c[1] + n[2] * c[2];
            let norm = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
            assert!(
                (dot - norm).abs() < 1e-14,
                "face {f}: n = {n:?}, centre {c:?}"
            );
            // all four nodes on the face plane
            assert!(p
                .iter()
                .all(|q| (q[0] * c[0] + q[1] * c[1] + q[2] * c[2] - 1.0).abs() < 1e-15));
        }
    }
}
