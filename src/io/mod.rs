//! Results writers. They take plain data (coordinates, connectivity, field values as flat slices),
//! never a mesh type, and are called on one rank with gathered data.
//!
//! - [`hdf5_xdmf`]: `results.h5` + `results.xdmf` (ParaView), one grid per cell type, one temporal
//!   collection per grid, load factor as time. Complete or absent: written under `.partial` names
//!   and renamed by [`ResultsWriter::finish`].
//! - [`history`]: `history.csv`, one row per converged step, flushed per row.
//! - [`summary`]: `summary.json` (run statistics, status), written atomically.
//! - [`outdir`]: claiming the output directory ([`claim_output_dir`], marker [`RUN_MARKER`]).
//! - [`lock`]: one writer per directory ([`DirLock`]); output files created without following
//!   symbolic links ([`create_nofollow`]).
//! - [`atomic`]: the shared write-to-temp-then-rename helpers.
//! - [`error`]: [`IoError`], naming the file and the dataset or field concerned.

pub mod atomic;
pub mod error;
pub mod hdf5_xdmf;
pub mod history;
pub mod lock;
pub mod outdir;
pub mod plots;
pub mod summary;

pub use atomic::{commit, partial_path, write_atomic};
pub use error::IoError;
pub use hdf5_xdmf::{CellKind, Center, FieldData, GridDef, ResultsWriter};
pub use history::{HistoryRow, HistoryWriter};
pub use lock::{create_nofollow, DirLock, LOCK_FILE};
pub use outdir::{claim_output_dir, RUN_MARKER};
pub use summary::{
    write_summary, ContactDataStats, ContactPatternStats, NewtonStats, PartitionStats, PhaseTimes,
    RankTimes, RunStatus, StepLog, Summary,
};
