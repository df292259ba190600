//! Structured 2D block of Quad4 cells (ironing block, peeling strip, DCB strips).
use super::{CellKind, Mesh, MeshError};

/// Side of a rectangle.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Side {
    Bottom,
    Right,
    Top,
    Left,
}

impl Side {
    /// Local face of a cell in the default (unrotated) numbering that lies on this side.
    fn default_face(self) -> u8 {
        match self {
            Side::Bottom => 0,
            Side::Right => 1,
            Side::Top => 2,
            Side::Left => 3,
        }
    }
}

/// Rectangle `[x0, x0 + lx] x [y0, y0 + ly]` split into `nx x ny` equal Quad4 cells, with local
/// face 0 of every cell facing down (the contact side of the peeling strip and the upper DCB
/// strip). See [`rectangle_oriented`] for the sets.
pub fn rectangle(origin: [f64; 2], size: [f64; 2], n: [usize; 2]) -> Result<Mesh, MeshError> {
    rectangle_oriented(origin, size, n, Side::Bottom)
}

/// Rectangle `[x0, x0 + lx] x [y0, y0 + ly]` split into `nx x ny` equal Quad4 cells. Every cell
/// is rotated so that its local face 0 faces `contact` (e.g. `Side::Top` for the ironing block
/// and the lower DCB strip), so the contact face is local face 0 on that side. Only one side
/// can carry local face 0: a strip with contact on two opposite sides (possible only if
/// `ny = 1` cells touch both) has local face 2 on the other one.
///
/// Nodes are numbered row by row from the bottom left, node (i, j) = j (nx + 1) + i; cells
/// likewise, cell (i, j) = j nx + i.
///
/// Named sets:
/// - node and face sets `bottom`, `top` (faces ordered left to right), `left`, `right`
///   (faces ordered bottom to top);
/// - corner node sets `bottom_left`, `bottom_right`, `top_left`, `top_right`;
/// - edge midpoint node sets `bottom_mid`, `top_mid`, `left_mid`, `right_mid` (`right_mid` is
///   the loaded / fixed point of the DCB): exact when the number of cells along that edge is
///   even; when it is odd there is no node at the midpoint and the nearest node with the lower
///   coordinate along the edge is taken.
pub fn rectangle_oriented(
    origin: [f64; 2],
    size: [f64; 2],
    n: [usize; 2],
    contact: Side,
) -> Result<Mesh, MeshError> {
    let [nx, ny] = n;
    for (name, v) in [("nx", nx), ("ny", ny)] {
        if v == 0 {
            return Err(MeshError::InvalidParameter {
                name,
                value: v.to_string(),
                reason: "need at least one cell",
            });
        }
    }
    for (name, v) in [("lx", size[0]), ("ly", size[1])] {
        if !(v > 0.0 && v.is_finite()) {
            return Err(MeshError::InvalidParameter {
                name,
                value: v.to_string(),
                reason: "size must be positive and finite",
            });
        }
    }
    let mut mesh = Mesh::new(2);
    for j in 0..=ny {
        for i in 0..=nx {
            mesh.push_node(&[
                origin[0] + size[0] * i as f64 / nx as f64,
                origin[1] + size[1] * j as f64 / ny as f64,
            ]);
        }
    }
    let node = |i: usize, j: usize| (j * (nx + 1) + i) as u32;
    for j in 0..ny {
        for i in 0..nx {
            mesh.push_cell(
                CellKind::Quad4,
                &[
                    node(i, j),
                    node(i + 1, j),
                    node(i + 1, j + 1),
                    node(i, j + 1),
                ],
            );
        }
    }
    let cell = |i: usize, j: usize| (j * nx + i) as u32;
    let sides: [(&str, Side, Vec<u32>, Vec<u32>); 4] = [
        (
            "bottom",
            Side::Bottom,
            (0..nx).map(|i| cell(i, 0)).collect(),
            (0..=nx).map(|i| node(i, 0)).collect(),
        ),
        (
            "right",
            Side::Right,
            (0..ny).map(|j| cell(nx - 1, j)).collect(),
            (0..=ny).map(|j| node(nx, j)).collect(),
        ),
        (
            "top",
            Side::Top,
            (0..nx).map(|i| cell(i, ny - 1)).collect(),
            (0..=nx).map(|i| node(i, ny)).collect(),
        ),
        (
            "left",
            Side::Left,
            (0..ny).map(|j| cell(0, j)).collect(),
            (0..=ny).map(|j| node(0, j)).collect(),
        ),
    ];
    for (name, side, cells, nodes) in sides {
        mesh.face_sets.insert(
            name.to_string(),
            cells
                .into_iter()
                .map(|c| (c, side.default_face()))
                .collect(),
        );
        mesh.insert_node_set(name, nodes);
    }
    for (name, i, j) in [
        ("bottom_left", 0, 0),
        ("bottom_right", nx, 0),
        ("top_left", 0, ny),
        ("top_right", nx, ny),
    ] {
        mesh.insert_node_set(name, vec![node(i, j)]);
    }
    // integer division picks the lower of the two middle nodes for an odd count
    for (name, i, j) in [
        ("bottom_mid", nx / 2, 0),
        ("top_mid", nx / 2, ny),
        ("left_mid", 0, ny / 2),
        ("right_mid", nx, ny / 2),
    ] {
        mesh.insert_node_set(name, vec![node(i, j)]);
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

    fn assert_ordered_along(m: &Mesh, set: &str, axis: usize, const_axis: usize, value: f64) {
        let faces = &m.face_sets[set];
        let mut last = f64::NEG_INFINITY;
        for &(c, f) in faces {
            let nodes = m.face_nodes(c as usize, f).unwrap();
            let mid: f64 = nodes.iter().map(|&n| m.node(n)[axis]).sum::<f64>() / 2.0;
            assert!(mid > last, "{set} not ordered");
            last = mid;
            for &n in &nodes {
                assert!(
                    (m.node(n)[const_axis] - value).abs() < 1e-14,
                    "{set}: node {n} off the side"
                );
            }
        }
    }

    #[test]
    fn rectangle_is_valid_has_exact_area_and_ordered_sets() {
        for (n, contact) in [
            ([1, 1], Side::Bottom),
            ([4, 2], Side::Top),
            ([40, 8], Side::Top),
            ([5, 3], Side::Left),
        ] {
            let m = rectangle_oriented([1.0, -2.0], [10.0, 2.0], n, contact).unwrap();
            m.validate().unwrap();
            assert!((m.measure() - 20.0).abs() < 1e-12);
            assert_eq!(m.n_cells(), n[0] * n[1]);
            assert_eq!(m.face_sets["bottom"].len(), n[0]);
            assert_eq!(m.node_sets["left"].len(), n[1] + 1);
            assert_ordered_along(&m, "bottom", 0, 1, -2.0);
            assert_ordered_along(&m, "top", 0, 1, 0.0);
            assert_ordered_along(&m, "left", 1, 0, 1.0);
            assert_ordered_along(&m, "right", 1, 0, 11.0);
            let contact_set = match contact {
                Side::Bottom => "bottom",
                Side::Top => "top",
                Side::Left => "left",
                Side::Right => "right",
            };
            assert!(m.face_sets[contact_set].iter().all(|&(_, f)| f == 0));
            assert_eq!(m.node(m.node_sets["top_right"][0]), &[11.0, 0.0]);
        }
    }

    #[test]
    fn right_mid_is_exact_for_even_and_nearest_below_for_odd() {
        let m = rectangle([0.0, 0.0], [20.0, 1.0], [40, 2]).unwrap();
        assert_eq!(m.node(m.node_sets["right_mid"][0]), &[20.0, 0.5]);
        let m = rectangle([0.0, 0.0], [20.0, 1.0], [40, 3]).unwrap();
        let p = m.node(m.node_sets["right_mid"][0]);
        assert_eq!(p[0], 20.0);
        assert!((p[1] - 1.0 / 3.0).abs() < 1e-14);
    }

    #[test]
    fn rectangle_rejects_zero_cells_and_bad_size() {
        assert!(matches!(
            rectangle([0.0, 0.0], [1.0, 1.0], [0, 1]),
            Err(MeshError::InvalidParameter { name: "nx", .. })
        ));
        assert!(matches!(
            rectangle([0.0, 0.0], [1.0, -1.0], [1, 1]),
            Err(MeshError::InvalidParameter { name: "ly", .. })
        ));
    }
}
