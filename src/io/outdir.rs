//! The output directory of a run: created if missing, reused if an earlier run of this program
//! wrote it (recognised by [`RUN_MARKER`]), and refused if it holds anything else, unless the user
//! asked to overwrite; locked for the run's whole life ([`DirLock`]). A run never deletes what it
//! did not write, and never writes through a symbolic link.
//!
//! A restart into the directory of the run it continues writes its output into [`RESTART_DIR`]
//! first and moves it into place only at the end, when it got at least as far as that run
//! ([`promote_restart`]): a restart that fails leaves the run's results as they were.

use crate::io::lock::{DirLock, LOCK_FILE};
use crate::io::IoError;
use std::path::{Path, PathBuf};

/// Name of the marker file that every run leaves in its output directory.
pub const RUN_MARKER: &str = ".nurbs-contact-run";

/// Folder in a run directory where a restart into that directory writes its output until it may
/// replace the run's own.
pub const RESTART_DIR: &str = "restart";

/// Entries of a run directory that a run writes, replaces or prunes: none may be a symbolic link
/// (the run would write or delete through it, into another run's files).
const OUTPUT_NAMES: &[&str] = &[
    RUN_MARKER,
    "history.csv",
    "history.csv.partial",
    "results.h5",
    "results.h5.partial",
    "results.xdmf",
    "results.xdmf.partial",
    "summary.json",
    "summary.json.partial",
    "case.toml",
    "case.toml.partial",
    crate::checkpoint::CHECKPOINTS,
    RESTART_DIR,
];

/// How many foreign entries an error about an occupied directory names.
const SHOWN: usize = 3;

/// Makes `dir` this run's output directory, locked and marked; `overwrite` allows a directory
/// that holds files of something else (ours replace theirs where the names clash; the rest stays).
/// Nothing in the directory is changed before the lock is held (only the lock file is created),
/// so a start refused because another process writes there leaves that process's files alone.
pub fn claim_output_dir(dir: &Path, overwrite: bool) -> Result<DirLock, IoError> {
    let refuse = |reason: String| IoError::OutputDir {
        path: dir.to_path_buf(),
        reason,
    };
    let io = |op: &'static str, path: &Path, source| IoError::File {
        path: path.to_path_buf(),
        op,
        source,
    };
    match std::fs::metadata(dir) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            std::fs::create_dir_all(dir).map_err(|e| io("create the output directory", dir, e))?;
        }
        Err(e) => return Err(io("inspect the output directory", dir, e)),
        Ok(m) if !m.is_dir() => {
            return Err(refuse("it exists and is not a directory".into()));
        }
        Ok(_) => {
            let marker = dir.join(RUN_MARKER);
            let mut entries: Vec<String> = std::fs::read_dir(dir)
                .map_err(|e| io("list the output directory", dir, e))?
                .filter_map(|e| e.ok())
                .map(|e| e.file_name().to_string_lossy().into_owned())
                // another run may have just created it, before its marker
                .filter(|n| n != LOCK_FILE)
                .collect();
            if !entries.is_empty() && !overwrite && std::fs::symlink_metadata(&marker).is_err() {
                entries.sort();
                let more = entries.len().saturating_sub(SHOWN);
                let mut shown = entries
                    .iter()
                    .take(SHOWN)
                    .map(|n| format!("`{n}`"))
                    .collect::<Vec<_>>()
                    .join(", ");
                if more > 0 {
                    shown += &format!(" and {more} more");
                }
                return Err(refuse(format!(
                    "it exists and holds {shown}, but no earlier nurbs-contact run (no \
                     {RUN_MARKER} file); choose another output directory (--out), or pass \
                     --overwrite to write into it anyway"
                )));
            }
        }
    }
    let lock = DirLock::exclusive(dir)?;
    refuse_symlinks(dir)?;
    let marker = dir.join(RUN_MARKER);
    let mut f = crate::io::create_nofollow(&marker)?;
    use std::io::Write;
    f.write_all(
        b"This directory holds the results of a nurbs-contact run; the next run with this output \
          directory replaces them.\n",
    )
    .map_err(|e| io("mark the output directory", &marker, e))?;
    Ok(lock)
}

