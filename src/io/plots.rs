//! Pictures of a finished run, made from its own files so that they show what was written:
//! - `history.svg` / `history.png`: the forces of `history.csv` (reactions `R_*`, contact resultants
//!   `P_*`) against the load factor, and `moments.svg` / `moments.png` for the moments (`M_*`) when
//!   there are any;
//! - `deformed.png` (and its `deformed.svg` source): the deformed bulk mesh of the last step in
//!   `results.h5`, coloured by the contact pressure (`contact_pressure` on the bulk nodes; in 2D the
//!   smooth enriched surfaces (`surface` grid) are drawn on top with their own pressure), with a
//!   colour bar. 3D meshes are drawn as their boundary faces in an oblique view, far faces first.
//!
//! Each file is written atomically (complete or absent).

use crate::io::{write_atomic, IoError};
use crate::study::png::svg_to_png;
use crate::study::svg::{Plot, Series};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Writes the run's pictures into `out_dir` and returns their paths (PNG first, for the user).
pub fn write_plots(out_dir: &Path) -> Result<Vec<PathBuf>, IoError> {
    let mut written = Vec::new();
    let history = out_dir.join("history.csv");
    if history.exists() {
        let table = read_history(&history)?;
        for (stem, plot) in history_plots(&table, &case_name(out_dir)) {
            written.extend(write_svg_png(out_dir, stem, &plot.to_svg())?);
        }
    }
    let results = out_dir.join("results.h5");
    if results.exists() {
        if let Some(svg) = deformed_svg(&results, &case_name(out_dir))? {
            written.extend(write_svg_png(out_dir, "deformed", &svg)?);
        }
    }
    written.sort_by_key(|p| p.extension().is_none_or(|e| e != "png"));
    Ok(written)
}

/// The case name from `summary.json` if it is there, else the folder's name.
fn case_name(out_dir: &Path) -> String {
    std::fs::read_to_string(out_dir.join("summary.json"))
        .ok()
        .and_then(|t| serde_json::from_str::<serde_json::Value>(&t).ok())
        .and_then(|v| v.get("case").and_then(|c| c.as_str()).map(str::to_string))
        .or_else(|| {
            out_dir
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
        })
        .unwrap_or_default()
}

fn write_svg_png(dir: &Path, stem: &str, svg: &str) -> Result<Vec<PathBuf>, IoError> {
    let svg_path = dir.join(format!("{stem}.svg"));
    write_atomic(&svg_path, svg.as_bytes())?;
    let png_path = dir.join(format!("{stem}.png"));
    let png = svg_to_png(svg).map_err(|reason| IoError::File {
        path: png_path.clone(),
        op: "render the picture",
        source: std::io::Error::other(reason),
    })?;
    write_atomic(&png_path, &png)?;
    Ok(vec![png_path, svg_path])
}

/// `history.csv` as column names and rows of numbers (non-numeric cells become NaN).
pub struct HistoryTable {
    pub columns: Vec<String>,
    pub rows: Vec<Vec<f64>>,
}

fn read_history(path: &Path) -> Result<HistoryTable, IoError> {
    let text = std::fs::read_to_string(path).map_err(|source| IoError::File {
        path: path.to_path_buf(),
        op: "read",
        source,
    })?;
    let mut lines = text.lines();
    let columns: Vec<String> = lines
        .next()
        .unwrap_or_default()
        .split(',')
        .map(str::to_string)
        .collect();
    let rows = lines
        .filter(|l| !l.trim().is_empty())
        .map(|l| {
            l.split(',')
                .map(|c| c.trim().parse::<f64>().unwrap_or(f64::NAN))
                .collect()
        })
        .collect();
    Ok(HistoryTable { columns, rows })
}

