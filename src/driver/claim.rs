//! The directories of a run: its output directory, locked by rank 0 for the run's whole life; the
//! directory a restart continues from another one, locked against writers while the run reads it;
//! and where a restart into the directory of the run it continues writes until it may replace
//! that run's results ([`crate::io::outdir::RESTART_DIR`]).

use super::{agree, Error, RunOptions};
use crate::io::{self, outdir, DirLock};
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;
use std::path::{Path, PathBuf};

/// A run's claimed directories.
pub(super) struct Dirs {
    /// The run directory: checkpoints, and the results once finished.
    pub(super) out: PathBuf,
    /// Where results.h5, history.csv and summary.json are written: `out`, or for a restart into
    /// the directory of the run it continues, the staging folder inside it.
    pub(super) write: PathBuf,
    /// With staging: the converged steps of the continued run's history.csv (rank 0).
    continued_rows: Option<usize>,
    /// Rank 0: held until the run ends.
    _locks: Vec<DirLock>,
}

impl Dirs {
    /// Whether the results are staged beside the continued run's.
    pub(super) fn staged(&self) -> bool {
        self.write != self.out
    }

    /// Rank 0, at the end of a staged restart: moves its output into the run directory when it
    /// converged or recorded more steps than the run it continues; otherwise leaves both as they
    /// are and says so. Returns where the results are.
    pub(super) fn settle(&self, converged: bool) -> Result<PathBuf, Error> {
        if !self.staged() {
            return Ok(self.out.clone());
        }
        let (old, new) = (
            self.continued_rows.unwrap_or(0),
            outdir::history_rows(&self.write),
        );
        if converged || new > old {
            outdir::promote_restart(&self.write, &self.out)?;
            return Ok(self.out.clone());
        }
        eprintln!(
            "note: the restart ended at converged load step {new}, not beyond step {old} of the run it continues: that run's results in {} are unchanged, the restart's are in {}",
            self.out.display(),
            self.write.display()
        );
        Ok(self.write.clone())
    }
}

/// Locks and prepares the directories of a run writing into `out` (rank 0; the outcome is agreed,
/// so every rank fails together when a directory is refused). With `--restart DIR`, DIR must hold
/// a checkpoint; when `out` is DIR itself the results are staged, otherwise DIR is locked shared
/// (no writer may prune the checkpoint being read).
///
/// Collective.
pub(super) fn claim(
    comm: &SimpleCommunicator,
    opts: &RunOptions,
    out: PathBuf,
) -> Result<Dirs, Error> {
    // a restart without a checkpoint is refused before anything is claimed
    if let Some(dir) = &opts.restart {
        agree(comm, crate::checkpoint::latest(dir).map_err(Error::Restart))?;
    }
    let root = comm.rank() == 0;
    let claimed = if root {
        claim_on_root(opts, &out)
    } else {
        Ok((Vec::new(), None))
    };
    let (locks, continued_rows) = agree(comm, claimed)?;
    let mut staged = i32::from(continued_rows.is_some());
    comm.process_at_rank(0).broadcast_into(&mut staged);
    let write = if staged != 0 {
        out.join(outdir::RESTART_DIR)
    } else {
        out.clone()
    };
    Ok(Dirs {
        out,
        write,
        continued_rows,
        _locks: locks,
    })
}

/// Rank 0's part of [`claim`]: the locks, and with staging the continued run's step count.
fn claim_on_root(opts: &RunOptions, out: &Path) -> Result<(Vec<DirLock>, Option<usize>), Error> {
    let mut locks = Vec::new();
    let same = opts.restart.as_deref().is_some_and(|r| same_dir(r, out));
    if let Some(source) = opts.restart.as_deref().filter(|_| !same) {
        locks.extend(DirLock::shared(source)?);
    }
    locks.push(io::claim_output_dir(out, opts.overwrite)?);
    let continued_rows = if same {
        outdir::restart_staging(out)?;
        Some(outdir::history_rows(out))
    } else {
        outdir::remove_restart_staging(out)?;
        None
    };
    Ok((locks, continued_rows))
}

/// Whether two paths name one existing directory.
fn same_dir(a: &Path, b: &Path) -> bool {
    match (a.canonicalize(), b.canonicalize()) {
        (Ok(x), Ok(y)) => x == y,
        _ => false,
    }
}