/// Refuses a run directory in which an entry the run writes is a symbolic link.
fn refuse_symlinks(dir: &Path) -> Result<(), IoError> {
    for name in OUTPUT_NAMES {
        let p = dir.join(name);
        if std::fs::symlink_metadata(&p).is_ok_and(|m| m.file_type().is_symlink()) {
            return Err(IoError::Symlink { path: p });
        }
    }
    Ok(())
}

/// Converged steps recorded in `dir/history.csv` (its rows after the header; 0 without one).
pub fn history_rows(dir: &Path) -> usize {
    std::fs::read_to_string(dir.join("history.csv"))
        .map(|t| t.lines().skip(1).filter(|l| !l.trim().is_empty()).count())
        .unwrap_or(0)
}

/// A fresh `dir/`[`RESTART_DIR`] for a restart's output (an earlier restart's is removed; the
/// caller holds `dir`'s lock).
pub fn restart_staging(dir: &Path) -> Result<PathBuf, IoError> {
    remove_restart_staging(dir)?;
    let staging = dir.join(RESTART_DIR);
    std::fs::create_dir(&staging).map_err(|source| IoError::File {
        path: staging.clone(),
        op: "create",
        source,
    })?;
    Ok(staging)
}

/// Removes the output an earlier restart left in `dir/`[`RESTART_DIR`] (the caller holds `dir`'s
/// lock and replaces or continues the run there).
pub fn remove_restart_staging(dir: &Path) -> Result<(), IoError> {
    let staging = dir.join(RESTART_DIR);
    match std::fs::symlink_metadata(&staging) {
        Ok(m) if m.file_type().is_symlink() => Err(IoError::Symlink { path: staging }),
        Ok(_) => std::fs::remove_dir_all(&staging).map_err(|source| IoError::File {
            path: staging,
            op: "remove the output of an earlier restart",
            source,
        }),
        Err(_) => Ok(()),
    }
}