/// The force plot and, when a moment column is not zero, the moment plot: one series per column
/// that is not zero to roundoff (relative to the largest value of its plot).
pub fn history_plots(table: &HistoryTable, case: &str) -> Vec<(&'static str, Plot)> {
    let Some(xi) = table.columns.iter().position(|c| c == "load_factor") else {
        return Vec::new();
    };
    let series_of = |prefixes: &[&str]| -> Vec<Series> {
        let cols: Vec<usize> = (0..table.columns.len())
            .filter(|&i| prefixes.iter().any(|p| table.columns[i].starts_with(p)))
            .collect();
        let peak = |i: usize| {
            table
                .rows
                .iter()
                .filter_map(|r| r.get(i))
                .filter(|v| v.is_finite())
                .fold(0.0f64, |m, v| m.max(v.abs()))
        };
        let largest = cols.iter().map(|&i| peak(i)).fold(0.0, f64::max);
        cols.into_iter()
            .filter(|&i| largest > 0.0 && peak(i) > 1e-9 * largest)
            .map(|i| Series {
                name: table.columns[i].clone(),
                points: std::iter::once((0.0, 0.0))
                    .chain(
                        table
                            .rows
                            .iter()
                            .filter_map(|r| Some((*r.get(xi)?, *r.get(i)?))),
                    )
                    .collect(),
            })
            .collect()
    };
    let mut plots = Vec::new();
    let forces = series_of(&["R_", "P_"]);
    if !forces.is_empty() {
        plots.push((
            "history",
            Plot {
                title: format!("{case}: forces"),
                x_label: "load factor".into(),
                y_label: "force".into(),
                series: forces,
                log_x: false,
                log_y: false,
                markers: false,
            },
        ));
    }
    let moments = series_of(&["M_"]);
    if !moments.is_empty() {
        plots.push((
            "moments",
            Plot {
                title: format!("{case}: moments"),
                x_label: "load factor".into(),
                y_label: "moment".into(),
                series: moments,
                log_x: false,
                log_y: false,
                markers: false,
            },
        ));
    }
    plots
}

/// One grid of the last step of `results.h5`: current coordinates, cells and the nodal contact
/// pressure (zero where the file has none).
pub struct GridFrame {
    /// Current positions [n][3].
    pub x: Vec<[f64; 3]>,
    /// Cells (node lists).
    pub cells: Vec<Vec<usize>>,
    /// Nodal contact pressure [n].
    pub pressure: Vec<f64>,
}

fn hdf5_err(path: &Path, what: &str) -> impl Fn(hdf5::Error) -> IoError {
    let (path, what) = (path.to_path_buf(), what.to_string());
    move |source| IoError::Hdf5 {
        path: path.clone(),
        what: what.clone(),
        source,
    }
}

/// Reads grid `grid` at the last step of `results.h5`; `None` when the file has no step or no such
/// grid.
pub fn read_last_frame(path: &Path, grid: &str) -> Result<Option<(f64, GridFrame)>, IoError> {
    let f = hdf5::File::open(path).map_err(hdf5_err(path, "the file"))?;
    let Ok(steps) = f.group("steps") else {
        return Ok(None);
    };
    let mut names = steps
        .member_names()
        .map_err(hdf5_err(path, "the step list"))?;
    names.sort();
    let Some(last) = names.last() else {
        return Ok(None);
    };
    let Ok(coords) = f.dataset(&format!("grids/{grid}/coordinates")) else {
        return Ok(None);
    };
    let xyz: Vec<f64> = coords
        .read_raw()
        .map_err(hdf5_err(path, &format!("grids/{grid}/coordinates")))?;
    let conn_ds = f
        .dataset(&format!("grids/{grid}/connectivity"))
        .map_err(hdf5_err(path, &format!("grids/{grid}/connectivity")))?;
    let per_cell = conn_ds.shape().get(1).copied().unwrap_or(1).max(1);
    let conn: Vec<i64> = conn_ds
        .read_raw()
        .map_err(hdf5_err(path, &format!("grids/{grid}/connectivity")))?;
    let n = xyz.len() / 3;
    let step = f
        .group(&format!("steps/{last}"))
        .map_err(hdf5_err(path, &format!("steps/{last}")))?;
    let load = step
        .attr("load_factor")
        .and_then(|a| a.read_scalar::<f64>())
        .unwrap_or(f64::NAN);
    let read_field = |name: &str| -> Option<Vec<f64>> {
        step.dataset(&format!("{grid}/{name}"))
            .ok()?
            .read_raw::<f64>()
            .ok()
    };
    let u = read_field("displacement").unwrap_or_else(|| vec![0.0; 3 * n]);
    let pressure = read_field("contact_pressure")
        .filter(|p| p.len() == n)
        .unwrap_or_else(|| vec![0.0; n]);
    if u.len() != 3 * n {
        return Err(IoError::Shape {
            what: format!("{}: steps/{last}/{grid}/displacement", path.display()),
            expected: 3 * n,
            got: u.len(),
        });
    }
    let x = (0..n)
        .map(|i| [0, 1, 2].map(|d| xyz[3 * i + d] + u[3 * i + d]))
        .collect();
    let mut cells = Vec::with_capacity(conn.len() / per_cell);
    for c in conn.chunks(per_cell) {
        let nodes: Option<Vec<usize>> = c
            .iter()
            .map(|&v| usize::try_from(v).ok().filter(|&v| v < n))
            .collect();
        match nodes {
            Some(nodes) => cells.push(nodes),
            None => {
                return Err(IoError::Shape {
                    what: format!(
                        "{}: grids/{grid}/connectivity names a node beyond the {n} points",
                        path.display()
                    ),
                    expected: n,
                    got: c.iter().copied().max().unwrap_or(0).max(0) as usize,
                })
            }
        }
    }
    Ok(Some((load, GridFrame { x, cells, pressure })))
}

