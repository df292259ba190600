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

    /// Another process writes into the directory (it holds the directory's lock).
    #[error("{}: in use by {holder}; only one run or study may write into a directory at a time: wait for it to end, or choose another output directory", .path.display())]
    Locked { path: PathBuf, holder: String },

    /// An output file or folder that is a symbolic link: output is never written through one.
    #[error("{}: is a symbolic link; nurbs-contact does not write its output through links (remove the link, or choose another output directory)", .path.display())]
    Symlink { path: PathBuf },

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