/// Moves a finished restart's output from `staging` into the run directory `dir`, replacing the
/// run's own files of the same names: the results first, `summary.json` (which says whether the
/// run completed) last; then removes `staging` and the unfinished results of a run killed before
/// it could finish them.
pub fn promote_restart(staging: &Path, dir: &Path) -> Result<(), IoError> {
    let io = |op: &'static str, path: &Path| {
        let p = path.to_path_buf();
        move |source| IoError::File {
            path: p,
            op,
            source,
        }
    };
    let mut names: Vec<String> = std::fs::read_dir(staging)
        .map_err(io("list", staging))?
        .filter_map(|e| e.ok())
        .filter(|e| e.file_type().is_ok_and(|t| t.is_file()))
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| !n.ends_with(".partial"))
        .collect();
    let rank = |n: &str| match n {
        "results.h5" => 0,
        "results.xdmf" => 1,
        "summary.json" => 3,
        _ => 2,
    };
    names.sort_by_key(|n| (rank(n), n.clone()));
    for n in &names {
        crate::io::commit(&staging.join(n), &dir.join(n))?;
    }
    for stale in ["results.h5.partial", "results.xdmf.partial"] {
        let p = dir.join(stale);
        if std::fs::symlink_metadata(&p).is_ok() {
            std::fs::remove_file(&p).map_err(io("remove the unfinished results of the run", &p))?;
        }
    }
    std::fs::remove_dir_all(staging).map_err(io("remove", staging))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(name: &str) -> std::path::PathBuf {
        let d = std::env::temp_dir().join(format!("nc_outdir_{}_{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        d
    }

    #[test]
    fn missing_directory_is_created_and_marked_then_reused() {
        let d = scratch("new").join("a/b");
        drop(claim_output_dir(&d, false).unwrap());
        assert!(d.join(RUN_MARKER).is_file());
        std::fs::write(d.join("summary.json"), "{}").unwrap();
        std::fs::write(d.join("notes.txt"), "mine").unwrap();
        // marked: an earlier run, reused whatever else is there
        claim_output_dir(&d, false).unwrap();
        assert!(d.join("notes.txt").is_file());
    }

    #[test]
    fn empty_directory_is_used() {
        let d = scratch("empty");
        std::fs::create_dir_all(&d).unwrap();
        drop(claim_output_dir(&d, false).unwrap());
        assert!(d.join(RUN_MARKER).is_file());
    }

    #[test]
    fn foreign_directory_is_refused_unless_overwrite() {
        let d = scratch("foreign");
        std::fs::create_dir_all(d.join("src")).unwrap();
        for f in ["a.txt", "b.txt", "c.txt"] {
            std::fs::write(d.join(f), "x").unwrap();
        }
        let e = claim_output_dir(&d, false).unwrap_err().to_string();
        assert!(e.contains(&d.display().to_string()), "{e}");
        assert!(
            e.contains("--overwrite") && e.contains("`a.txt`") && e.contains("1 more"),
            "{e}"
        );
        assert!(!d.join(RUN_MARKER).exists() && !d.join(LOCK_FILE).exists());
        drop(claim_output_dir(&d, true).unwrap());
        assert!(d.join(RUN_MARKER).is_file() && d.join("src").is_dir());
    }

    #[test]
    fn a_file_is_not_a_directory() {
        let d = scratch("file");
        std::fs::write(&d, "x").unwrap();
        let e = claim_output_dir(&d, true).unwrap_err().to_string();
        assert!(e.contains("not a directory"), "{e}");
        std::fs::remove_file(&d).unwrap();
    }

    #[test]
    fn a_held_directory_is_refused_and_left_as_it_is() {
        let d = scratch("held");
        std::fs::create_dir_all(&d).unwrap();
        let lock = claim_output_dir(&d, false).unwrap();
        std::fs::write(d.join("history.csv"), "step\n1\n").unwrap();
        let e = claim_output_dir(&d, false).unwrap_err().to_string();
        assert!(
            e.contains(&d.display().to_string()) && e.contains("in use by process"),
            "{e}"
        );
        assert_eq!(
            std::fs::read_to_string(d.join("history.csv")).unwrap(),
            "step\n1\n"
        );
        drop(lock);
        drop(claim_output_dir(&d, false).unwrap());
    }

    #[test]
    fn a_symlinked_checkpoints_folder_or_output_file_is_refused() {
        let d = scratch("links");
        let other = scratch("links_other");
        std::fs::create_dir_all(&d).unwrap();
        std::os::unix::fs::symlink(&other, d.join("checkpoints")).unwrap();
        let e = claim_output_dir(&d, true).unwrap_err();
        assert!(matches!(e, IoError::Symlink { .. }), "{e}");
        assert!(e.to_string().contains("checkpoints"), "{e}");
        std::fs::remove_file(d.join("checkpoints")).unwrap();
        std::os::unix::fs::symlink(other.join("h.csv"), d.join("history.csv")).unwrap();
        let e = claim_output_dir(&d, true).unwrap_err().to_string();
        assert!(
            e.contains("history.csv") && e.contains("symbolic link"),
            "{e}"
        );
    }

    #[test]
    fn a_restart_is_promoted_results_first_and_staging_removed() {
        let d = scratch("promote");
        drop(claim_output_dir(&d, false).unwrap());
        std::fs::write(d.join("history.csv"), "h\n1\n2\n3\n").unwrap();
        std::fs::write(d.join("results.h5.partial"), "killed").unwrap();
        assert_eq!(history_rows(&d), 3);
        let s = restart_staging(&d).unwrap();
        std::fs::write(s.join("history.csv"), "h\n1\n2\n3\n4\n").unwrap();
        std::fs::write(s.join("summary.json"), "{}").unwrap();
        std::fs::write(s.join("results.h5"), "r").unwrap();
        // an earlier restart's leftovers go
        assert!(restart_staging(&d)
            .unwrap()
            .read_dir()
            .unwrap()
            .next()
            .is_none());
        std::fs::write(s.join("history.csv"), "h\n1\n2\n3\n4\n").unwrap();
        std::fs::write(s.join("results.h5"), "r").unwrap();
        promote_restart(&s, &d).unwrap();
        assert_eq!(history_rows(&d), 4);
        assert!(!s.exists() && !d.join("results.h5.partial").exists());
        assert_eq!(std::fs::read_to_string(d.join("results.h5")).unwrap(), "r");
    }
}