/// A perceptually ordered colour map (viridis, 9 stops) at `t` in [0, 1].
pub fn colour(t: f64) -> (u8, u8, u8) {
    const STOPS: [(u8, u8, u8); 9] = [
        (68, 1, 84),
        (71, 44, 122),
        (59, 81, 139),
        (44, 113, 142),
        (33, 144, 141),
        (39, 173, 129),
        (92, 200, 99),
        (170, 220, 50),
        (253, 231, 37),
    ];
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let s = t * (STOPS.len() - 1) as f64;
    let i = (s.floor() as usize).min(STOPS.len() - 2);
    let f = s - i as f64;
    let mix = |a: u8, b: u8| (a as f64 + f * (b as f64 - a as f64)).round() as u8;
    let (a, b) = (STOPS[i], STOPS[i + 1]);
    (mix(a.0, b.0), mix(a.1, b.1), mix(a.2, b.2))
}

fn hex((r, g, b): (u8, u8, u8)) -> String {
    format!("#{r:02x}{g:02x}{b:02x}")
}

/// Shares of the colour bar below which a pressure counts as no contact (grey, not the map's
/// lowest colour): the L2-projected pressure rings slightly around the contact edge.
const NO_CONTACT: f64 = 0.01;

/// 2D meshes of more cells are drawn as their outline (drawing 6,000 cells takes 0.8 s).
const MAX_CELLS_DRAWN: usize = 50_000;

/// Shapes in drawing coordinates (y up), drawn in order: filled polygons and thick lines.
#[derive(Default)]
struct Scene {
    polygons: Vec<(Vec<[f64; 2]>, String, f64)>,
    lines: Vec<([f64; 2], [f64; 2], String, f64)>,
}

impl Scene {
    fn bounds(&self) -> Option<([f64; 2], [f64; 2])> {
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        let pts = self
            .polygons
            .iter()
            .flat_map(|p| p.0.iter())
            .chain(self.lines.iter().flat_map(|l| [&l.0, &l.1]));
        for p in pts {
            for d in 0..2 {
                if p[d].is_finite() {
                    lo[d] = lo[d].min(p[d]);
                    hi[d] = hi[d].max(p[d]);
                }
            }
        }
        (lo[0] < hi[0] || lo[1] < hi[1]).then_some((lo, hi))
    }

    /// The height the scene takes when fitted to `width`, between `min` and `max`.
    fn height_for(&self, width: f64, min: f64, max: f64) -> f64 {
        match self.bounds() {
            Some((lo, hi)) => {
                let ext = (hi[0] - lo[0]).max(hi[1] - lo[1]);
                let aspect = (hi[1] - lo[1]).max(1e-12 * ext) / (hi[0] - lo[0]).max(1e-12 * ext);
                (width * aspect).clamp(min, max)
            }
            None => min,
        }
    }

