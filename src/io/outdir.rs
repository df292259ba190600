//! The output directory of a run: created if missing, reused if an earlier run of this program
//! wrote it (recognised by [`RUN_MARKER`]), and refused if it holds anything else, unless the user
//! asked to overwrite. A run never deletes what it did not write.

use crate::io::IoError;
use std::path::Path;

/// Name of the marker file that every run leaves in its output directory.
pub const RUN_MARKER: &str = ".nurbs-contact-run";

/// How many foreign entries an error about an occupied directory names.
const SHOWN: usize = 3;

/// Makes `dir` this run's output directory and marks it; `overwrite` allows a directory that holds
/// files of something else (ours replace theirs where the names clash; the rest stays).
pub fn claim_output_dir(dir: &Path, overwrite: bool) -> Result<(), IoError> {
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
            if marker.exists() {
                return Ok(());
            }
            let mut entries: Vec<String> = std::fs::read_dir(dir)
                .map_err(|e| io("list the output directory", dir, e))?
                .filter_map(|e| e.ok())
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .collect();
            if !entries.is_empty() && !overwrite {
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
    let marker = dir.join(RUN_MARKER);
    std::fs::write(
        &marker,
        "This directory holds the results of a nurbs-contact run; the next run with this output \
         directory replaces them.\n",
    )
    .map_err(|e| io("mark the output directory", &marker, e))
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
        claim_output_dir(&d, false).unwrap();
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
        claim_output_dir(&d, false).unwrap();
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
        assert!(!d.join(RUN_MARKER).exists());
        claim_output_dir(&d, true).unwrap();
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
}
