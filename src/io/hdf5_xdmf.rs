//! `results.h5` + `results.xdmf`: mesh and per-step fields in HDF5, described by an XDMF 3 file that
//! ParaView opens directly (XDMF3 reader).
//!
//! HDF5 layout (all datasets 2D, row-major):
//! - `/grids/<grid>/coordinates`  `[n_points][3]` f64 (2D coordinates padded with z = 0)
//! - `/grids/<grid>/connectivity` `[n_cells][nodes_per_cell]` i64
//! - `/steps/<k>/<grid>/<field>`  `[n_points or n_cells]` (scalar) or `[..][3]` (vector) f64, `k` = output index `000000`, ...;
//!   attribute `load_factor` on `/steps/<k>`.
//!
//! XDMF: one temporal collection per grid (the bulk mesh `bulk`; later a `surface` grid sampling the
//! enriched surfaces as polylines/polygons), each step a uniform grid at time = load factor whose
//! geometry and topology point at the shared datasets. A second grid is just a second [`GridDef`].

use crate::io::atomic::{commit, partial_path};

mod resume;
use crate::io::IoError;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// The cell type of a grid (one type per grid keeps XDMF simple and ParaView fast).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CellKind {
    /// 4-node quadrilateral, counter-clockwise.
    Quadrilateral,
    /// 8-node hexahedron, VTK node order.
    Hexahedron,
    /// Open polyline of `nodes_per_cell` points (sampled 2D contact surfaces).
    Polyline { nodes_per_cell: usize },
    /// Polygon of `nodes_per_cell` points (sampled 3D contact surface patches).
    Polygon { nodes_per_cell: usize },
    /// Single points (the contact quadrature points).
    Polyvertex,
}

impl CellKind {
    pub fn nodes_per_cell(self) -> usize {
        match self {
            CellKind::Quadrilateral => 4,
            CellKind::Hexahedron => 8,
            CellKind::Polyvertex => 1,
            CellKind::Polyline { nodes_per_cell } | CellKind::Polygon { nodes_per_cell } => {
                nodes_per_cell
            }
        }
    }

    /// `TopologyType` attribute, plus `NodesPerElement` for the variable-size kinds.
    fn xdmf_topology(self) -> String {
        match self {
            CellKind::Quadrilateral => "TopologyType=\"Quadrilateral\"".to_string(),
            CellKind::Hexahedron => "TopologyType=\"Hexahedron\"".to_string(),
            CellKind::Polyvertex => "TopologyType=\"Polyvertex\" NodesPerElement=\"1\"".to_string(),
            CellKind::Polyline { nodes_per_cell } => {
                format!("TopologyType=\"Polyline\" NodesPerElement=\"{nodes_per_cell}\"")
            }
            CellKind::Polygon { nodes_per_cell } => {
                format!("TopologyType=\"Polygon\" NodesPerElement=\"{nodes_per_cell}\"")
            }
        }
    }
}

/// A grid to write: points and cells of one type.
#[derive(Debug, Clone, Copy)]
pub struct GridDef<'a> {
    /// Grid name in ParaView and in HDF5 paths; `[A-Za-z0-9_]` only.
    pub name: &'a str,
    /// Coordinates per point, 2 or 3.
    pub dim: usize,
    /// `[n_points][dim]`
    pub coords: &'a [f64],
    pub kind: CellKind,
    /// `[n_cells][kind.nodes_per_cell()]`, 0-based point indices.
    pub connectivity: &'a [usize],
}

/// Where a field lives.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Center {
    Node,
    Cell,
}

/// One field of one grid at one step.
#[derive(Debug, Clone, Copy)]
pub struct FieldData<'a> {
    pub grid: &'a str,
    /// `[A-Za-z0-9_]` only.
    pub name: &'a str,
    pub center: Center,
    /// 1 (scalar), 2 (2D vector, padded to 3 on output) or 3.
    pub components: usize,
    /// `[n_points or n_cells][components]`
    pub values: &'a [f64],
}