    /// SVG elements of the scene fitted (aspect kept, centred) into the box at (x, y) of size w x h.
    fn draw(&self, out: &mut String, x: f64, y: f64, w: f64, h: f64) {
        let Some((lo, hi)) = self.bounds() else {
            return;
        };
        let ext = (hi[0] - lo[0]).max(hi[1] - lo[1]).max(1e-300);
        let scale =
            (w / (hi[0] - lo[0]).max(1e-12 * ext)).min(h / (hi[1] - lo[1]).max(1e-12 * ext));
        let ox = x + 0.5 * (w - scale * (hi[0] - lo[0]));
        let oy = y + 0.5 * (h - scale * (hi[1] - lo[1]));
        let sx = |p: &[f64; 2]| ox + (p[0] - lo[0]) * scale;
        let sy = |p: &[f64; 2]| oy + (hi[1] - p[1]) * scale;
        for (poly, fill, stroke_w) in &self.polygons {
            let pts: Vec<String> = poly
                .iter()
                .map(|p| format!("{:.2},{:.2}", sx(p), sy(p)))
                .collect();
            let _ = writeln!(
                out,
                r##"<polygon points="{}" fill="{fill}" stroke="#404040" stroke-width="{stroke_w}" stroke-linejoin="round"/>"##,
                pts.join(" ")
            );
        }
        for (a, b, col, w) in &self.lines {
            let _ = writeln!(
                out,
                r#"<line x1="{:.2}" y1="{:.2}" x2="{:.2}" y2="{:.2}" stroke="{col}" stroke-width="{w}" stroke-linecap="round"/>"#,
                sx(a),
                sy(a),
                sx(b),
                sy(b)
            );
        }
    }
}

/// The fill of a face or cell: the colour map where the pressure counts as contact, else a grey of
/// the given shade in [0, 1].
fn fill_of(p: f64, p_max: f64, shade: f64) -> String {
    if p_max > 0.0 && p > NO_CONTACT * p_max {
        hex(colour(p / p_max))
    } else {
        let g = (150.0 + 80.0 * shade).round().clamp(0.0, 255.0) as u8;
        hex((g, g, g))
    }
}

/// 2D: the deformed cells in grey, contact edges and the smooth enriched surfaces drawn thick in
/// the pressure's colour (thin dark grey out of contact).
fn scene_2d(bulk: &GridFrame, surface: Option<&GridFrame>, p_max: f64) -> Scene {
    let xy = |x: &[f64; 3]| [x[0], x[1]];
    let mut sc = Scene::default();
    if bulk.cells.len() <= MAX_CELLS_DRAWN {
        for c in &bulk.cells {
            let poly = c.iter().map(|&n| xy(&bulk.x[n])).collect();
            sc.polygons.push((poly, fill_of(0.0, p_max, 0.6), 0.5));
        }
    } else {
        // too many cells to draw one by one (the picture would take longer than a small run):
        // the mesh's outline, the edges that belong to one cell only
        let mut count: std::collections::HashMap<(usize, usize), usize> = Default::default();
        for c in &bulk.cells {
            for i in 0..c.len() {
                let (a, b) = (c[i], c[(i + 1) % c.len()]);
                *count.entry((a.min(b), a.max(b))).or_default() += 1;
            }
        }
        let mut outline: Vec<(usize, usize)> = count
            .into_iter()
            .filter(|&(_, k)| k == 1)
            .map(|(e, _)| e)
            .collect();
        outline.sort_unstable();
        for (a, b) in outline {
            sc.lines
                .push((xy(&bulk.x[a]), xy(&bulk.x[b]), "#404040".into(), 1.0));
        }
    }
    // cell edges whose both nodes carry pressure: the contact zone of surfaces without a smooth
    // `surface` grid (Q1C1), under the smooth curves of the enriched ones
    for c in &bulk.cells {
        for i in 0..c.len() {
            let (a, b) = (c[i], c[(i + 1) % c.len()]);
            let (pa, pb) = (bulk.pressure[a], bulk.pressure[b]);
            if p_max > 0.0 && pa.min(pb) > NO_CONTACT * p_max {
                let col = hex(colour(0.5 * (pa + pb) / p_max));
                sc.lines.push((xy(&bulk.x[a]), xy(&bulk.x[b]), col, 4.0));
            }
        }
    }
    if let Some(surf) = surface {
        for c in &surf.cells {
            for w in c.windows(2) {
                let (a, b) = (w[0], w[1]);
                let p = 0.5 * (surf.pressure[a] + surf.pressure[b]);
                let (col, width) = if p_max > 0.0 && p > NO_CONTACT * p_max {
                    (hex(colour(p / p_max)), 4.0)
                } else {
                    ("#505050".to_string(), 2.0)
                };
                sc.lines.push((xy(&surf.x[a]), xy(&surf.x[b]), col, width));
            }
        }
    }
    sc
}

