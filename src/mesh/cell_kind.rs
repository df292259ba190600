//! Topology of the linear parent elements (Quad4, Hex8): node order, local faces, bilinear /
//! trilinear shape-function gradients and the reference Jacobian determinant.

/// Topology of the linear parent element of a cell.
///
/// Node order Quad4: (-1,-1), (1,-1), (1,1), (-1,1) (counter-clockwise, positive area).
/// Hex8: the zeta = -1 face (-1,-1), (1,-1), (1,1), (-1,1), then the same at zeta = +1.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum CellKind {
    Quad4,
    Hex8,
}

/// Reference coordinates of the Quad4 nodes, [4][2]: the element kernels' convention, one source.
const QUAD4_REF: [[f64; 2]; 4] = crate::fem::quad4::NODES;
/// Reference coordinates of the Hex8 nodes, [8][3].
const HEX8_REF: [[f64; 3]; 8] = crate::fem::hex8::NODES;
/// Local faces of Quad4: 0: eta=-1, 1: xi=+1, 2: eta=+1, 3: xi=-1; each traversed with the
/// cell on its left (counter-clockwise).
const QUAD4_FACES: [[usize; 2]; 4] = crate::fem::quad4::FACES;
/// Local faces of Hex8: 0: zeta=-1, 1: zeta=+1, 2: eta=-1, 3: xi=+1, 4: eta=+1, 5: xi=-1;
/// each ordered counter-clockwise seen from outside (outward normal by the right-hand rule).
const HEX8_FACES: [[usize; 4]; 6] = crate::fem::hex8::FACES;
/// Outward reference normals of the Quad4 faces, [4][2].
const QUAD4_NORMALS: [[f64; 2]; 4] = [[0.0, -1.0], [1.0, 0.0], [0.0, 1.0], [-1.0, 0.0]];
/// Outward reference normals of the Hex8 faces, [6][3].
const HEX8_NORMALS: [[f64; 3]; 6] = [
    [0.0, 0.0, -1.0],
    [0.0, 0.0, 1.0],
    [0.0, -1.0, 0.0],
    [1.0, 0.0, 0.0],
    [0.0, 1.0, 0.0],
    [-1.0, 0.0, 0.0],
];

impl CellKind {
    /// Spatial (and reference) dimension of the cell.
    pub fn dim(self) -> usize {
        match self {
            CellKind::Quad4 => 2,
            CellKind::Hex8 => 3,
        }
    }

    /// Number of nodes of the linear parent element.
    pub fn n_nodes(self) -> usize {
        match self {
            CellKind::Quad4 => 4,
            CellKind::Hex8 => 8,
        }
    }

    /// Number of local faces (edges in 2D).
    pub fn n_faces(self) -> usize {
        match self {
            CellKind::Quad4 => 4,
            CellKind::Hex8 => 6,
        }
    }

    /// Number of nodes on one face: 2 (edge) in 2D, 4 in 3D; also the number of nodes two
    /// cells must share to be face neighbours.
    pub fn n_face_nodes(self) -> usize {
        match self {
            CellKind::Quad4 => 2,
            CellKind::Hex8 => 4,
        }
    }