impl<'a> FieldData<'a> {
    /// A point vector field such as `displacement`, `[n_points][dim]`.
    pub fn node_vector(grid: &'a str, name: &'a str, dim: usize, values: &'a [f64]) -> Self {
        FieldData {
            grid,
            name,
            center: Center::Node,
            components: dim,
            values,
        }
    }

    /// A cell scalar such as `I1`, `von_mises`, `rank`, `[n_cells]`.
    pub fn cell_scalar(grid: &'a str, name: &'a str, values: &'a [f64]) -> Self {
        FieldData {
            grid,
            name,
            center: Center::Cell,
            components: 1,
            values,
        }
    }
}

/// What the writer remembers of a grid to describe it in XDMF.
#[derive(Debug, Clone)]
struct GridInfo {
    name: String,
    kind: CellKind,
    n_points: usize,
    n_cells: usize,
}

/// What the writer remembers of a written field.
#[derive(Debug, Clone)]
struct FieldInfo {
    grid: usize,
    name: String,
    center: Center,
    /// Points or cells of the grid.
    rows: usize,
    /// 1 or 3 (after padding).
    width: usize,
}

impl FieldInfo {
    /// Dataset shape: `[rows]` for scalars (the usual XDMF form), `[rows][3]` for vectors.
    fn dims(&self) -> Vec<usize> {
        if self.width == 1 {
            vec![self.rows]
        } else {
            vec![self.rows, self.width]
        }
    }
}

#[derive(Debug, Clone)]
struct StepInfo {
    index: usize,
    load_factor: f64,
    fields: Vec<FieldInfo>,
}

/// Writes `results.h5` and `results.xdmf` in a directory; both appear only on [`ResultsWriter::finish`].
/// Call on one rank (with gathered data).
pub struct ResultsWriter {
    h5: hdf5::File,
    h5_partial: PathBuf,
    h5_final: PathBuf,
    xdmf_partial: PathBuf,
    xdmf_final: PathBuf,
    grids: Vec<GridInfo>,
    steps: Vec<StepInfo>,
}

/// HDF5 file name the XDMF refers to (relative, so the results directory can be moved).
const H5_NAME: &str = "results.h5";
const XDMF_NAME: &str = "results.xdmf";