/// 3D: the boundary faces that face the viewer of `view`, far ones first, filled with their mean
/// nodal pressure (grey, shaded, out of contact); `only` keeps a subset of the faces.
fn scene_3d(
    bulk: &GridFrame,
    faces: &[Vec<usize>],
    view: &View,
    p_max: f64,
    only: impl Fn(&[usize]) -> bool,
) -> Scene {
    let pts: Vec<[f64; 3]> = bulk.x.iter().map(|x| view.project(x)).collect();
    let depth = |f: &[usize]| f.iter().map(|&n| pts[n][2]).sum::<f64>() / f.len() as f64;
    let mut order: Vec<&Vec<usize>> = faces.iter().filter(|f| only(f)).collect();
    order.sort_by(|a, b| depth(a).total_cmp(&depth(b)));
    let mut sc = Scene::default();
    for f in order {
        // facing the viewer: counter-clockwise on screen (outward normals of VTK hex faces)
        if area2(f.iter().map(|&n| (pts[n][0], pts[n][1]))) <= 0.0 {
            continue;
        }
        let p = f.iter().map(|&n| bulk.pressure[n]).sum::<f64>() / f.len() as f64;
        let shade = view.shade(f.iter().map(|&n| bulk.x[n]).collect());
        let poly = f.iter().map(|&n| [pts[n][0], pts[n][1]]).collect();
        sc.polygons.push((poly, fill_of(p, p_max, shade), 0.4));
    }
    sc
}

