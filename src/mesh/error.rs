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
    /// A node coordinate is not finite or too large for the geometry (see
    /// [`super::MAX_COORDINATE`]).
    #[error("node {node} has the coordinates {x:?}: {why}")]
    BadCoordinate { node: u32, x: Vec<f64>, why: String },
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
    /// A node appears twice in one cell, and it is not a collapsed point that the mesh's generator
    /// declared ([`super::Mesh::collapsed_nodes`]): the cell covers less than its shape suggests
    /// (a quad with a repeated node is a triangle, leaving a hole beside it).
    #[error("cell {cell} ({kind:?}) lists node {node} twice (a collapsed cell): nodes {nodes:?}")]
    RepeatedNode {
        cell: usize,
        kind: CellKind,
        node: u32,
        nodes: Vec<u32>,
    },
    /// Two different nodes of one cell lie at the same point: the cell is collapsed there.
    #[error(
        "cell {cell} ({kind:?}) has nodes {a} and {b} at the same point {x:?} (a collapsed cell)"
    )]
    CoincidentNodes {
        cell: usize,
        kind: CellKind,
        a: u32,
        b: u32,
        x: Vec<f64>,
    },
    /// Two cells have the same set of nodes: the region would count twice (stiffer, heavier).
    #[error("cell {cell} duplicates cell {first}: both have the nodes {nodes:?}")]
    DuplicateCell {
        cell: usize,
        first: usize,
        nodes: Vec<u32>,
    },
    /// A mesh bigger than the process can allocate.
    #[error("mesh too large: {0}")]
    TooLarge(String),
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

impl MeshError {
    /// The cell this error is about, if it is about one cell (so that a reader can name the line
    /// that defined it).
    pub fn cell(&self) -> Option<usize> {
        match self {
            MeshError::InvertedCell { cell, .. }
            | MeshError::NodeIndexOutOfRange { cell, .. }
            | MeshError::CellNodeCount { cell, .. }
            | MeshError::CellDimension { cell, .. }
            | MeshError::RepeatedNode { cell, .. }
            | MeshError::CoincidentNodes { cell, .. }
            | MeshError::DuplicateCell { cell, .. } => Some(*cell),
            _ => None,
        }
    }
}
