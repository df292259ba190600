//! Why a model could not be built from a case.

use crate::mesh::MeshError;
use crate::scene::SceneError;

/// Why a model could not be built from a (schema-valid) case.
#[derive(Debug, thiserror::Error)]
pub enum ModelError {
    /// A mesh could not be generated or read.
    #[error("{}: mesh `{mesh}`: {source}", .file.display())]
    Mesh {
        /// The case file.
        file: std::path::PathBuf,
        /// The mesh table name.
        mesh: String,
        /// What went wrong.
        source: MeshError,
    },
    /// A set named in the case does not exist, or other case-level problems found once meshes exist.
    #[error(transparent)]
    Scene(#[from] SceneError),
    /// A material constant is out of range.
    #[error("{}: `bodies.{body}.material`: {msg}", .file.display())]
    Material {
        /// The case file.
        file: std::path::PathBuf,
        /// The body.
        body: String,
        /// What is wrong.
        msg: String,
    },
    /// A cell's reference geometry is invalid for its element family.
    #[error("{}: body `{body}` cell {cell} ({family}): {msg}", .file.display())]
    Element {
        /// The case file.
        file: std::path::PathBuf,
        /// The body.
        body: String,
        /// Body-local cell id.
        cell: usize,
        /// Element family.
        family: String,
        /// What is wrong.
        msg: String,
    },
    /// A periodic tie could not match its node sets.
    #[error("{}: `ties.{index}`: {msg}", .file.display())]
    Tie {
        /// The case file.
        file: std::path::PathBuf,
        /// Index of the tie.
        index: usize,
        /// What is wrong.
        msg: String,
    },
    /// The enriched layer of a body could not be built on its `enriched_surface`.
    #[error("{}: `bodies.{body}.enriched_surface`: {source}", .file.display())]
    Enrichment {
        /// The case file.
        file: std::path::PathBuf,
        /// The body.
        body: String,
        /// What went wrong.
        source: super::enrich::EnrichError,
    },
    /// A `[[contact]]` pair is invalid.
    #[error("{}: `{key}`: {msg}", .file.display())]
    Contact {
        /// The case file.
        file: std::path::PathBuf,
        /// The key.
        key: String,
        /// What is wrong.
        msg: String,
    },
    /// A `[bodies.<name>.node_sets.<set>]` selection is invalid or selects nothing.
    #[error("{}: `{key}`: {msg}", .file.display())]
    NodeSelection {
        /// The case file.
        file: std::path::PathBuf,
        /// The key.
        key: String,
        /// What is wrong.
        msg: String,
    },
    /// The case asks for something this version cannot build yet.
    #[error("{}: `{key}`: {msg}", .file.display())]
    Unsupported {
        /// The case file.
        file: std::path::PathBuf,
        /// The key.
        key: String,
        /// What is missing.
        msg: String,
    },
}