/// The picture of the last step: `None` when the file has no step.
fn deformed_svg(path: &Path, case: &str) -> Result<Option<String>, IoError> {
    let Some((load, bulk)) = read_last_frame(path, "bulk")? else {
        return Ok(None);
    };
    let three_d = bulk.cells.first().is_some_and(|c| c.len() == 8);
    // the smooth enriched surfaces (2D polylines) carry the pressure where the bulk has display nodes
    let surface = if three_d {
        None
    } else {
        read_last_frame(path, "surface")?.map(|(_, s)| s)
    };
    let p_max = bulk
        .pressure
        .iter()
        .chain(surface.iter().flat_map(|s| s.pressure.iter()))
        .filter(|p| p.is_finite())
        .fold(0.0f64, |m, &p| m.max(p));
    const BAR: f64 = 130.0;
    let top = 50.0;
    // panels: (scene, width, caption)
    let mut panels: Vec<(Scene, f64, String)> = Vec::new();
    if three_d {
        let faces = boundary_faces(&bulk.cells);
        let oblique = scene_3d(&bulk, &faces, &View::oblique(), p_max, |_| true);
        panels.push((oblique, 560.0, "oblique view".into()));
        // the contact zone seen along its normal (the direction in which the contact faces'
        // centres spread least), from the side the normal points to (upwards where it can)
        let in_contact =
            |f: &[usize]| p_max > 0.0 && f.iter().any(|&n| bulk.pressure[n] > NO_CONTACT * p_max);
        let centres: Vec<[f64; 3]> = faces
            .iter()
            .filter(|f| in_contact(f))
            .map(|f| {
                [0, 1, 2].map(|d| f.iter().map(|&n| bulk.x[n][d]).sum::<f64>() / f.len() as f64)
            })
            .collect();
        if let Some(view) = View::along_normal(&centres) {
            // faces whose mean pressure counts as contact (a face touching the zone's edge by
            // one node only would be a grey speck)
            let mean_in_contact = |f: &[usize]| {
                f.iter().map(|&n| bulk.pressure[n]).sum::<f64>()
                    > NO_CONTACT * p_max * f.len() as f64
            };
            let map = scene_3d(&bulk, &faces, &view, p_max, mean_in_contact);
            if map.bounds().is_some() {
                let caption = format!(
                    "contact zone along n = ({:.2}, {:.2}, {:.2})",
                    view.rot[2][0], view.rot[2][1], view.rot[2][2]
                );
                panels.push((map, 330.0, caption));
            }
        }
    } else {
        panels.push((
            scene_2d(&bulk, surface.as_ref(), p_max),
            590.0,
            String::new(),
        ));
    }
    if panels[0].0.bounds().is_none() {
        return Ok(None);
    }
    let height = panels
        .iter()
        .map(|(sc, w, _)| sc.height_for(*w, 300.0, 620.0))
        .fold(0.0, f64::max);
    let gap = 20.0;
    let width = 20.0 + panels.iter().map(|p| p.1 + gap).sum::<f64>() + BAR;
    let h_canvas = (top + height + 40.0).round();
    let mut s = String::new();
    let _ = writeln!(
        s,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{h_canvas}" viewBox="0 0 {width} {h_canvas}" font-family="sans-serif">"#
    );
    let _ = writeln!(
        s,
        r#"<rect width="{width}" height="{h_canvas}" fill="white"/>"#
    );
    let _ = writeln!(
        s,
        r#"<text x="{:.1}" y="28" font-size="16" text-anchor="middle">{}: deformed mesh at load {load:.4}, coloured by contact pressure</text>"#,
        width / 2.0,
        esc(case)
    );
    let mut x = 20.0;
    for (sc, w, caption) in &panels {
        sc.draw(&mut s, x, top, *w, height);
        if !caption.is_empty() {
            let _ = writeln!(
                s,
                r##"<text x="{:.1}" y="{:.1}" font-size="13" text-anchor="middle" fill="#303030">{}</text>"##,
                x + w / 2.0,
                top + height + 25.0,
                esc(caption)
            );
        }
        x += w + gap;
    }
    // colour bar
    let (bx, by, bh) = (width - BAR + 10.0, top + 20.0, height - 70.0);
    let _ = writeln!(
        s,
        r#"<defs><linearGradient id="bar" x1="0" y1="1" x2="0" y2="0">"#
    );
    for k in 0..=8 {
        let t = k as f64 / 8.0;
        let _ = writeln!(
            s,
            r#"<stop offset="{t:.3}" stop-color="{}"/>"#,
            hex(colour(t))
        );
    }
    let _ = writeln!(s, "</linearGradient></defs>");
    let _ = writeln!(
        s,
        r##"<rect x="{bx}" y="{by}" width="22" height="{bh}" fill="url(#bar)" stroke="#404040" stroke-width="0.8"/>"##
    );
    let _ = writeln!(
        s,
        r#"<text x="{bx}" y="{:.1}" font-size="14">contact pressure</text>"#,
        by - 10.0
    );
    for k in 0..=4 {
        let t = k as f64 / 4.0;
        let y = by + bh * (1.0 - t);
        let _ = writeln!(
            s,
            r#"<text x="{:.1}" y="{:.1}" font-size="12">{}</text>"#,
            bx + 28.0,
            y + 4.0,
            tick_label(t * p_max)
        );
    }
    let _ = writeln!(
        s,
        r#"<text x="{bx}" y="{:.1}" font-size="12">grey: no contact</text>"#,
        by + bh + 24.0
    );
    s.push_str("</svg>\n");
    Ok(Some(s))
}

fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

fn tick_label(v: f64) -> String {
    if v == 0.0 {
        "0".into()
    } else if (1e-2..1e4).contains(&v.abs()) {
        format!("{v:.3}")
    } else {
        format!("{v:.2e}")
    }
}

/// Twice the signed area of a polygon (counter-clockwise positive, y up).
fn area2(p: impl Iterator<Item = (f64, f64)>) -> f64 {
    let p: Vec<(f64, f64)> = p.collect();
    (0..p.len())
        .map(|i| {
            let (a, b) = (p[i], p[(i + 1) % p.len()]);
            a.0 * b.1 - b.0 * a.1
        })
        .sum()
}

