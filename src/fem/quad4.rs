//! Bilinear 4-node quadrilateral (Q1C1 in 2D).
//!
//! Reference nodes: 0 (-1,-1), 1 (1,-1), 2 (1,1), 3 (-1,1), so `N_a = (1 + xi xi_a)(1 + eta eta_a)/4`.
//! Local faces (counter-clockwise, outward normal on the right of the node order):
//! face 0: `eta = -1` (nodes 0,1); face 1: `xi = +1` (1,2); face 2: `eta = +1` (2,3); face 3: `xi = -1` (3,0).

use super::kernel::TlElement;
use super::quadrature::tensor_rule;
use super::ElementError;

/// [4][2] reference coordinates of the nodes.
pub const NODES: [[f64; 2]; 4] = [[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]];

/// [4][2] local nodes of each face, ordered so the outward normal points right of the edge direction.
pub const FACES: [[usize; 2]; 4] = [[0, 1], [1, 2], [2, 3], [3, 0]];

/// Shape functions `N_a(xi)`, [4].
pub fn shape_functions(xi: &[f64; 2]) -> [f64; 4] {
    NODES.map(|n| 0.25 * (1.0 + xi[0] * n[0]) * (1.0 + xi[1] * n[1]))
}

/// Reference derivatives `dN_a/dxi_J`, [4][2].
pub fn shape_derivatives(xi: &[f64; 2]) -> [[f64; 2]; 4] {
    NODES.map(|n| {
        [
            0.25 * n[0] * (1.0 + xi[1] * n[1]),
            0.25 * n[1] * (1.0 + xi[0] * n[0]),
        ]
    })
}

/// Reference-derivative table at the given points (`points`: [n_qp][2]) -> [n_qp][4][2].
pub fn derivative_table(points: &[f64]) -> Vec<f64> {
    points
        .chunks_exact(2)
        .flat_map(|p| shape_derivatives(&[p[0], p[1]]).into_iter().flatten())
        .collect()
}

/// Total Lagrangian kernel of one element with an `n_gauss x n_gauss` rule; `X_e`: [4][2] nodal coordinates.
#[allow(non_snake_case)]
pub fn tl_element(X_e: &[f64], n_gauss: usize) -> Result<TlElement, ElementError> {
    let rule = tensor_rule(&[n_gauss, n_gauss])?;
    TlElement::new(2, X_e, &derivative_table(&rule.points), &rule.weights)
}

#[cfg(test)]
#[allow(non_snake_case)]
mod tests {
    use super::*;

    #[test]
    fn quad4_basis_is_kronecker_and_partition_of_unity() {
        for (a, n) in NODES.iter().enumerate() {
            let N = shape_functions(n);
            for (b, v) in N.iter().enumerate() {
                assert_eq!(*v, if a == b { 1.0 } else { 0.0 });
            }
        }
        let xi = [0.3, -0.7];
        assert!((shape_functions(&xi).iter().sum::<f64>() - 1.0).abs() < 1e-15);
        let dN = shape_derivatives(&xi);
        for j in 0..2 {
            assert!(dN.iter().map(|d| d[j]).sum::<f64>().abs() < 1e-15);
        }
    }

    #[test]
    fn quad4_derivatives_match_finite_differences() {
        let xi = [0.21, -0.43];
        let dN = shape_derivatives(&xi);
        let h = 1e-7;
        for j in 0..2 {
            let (mut p, mut m) = (xi, xi);
            p[j] += h;
            m[j] -= h;
            let (Np, Nm) = (shape_functions(&p), shape_functions(&m));
            for a in 0..4 {
                assert!((dN[a][j] - (Np[a] - Nm[a]) / (2.0 * h)).abs() < 1e-9);
            }
        }
    }

    #[test]
    fn quad4_faces_have_outward_normals() {
        // the edge direction rotated clockwise, (t_y, -t_x), must point away from the centre
        for (f, [a, b]) in FACES.iter().enumerate() {
            let t = [NODES[*b][0] - NODES[*a][0], NODES[*b][1] - NODES[*a][1]];
            let n = [t[1], -t[0]];
            let mid = [
                0.5 * (NODES[*a][0] + NODES[*b][0]),
                0.5 * (NODES[*a][1] + NODES[*b][1]),
            ];
            assert!(n[0] * mid[0] + n[1] * mid[1] > 0.0, "face {f}");
        }
    }
}