    /// Local node numbers of local face `face` (outward orientation), or `None` if out of range.
    pub fn face_local_nodes(self, face: u8) -> Option<&'static [usize]> {
        match self {
            CellKind::Quad4 => QUAD4_FACES.get(face as usize).map(|f| &f[..]),
            CellKind::Hex8 => HEX8_FACES.get(face as usize).map(|f| &f[..]),
        }
    }

    /// Outward reference normal of local face `face`, [dim], or `None` if out of range.
    pub fn face_reference_normal(self, face: u8) -> Option<&'static [f64]> {
        match self {
            CellKind::Quad4 => QUAD4_NORMALS.get(face as usize).map(|n| &n[..]),
            CellKind::Hex8 => HEX8_NORMALS.get(face as usize).map(|n| &n[..]),
        }
    }

    /// Reference coordinates of local node `a`, [dim].
    pub fn node_reference(self, a: usize) -> &'static [f64] {
        match self {
            CellKind::Quad4 => &QUAD4_REF[a],
            CellKind::Hex8 => &HEX8_REF[a],
        }
    }

    /// Gradients of the (bi/tri)linear shape functions at reference point `xi` ([dim]),
    /// written into `dN` as [n_nodes][dim].
    #[allow(non_snake_case)]
    pub fn shape_gradients(self, xi: &[f64], dN: &mut [f64]) {
        let d = self.dim();
        for a in 0..self.n_nodes() {
            let xa = self.node_reference(a);
            for k in 0..d {
                // N_a = prod_j (1 + xa_j xi_j) / 2, so dN_a/dxi_k = xa_k/2 prod_{j != k} (1 + xa_j xi_j)/2
                let mut g = 0.5 * xa[k];
                for j in 0..d {
                    if j != k {
                        g *= 0.5 * (1.0 + xa[j] * xi[j]);
                    }
                }
                dN[a * d + k] = g;
            }
        }
    }

    /// Determinant of the reference Jacobian dx/dxi at `xi` ([dim]) for nodal coordinates
    /// `x` ([n_nodes][dim]).
    #[allow(non_snake_case)]
    pub fn jacobian_det(self, x: &[f64], xi: &[f64]) -> f64 {
        let d = self.dim();
        let mut dN = [0.0; 24];
        self.shape_gradients(xi, &mut dN);
        let mut J = [[0.0; 3]; 3];
        for a in 0..self.n_nodes() {
            for i in 0..d {
                for k in 0..d {
                    J[i][k] += x[a * d + i] * dN[a * d + k];
                }
            }
        }
        if d == 2 {
            J[0][0] * J[1][1] - J[0][1] * J[1][0]
        } else {
            J[0][0] * (J[1][1] * J[2][2] - J[1][2] * J[2][1])
                - J[0][1] * (J[1][0] * J[2][2] - J[1][2] * J[2][0])
                + J[0][2] * (J[1][0] * J[2][1] - J[1][1] * J[2][0])
        }
    }

    /// Points of the 2-point-per-direction Gauss rule (all weights 1), [2^dim][dim] flattened.
    /// Exact for the area of a Quad4 and the volume of a Hex8.
    pub fn gauss2_points(self) -> Vec<f64> {
        let g = 1.0 / 3.0_f64.sqrt();
        let d = self.dim();
        let n = 1 << d;
        let mut pts = Vec::with_capacity(n * d);
        for p in 0..n {
            for k in 0..d {
                pts.push(if (p >> k) & 1 == 0 { -g } else { g });
            }
        }
        pts
    }

    /// Local node permutation `perm` (new local node i = old local node `perm[i]`) of a proper
    /// rotation of the reference cell that makes old local face `face` the new local face 0.
    /// Also returns the map old face -> new face.
    pub fn rotation_to_face0(self, face: u8) -> Option<(Vec<usize>, Vec<u8>)> {
        let d = self.dim();
        // Q maps new reference coordinates to old ones; det Q = +1 keeps the orientation and
        // Q n_0 = n_face makes the old face the new face 0.
        let q: [[f64; 3]; 3] = match (self, face) {
            (CellKind::Quad4, 0) | (CellKind::Hex8, 0) => {
                [[1., 0., 0.], [0., 1., 0.], [0., 0., 1.]]
            }
            (CellKind::Quad4, 1) => [[0., -1., 0.], [1., 0., 0.], [0., 0., 1.]],
            (CellKind::Quad4, 2) => [[-1., 0., 0.], [0., -1., 0.], [0., 0., 1.]],
            (CellKind::Quad4, 3) => [[0., 1., 0.], [-1., 0., 0.], [0., 0., 1.]],
            (CellKind::Hex8, 1) => [[1., 0., 0.], [0., -1., 0.], [0., 0., -1.]],
            (CellKind::Hex8, 2) => [[1., 0., 0.], [0., 0., 1.], [0., -1., 0.]],
            (CellKind::Hex8, 3) => [[0., 0., -1.], [0., 1., 0.], [1., 0., 0.]],
            (CellKind::Hex8, 4) => [[1., 0., 0.], [0., 0., -1.], [0., 1., 0.]],
            (CellKind::Hex8, 5) => [[0., 0., 1.], [0., 1., 0.], [-1., 0., 0.]],
            _ => return None,
        };
        let n = self.n_nodes();
        let mut perm = Vec::with_capacity(n);
        for i in 0..n {
            let xi = self.node_reference(i);
            let mut old = [0.0; 3];
            for r in 0..d {
                old[r] = (0..d).map(|c| q[r][c] * xi[c]).sum();
            }
            let a = (0..n).find(|&a| {
                let xa = self.node_reference(a);
                (0..d).all(|k| (xa[k] - old[k]).abs() < 1e-12)
            })?;
            perm.push(a);
        }
        // Old face g has node set S_g (old numbering); the new face with the same node set is its image.
        let mut face_map = Vec::with_capacity(self.n_faces());
        for g in 0..self.n_faces() as u8 {
            let mut old_set: Vec<usize> = self.face_local_nodes(g)?.to_vec();
            old_set.sort_unstable();
            let image = (0..self.n_faces() as u8).find(|&h| {
                let mut new_set: Vec<usize> = self
                    .face_local_nodes(h)
                    .map(|f| f.iter().map(|&i| perm[i]).collect())
                    .unwrap_or_default();
                new_set.sort_unstable();
                new_set == old_set
            })?;
            face_map.push(image);
        }
        Some((perm, face_map))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rotations_to_face0_preserve_orientation_and_map_the_face() {
        for kind in [CellKind::Quad4, CellKind::Hex8] {
            let d = kind.dim();
            // a distorted but valid cell: reference corners stretched and sheared
            let mut x = Vec::new();
            for a in 0..kind.n_nodes() {
                let r = kind.node_reference(a);
                x.push(2.0 * r[0] + 0.3 * r[1]);
                x.push(1.5 * r[1]);
                if d == 3 {
                    x.push(r[2] + 0.1 * r[0]);
                }
            }
            let centre = [0.0; 3];
            let det0 = kind.jacobian_det(&x, &centre[..d]);
            assert!(det0 > 0.0);
            for face in 0..kind.n_faces() as u8 {
                let (perm, face_map) = kind.rotation_to_face0(face).unwrap();
                assert_eq!(face_map[face as usize], 0);
                let y: Vec<f64> = perm
                    .iter()
                    .flat_map(|&a| x[a * d..a * d + d].to_vec())
                    .collect();
                let det = kind.jacobian_det(&y, &centre[..d]);
                assert!((det - det0).abs() < 1e-12, "face {face}: {det} vs {det0}");
                let mut s0: Vec<usize> = kind
                    .face_local_nodes(0)
                    .unwrap()
                    .iter()
                    .map(|&i| perm[i])
                    .collect();
                let mut sf = kind.face_local_nodes(face).unwrap().to_vec();
                s0.sort_unstable();
                sf.sort_unstable();
                assert_eq!(s0, sf);
            }
        }
    }

    #[test]
    fn unit_cells_have_jacobian_one_over_2_pow_dim_scaled() {
        // the [0,1]^d cell has dx/dxi = 1/2 I
        for kind in [CellKind::Quad4, CellKind::Hex8] {
            let d = kind.dim();
            let x: Vec<f64> = (0..kind.n_nodes())
                .flat_map(|a| {
                    kind.node_reference(a)
                        .iter()
                        .map(|r| 0.5 * (r + 1.0))
                        .collect::<Vec<_>>()
                })
                .collect();
            let det = kind.jacobian_det(&x, &[0.3, -0.2, 0.7][..d]);
            assert!((det - 0.5f64.powi(d as i32)).abs() < 1e-14);
        }
    }
}