/// Faces of 8-node hexahedra (VTK order) that belong to one cell only, each ordered
/// counter-clockwise seen from outside the cell.
pub fn boundary_faces(cells: &[Vec<usize>]) -> Vec<Vec<usize>> {
    // the hex8 element's faces (its node order is VTK's), counter-clockwise from outside
    use crate::fem::hex8::FACES;
    let mut count: std::collections::HashMap<[usize; 4], (usize, Vec<usize>)> =
        std::collections::HashMap::new();
    for c in cells.iter().filter(|c| c.len() == 8) {
        for f in FACES {
            let nodes: Vec<usize> = f.iter().map(|&i| c[i]).collect();
            let mut key = [nodes[0], nodes[1], nodes[2], nodes[3]];
            key.sort_unstable();
            count.entry(key).or_insert((0, nodes)).0 += 1;
        }
    }
    let mut faces: Vec<Vec<usize>> = count
        .into_values()
        .filter(|(k, _)| *k == 1)
        .map(|(_, f)| f)
        .collect();
    faces.sort();
    faces
}

/// A projection of 3D points: rows of `rot` are the screen's x and y axes and the depth towards
/// the viewer. `project` returns screen x, y and that depth.
struct View {
    rot: [[f64; 3]; 3],
}

impl View {
    /// Rotated -35 degrees about z, then tilted 25 degrees about the screen's x axis: an oblique
    /// view from the front-right and above.
    fn oblique() -> Self {
        let (a, b) = (35f64.to_radians(), 25f64.to_radians());
        let rz = [
            [a.cos(), a.sin(), 0.0],
            [-a.sin(), a.cos(), 0.0],
            [0.0, 0.0, 1.0],
        ];
        // rows: screen x, screen y (z up, tilted towards the viewer), depth (towards the viewer)
        let rx = [
            [1.0, 0.0, 0.0],
            [0.0, b.sin(), b.cos()],
            [0.0, -b.cos(), b.sin()],
        ];
        let mut rot = [[0.0; 3]; 3];
        for i in 0..3 {
            for j in 0..3 {
                rot[i][j] = (0..3).map(|k| rx[i][k] * rz[k][j]).sum();
            }
        }
        View { rot }
    }

    /// Looking along the direction in which `points` spread least (their plane's normal), from the
    /// side with a positive z component (positive x, then y, when the normal lies in the x-y
    /// plane); `None` for fewer than 3 points.
    fn along_normal(points: &[[f64; 3]]) -> Option<Self> {
        if points.len() < 3 {
            return None;
        }
        let n = points.len() as f64;
        let c = [0, 1, 2].map(|d| points.iter().map(|p| p[d]).sum::<f64>() / n);
        let mut cov = nalgebra::Matrix3::<f64>::zeros();
        for p in points {
            let v = nalgebra::Vector3::new(p[0] - c[0], p[1] - c[1], p[2] - c[2]);
            cov += v * v.transpose();
        }
        let eig = cov.symmetric_eigen();
        let mut idx = [0usize, 1, 2];
        idx.sort_by(|&a, &b| eig.eigenvalues[b].total_cmp(&eig.eigenvalues[a]));
        let col = |k: usize| {
            let v = eig.eigenvectors.column(idx[k]);
            [v[0], v[1], v[2]]
        };
        let mut normal = col(2);
        let key = if normal[2].abs() > 1e-6 {
            normal[2]
        } else if normal[0].abs() > 1e-6 {
            normal[0]
        } else {
            normal[1]
        };
        if key < 0.0 {
            normal = normal.map(|v| -v);
        }
        let e1 = col(0);
        // e2 = normal x e1 keeps the frame right-handed (screen x, screen y, towards the viewer)
        let e2 = [
            normal[1] * e1[2] - normal[2] * e1[1],
            normal[2] * e1[0] - normal[0] * e1[2],
            normal[0] * e1[1] - normal[1] * e1[0],
        ];
        Some(View {
            rot: [e1, e2, normal],
        })
    }

    fn project(&self, x: &[f64; 3]) -> [f64; 3] {
        [0, 1, 2].map(|i| (0..3).map(|j| self.rot[i][j] * x[j]).sum())
    }

