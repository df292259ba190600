//! `history.csv`: one row per converged step, flushed as it is written.
//!
//! Columns: `step, stage, load_factor, newton_iterations, residual, cutbacks`, then three (3D) or two
//! (2D) columns `R_<body>_<set>_<x|y|z>` per reaction set, then the caller's extra columns (contact
//! resultants, reaction moments: see `crate::driver`), then `wall_time`. `step` counts converged
//! steps from 1; `stage` is the 0-based index into `[[stages]]` (as in `stages.0`).
//!
//! Written directly under its final name, not through `.partial`: the history of a run that failed
//! or was killed is exactly what one needs to look at, and `summary.json` (written only at the end,
//! with the status) says whether the run completed.

use crate::io::IoError;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

/// One converged step.
#[derive(Debug, Clone, Copy)]
pub struct HistoryRow<'a> {
    pub step: usize,
    pub stage: usize,
    pub load_factor: f64,
    pub newton_iterations: u32,
    /// Final residual norm.
    pub residual: f64,
    /// Cutbacks needed to converge this step.
    pub cutbacks: u32,
    /// `[n_reaction_sets][dim]`, in the order given to [`HistoryWriter::create`].
    pub reactions: &'a [f64],
    /// Values of the extra columns given to [`HistoryWriter::create`].
    pub extra: &'a [f64],
    /// Seconds since the start of the run.
    pub wall_time: f64,
}

pub struct HistoryWriter {
    path: PathBuf,
    out: BufWriter<File>,
    /// Expected length of [`HistoryRow::reactions`].
    n_reaction_values: usize,
    /// Expected length of [`HistoryRow::extra`].
    n_extra: usize,
}

impl HistoryWriter {
    /// Create `dir/history.csv` and write its header. `reactions` are `(body, set)` pairs.
    /// `extra` names further columns, written after the reactions.
    pub fn create(
        dir: &Path,
        dim: usize,
        reactions: &[(&str, &str)],
        extra: &[String],
    ) -> Result<Self, IoError> {
        if dim != 2 && dim != 3 {
            return Err(IoError::Invalid {
                what: "history.csv".to_string(),
                message: format!("dim must be 2 or 3, got {dim}"),
            });
        }
        let path = dir.join("history.csv");
        let file = crate::io::create_nofollow(&path)?;
        let header = header(dim, reactions, extra);
        let mut w = HistoryWriter {
            path,
            out: BufWriter::new(file),
            n_reaction_values: reactions.len() * dim,
            n_extra: extra.len(),
        };
        w.line(&header.join(","))?;
        Ok(w)
    }

