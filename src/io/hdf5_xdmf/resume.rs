//! Continuing a results file after a restart: the writer's description of what it has written
//! (kept in a checkpoint with a copy of the file), and a writer reopened on that copy.

use super::{
    partial_path, Center, FieldInfo, GridDef, GridInfo, ResultsWriter, StepInfo, H5_NAME, XDMF_NAME,
};
use crate::io::IoError;
use std::fmt::Write as _;
use std::path::Path;

impl ResultsWriter {
    /// The steps and fields written so far, as text for [`ResultsWriter::resume`].
    pub fn layout(&self) -> String {
        let mut s = String::new();
        for st in &self.steps {
            let _ = writeln!(s, "step {} {}", st.index, st.load_factor);
            for f in &st.fields {
                let c = match f.center {
                    Center::Node => "node",
                    Center::Cell => "cell",
                };
                let _ = writeln!(s, "field {} {} {c} {} {}", f.grid, f.name, f.rows, f.width);
            }
        }
        s
    }

    /// Flushes the file to disk (before it is copied).
    pub fn flush(&self) -> Result<(), IoError> {
        self.h5.flush().map_err(self.h5_err("the file (flush)"))
    }

    /// The path of the file being written (`results.h5.partial`), e.g. to copy it once flushed.
    pub fn partial_file(&self) -> &Path {
        &self.h5_partial
    }

    /// Continues `dir/results.h5` from `copy` (a results file as [`layout`](Self::layout) describes
    /// it, flushed when it was copied): the copy becomes `results.h5.partial`, the steps after it
    /// are appended. `grids` must be the ones the file was created with.
    pub fn resume(
        dir: &Path,
        copy: &Path,
        grids: &[GridDef<'_>],
        layout: &str,
    ) -> Result<Self, IoError> {
        let h5_final = dir.join(H5_NAME);
        let xdmf_final = dir.join(XDMF_NAME);
        for stale in [&h5_final, &xdmf_final] {
            if stale.exists() {
                std::fs::remove_file(stale).map_err(|source| IoError::File {
                    path: stale.clone(),
                    op: "remove the results of an earlier run",
                    source,
                })?;
            }
        }
        let h5_partial = partial_path(&h5_final);
        super::remove_partial(&h5_partial)?;
        std::fs::copy(copy, &h5_partial).map_err(|source| IoError::File {
            path: copy.to_path_buf(),
            op: "copy the checkpoint's results to results.h5.partial",
            source,
        })?;
        let h5 = hdf5::File::open_rw(&h5_partial).map_err(|source| IoError::Hdf5 {
            path: h5_partial.clone(),
            what: "the file".to_string(),
            source,
        })?;
        let bad = |message: String| IoError::Invalid {
            what: format!("{} (checkpoint results)", copy.display()),
            message,
        };
        let mut infos = Vec::new();
        for g in grids {
            let n_points = g.coords.len() / g.dim.max(1);
            let n_cells = g.connectivity.len() / g.kind.nodes_per_cell().max(1);
            let shape = h5
                .dataset(&format!("grids/{}/coordinates", g.name))
                .map(|d| d.shape())
                .map_err(|_| bad(format!("no grid `{}`", g.name)))?;
            if shape.first() != Some(&n_points) {
                return Err(bad(format!(
                    "grid `{}` has {:?} points, the model {n_points}",
                    g.name,
                    shape.first()
                )));
            }
            infos.push(GridInfo {
                name: g.name.to_string(),
                kind: g.kind,
                n_points,
                n_cells,
            });
        }
        let mut steps: Vec<StepInfo> = Vec::new();
        for (ln, line) in layout.lines().enumerate() {
            let w: Vec<&str> = line.split_whitespace().collect();
            let parse_err = || bad(format!("layout line {}: `{line}`", ln + 1));
            match w.as_slice() {
                ["step", index, load] => steps.push(StepInfo {
                    index: index.parse().map_err(|_| parse_err())?,
                    load_factor: load.parse().map_err(|_| parse_err())?,
                    fields: Vec::new(),
                }),
                ["field", grid, name, center, rows, width] => {
                    let f = FieldInfo {
                        grid: grid.parse().map_err(|_| parse_err())?,
                        name: name.to_string(),
                        center: match *center {
                            "node" => Center::Node,
                            "cell" => Center::Cell,
                            _ => return Err(parse_err()),
                        },
                        rows: rows.parse().map_err(|_| parse_err())?,
                        width: width.parse().map_err(|_| parse_err())?,
                    };
                    if f.grid >= infos.len() {
                        return Err(parse_err());
                    }
                    steps.last_mut().ok_or_else(parse_err)?.fields.push(f);
                }
                _ => return Err(parse_err()),
            }
        }
        // the layout describes the copy: every field is there, as many rows as its grid has points
        // or cells, in the shape the layout gives (which the XDMF file will declare)
        for st in &steps {
            for f in &st.fields {
                let g = &infos[f.grid];
                let what = format!(
                    "layout: step {} field `{}` of grid `{}`",
                    st.index, f.name, g.name
                );
                let (rows, of) = match f.center {
                    Center::Node => (g.n_points, "points"),
                    Center::Cell => (g.n_cells, "cells"),
                };
                if f.rows != rows {
                    return Err(bad(format!(
                        "{what}: {} rows, the grid has {rows} {of}",
                        f.rows
                    )));
                }
                let name = format!("steps/{:06}/{}/{}", st.index, g.name, f.name);
                let shape = h5
                    .dataset(&name)
                    .map(|d| d.shape())
                    .map_err(|_| bad(format!("{what}: no dataset `{name}` in the copy")))?;
                if shape != f.dims() {
                    return Err(bad(format!(
                        "{what}: the dataset has the shape {shape:?}, the layout {:?}",
                        f.dims()
                    )));
                }
            }
        }
        let w = ResultsWriter {
            h5,
            h5_partial,
            h5_final,
            xdmf_partial: partial_path(&xdmf_final),
            xdmf_final,
            grids: infos,
            steps,
        };
        w.write_xdmf()?;
        Ok(w)
    }
}