    /// Lambert shade in [0, 1] of a face with these corner positions.
    fn shade(&self, x: Vec<[f64; 3]>) -> f64 {
        if x.len() < 3 {
            return 0.5;
        }
        let (a, b) = (
            [0, 1, 2].map(|d| x[2][d] - x[0][d]),
            [0, 1, 2].map(|d| x[3 % x.len()][d] - x[1][d]),
        );
        let n = [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ];
        let len = n.iter().map(|v| v * v).sum::<f64>().sqrt();
        if len == 0.0 {
            return 0.5;
        }
        // light from above, in front and to the left
        let l = [-0.3, -0.5, 0.8];
        let ll = (l.iter().map(|v: &f64| v * v).sum::<f64>()).sqrt();
        ((0..3).map(|d| n[d] * l[d]).sum::<f64>() / (len * ll)).abs()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_colour_map_runs_from_dark_violet_to_yellow_and_clamps() {
        assert_eq!(colour(0.0), (68, 1, 84));
        assert_eq!(colour(1.0), (253, 231, 37));
        assert_eq!(colour(-3.0), colour(0.0));
        assert_eq!(colour(7.0), colour(1.0));
        assert_eq!(colour(f64::NAN), colour(0.0));
        // brightness rises along the map
        let lum = |(r, g, b): (u8, u8, u8)| 0.3 * r as f64 + 0.59 * g as f64 + 0.11 * b as f64;
        for k in 0..20 {
            assert!(lum(colour((k + 1) as f64 / 20.0)) > lum(colour(k as f64 / 20.0)));
        }
    }

    #[test]
    fn a_cube_of_two_by_one_by_one_hexes_has_ten_boundary_faces_facing_out() {
        // nodes of a 2 x 1 x 1 block, x fastest
        let node = |i: usize, j: usize, k: usize| i + 3 * j + 6 * k;
        let hex = |i: usize| {
            vec![
                node(i, 0, 0),
                node(i + 1, 0, 0),
                node(i + 1, 1, 0),
                node(i, 1, 0),
                node(i, 0, 1),
                node(i + 1, 0, 1),
                node(i + 1, 1, 1),
                node(i, 1, 1),
            ]
        };
        let faces = boundary_faces(&[hex(0), hex(1)]);
        assert_eq!(faces.len(), 10);
        // the shared face x = 1 is not among them
        assert!(!faces.iter().any(|f| f.iter().all(|&n| n % 3 == 1)));
        // every face's normal points away from the block's centre (1, 0.5, 0.5)
        let pos = |n: usize| [(n % 3) as f64, ((n / 3) % 2) as f64, (n / 6) as f64];
        for f in &faces {
            let p: Vec<[f64; 3]> = f.iter().map(|&n| pos(n)).collect();
            let a = [0, 1, 2].map(|d| p[1][d] - p[0][d]);
            let b = [0, 1, 2].map(|d| p[2][d] - p[1][d]);
            let n = [
                a[1] * b[2] - a[2] * b[1],
                a[2] * b[0] - a[0] * b[2],
                a[0] * b[1] - a[1] * b[0],
            ];
            let c = [0, 1, 2].map(|d| p.iter().map(|q| q[d]).sum::<f64>() / 4.0);
            let out = [c[0] - 1.0, c[1] - 0.5, c[2] - 0.5];
            assert!(
                (0..3).map(|d| n[d] * out[d]).sum::<f64>() > 0.0,
                "face {f:?}"
            );
        }
    }

    #[test]
    fn history_plots_skip_zero_columns_and_split_moments() {
        let table = HistoryTable {
            columns: [
                "step",
                "load_factor",
                "R_a_x",
                "R_a_y",
                "P_c_y",
                "M_c",
                "wall_time",
            ]
            .map(String::from)
            .to_vec(),
            rows: vec![
                vec![1.0, 0.5, 1e-18, -1.0, 1.0, 0.0, 0.1],
                vec![2.0, 1.0, -1e-17, -2.0, 2.0, 0.0, 0.2],
            ],
        };
        let plots = history_plots(&table, "c");
        assert_eq!(plots.len(), 1, "a zero moment column gives no moment plot");
        let names: Vec<&str> = plots[0].1.series.iter().map(|s| s.name.as_str()).collect();
        assert_eq!(names, ["R_a_y", "P_c_y"]);
        // each series starts at the unloaded state
        assert_eq!(plots[0].1.series[0].points[0], (0.0, 0.0));
        assert_eq!(plots[0].1.series[0].points[2], (1.0, -2.0));
        let mut with_moment = table;
        with_moment.rows[1][5] = 0.3;
        let plots = history_plots(&with_moment, "c");
        assert_eq!(plots.len(), 2);
        assert_eq!(plots[1].0, "moments");
        assert_eq!(plots[1].1.series[0].name, "M_c");
    }
}