    /// Append one row and flush it to the file.
    pub fn write_row(&mut self, row: &HistoryRow<'_>) -> Result<(), IoError> {
        if row.reactions.len() != self.n_reaction_values {
            return Err(IoError::Shape {
                what: format!("{} reactions of step {}", self.path.display(), row.step),
                expected: self.n_reaction_values,
                got: row.reactions.len(),
            });
        }
        if row.extra.len() != self.n_extra {
            return Err(IoError::Shape {
                what: format!("{} extra columns of step {}", self.path.display(), row.step),
                expected: self.n_extra,
                got: row.extra.len(),
            });
        }
        // `{}` on f64 prints the shortest text that reads back to the same number.
        let mut line = format!(
            "{},{},{},{},{},{}",
            row.step, row.stage, row.load_factor, row.newton_iterations, row.residual, row.cutbacks
        );
        for r in row.reactions.iter().chain(row.extra) {
            line.push(',');
            line.push_str(&r.to_string());
        }
        line.push(',');
        line.push_str(&row.wall_time.to_string());
        self.line(&line)
    }

    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Continues `dir/history.csv` from `copy` (a history a checkpoint kept, whose rows are the
    /// steps up to the checkpoint): the copy replaces the file and the following rows are appended.
    /// Its header must be the one [`create`](Self::create) writes for these columns.
    pub fn resume(
        dir: &Path,
        copy: &Path,
        dim: usize,
        reactions: &[(&str, &str)],
        extra: &[String],
    ) -> Result<Self, IoError> {
        let header = header(dim, reactions, extra).join(",");
        let text = std::fs::read_to_string(copy).map_err(|source| IoError::File {
            path: copy.to_path_buf(),
            op: "read",
            source,
        })?;
        if text.lines().next() != Some(header.as_str()) {
            return Err(IoError::Invalid {
                what: copy.display().to_string(),
                message: "its columns are not the ones this run writes".to_string(),
            });
        }
        let path = dir.join("history.csv");
        crate::io::write_atomic(&path, text.as_bytes())?;
        let file = {
            use crate::io::lock::NoFollow;
            std::fs::OpenOptions::new()
                .append(true)
                .custom_flags_nofollow()
                .open(&path)
                .map_err(|e| crate::io::lock::nofollow_error(&path, "open to append", e))?
        };
        Ok(HistoryWriter {
            path,
            out: BufWriter::new(file),
            n_reaction_values: reactions.len() * dim,
            n_extra: extra.len(),
        })
    }

    fn line(&mut self, text: &str) -> Result<(), IoError> {
        writeln!(self.out, "{text}")
            .and_then(|_| self.out.flush())
            .map_err(|source| IoError::File {
                path: self.path.clone(),
                op: "write",
                source,
            })
    }
}

/// The columns of `history.csv`.
fn header(dim: usize, reactions: &[(&str, &str)], extra: &[String]) -> Vec<String> {
    let mut header: Vec<String> = [
        "step",
        "stage",
        "load_factor",
        "newton_iterations",
        "residual",
        "cutbacks",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    for (body, set) in reactions {
        for axis in &["x", "y", "z"][..dim] {
            header.push(format!(
                "R_{}_{}_{axis}",
                column_safe(body),
                column_safe(set)
            ));
        }
    }
    header.extend(extra.iter().map(|c| column_safe(c)));
    header.push("wall_time".to_string());
    header
}

/// Body and set names go into column names: keep CSV and plotting tools happy.
fn column_safe(name: &str) -> String {
    name.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' {
                c
            } else {
                '_'
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tmp(tag: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("io_history_{tag}_{}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn history_has_reaction_columns_and_rows_are_flushed() {
        let dir = tmp("cols");
        let mut w =
            HistoryWriter::create(&dir, 3, &[("block", "zmin"), ("punch", "top face")], &[])
                .unwrap();
        let r = [1.0, 2.0, -3.5, 0.0, 0.0, 0.25];
        w.write_row(&HistoryRow {
            step: 1,
            stage: 0,
            load_factor: 0.2,
            newton_iterations: 5,
            residual: 1e-11,
            cutbacks: 1,
            reactions: &r,
            extra: &[],
            wall_time: 0.5,
        })
        .unwrap();
        // Read while the writer is still open: the row must already be on disk.
        let text = std::fs::read_to_string(dir.join("history.csv")).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(
            lines[0],
            "step,stage,load_factor,newton_iterations,residual,cutbacks,\
             R_block_zmin_x,R_block_zmin_y,R_block_zmin_z,R_punch_top_face_x,R_punch_top_face_y,R_punch_top_face_z,wall_time"
        );
        let cells: Vec<f64> = lines[1].split(',').map(|c| c.parse().unwrap()).collect();
        assert_eq!(
            cells,
            vec![1.0, 0.0, 0.2, 5.0, 1e-11, 1.0, 1.0, 2.0, -3.5, 0.0, 0.0, 0.25, 0.5]
        );
        drop(w);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn history_2d_has_two_columns_per_set_and_rejects_wrong_length() {
        let dir = tmp("2d");
        let mut w = HistoryWriter::create(&dir, 2, &[("strip", "xmax")], &[]).unwrap();
        let e = w
            .write_row(&HistoryRow {
                step: 1,
                stage: 0,
                load_factor: 1.0,
                newton_iterations: 1,
                residual: 0.0,
                cutbacks: 0,
                reactions: &[1.0, 2.0, 3.0],
                extra: &[],
                wall_time: 0.0,
            })
            .unwrap_err();
        assert!(e.to_string().contains("expected 2 values, got 3"), "{e}");
        let text = std::fs::read_to_string(w.path()).unwrap();
        assert!(text.starts_with("step,stage,load_factor,newton_iterations,residual,cutbacks,R_strip_xmax_x,R_strip_xmax_y,wall_time\n"));
        assert_eq!(text.lines().count(), 1, "the bad row must not be written");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
