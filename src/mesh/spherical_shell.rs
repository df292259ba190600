//! The layered shell that both hemisphere generators build: `m + 1` copies of one grid of unit
//! directions at the radii `R, R - h/m, ..., R - h`, joined by `n x n` hexahedra per layer, with the
//! `outer` / `inner` face and node sets. The generators differ only in their direction grid and in
//! which grid points share a node (collapsed points of a degenerate surface).

use super::{CellKind, Mesh, MeshError};

/// Checks the parameters both hemisphere generators take.
#[allow(non_snake_case)]
pub(super) fn check_shell_parameters(R: f64, h: f64, m: usize) -> Result<(), MeshError> {
    if !(R > 0.0 && R.is_finite()) {
        return Err(MeshError::InvalidParameter {
            name: "R",
            value: R.to_string(),
            reason: "must be positive and finite",
        });
    }
    if !(h > 0.0 && h < R) {
        return Err(MeshError::InvalidParameter {
            name: "h",
            value: h.to_string(),
            reason: "must lie in (0, R)",
        });
    }
    if m == 0 {
        return Err(MeshError::InvalidParameter {
            name: "m",
            value: m.to_string(),
            reason: "need at least one cell through the thickness",
        });
    }
    Ok(())
}

/// Builds the shell. `dirs` holds the unit direction of each node of one layer, `[per_layer][3]`;
/// `layer_node(i, j)` gives the layer-local node of grid point `(i, j)`, `0 <= i, j <= n` (several
/// points may share a node). Node `(i, j)` of layer `l` (0 = outer) is `l * per_layer +
/// layer_node(i, j)`; cell `(i, j)` of layer `l` is `(l * n + j) * n + i`, its local face 0
/// (zeta = -1) on the outer side. Sets: `outer`/`inner` (faces of the first/last layer, ordered
/// row-major, and all nodes of the outermost/innermost layer). Nodes shared by several grid points
/// become [`Mesh::collapsed_nodes`].
#[allow(non_snake_case)]
pub(super) fn spherical_shell(
    center: [f64; 3],
    R: f64,
    h: f64,
    n: usize,
    m: usize,
    dirs: &[[f64; 3]],
    layer_node: &dyn Fn(usize, usize) -> usize,
) -> Mesh {
    let per_layer = dirs.len();
    let node = |i: usize, j: usize, l: usize| (l * per_layer + layer_node(i, j)) as u32;
    let mut mesh = Mesh::new(3);
    for l in 0..=m {
        let r = R - h * l as f64 / m as f64;
        for d in dirs {
            mesh.push_node(&[
                center[0] + r * d[0],
                center[1] + r * d[1],
                center[2] + r * d[2],
            ]);
        }
    }
    for l in 0..m {
        for j in 0..n {
            for i in 0..n {
                mesh.push_cell(
                    CellKind::Hex8,
                    &[
                        node(i, j, l),
                        node(i + 1, j, l),
                        node(i + 1, j + 1, l),
                        node(i, j + 1, l),
                        node(i, j, l + 1),
                        node(i + 1, j, l + 1),
                        node(i + 1, j + 1, l + 1),
                        node(i, j + 1, l + 1),
                    ],
                );
            }
        }
    }
    let cell = |i: usize, j: usize, l: usize| ((l * n + j) * n + i) as u32;
    let grid: Vec<(usize, usize)> = (0..n).flat_map(|j| (0..n).map(move |i| (i, j))).collect();
    mesh.face_sets.insert(
        "outer".into(),
        grid.iter().map(|&(i, j)| (cell(i, j, 0), 0)).collect(),
    );
    mesh.face_sets.insert(
        "inner".into(),
        grid.iter().map(|&(i, j)| (cell(i, j, m - 1), 1)).collect(),
    );
    let layer = |l: usize| -> Vec<u32> {
        (l * per_layer..(l + 1) * per_layer)
            .map(|a| a as u32)
            .collect()
    };
    // grid points that share a node are the degenerate points of the surface: declare their
    // nodes (in every layer) as collapsed, the only repeated nodes `Mesh::validate` accepts
    let mut shared = vec![0usize; per_layer];
    for j in 0..=n {
        for i in 0..=n {
            shared[layer_node(i, j)] += 1;
        }
    }
    mesh.collapsed_nodes = (0..=m)
        .flat_map(|l| {
            let shared = &shared;
            (0..per_layer)
                .filter(move |&a| shared[a] > 1)
                .map(move |a| (l * per_layer + a) as u32)
        })
        .collect();
    mesh.insert_node_set("outer", layer(0));
    mesh.insert_node_set("inner", layer(m));
    mesh
}
