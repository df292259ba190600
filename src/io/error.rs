//! The error type of the results writers.

use std::path::PathBuf;
use thiserror::Error;

#[derive(Debug, Error)]
pub enum IoError {
    #[error("{}: cannot {op}: {source}", .path.display())]
    File {
        path: PathBuf,
        op: &'static str,
        #[source]
        source: std::io::Error,
    },

    /// The output directory cannot be used (it holds something else, or is not a directory).
    #[error("{}: cannot use as the output directory: {reason}", .path.display())]
    OutputDir { path: PathBuf, reason: String },

    #[error("{}: HDF5 error while writing {what}: {source}", .path.display())]
    Hdf5 {
        path: PathBuf,
        what: String,
        #[source]
        source: hdf5::Error,
    },

    #[error("{}: cannot serialise JSON: {source}", .path.display())]
    Json {
        path: PathBuf,
        #[source]
        source: serde_json::Error,
    },

    /// A slice handed to a writer has the wrong length.
    #[error("{what}: expected {expected} values, got {got}")]
    Shape {
        what: String,
        expected: usize,
        got: usize,
    },

    /// Malformed grid or field description.
    #[error("{what}: {message}")]
    Invalid { what: String, message: String },
}
