//! Errors of the mesh layer.
use super::CellKind;

/// Every failure of the mesh layer; messages name the offending cell, node, set, file or value.
#[derive(Debug, thiserror::Error)]
pub enum MeshError {
    /// The reference Jacobian determinant is not positive at a checked point of a cell.
    #[error(
        "cell {cell} ({kind:?}) is inverted or degenerate: det J = {det:e} at reference point {xi:?}"
    )]
    InvertedCell {
        cell: usize,
        kind: CellKind,
        /// reference coordinates of the checked point, [dim] (padded with 0 in 2D)
        xi: [f64; 3],
        det: f64,
    },
    #[error("cell {cell} refers to node {node}, but the mesh has only {n_nodes} nodes")]
    NodeIndexOutOfRange {
        cell: usize,
        node: u32,
        n_nodes: usize,
    },
    #[error("cell {cell} of kind {kind:?} has {got} nodes, expected {expected}")]
    CellNodeCount {
        cell: usize,
        kind: CellKind,
        expected: usize,
        got: usize,
    },
    #[error("cell {cell} of kind {kind:?} does not fit a mesh of dimension {dim}")]
    CellDimension {
        cell: usize,
        kind: CellKind,
        dim: usize,
    },
    #[error("inconsistent mesh arrays: {0}")]
    Inconsistent(String),
    #[error("cell {cell} does not exist (mesh has {n_cells} cells)")]
    CellOutOfRange { cell: usize, n_cells: usize },
    #[error("cell {cell} ({kind:?}) has no local face {face}")]
    FaceOutOfRange {
        cell: usize,
        kind: CellKind,
        face: u8,
    },
    #[error("node set '{set}' refers to node {node}, but the mesh has only {n_nodes} nodes")]
    NodeSetOutOfRange {
        set: String,
        node: u32,
        n_nodes: usize,
    },
    #[error("node set '{set}' is not sorted and unique at position {position}")]
    NodeSetUnsorted { set: String, position: usize },
    #[error("face set '{set}' refers to (cell {cell}, face {face}), which does not exist")]
    FaceSetOutOfRange { set: String, cell: u32, face: u8 },
    #[error("no set named '{0}'")]
    UnknownSet(String),
    #[error("invalid parameter {name} = {value}: {reason}")]
    InvalidParameter {
        name: &'static str,
        value: String,
        reason: &'static str,
    },
    #[error("cannot merge meshes: {0}")]
    Merge(String),
    #[error("{path}:{line}: {msg}")]
    Gmsh {
        path: String,
        line: usize,
        msg: String,
    },
    #[error("cannot read mesh file '{path}': {source}")]
    Io {
        path: String,
        #[source]
        source: std::io::Error,
    },
}