impl ResultsWriter {
    /// Start `dir/results.h5` (as `results.h5.partial`) with the grids' geometry and topology.
    /// Removes `results.h5` / `results.xdmf` of an earlier run so that a crash cannot leave stale
    /// results looking like this run's.
    pub fn create(dir: &Path, grids: &[GridDef<'_>]) -> Result<Self, IoError> {
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
        // HDF5 follows a symbolic link: the temporary name of an earlier run goes first
        remove_partial(&h5_partial)?;
        let h5 = hdf5::File::create(&h5_partial).map_err(|source| IoError::Hdf5 {
            path: h5_partial.clone(),
            what: "the file".to_string(),
            source,
        })?;
        let mut w = ResultsWriter {
            h5,
            h5_partial,
            h5_final,
            xdmf_partial: partial_path(&xdmf_final),
            xdmf_final,
            grids: Vec::new(),
            steps: Vec::new(),
        };
        for g in grids {
            w.add_grid(g)?;
        }
        w.write_xdmf()?;
        Ok(w)
    }

    fn h5_err(&self, what: impl Into<String>) -> impl FnOnce(hdf5::Error) -> IoError {
        let path = self.h5_partial.clone();
        let what = what.into();
        move |source| IoError::Hdf5 { path, what, source }
    }

    fn add_grid(&mut self, g: &GridDef<'_>) -> Result<(), IoError> {
        let what = format!("grid `{}`", g.name);
        check_name(&what, g.name)?;
        if self.grids.iter().any(|x| x.name == g.name) {
            return Err(invalid(&what, "duplicate grid name"));
        }
        if g.dim != 2 && g.dim != 3 {
            return Err(invalid(
                &what,
                &format!("dim must be 2 or 3, got {}", g.dim),
            ));
        }
        if !g.coords.len().is_multiple_of(g.dim) {
            return Err(IoError::Shape {
                what: format!("{what} coordinates"),
                expected: g.coords.len().next_multiple_of(g.dim),
                got: g.coords.len(),
            });
        }
        let n_points = g.coords.len() / g.dim;
        let npc = g.kind.nodes_per_cell();
        if npc == 0 || !g.connectivity.len().is_multiple_of(npc) {
            return Err(invalid(
                &what,
                &format!(
                    "connectivity length {} is not a multiple of {npc} nodes per cell",
                    g.connectivity.len()
                ),
            ));
        }
        let n_cells = g.connectivity.len() / npc;
        let mut conn = Vec::with_capacity(g.connectivity.len());
        for (i, &p) in g.connectivity.iter().enumerate() {
            if p >= n_points {
                return Err(invalid(
                    &what,
                    &format!(
                        "cell {} refers to point {p} but there are {n_points} points",
                        i / npc
                    ),
                ));
            }
            // p < n_points <= isize::MAX, so it fits an i64.
            conn.push(p as i64);
        }
        let xyz = pad_to_3(g.coords, g.dim);

        let group = self
            .h5
            .create_group(&format!("grids/{}", g.name))
            .map_err(self.h5_err(what.clone()))?;
        group
            .new_dataset::<f64>()
            .shape([n_points, 3])
            .create("coordinates")
            .and_then(|d| d.write_raw(&xyz[..]))
            .map_err(self.h5_err(format!("{what} coordinates")))?;
        group
            .new_dataset::<i64>()
            .shape([n_cells, npc])
            .create("connectivity")
            .and_then(|d| d.write_raw(&conn[..]))
            .map_err(self.h5_err(format!("{what} connectivity")))?;
        self.grids.push(GridInfo {
            name: g.name.to_string(),
            kind: g.kind,
            n_points,
            n_cells,
        });
        Ok(())
    }

    /// Write one output step at time `load_factor`. Every field names one of the grids.
    /// All fields are checked before anything is written, so a rejected call leaves the file as it was.
    pub fn write_step(
        &mut self,
        load_factor: f64,
        fields: &[FieldData<'_>],
    ) -> Result<(), IoError> {
        let index = self.steps.len();
        let infos = self.check_fields(index, fields)?;

        let step_path = format!("steps/{index:06}");
        let step = self
            .h5
            .create_group(&step_path)
            .map_err(self.h5_err(format!("step {index}")))?;
        step.new_attr::<f64>()
            .create("load_factor")
            .and_then(|a| a.write_scalar(&load_factor))
            .map_err(self.h5_err(format!("step {index} load_factor")))?;
        for (f, info) in fields.iter().zip(&infos) {
            let what = format!("step {index} field `{}` of grid `{}`", f.name, f.grid);
            let padded;
            let data: &[f64] = if f.components == 2 {
                padded = pad_to_3(f.values, 2);
                &padded
            } else {
                f.values
            };
            let group_path = format!("{step_path}/{}", f.grid);
            let group = match self.h5.group(&group_path) {
                Ok(g) => g,
                Err(_) => self
                    .h5
                    .create_group(&group_path)
                    .map_err(self.h5_err(what.clone()))?,
            };
            group
                .new_dataset::<f64>()
                .shape(info.dims())
                .create(f.name)
                .and_then(|d| d.write_raw(data))
                .map_err(self.h5_err(what))?;
        }
        self.h5
            .flush()
            .map_err(self.h5_err(format!("step {index} (flush)")))?;
        self.steps.push(StepInfo {
            index,
            load_factor,
            fields: infos,
        });
        // Keep the partial XDMF current so that a running job can be inspected.
        self.write_xdmf()
    }

    /// Check names, grids, component counts and lengths of one step's fields.
    fn check_fields(
        &self,
        index: usize,
        fields: &[FieldData<'_>],
    ) -> Result<Vec<FieldInfo>, IoError> {
        let mut infos: Vec<FieldInfo> = Vec::with_capacity(fields.len());
        for f in fields {
            let what = format!("step {index} field `{}` of grid `{}`", f.name, f.grid);
            check_name(&what, f.name)?;
            let grid = self
                .grids
                .iter()
                .position(|g| g.name == f.grid)
                .ok_or_else(|| invalid(&what, "no such grid"))?;
            if infos.iter().any(|i| i.grid == grid && i.name == f.name) {
                return Err(invalid(&what, "written twice in one step"));
            }
            let rows = match f.center {
                Center::Node => self.grids[grid].n_points,
                Center::Cell => self.grids[grid].n_cells,
            };
            let width = match f.components {
                1 => 1,
                2 | 3 => 3,
                c => {
                    return Err(invalid(
                        &what,
                        &format!("{c} components; expected 1, 2 or 3"),
                    ))
                }
            };
            if f.values.len() != rows * f.components {
                return Err(IoError::Shape {
                    what,
                    expected: rows * f.components,
                    got: f.values.len(),
                });
            }
            infos.push(FieldInfo {
                grid,
                name: f.name.to_string(),
                center: f.center,
                rows,
                width,
            });
        }
        Ok(infos)
    }

    /// Number of steps written so far.
    pub fn steps_written(&self) -> usize {
        self.steps.len()
    }

    /// Close the HDF5 file and move both files to their final names. Returns `(results.h5, results.xdmf)`.
    pub fn finish(self) -> Result<(PathBuf, PathBuf), IoError> {
        self.write_xdmf()?;
        self.h5.flush().map_err(self.h5_err("the file (flush)"))?;
        let ResultsWriter {
            h5,
            h5_partial,
            h5_final,
            xdmf_partial,
            xdmf_final,
            ..
        } = self;
        // Dropping the last handle closes the file; the rename must come after that.
        h5.close().map_err(|source| IoError::Hdf5 {
            path: h5_partial.clone(),
            what: "the file (close)".to_string(),
            source,
        })?;
        commit(&h5_partial, &h5_final)?;
        commit(&xdmf_partial, &xdmf_final)?;
        Ok((h5_final, xdmf_final))
    }

    /// The XDMF text for the grids and steps so far.
    fn xdmf_text(&self) -> String {
        let mut s = String::new();
        s.push_str("<?xml version=\"1.0\" ?>\n<Xdmf Version=\"3.0\">\n  <Domain>\n");
        for (gi, g) in self.grids.iter().enumerate() {
            let npc = g.kind.nodes_per_cell();
            let _ = writeln!(
                s,
                "    <Grid Name=\"{}\" GridType=\"Collection\" CollectionType=\"Temporal\">",
                g.name
            );
            for st in &self.steps {
                let _ = writeln!(
                    s,
                    "      <Grid Name=\"{}_{:06}\" GridType=\"Uniform\">\n        <Time Value=\"{}\"/>",
                    g.name, st.index, st.load_factor
                );
                let _ = writeln!(
                    s,
                    "        <Topology {} NumberOfElements=\"{}\">\n          {}\n        </Topology>",
                    g.kind.xdmf_topology(),
                    g.n_cells,
                    data_item(&[g.n_cells, npc], "Int", &format!("/grids/{}/connectivity", g.name))
                );
                let _ =
                    writeln!(
                    s,
                    "        <Geometry GeometryType=\"XYZ\">\n          {}\n        </Geometry>",
                    data_item(&[g.n_points, 3], "Float", &format!("/grids/{}/coordinates", g.name))
                );
                for f in st.fields.iter().filter(|f| f.grid == gi) {
                    let center = match f.center {
                        Center::Node => "Node",
                        Center::Cell => "Cell",
                    };
                    let ty = if f.width == 1 { "Scalar" } else { "Vector" };
                    let _ = writeln!(
                        s,
                        "        <Attribute Name=\"{}\" AttributeType=\"{ty}\" Center=\"{center}\">\n          {}\n        </Attribute>",
                        f.name,
                        data_item(
                            &f.dims(),
                            "Float",
                            &format!("/steps/{:06}/{}/{}", st.index, g.name, f.name)
                        )
                    );
                }
                s.push_str("      </Grid>\n");
            }
            s.push_str("    </Grid>\n");
        }
        s.push_str("  </Domain>\n</Xdmf>\n");
        s
    }

    fn write_xdmf(&self) -> Result<(), IoError> {
        use std::io::Write;
        crate::io::create_nofollow(&self.xdmf_partial)?
            .write_all(self.xdmf_text().as_bytes())
            .map_err(|source| IoError::File {
                path: self.xdmf_partial.clone(),
                op: "write",
                source,
            })
    }
}

/// Removes the file (or symbolic link) at a temporary name before it is created again.
fn remove_partial(path: &Path) -> Result<(), IoError> {
    if std::fs::symlink_metadata(path).is_ok() {
        std::fs::remove_file(path).map_err(|source| IoError::File {
            path: path.to_path_buf(),
            op: "remove the unfinished file of an earlier run",
            source,
        })?;
    }
    Ok(())
}

fn data_item(dims: &[usize], number_type: &str, dataset: &str) -> String {
    let dims: Vec<String> = dims.iter().map(|d| d.to_string()).collect();
    format!(
        "<DataItem Dimensions=\"{}\" NumberType=\"{number_type}\" Precision=\"8\" Format=\"HDF\">{H5_NAME}:{dataset}</DataItem>",
        dims.join(" ")
    )
}

/// `[n][dim]` -> `[n][3]` with zero padding (ParaView wants 3-component points and vectors).
fn pad_to_3(values: &[f64], dim: usize) -> Vec<f64> {
    if dim == 3 {
        return values.to_vec();
    }
    let mut out = Vec::with_capacity(values.len() / dim * 3);
    for row in values.chunks_exact(dim) {
        out.extend_from_slice(row);
        out.extend(std::iter::repeat_n(0.0, 3 - dim));
    }
    out
}

/// Names become HDF5 path components and XML attribute values: keep them plain.
fn check_name(what: &str, name: &str) -> Result<(), IoError> {
    if name.is_empty() || !name.bytes().all(|b| b.is_ascii_alphanumeric() || b == b'_') {
        return Err(invalid(
            what,
            "name must be non-empty and use only [A-Za-z0-9_]",
        ));
    }
    Ok(())
}

fn invalid(what: &str, message: &str) -> IoError {
    IoError::Invalid {
        what: what.to_string(),
        message: message.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// HDF5 opens files without `O_CLOEXEC`, so the `h5dump` child of one test inherits the open
    /// (flock-locked) file descriptors of writers in other test threads, and a re-open in those
    /// tests then fails with EWOULDBLOCK. The HDF5 tests therefore run one at a time.
    fn h5_serial() -> std::sync::MutexGuard<'static, ()> {
        static LOCK: std::sync::Mutex<()> = std::sync::Mutex::new(());
        LOCK.lock().unwrap_or_else(|poisoned| poisoned.into_inner())
    }

    fn tmp(tag: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("io_h5_{tag}_{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    /// Two quads side by side: points `[6][2]`, cells `[2][4]`.
    const QUAD_COORDS: [f64; 12] = [0.0, 0.0, 1.0, 0.0, 2.0, 0.0, 0.0, 1.0, 1.0, 1.0, 2.0, 1.0];
    const QUAD_CONN: [usize; 8] = [0, 1, 4, 3, 1, 2, 5, 4];
    /// The top edge as a 2-segment polyline: a stand-in for a sampled enriched surface.
    const EDGE_COORDS: [f64; 6] = [0.0, 1.0, 1.0, 1.0, 2.0, 1.0];
    const EDGE_CONN: [usize; 4] = [0, 1, 1, 2];

    fn grids() -> [GridDef<'static>; 2] {
        [
            GridDef {
                name: "bulk",
                dim: 2,
                coords: &QUAD_COORDS,
                kind: CellKind::Quadrilateral,
                connectivity: &QUAD_CONN,
            },
            GridDef {
                name: "surface",
                dim: 2,
                coords: &EDGE_COORDS,
                kind: CellKind::Polyline { nodes_per_cell: 2 },
                connectivity: &EDGE_CONN,
            },
        ]
    }

    fn displacement(step: usize) -> Vec<f64> {
        (0..12).map(|i| (step * 100 + i) as f64 * 0.01).collect()
    }

    fn write_two_steps(dir: &Path) -> ResultsWriter {
        let mut w = ResultsWriter::create(dir, &grids()).unwrap();
        for (k, lf) in [(0usize, 0.5), (1, 1.0)] {
            let u = displacement(k);
            let i1 = [k as f64 + 0.25, -(k as f64) - 0.75];
            let rank = [0.0, 1.0];
            let gap = [0.1 * k as f64, 0.2, 0.3];
            w.write_step(
                lf,
                &[
                    FieldData::node_vector("bulk", "displacement", 2, &u),
                    FieldData::cell_scalar("bulk", "I1", &i1),
                    FieldData::cell_scalar("bulk", "rank", &rank),
                    FieldData {
                        grid: "surface",
                        name: "gap",
                        center: Center::Node,
                        components: 1,
                        values: &gap,
                    },
                ],
            )
            .unwrap();
        }
        w
    }

    /// `(dimensions, dataset path)` of every `<DataItem>` in an XDMF text.
    fn data_items(xdmf: &str) -> Vec<(Vec<usize>, String)> {
        xdmf.split("<DataItem ")
            .skip(1)
            .map(|chunk| {
                let dims_attr = chunk.split("Dimensions=\"").nth(1).unwrap();
                let dims: Vec<usize> = dims_attr
                    .split('"')
                    .next()
                    .unwrap()
                    .split_whitespace()
                    .map(|d| d.parse().unwrap())
                    .collect();
                let body = chunk.split('>').nth(1).unwrap().split('<').next().unwrap();
                let (file, path) = body.split_once(':').unwrap();
                assert_eq!(file, "results.h5");
                (dims, path.to_string())
            })
            .collect()
    }

    #[test]
    fn dropped_writer_leaves_no_results_file() {
        let _serial = h5_serial();
        let dir = tmp("crash");
        {
            let w = write_two_steps(&dir);
            assert_eq!(w.steps_written(), 2);
            // Simulated crash: the writer goes away without finish().
        }
        assert!(!dir.join("results.h5").exists());
        assert!(!dir.join("results.xdmf").exists());
        assert!(dir.join("results.h5.partial").exists());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn create_removes_results_of_an_earlier_run() {
        let _serial = h5_serial();
        let dir = tmp("stale");
        std::fs::write(dir.join("results.h5"), b"old").unwrap();
        std::fs::write(dir.join("results.xdmf"), b"old").unwrap();
        let w = ResultsWriter::create(&dir, &grids()).unwrap();
        assert!(!dir.join("results.h5").exists());
        assert!(!dir.join("results.xdmf").exists());
        drop(w);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn finished_results_read_back_with_padded_values() {
        let _serial = h5_serial();
        let dir = tmp("readback");
        let (h5_path, xdmf_path) = write_two_steps(&dir).finish().unwrap();
        assert_eq!(h5_path, dir.join("results.h5"));
        assert!(!dir.join("results.h5.partial").exists());
        assert!(!dir.join("results.xdmf.partial").exists());

        let f = hdf5::File::open(&h5_path).unwrap();
        let coords = f.dataset("grids/bulk/coordinates").unwrap();
        assert_eq!(coords.shape(), vec![6, 3]);
        let xyz: Vec<f64> = coords.read_raw().unwrap();
        assert_eq!(&xyz[12..15], &[1.0, 1.0, 0.0], "point 4 with z = 0");
        let conn = f.dataset("grids/bulk/connectivity").unwrap();
        assert_eq!(conn.shape(), vec![2, 4]);
        assert_eq!(
            conn.read_raw::<i64>().unwrap(),
            vec![0, 1, 4, 3, 1, 2, 5, 4]
        );
        assert_eq!(
            f.dataset("grids/surface/connectivity").unwrap().shape(),
            vec![2, 2]
        );

        let u1 = f.dataset("steps/000001/bulk/displacement").unwrap();
        assert_eq!(u1.shape(), vec![6, 3]);
        let u1: Vec<f64> = u1.read_raw().unwrap();
        let given = displacement(1);
        for p in 0..6 {
            assert_eq!(&u1[3 * p..3 * p + 2], &given[2 * p..2 * p + 2]);
            assert_eq!(u1[3 * p + 2], 0.0);
        }
        let i1: Vec<f64> = f
            .dataset("steps/000001/bulk/I1")
            .unwrap()
            .read_raw()
            .unwrap();
        assert_eq!(i1, vec![1.25, -1.75]);
        let lf: f64 = f
            .group("steps/000000")
            .unwrap()
            .attr("load_factor")
            .unwrap()
            .read_scalar()
            .unwrap();
        assert_eq!(lf, 0.5);

        // Every dataset the XDMF names exists with the dimensions it states.
        let xdmf = std::fs::read_to_string(&xdmf_path).unwrap();
        let items = data_items(&xdmf);
        // 2 steps x (bulk: topology, geometry, 3 fields; surface: topology, geometry, 1 field).
        assert_eq!(items.len(), 2 * (5 + 3));
        for (dims, path) in &items {
            let ds = f.dataset(path).unwrap_or_else(|e| panic!("{path}: {e}"));
            assert_eq!(&ds.shape(), dims, "{path}");
        }
        assert_eq!(xdmf.matches("CollectionType=\"Temporal\"").count(), 2);
        let times: Vec<f64> = xdmf
            .split("<Time Value=\"")
            .skip(1)
            .map(|c| c.split('"').next().unwrap().parse().unwrap())
            .collect();
        assert_eq!(times, vec![0.5, 1.0, 0.5, 1.0]);
        assert!(xdmf.contains("TopologyType=\"Polyline\" NodesPerElement=\"2\""));
        assert!(xdmf.contains("AttributeType=\"Vector\" Center=\"Node\""));
        assert!(xdmf.contains("<Attribute Name=\"rank\" AttributeType=\"Scalar\" Center=\"Cell\">"));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn h5dump_reads_the_finished_file() {
        let _serial = h5_serial();
        let dir = tmp("h5dump");
        let (h5_path, _) = write_two_steps(&dir).finish().unwrap();
        let out = match std::process::Command::new("h5dump")
            .arg("-H")
            .arg(&h5_path)
            .output()
        {
            Ok(out) => out,
            Err(_) => {
                eprintln!("h5dump not installed (package hdf5-tools); skipping");
                std::fs::remove_dir_all(&dir).unwrap();
                return;
            }
        };
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let text = String::from_utf8_lossy(&out.stdout);
        assert!(text.contains("DATASET \"coordinates\""), "{text}");
        assert!(
            text.contains("DATASPACE  SIMPLE { ( 6, 3 ) / ( 6, 3 ) }"),
            "{text}"
        );
        assert!(text.contains("ATTRIBUTE \"load_factor\""), "{text}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn hexahedron_grid_is_written_in_3d() {
        let _serial = h5_serial();
        let dir = tmp("hex");
        let coords: Vec<f64> = (0..8)
            .flat_map(|i| [(i & 1) as f64, ((i >> 1) & 1) as f64, ((i >> 2) & 1) as f64])
            .collect();
        let conn = [0, 1, 3, 2, 4, 5, 7, 6];
        let g = GridDef {
            name: "bulk",
            dim: 3,
            coords: &coords,
            kind: CellKind::Hexahedron,
            connectivity: &conn,
        };
        let mut w = ResultsWriter::create(&dir, &[g]).unwrap();
        let u = vec![0.5; 24];
        w.write_step(
            1.0,
            &[FieldData::node_vector("bulk", "displacement", 3, &u)],
        )
        .unwrap();
        let (h5, xdmf) = w.finish().unwrap();
        let xdmf = std::fs::read_to_string(xdmf).unwrap();
        assert!(xdmf.contains("TopologyType=\"Hexahedron\" NumberOfElements=\"1\""));
        let f = hdf5::File::open(h5).unwrap();
        assert_eq!(
            f.dataset("grids/bulk/connectivity").unwrap().shape(),
            vec![1, 8]
        );
        let xyz: Vec<f64> = f
            .dataset("grids/bulk/coordinates")
            .unwrap()
            .read_raw()
            .unwrap();
        assert_eq!(xyz, coords);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_layout_that_does_not_describe_the_copy_is_refused_naming_the_field() {
        let _serial = h5_serial();
        let dir = tmp("resume");
        let w = write_two_steps(&dir);
        w.flush().unwrap();
        let layout = w.layout();
        let copy = dir.join("copy.h5");
        std::fs::copy(w.partial_file(), &copy).unwrap();
        drop(w);
        let good = ResultsWriter::resume(&dir, &copy, &grids(), &layout).unwrap();
        assert_eq!(good.steps_written(), 2);
        drop(good);
        for (from, to, want) in [
            // more rows than the grid has points
            (
                "field 0 displacement node 6 3",
                "field 0 displacement node 9 3",
                "displacement",
            ),
            // a cell field called a node field
            ("field 0 I1 cell 2 1", "field 0 I1 node 2 1", "`I1`"),
            // a step the copy does not hold
            ("step 1 1", "step 7 1", "step 7"),
            // a field the copy does not hold
            ("field 1 gap node 3 1", "field 1 pap node 3 1", "`pap`"),
        ] {
            let bad = layout.replacen(from, to, 1);
            assert_ne!(bad, layout, "{from}");
            let e = ResultsWriter::resume(&dir, &copy, &grids(), &bad)
                .err()
                .unwrap_or_else(|| panic!("{to}: accepted"))
                .to_string();
            assert!(
                e.contains("copy.h5 (checkpoint results)") && e.contains(want),
                "{to}: {e}"
            );
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn bad_grids_and_fields_are_rejected_with_names() {
        let _serial = h5_serial();
        let dir = tmp("bad");
        let bad_conn = [0, 1, 4, 9];
        let e = ResultsWriter::create(
            &dir,
            &[GridDef {
                name: "bulk",
                dim: 2,
                coords: &QUAD_COORDS,
                kind: CellKind::Quadrilateral,
                connectivity: &bad_conn,
            }],
        )
        .err()
        .unwrap();
        assert!(e.to_string().contains("cell 0 refers to point 9"), "{e}");

        let mut w = ResultsWriter::create(&dir, &grids()).unwrap();
        let short = [0.0; 3];
        let e = w
            .write_step(0.1, &[FieldData::cell_scalar("bulk", "I1", &short)])
            .unwrap_err();
        assert!(
            e.to_string().contains("`I1`") && e.to_string().contains("expected 2 values, got 3"),
            "{e}"
        );
        let e = w
            .write_step(0.2, &[FieldData::cell_scalar("contact", "p", &short)])
            .unwrap_err();
        assert!(
            e.to_string().contains("grid `contact`") && e.to_string().contains("no such grid"),
            "{e}"
        );
        let e = w
            .write_step(
                0.3,
                &[FieldData::cell_scalar("bulk", "von mises", &short[..2])],
            )
            .unwrap_err();
        assert!(e.to_string().contains("[A-Za-z0-9_]"), "{e}");
        // The rejected calls wrote nothing: the next good step is step 0.
        let i1 = [1.0, 2.0];
        w.write_step(0.4, &[FieldData::cell_scalar("bulk", "I1", &i1)])
            .unwrap();
        assert_eq!(w.steps_written(), 1);
        let (h5, _) = w.finish().unwrap();
        let f = hdf5::File::open(h5).unwrap();
        assert_eq!(
            f.dataset("steps/000000/bulk/I1")
                .unwrap()
                .read_raw::<f64>()
                .unwrap(),
            vec![1.0, 2.0]
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
