//! Structured 3D box of Hex8 cells (the twisting cube of Corbett & Sauer 2014, section 4.4).
use super::{CellKind, Mesh, MeshError};

/// Face of an axis-aligned box.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BoxFace {
    Xmin,
    Xmax,
    Ymin,
    Ymax,
    Zmin,
    Zmax,
}

impl BoxFace {
    /// Local Hex8 face lying on this box face in the default (unrotated) cell numbering.
    fn default_face(self) -> u8 {
        match self {
            BoxFace::Zmin => 0,
            BoxFace::Zmax => 1,
            BoxFace::Ymin => 2,
            BoxFace::Xmax => 3,
            BoxFace::Ymax => 4,
            BoxFace::Xmin => 5,
        }
    }
}

/// Box `origin + [0, lx] x [0, ly] x [0, lz]` split into `nx x ny x nz` equal Hex8 cells, with
/// local face 0 of every cell facing -z. See [`box3d_oriented`].
pub fn box3d(origin: [f64; 3], size: [f64; 3], n: [usize; 3]) -> Result<Mesh, MeshError> {
    box3d_oriented(origin, size, n, BoxFace::Zmin)
}

/// Box `origin + [0, lx] x [0, ly] x [0, lz]` split into `nx x ny x nz` equal Hex8 cells. Every
/// cell is rotated (proper rotation, positive volume kept) so that its local face 0 faces
/// `contact` (`BoxFace::Zmax` for the twisting cube, whose top is the contact surface).
///
/// Nodes (i, j, k) are numbered `(k (ny + 1) + j) (nx + 1) + i`, cells (i, j, k) likewise
/// `(k ny + j) nx + i`.
///
/// Named sets:
/// - node and face sets `xmin`, `xmax`, `ymin`, `ymax`, `zmin`, `zmax`; faces ordered
///   row-major over the face's two in-plane cell indices in (x, y, z) order, the first
///   fastest (zmin/zmax: i fastest, then j; ymin/ymax: i, then k; xmin/xmax: j, then k);
/// - `zmin_center`, `zmax_center`: the node at the centre of that face, only if `nx` and
///   `ny` are even (otherwise there is none);
/// - `zmin_xline`, `zmax_xline` (nodes of that face with y at the centre, only if `ny` even) and `zmin_yline`, `zmax_yline`
///   (nodes of zmin with x at the centre, only if `nx` even), for supports that let the base
///   expand about its midpoint while blocking the rigid rotation about z.
pub fn box3d_oriented(
    origin: [f64; 3],
    size: [f64; 3],
    n: [usize; 3],
    contact: BoxFace,
) -> Result<Mesh, MeshError> {
    let [nx, ny, nz] = n;
    for (name, v) in [("nx", nx), ("ny", ny), ("nz", nz)] {
        if v == 0 {
            return Err(MeshError::InvalidParameter {
                name,
                value: v.to_string(),
                reason: "need at least one cell",
            });
        }
    }
    for (name, v) in [("lx", size[0]), ("ly", size[1]), ("lz", size[2])] {
        if !(v > 0.0 && v.is_finite()) {
            return Err(MeshError::InvalidParameter {
                name,
                value: v.to_string(),
                reason: "size must be positive and finite",
            });
        }
    }
    let mut mesh = Mesh::new(3);
    for k in 0..=nz {
        for j in 0..=ny {
            for i in 0..=nx {
                mesh.push_node(&[
                    origin[0] + size[0] * i as f64 / nx as f64,
                    origin[1] + size[1] * j as f64 / ny as f64,
                    origin[2] + size[2] * k as f64 / nz as f64,
                ]);
            }
        }
    }
    let node = |i: usize, j: usize, k: usize| ((k * (ny + 1) + j) * (nx + 1) + i) as u32;
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                mesh.push_cell(
                    CellKind::Hex8,
                    &[
                        node(i, j, k),
                        node(i + 1, j, k),
                        node(i + 1, j + 1, k),
                        node(i, j + 1, k),
                        node(i, j, k + 1),
                        node(i + 1, j, k + 1),
                        node(i + 1, j + 1, k + 1),
                        node(i, j + 1, k + 1),
                    ],
                );
            }
        }
    }
    let cell = |i: usize, j: usize, k: usize| ((k * ny + j) * nx + i) as u32;
    let mut faces = |name: &str, face: BoxFace, cells: Vec<u32>, nodes: Vec<u32>| {
        let f = face.default_face();
        mesh.face_sets.insert(
            name.to_string(),
            cells.into_iter().map(|c| (c, f)).collect(),
        );
        mesh.insert_node_set(name, nodes);
    };
    let grid2 = |a: usize, b: usize| -> Vec<(usize, usize)> {
        (0..b).flat_map(|q| (0..a).map(move |p| (p, q))).collect()
    };
    faces(
        "zmin",
        BoxFace::Zmin,
        grid2(nx, ny).iter().map(|&(i, j)| cell(i, j, 0)).collect(),
        grid2(nx + 1, ny + 1)
            .iter()
            .map(|&(i, j)| node(i, j, 0))
            .collect(),
    );
    faces(
        "zmax",
        BoxFace::Zmax,
        grid2(nx, ny)
            .iter()
            .map(|&(i, j)| cell(i, j, nz - 1))
            .collect(),
        grid2(nx + 1, ny + 1)
            .iter()
            .map(|&(i, j)| node(i, j, nz))
            .collect(),
    );
    faces(
        "ymin",
        BoxFace::Ymin,
        grid2(nx, nz).iter().map(|&(i, k)| cell(i, 0, k)).collect(),
        grid2(nx + 1, nz + 1)
            .iter()
            .map(|&(i, k)| node(i, 0, k))
            .collect(),
    );
    faces(
        "ymax",
        BoxFace::Ymax,
        grid2(nx, nz)
            .iter()
            .map(|&(i, k)| cell(i, ny - 1, k))
            .collect(),
        grid2(nx + 1, nz + 1)
            .iter()
            .map(|&(i, k)| node(i, ny, k))
            .collect(),
    );
    faces(
        "xmin",
        BoxFace::Xmin,
        grid2(ny, nz).iter().map(|&(j, k)| cell(0, j, k)).collect(),
        grid2(ny + 1, nz + 1)
            .iter()
            .map(|&(j, k)| node(0, j, k))
            .collect(),
    );
    faces(
        "xmax",
        BoxFace::Xmax,
        grid2(ny, nz)
            .iter()
            .map(|&(j, k)| cell(nx - 1, j, k))
            .collect(),
        grid2(ny + 1, nz + 1)
            .iter()
            .map(|&(j, k)| node(nx, j, k))
            .collect(),
    );
    if nx % 2 == 0 && ny % 2 == 0 {
        mesh.insert_node_set("zmin_center", vec![node(nx / 2, ny / 2, 0)]);
        mesh.insert_node_set("zmax_center", vec![node(nx / 2, ny / 2, nz)]);
    }
    if ny % 2 == 0 {
        mesh.insert_node_set("zmin_xline", (0..=nx).map(|i| node(i, ny / 2, 0)).collect());
        mesh.insert_node_set(
            "zmax_xline",
            (0..=nx).map(|i| node(i, ny / 2, nz)).collect(),
        );
    }
    if nx % 2 == 0 {
        mesh.insert_node_set("zmin_yline", (0..=ny).map(|j| node(nx / 2, j, 0)).collect());
        mesh.insert_node_set(
            "zmax_yline",
            (0..=ny).map(|j| node(nx / 2, j, nz)).collect(),
        );
    }
    let face = contact.default_face();
    if face != 0 {
        for c in 0..mesh.n_cells() {
            mesh.orient_face_to_local0(c, face)?;
        }
    }
    Ok(mesh)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn box_is_valid_with_exact_volume_for_every_orientation() {
        for contact in [
            BoxFace::Xmin,
            BoxFace::Xmax,
            BoxFace::Ymin,
            BoxFace::Ymax,
            BoxFace::Zmin,
            BoxFace::Zmax,
        ] {
            for n in [[1, 1, 1], [2, 3, 4], [4, 4, 4]] {
                let m = box3d_oriented([-1.0, -1.0, -2.0], [2.0, 2.0, 2.0], n, contact).unwrap();
                m.validate().unwrap();
                assert!((m.measure() - 8.0).abs() < 1e-12);
                let name = format!("{contact:?}").to_lowercase();
                assert!(m.face_sets[&name].iter().all(|&(_, f)| f == 0), "{name}");
            }
        }
    }

    #[test]
    fn box_face_sets_lie_on_their_planes_and_have_expected_counts() {
        let m = box3d([0.0, 0.0, 0.0], [2.0, 3.0, 4.0], [2, 3, 4]).unwrap();
        let planes = [
            ("xmin", 0, 0.0, 12),
            ("xmax", 0, 2.0, 12),
            ("ymin", 1, 0.0, 8),
            ("ymax", 1, 3.0, 8),
            ("zmin", 2, 0.0, 6),
            ("zmax", 2, 4.0, 6),
        ];
        for (name, axis, value, n_faces) in planes {
            assert_eq!(m.face_sets[name].len(), n_faces, "{name}");
            for &(c, f) in &m.face_sets[name] {
                for n in m.face_nodes(c as usize, f).unwrap() {
                    assert_eq!(m.node(n)[axis], value, "{name}");
                }
            }
            let nodes = m.node_set_from_faces(name).unwrap();
            assert_eq!(&nodes, &m.node_sets[name]);
        }
        // zmax faces ordered i fastest, then j: face centres increase lexicographically in (y, x)
        let centres: Vec<(f64, f64)> = m.face_sets["zmax"]
            .iter()
            .map(|&(c, f)| {
                let n = m.face_nodes(c as usize, f).unwrap();
                let x = n.iter().map(|&a| m.node(a)[0]).sum::<f64>() / 4.0;
                let y = n.iter().map(|&a| m.node(a)[1]).sum::<f64>() / 4.0;
                (y, x)
            })
            .collect();
        assert!(centres.windows(2).all(|w| w[0] < w[1]));
        assert!(!m.node_sets.contains_key("zmin_center")); // ny = 3 is odd
        let m = box3d([-1.0, -1.0, -2.0], [2.0, 2.0, 2.0], [4, 4, 4]).unwrap();
        assert_eq!(m.node(m.node_sets["zmin_center"][0]), &[0.0, 0.0, -2.0]);
        assert_eq!(m.node_sets["zmin_xline"].len(), 5);
        assert!(m.node_sets["zmin_yline"]
            .iter()
            .all(|&n| m.node(n)[0] == 0.0 && m.node(n)[2] == -2.0));
    }
}
