//! The enriched layer of a body (Corbett & Sauer 2014, sections 3.1-3.6): from the linear mesh's
//! ordered contact faces, the exact surface geometry (a straight line or circular arc in 2D, a plane
//! in 3D, or in 3D the exact surface a generator attached to the face set, e.g. the hemisphere of
//! `crate::mesh::hemisphere_nurbs`), refined to the body's family, and the node lists of the
//! enriched cells.
//!
//! Numbering (body-local, before global numbering): the mesh nodes keep their ids; new nodes
//! (control points, Q1C2 mid-face nodes, Q1CH tangent pseudo-nodes) are appended after them, with
//! their reference coordinates in [`Enrichment::extra_coords`] (a tangent pseudo-node's
//! "coordinates" are the reference unit tangent `dX/ds`). Surface nodes that a family replaces by
//! control points (Q1Np: all but the patch corners / curve ends, which interpolate) stay in the mesh
//! as *display nodes*: no element uses them, so they carry no unknowns; their displacement is
//! interpolated for output from the element that has them as a corner ([`Enrichment::display`]).
//!
//! Linear cells that touch the surface only at a replaced node (an unstructured mesh's cell
//! between two enriched cells, or in 3D along an edge, never a face) are tied to the surface's
//! interpolation there ([`TiedCell`]): the node follows the layer, `u_n = sum_A N_A(xi_n) u_A`, a
//! constraint built once into the cell's node list, so assembly needs nothing special.
//!
//! Node sets ([`Enrichment::remap`]): a replaced surface node in a set is replaced by the
//! position-type nodes (control points / mid nodes, never tangent pseudo-nodes) of every enriched
//! element whose basis is nonzero at that node, and every enriched element whose whole linear face
//! lies in the set brings all its position-type nodes; in 3D, a face edge whose two corners lie in the
//! set brings the control points of that edge row (with t >= 1 some vanish at both corners). So a
//! set holding a whole enriched surface gets all its control points, a patch edge gets the control
//! points of that edge row, and a single interior node gets the `p` control points whose functions
//! are nonzero there.
//!
//! Exact geometry and its limits: a 2D arc is split into the fewest equal rational quadratic
//! segments (< 180 degrees) whose joints are mesh nodes; those joints stay C^0 knots (multiplicity
//! p+t) of the refined curve, every other element boundary has the continuity of Table 1; the same
//! holds for the C^0 knot lines of a generator's exact 3D surface. Curves other than lines and
//! circles are enriched only with `enriched_geometry = "smooth"` (fitted to the C^2 cubic
//! interpolant of their nodes, [`Enrichment::interpolated_reference`]); closed curves, and non-planar or non-rectangular 3D patches without an exact surface
//! from the generator ([`Mesh::exact_surfaces`]) are reported as unsupported: in particular the
//! Coons-map `hemisphere` generator's surface (use `hemisphere_nurbs`).
//!
//! Smooth geometry (`bodies.X.enriched_geometry = "smooth"`, Q1Np(.t) only,
//! [`build_enrichment_with`]): an exact surface with C^0 joints is replaced by a polynomial
//! B-spline of order p with one span per face and single interior knots (C^{p-1} everywhere),
//! least-squares fitted to it in arc length with its ends/corners interpolated
//! ([`crate::geometry::fit`]), then elevated `t` times; [`Enrichment::smooth_deviation`] is its
//! largest distance from the exact surface (17 samples per element and direction). In 3D the
//! tensor-product fit keeps a collapsed edge collapsed (the hemisphere's rim points stay one node)
//! and a planar boundary row planar. The fit does not pass through the interior mesh nodes; they
//! stay display nodes, interpolated from the layer for output.
//!
//! Degenerate patches: where an edge of the exact surface collapses to a point (the hemisphere's two
//! rim points), its coincident control points become one node, as the generator merged its mesh
//! nodes there; an element then lists that node several times, which assembly sums.
//! The bulk of an enriched body is Q1C1.
#![allow(clippy::needless_range_loop)] // index loops mirror the equations
use crate::fem::enriched::{
    q1c2_2d, q1ch_2d, q1np_2d, q1np_3d, EnrichedBasis, EnrichedElementData,
};
use crate::geometry::conics::{circular_arc_segments, line_segment, plane_patch};
use crate::geometry::fit::{
    distance_to_curve, distance_to_surface, fit_curve, fit_surface, interpolate_cubic, ArcLength,
};
use crate::geometry::knots::KnotVector;
use crate::geometry::nurbs::{NurbsCurve, NurbsSurface};
use crate::geometry::refine::Direction;
use crate::geometry::GeometryError;
use crate::mesh::{CellKind, ExactPatch, Mesh};
use crate::scene::{ElementFamily, EnrichedGeometry};
use std::collections::{BTreeMap, BTreeSet};
use std::f64::consts::PI;

/// Relative tolerance (in units of the surface's size) for "lies on a line / circle / plane".
const GEOMETRY_TOL: f64 = 1e-10;

/// Why an enriched layer could not be built.
#[derive(Debug, thiserror::Error)]
pub enum EnrichError {
    /// The face set is missing, empty or not a chain/grid of local-0 faces.
    #[error("enriched surface `{set}`: {msg}")]
    Faces {
        /// The face set.
        set: String,
        /// What is wrong.
        msg: String,
    },
    /// The surface is of a kind this version cannot represent exactly.
    #[error("enriched surface `{set}`: {msg}")]
    Unsupported {
        /// The face set.
        set: String,
        /// What is missing.
        msg: String,
    },
    /// The exact geometry could not be built or refined.
    #[error("enriched surface `{set}`: {source}")]
    Geometry {
        /// The face set.
        set: String,
        /// The geometry kernel's error.
        source: GeometryError,
    },
}

/// One enriched cell: node list in the order of `crate::fem::enriched`, and its basis.
#[derive(Debug, Clone, PartialEq)]
pub struct EnrichedCell {
    /// Body-local cell id (its linear parent in the mesh).
    pub cell: usize,
    /// Body-local node ids in the element's node order.
    pub nodes: Vec<u32>,
    /// Number of leading position-type surface nodes (control points, mid nodes, Hermite positions).
    pub n_position: usize,
    /// The linear parent's surface corners (body-local), in reference order: 2D xi = -1, +1;
    /// 3D (xi,eta) = (-1,-1), (1,-1), (1,1), (-1,1).
    pub corners: Vec<u32>,
    /// Reference basis.
    pub basis: EnrichedBasis,
}

impl EnrichedCell {
    /// Number of element nodes.
    pub fn n_nodes(&self) -> usize {
        self.nodes.len()
    }

    /// Shape functions `N` [n_nodes] and reference derivatives `dN` [n_nodes][dim] at `xi` [dim].
    #[allow(non_snake_case)]
    pub fn shape(&self, xi: &[f64], N: &mut [f64], dN: &mut [f64]) {
        match &self.basis {
            EnrichedBasis::Nurbs(d) if d.q == 0 => q1np_2d(d, xi[0], xi[1], N, dN),
            EnrichedBasis::Nurbs(d) => q1np_3d(d, xi[0], xi[1], xi[2], N, dN),
            EnrichedBasis::C2 => q1c2_2d(xi[0], xi[1], N, dN),
            EnrichedBasis::Hermite { h } => q1ch_2d(*h, xi[0], xi[1], N, dN),
        }
    }

    /// Quadrature point counts per reference direction (section 3.4): `n_s` per surface direction
    /// (`p+t+1`; Q1C2: 3, Q1CH: 4) and 2 through the thickness.
    pub fn quadrature_counts(&self) -> Vec<usize> {
        match &self.basis {
            EnrichedBasis::Nurbs(d) if d.q == 0 => vec![d.p + 1, 2],
            EnrichedBasis::Nurbs(d) => vec![d.p + 1, d.q + 1, 2],
            EnrichedBasis::C2 => vec![3, 2],
            EnrichedBasis::Hermite { .. } => vec![4, 2],
        }
    }

    /// Reference coordinates of surface corner `k` (see [`EnrichedCell::corners`]).
    pub fn corner_reference(&self, k: usize) -> Vec<f64> {
        if self.corners.len() == 2 {
            vec![if k == 0 { -1.0 } else { 1.0 }, -1.0]
        } else {
            let (x, e) = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)][k];
            vec![x, e, -1.0]
        }
    }
}

/// A linear (non-enriched) cell that touches the enriched surface only at nodes the layer replaced
/// by control points (a node, or in 3D an edge, but no face): each such node follows the surface,
/// `u_n = sum_A N_A(xi_n) u_A` over the control points of the enriched cell that has `n` as a
/// corner (the display interpolation of `n`), a constraint built once. The cell is the same linear
/// element with its shape functions mapped, `N'_j = sum_a N_a T_aj`: the tied node's function is
/// shared among the control points, so assembly needs nothing special, and its reference position
/// is the surface point `sum_A N_A(xi_n) X_A` (the mesh node itself where the layer interpolates
/// it; on a smooth fit the point of the fit, so the cell stays conforming with its enriched
/// neighbours and an affine field is reproduced exactly). In 2D the tie is conforming (the cell
/// meets its enriched neighbours along straight sides that end at the tied node); in 3D a cell
/// touching the surface along an edge is tied at the edge's two nodes, and its straight edge
/// follows the curved surface only there.
#[derive(Debug, Clone, PartialEq)]
pub struct TiedCell {
    /// Body-local cell id.
    pub cell: usize,
    /// Element nodes (body-local): the cell's nodes that keep their unknowns, then the control
    /// points of its tied nodes, each once.
    pub nodes: Vec<u32>,
    /// For each node of the linear cell, in the cell's order: `(index into nodes, weight)`.
    pub map: Vec<Vec<(usize, f64)>>,
}

impl TiedCell {
    /// Maps a table of the linear cell's values at points, `[n_points][n_linear][k]`, to the
    /// element's nodes, `[n_points][nodes.len()][k]` (e.g. `k = dim` for reference derivatives).
    pub fn expand(&self, table: &[f64], k: usize) -> Vec<f64> {
        let (nl, n) = (self.map.len(), self.nodes.len());
        let n_points = table.len() / (nl * k);
        let mut out = vec![0.0; n_points * n * k];
        for q in 0..n_points {
            for (a, row) in self.map.iter().enumerate() {
                let src = &table[(q * nl + a) * k..(q * nl + a + 1) * k];
                for &(j, w) in row {
                    for (o, s) in out[(q * n + j) * k..(q * n + j + 1) * k]
                        .iter_mut()
                        .zip(src)
                    {
                        *o += w * s;
                    }
                }
            }
        }
        out
    }
}

/// The surface the enriched layer was built on: the exact one (refined to the family for Q1Np), or
/// for `enriched_geometry = "smooth"` its smooth fit (elevated to the family).
#[derive(Debug, Clone, PartialEq)]
pub enum ExactSurface {
    /// 2D: the curve in traversal order of the face set; for Q1Np refined so that knot spans
    /// are the enriched elements.
    Curve(NurbsCurve),
    /// 3D plane or generator-provided exact surface, refined; element `e_u + n_el_u e_v` is face
    /// `(e_u, e_v)` of the face grid.
    Surface(NurbsSurface),
}

/// The enriched layer of one body.
#[derive(Debug, Clone, PartialEq)]
pub struct Enrichment {
    /// The face set it was built on.
    pub face_set: String,
    /// Number of mesh nodes; new nodes are numbered from here.
    pub n_mesh_nodes: usize,
    /// Reference coordinates of the new nodes. [n_extra][dim]
    pub extra_coords: Vec<f64>,
    /// Enriched cells in face-set order.
    pub cells: Vec<EnrichedCell>,
    /// Index into `cells` of each mesh cell, `None` for linear cells. [n_cells]
    pub cell_index: Vec<Option<usize>>,
    /// Mesh surface nodes replaced by control points (display nodes), sorted.
    pub replaced: Vec<u32>,
    /// Q1CH tangent pseudo-nodes (never in node sets), sorted.
    pub pseudo_nodes: Vec<u32>,
    /// Each display node with its interpolation `(element node, weight)` from one enriched cell.
    pub display: Vec<(u32, Vec<(u32, f64)>)>,
    /// The (refined) surface of the layer: exact, or its smooth fit.
    pub exact: ExactSurface,
    /// For a smooth fit (`enriched_geometry = "smooth"` on a surface with C^0 joints, Q1Np only):
    /// the largest distance between the fit and the exact surface, sampled at 17 points per
    /// element and direction; `None` when the layer interpolates the exact surface.
    pub smooth_deviation: Option<f64>,
    /// The face set's geometry was unknown (2D: neither a line nor a circle; 3D: neither a plane
    /// nor a generator's exact surface), so the layer was fitted to the cubic interpolant of its
    /// nodes, the reference of `smooth_deviation`.
    pub interpolated_reference: bool,
    /// Linear cells tied to the layer: they touch the surface only at replaced nodes.
    pub tied: Vec<TiedCell>,
    /// Index into `tied` of each mesh cell. [n_cells]
    pub tied_index: Vec<Option<usize>>,
}

impl Enrichment {
    /// Number of new nodes.
    pub fn n_extra(&self) -> usize {
        self.extra_coords.len() / self.dim()
    }

    fn dim(&self) -> usize {
        match self.exact {
            ExactSurface::Curve(_) => 2,
            ExactSurface::Surface(_) => 3,
        }
    }

    /// Remaps a body-local node set (see the module docs): replaced surface nodes leave it, the
    /// control points / mid nodes they stand for enter it. Sorted, unique.
    #[allow(non_snake_case)]
    pub fn remap(&self, nodes: &[u32]) -> Vec<u32> {
        let set: BTreeSet<u32> = nodes.iter().copied().collect();
        let mut out: BTreeSet<u32> = set.clone();
        let mut N = vec![0.0; 64];
        let mut dN = vec![0.0; 192];
        for c in &self.cells {
            let n = c.n_nodes();
            if N.len() < n {
                N.resize(n, 0.0);
                dN.resize(3 * n, 0.0);
            }
            if c.corners.iter().all(|k| set.contains(k)) {
                out.extend(&c.nodes[..c.n_position]);
                continue;
            }
            let mut points: Vec<Vec<f64>> = Vec::new();
            for (k, corner) in c.corners.iter().enumerate() {
                if set.contains(corner) {
                    points.push(c.corner_reference(k));
                }
            }
            // a 3D face edge with both ends in the set brings its whole control row: with t >= 1
            // some of its functions vanish at both corners, but none at the edge's midpoint
            // (B-spline functions are positive inside their support)
            if c.corners.len() == 4 {
                for k in 0..4 {
                    let l = (k + 1) % 4;
                    if set.contains(&c.corners[k]) && set.contains(&c.corners[l]) {
                        let (a, b) = (c.corner_reference(k), c.corner_reference(l));
                        points.push(a.iter().zip(&b).map(|(x, y)| 0.5 * (x + y)).collect());
                    }
                }
            }
            for xi in &points {
                c.shape(xi, &mut N[..n], &mut dN[..3 * n]);
                for a in 0..c.n_position {
                    if N[a].abs() > 1e-14 {
                        out.insert(c.nodes[a]);
                    }
                }
            }
        }
        for r in &self.replaced {
            out.remove(r);
        }
        out.into_iter().collect()
    }
}

fn faces_err(set: &str, msg: impl Into<String>) -> EnrichError {
    EnrichError::Faces {
        set: set.to_string(),
        msg: msg.into(),
    }
}

fn unsupported(set: &str, msg: impl Into<String>) -> EnrichError {
    EnrichError::Unsupported {
        set: set.to_string(),
        msg: msg.into(),
    }
}

/// Builds the enriched layer of `mesh` on face set `set` for `family`. Cells with a face in the set
/// are rotated so that face becomes local face 0 (a no-op for the generators, which already do so).
pub fn build_enrichment(
    mesh: &mut Mesh,
    set: &str,
    family: ElementFamily,
) -> Result<Enrichment, EnrichError> {
    build_enrichment_with(mesh, set, family, EnrichedGeometry::Exact)
}

/// [`build_enrichment`] with the choice of geometry: for Q1Np(.t), `Smooth` replaces an exact
/// surface that has C^0 joints by its C^{p-1} fit (see [`crate::geometry::fit`]), with one span per
/// face; other families and surfaces without joints keep the exact geometry.
pub fn build_enrichment_with(
    mesh: &mut Mesh,
    set: &str,
    family: ElementFamily,
    geometry: EnrichedGeometry,
) -> Result<Enrichment, EnrichError> {
    let smooth = geometry == EnrichedGeometry::Smooth;
    let faces = mesh
        .face_sets
        .get(set)
        .cloned()
        .ok_or_else(|| faces_err(set, "no such face set"))?;
    if faces.is_empty() {
        return Err(faces_err(set, "the face set is empty"));
    }
    for &(cell, face) in &faces {
        if face != 0 {
            mesh.orient_face_to_local0(cell as usize, face)
                .map_err(|e| faces_err(set, e.to_string()))?;
        }
    }
    let cells: Vec<usize> = faces.iter().map(|&(c, _)| c as usize).collect();
    let mut seen = BTreeSet::new();
    if let Some(c) = cells.iter().find(|&&c| !seen.insert(c)) {
        return Err(faces_err(
            set,
            format!("cell {c} has more than one face in the set"),
        ));
    }
    let layer = match mesh.dim {
        2 => build_2d(mesh, set, &cells, family, smooth)?,
        _ => build_3d(mesh, set, &cells, family, smooth)?,
    };
    let mut layer = layer;
    tie_linear_cells(mesh, set, &mut layer)?;
    Ok(layer)
}

/// Ties the linear cells that touch the enriched surface at replaced nodes (display nodes, which
/// carry no unknowns) to the surface's interpolation there (see [`TiedCell`]). A linear cell with a
/// whole face on the surface, or an enriched cell whose bulk side touches it, is an error.
fn tie_linear_cells(mesh: &Mesh, set: &str, e: &mut Enrichment) -> Result<(), EnrichError> {
    let replaced: BTreeSet<u32> = e.replaced.iter().copied().collect();
    if replaced.is_empty() {
        return Ok(());
    }
    let surface: BTreeSet<u32> = e
        .cells
        .iter()
        .flat_map(|c| c.corners.iter().copied())
        .collect();
    let display: BTreeMap<u32, &Vec<(u32, f64)>> = e.display.iter().map(|(n, w)| (*n, w)).collect();
    for c in &e.cells {
        if let Some(n) = c.nodes[c.n_position..]
            .iter()
            .find(|n| replaced.contains(n))
        {
            return Err(unsupported(
                set,
                format!(
                    "the bulk side of enriched cell {} touches the surface at node {n} (a cell \
                     with more than one side on the surface); refine the mesh there",
                    c.cell
                ),
            ));
        }
    }
    for c in 0..mesh.n_cells() {
        if e.cell_index[c].is_some() {
            continue;
        }
        let cn = mesh.cell(c);
        if !cn.iter().any(|n| replaced.contains(n)) {
            continue;
        }
        let kind = mesh.cell_kind[c];
        for f in 0..kind.n_faces() as u8 {
            let fnodes = mesh
                .face_nodes(c, f)
                .map_err(|err| faces_err(set, err.to_string()))?;
            if fnodes.iter().all(|n| surface.contains(n)) {
                return Err(faces_err(
                    set,
                    format!(
                        "cell {c} has its face {f} on the enriched surface but the face is not \
                         in the set"
                    ),
                ));
            }
        }
        let mut nodes: Vec<u32> = cn
            .iter()
            .copied()
            .filter(|n| !replaced.contains(n))
            .collect();
        let mut map = Vec::with_capacity(cn.len());
        for n in cn {
            let weights = match display.get(n) {
                Some(w) => w.to_vec(),
                None => vec![(*n, 1.0)],
            };
            let mut row = Vec::with_capacity(weights.len());
            for (a, w) in weights {
                let i = nodes.iter().position(|&b| b == a).unwrap_or_else(|| {
                    nodes.push(a);
                    nodes.len() - 1
                });
                row.push((i, w));
            }
            map.push(row);
        }
        e.tied_index[c] = Some(e.tied.len());
        e.tied.push(TiedCell {
            cell: c,
            nodes,
            map,
        });
    }
    Ok(())
}

fn dist(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y) * (x - y))
        .sum::<f64>()
        .sqrt()
}

/// Exact 2D curve through the chain of surface nodes, with a monotone "position along the curve"
/// (distance for a line, swept angle for an arc) used to find node parameters.
type AlongCurve = Box<dyn Fn(&NurbsCurve, f64) -> f64>;

struct Curve2d {
    curve: NurbsCurve,
    /// position along the curve of each surface node
    pos: Vec<f64>,
    /// `u -> position along the curve`
    along: AlongCurve,
    /// No exact geometry: `curve` is the cubic interpolant of the nodes.
    free: bool,
}

impl Curve2d {
    /// Parameter at position `s` (bisection on the monotone `along`; exact to round-off).
    fn param(&self, s: f64) -> f64 {
        let (mut a, mut b) = (0.0, 1.0);
        for _ in 0..200 {
            let m = 0.5 * (a + b);
            if (self.along)(&self.curve, m) < s {
                a = m;
            } else {
                b = m;
            }
            if b - a <= f64::EPSILON {
                break;
            }
        }
        0.5 * (a + b)
    }
}

fn reverse_curve(c: &NurbsCurve) -> Result<NurbsCurve, GeometryError> {
    let p = c.degree();
    let knots: Vec<f64> = c.knots.knots().iter().rev().map(|u| 1.0 - u).collect();
    let n = c.n_ctrl();
    let ctrl: Vec<f64> = (0..n)
        .rev()
        .flat_map(|a| c.ctrl[a * c.dim..(a + 1) * c.dim].to_vec())
        .collect();
    let w = c.weights.iter().rev().copied().collect();
    NurbsCurve::new(KnotVector::new(p, knots)?, c.dim, ctrl, w)
}

/// The curve of a face set without known exact geometry (`enriched_geometry = "smooth"` only): the
/// C^2 cubic interpolant of its nodes in chord length (see
/// [`crate::geometry::fit::interpolate_cubic`]), the reference the smooth layer is fitted to.
fn free_curve(set: &str, pts: &[[f64; 2]]) -> Result<Curve2d, EnrichError> {
    let mut pos = vec![0.0];
    for w in pts.windows(2) {
        pos.push(pos[pos.len() - 1] + dist(&w[0], &w[1]));
    }
    let total = pos[pos.len() - 1];
    let t: Vec<f64> = pos.iter().map(|s| s / total).collect();
    let q: Vec<[f64; 3]> = pts.iter().map(|x| [x[0], x[1], 0.0]).collect();
    let curve = interpolate_cubic(&q, &t, 2).map_err(|source| EnrichError::Geometry {
        set: set.to_string(),
        source,
    })?;
    let along = Box::new(move |_: &NurbsCurve, u: f64| u * total);
    Ok(Curve2d {
        curve,
        pos,
        along,
        free: true,
    })
}

fn detect_curve(set: &str, pts: &[[f64; 2]], smooth: bool) -> Result<Curve2d, EnrichError> {
    let geo = |source| EnrichError::Geometry {
        set: set.to_string(),
        source,
    };
    let n = pts.len() - 1;
    let (a, b) = (pts[0], pts[n]);
    let len = dist(&a, &b);
    let scale = pts
        .windows(2)
        .map(|w| dist(&w[0], &w[1]))
        .sum::<f64>()
        .max(f64::MIN_POSITIVE);
    let tol = GEOMETRY_TOL * scale.max(1.0);
    // straight line?
    if len > 0.0 {
        let d = [(b[0] - a[0]) / len, (b[1] - a[1]) / len];
        let off = |x: &[f64; 2]| ((x[0] - a[0]) * d[1] - (x[1] - a[1]) * d[0]).abs();
        if pts.iter().all(|x| off(x) <= tol) {
            let pos: Vec<f64> = pts
                .iter()
                .map(|x| (x[0] - a[0]) * d[0] + (x[1] - a[1]) * d[1])
                .collect();
            let curve = line_segment(&a, &b).map_err(geo)?;
            let along = Box::new(move |c: &NurbsCurve, u: f64| {
                let x = c.point(u);
                (x[0] - a[0]) * d[0] + (x[1] - a[1]) * d[1]
            });
            return Ok(Curve2d {
                curve,
                pos,
                along,
                free: false,
            });
        }
    }
    if n < 2 {
        return Err(unsupported(set, "a single face that is not straight"));
    }
    // circle through the first, middle and last node
    let m = pts[n / 2];
    let (ax, ay, bx, by, cx, cy) = (a[0], a[1], m[0], m[1], b[0], b[1]);
    let det = 2.0 * (ax * (by - cy) + bx * (cy - ay) + cx * (ay - by));
    let not_conic = || {
        if smooth {
            return free_curve(set, pts);
        }
        Err(unsupported(
            set,
            "the surface nodes lie neither on a straight line nor on a circle (within 1e-10); \
             other curves can be enriched with enriched_geometry = \"smooth\" (a smooth fit \
             through the nodes)",
        ))
    };
    if det.abs() <= 1e-14 * scale * scale {
        return not_conic();
    }
    let (a2, b2, c2) = (ax * ax + ay * ay, bx * bx + by * by, cx * cx + cy * cy);
    let center = [
        (a2 * (by - cy) + b2 * (cy - ay) + c2 * (ay - by)) / det,
        (a2 * (cx - bx) + b2 * (ax - cx) + c2 * (bx - ax)) / det,
    ];
    let r = dist(&a, &center);
    if pts.iter().any(|x| (dist(x, &center) - r).abs() > tol) {
        return not_conic();
    }
    // unwrapped node angles, monotone in traversal order
    let ang = |x: &[f64; 2]| (x[1] - center[1]).atan2(x[0] - center[0]);
    let mut th = vec![ang(&pts[0])];
    for x in &pts[1..] {
        let prev = th[th.len() - 1];
        let mut t = ang(x);
        while t - prev > PI {
            t -= 2.0 * PI;
        }
        while t - prev < -PI {
            t += 2.0 * PI;
        }
        th.push(t);
    }
    let ccw = th[n] > th[0];
    if th.windows(2).any(|w| (w[1] > w[0]) != ccw || w[1] == w[0]) {
        return Err(faces_err(
            set,
            "the faces do not run monotonically along the arc",
        ));
    }
    let sweep = (th[n] - th[0]).abs();
    if sweep >= 2.0 * PI * (1.0 - 1e-12) {
        return Err(unsupported(set, "closed circles are not supported"));
    }
    // fewest equal rational quadratic segments (< 180 degrees each) whose joints are mesh nodes,
    // so every C^0 joint of the exact base curve sits on an element boundary
    let pos: Vec<f64> = th.iter().map(|t| (t - th[0]).abs()).collect();
    let n_seg = (1..=n)
        .find(|&k| {
            sweep / (k as f64) < PI * (1.0 - 1e-6)
                && (1..k).all(|j| {
                    let s = sweep * j as f64 / k as f64;
                    pos.iter().any(|&q| (q - s).abs() <= tol / r)
                })
        })
        .ok_or_else(|| {
            unsupported(
                set,
                "no split of the arc into equal segments below 180 degrees has its joints at mesh nodes",
            )
        })?;
    let (lo, hi) = if ccw { (th[0], th[n]) } else { (th[n], th[0]) };
    let mut curve = circular_arc_segments(center, r, lo, hi, n_seg).map_err(geo)?;
    if !ccw {
        curve = reverse_curve(&curve).map_err(geo)?;
    }
    let (th0, sign) = (th[0], if ccw { 1.0 } else { -1.0 });
    let along = Box::new(move |c: &NurbsCurve, u: f64| {
        let x = c.point(u);
        let t = (x[1] - center[1]).atan2(x[0] - center[0]);
        (sign * (t - th0)).rem_euclid(2.0 * PI)
    });
    Ok(Curve2d {
        curve,
        pos,
        along,
        free: false,
    })
}

/// Element half-length in arc length, `ds/dxi`, of span `[ua, ub]` (20-point Gauss: exact to
/// round-off for lines and arcs, whose speed `|dC/du|` is smooth on a span).
fn half_length(c: &NurbsCurve, ua: f64, ub: f64) -> Result<f64, crate::fem::ElementError> {
    let (x, w) = crate::fem::quadrature::gauss_legendre(20)?;
    let half = 0.5 * (ub - ua);
    Ok(x.iter()
        .zip(&w)
        .map(|(&xi, &wi)| {
            let (_, d) = c.eval(0.5 * (ua + ub) + half * xi);
            wi * (d[0] * d[0] + d[1] * d[1]).sqrt() * half
        })
        .sum::<f64>()
        * 0.5)
}

fn build_2d(
    mesh: &Mesh,
    set: &str,
    cells: &[usize],
    family: ElementFamily,
    smooth: bool,
) -> Result<Enrichment, EnrichError> {
    let geo = |source| EnrichError::Geometry {
        set: set.to_string(),
        source,
    };
    for &c in cells {
        if mesh.cell_kind[c] != CellKind::Quad4 {
            return Err(faces_err(set, format!("cell {c} is not a Quad4")));
        }
    }
    // chain of surface nodes: face 0 of a quad runs from node 0 to node 1 (increasing xi); the
    // set may list the faces against that direction (e.g. a top side listed left to right)
    let chain = |cells: &[usize]| -> Option<Vec<u32>> {
        let mut snodes = vec![mesh.cell(cells[0])[0]];
        for (i, &c) in cells.iter().enumerate() {
            let cn = mesh.cell(c);
            if cn[0] != snodes[i] {
                return None;
            }
            snodes.push(cn[1]);
        }
        Some(snodes)
    };
    let reversed: Vec<usize> = cells.iter().rev().copied().collect();
    let (cells, snodes) = match (chain(cells), chain(&reversed)) {
        (Some(s), _) => (cells.to_vec(), s),
        (None, Some(s)) => (reversed, s),
        (None, None) => {
            return Err(faces_err(
                set,
                "the faces are not a chain ordered along the surface (each face must start \
                 where the previous one ends)",
            ))
        }
    };
    let cells = &cells[..];
    if snodes[0] == snodes[snodes.len() - 1] {
        return Err(unsupported(set, "closed surfaces are not supported"));
    }
    let pts: Vec<[f64; 2]> = snodes
        .iter()
        .map(|&n| [mesh.node(n)[0], mesh.node(n)[1]])
        .collect();
    let exact = detect_curve(set, &pts, smooth)?;
    let n_el = cells.len();
    let mut params: Vec<f64> = exact.pos.iter().map(|&s| exact.param(s)).collect();
    (params[0], params[n_el]) = (0.0, 1.0);
    let n_mesh = mesh.n_nodes();
    let mut extra: Vec<f64> = Vec::new();
    let mut push = |x: &[f64]| -> u32 {
        extra.extend_from_slice(&x[..2]);
        (n_mesh + extra.len() / 2 - 1) as u32
    };
    let bulk = |c: usize| [mesh.cell(c)[2], mesh.cell(c)[3]];
    let mut out_cells = Vec::with_capacity(n_el);
    let (mut replaced, mut pseudo) = (Vec::new(), Vec::new());
    let curve_out;
    let mut deviation = None;
    match family {
        ElementFamily::Q1N { p, t } => {
            let (p, t) = (p as usize, t as usize);
            let base = &exact.curve;
            if smooth && p < 2 && base.knots.n_elements() > 1 {
                return Err(unsupported(
                    set,
                    "enriched_geometry = \"smooth\" needs an order p >= 2 (Q1N1 is C^0)",
                ));
            }
            if !smooth && p < base.degree() {
                return Err(unsupported(
                    set,
                    format!(
                        "Q1N{p} cannot represent this curve exactly (its exact NURBS has order {})",
                        base.degree()
                    ),
                ));
            }
            let c = if smooth && base.knots.n_elements() > 1 {
                let (fit, d) = smooth_curve(&exact, p).map_err(geo)?;
                deviation = Some(d);
                fit.elevate(t).map_err(geo)?
            } else {
                let e = base.elevate(p - base.degree()).map_err(geo)?;
                // the base joints are nodes up to round-off: they are element boundaries already
                let knots = e.knots.unique_with_multiplicity();
                let x: Vec<f64> = params[1..n_el]
                    .iter()
                    .copied()
                    .filter(|&u| knots.iter().all(|&(k, _)| (k - u).abs() > 1e-12))
                    .collect();
                e.insert_knots(&x).map_err(geo)?.elevate(t).map_err(geo)?
            };
            if c.knots.n_elements() != n_el {
                return Err(faces_err(
                    set,
                    format!(
                        "refined curve has {} elements for {n_el} faces",
                        c.knots.n_elements()
                    ),
                ));
            }
            let data = EnrichedElementData::elements_from_curve(&c)
                .map_err(|e| faces_err(set, e.to_string()))?;
            let n_ctrl = c.n_ctrl();
            let ids: Vec<u32> = (0..n_ctrl)
                .map(|a| match a {
                    0 => snodes[0],
                    a if a + 1 == n_ctrl => snodes[n_el],
                    a => push(&c.ctrl[2 * a..2 * a + 2]),
                })
                .collect();
            replaced.extend_from_slice(&snodes[1..n_el]);
            for (i, d) in data.into_iter().enumerate() {
                let mut nodes: Vec<u32> = d.ctrl_ids.iter().map(|&a| ids[a]).collect();
                let n_position = nodes.len();
                nodes.extend(bulk(cells[i]));
                out_cells.push(EnrichedCell {
                    cell: cells[i],
                    nodes,
                    n_position,
                    corners: vec![snodes[i], snodes[i + 1]],
                    basis: EnrichedBasis::Nurbs(d),
                });
            }
            curve_out = c;
        }
        ElementFamily::Q1C2 => {
            for i in 0..n_el {
                let u = exact.param(0.5 * (exact.pos[i] + exact.pos[i + 1]));
                let mid = push(&exact.curve.point(u));
                let [b0, b1] = bulk(cells[i]);
                out_cells.push(EnrichedCell {
                    cell: cells[i],
                    nodes: vec![snodes[i], mid, snodes[i + 1], b0, b1],
                    n_position: 3,
                    corners: vec![snodes[i], snodes[i + 1]],
                    basis: EnrichedBasis::C2,
                });
            }
            curve_out = exact.curve.clone();
        }
        ElementFamily::Q1CH => {
            let tangents: Vec<u32> = params
                .iter()
                .map(|&u| {
                    let (_, d) = exact.curve.eval(u);
                    let l = (d[0] * d[0] + d[1] * d[1]).sqrt();
                    push(&[d[0] / l, d[1] / l])
                })
                .collect();
            pseudo.extend_from_slice(&tangents);
            for i in 0..n_el {
                let h = half_length(&exact.curve, params[i], params[i + 1])
                    .map_err(|e| faces_err(set, e.to_string()))?;
                let [b0, b1] = bulk(cells[i]);
                out_cells.push(EnrichedCell {
                    cell: cells[i],
                    nodes: vec![
                        snodes[i],
                        snodes[i + 1],
                        tangents[i],
                        tangents[i + 1],
                        b0,
                        b1,
                    ],
                    n_position: 2,
                    corners: vec![snodes[i], snodes[i + 1]],
                    basis: EnrichedBasis::Hermite { h },
                });
            }
            curve_out = exact.curve.clone();
        }
        other => {
            return Err(unsupported(
                set,
                format!("element family {other} has no enriched layer"),
            ))
        }
    }
    finish(
        mesh,
        set,
        extra,
        out_cells,
        replaced,
        pseudo,
        ExactSurface::Curve(curve_out),
    )
    .map(|e| Enrichment {
        smooth_deviation: deviation,
        interpolated_reference: exact.free,
        ..e
    })
}

/// Points per element and direction at which a fit's distance from the exact surface is measured.
const DEVIATION_SAMPLES: usize = 16;

/// The smooth fit of order `p` of a 2D exact curve (see [`crate::geometry::fit`]): parametrised by
/// the position along the curve (arc length for a line, angle for an arc), one span per face, and
/// its largest distance from the exact curve.
fn smooth_curve(exact: &Curve2d, p: usize) -> Result<(NurbsCurve, f64), GeometryError> {
    let n_el = exact.pos.len() - 1;
    let total = exact.pos[n_el];
    let breaks: Vec<f64> = exact.pos[1..n_el].iter().map(|s| s / total).collect();
    let at = |s: f64| exact.param(s * total);
    let fit = fit_curve(p, &breaks, 2, &|s| exact.curve.point(at(s)))?;
    let mut dev: f64 = 0.0;
    for i in 0..n_el {
        let (a, b) = (exact.pos[i] / total, exact.pos[i + 1] / total);
        for k in 0..=DEVIATION_SAMPLES {
            let s = a + (b - a) * k as f64 / DEVIATION_SAMPLES as f64;
            dev = dev.max(distance_to_curve(&exact.curve, fit.point(s), at(s)));
        }
    }
    Ok((fit, dev))
}

/// Assembles the [`Enrichment`] and the display-node interpolation.
#[allow(non_snake_case)]
fn finish(
    mesh: &Mesh,
    set: &str,
    extra_coords: Vec<f64>,
    cells: Vec<EnrichedCell>,
    mut replaced: Vec<u32>,
    mut pseudo_nodes: Vec<u32>,
    exact: ExactSurface,
) -> Result<Enrichment, EnrichError> {
    let mut cell_index = vec![None; mesh.n_cells()];
    for (i, c) in cells.iter().enumerate() {
        cell_index[c.cell] = Some(i);
    }
    replaced.sort_unstable();
    replaced.dedup();
    pseudo_nodes.sort_unstable();
    let mut display: BTreeMap<u32, Vec<(u32, f64)>> = BTreeMap::new();
    for c in &cells {
        let n = c.n_nodes();
        let (mut N, mut dN) = (vec![0.0; n], vec![0.0; 3 * n]);
        for (k, &corner) in c.corners.iter().enumerate() {
            if replaced.binary_search(&corner).is_ok() && !display.contains_key(&corner) {
                c.shape(&c.corner_reference(k), &mut N, &mut dN);
                let w = c
                    .nodes
                    .iter()
                    .zip(&N)
                    .filter(|(_, w)| w.abs() > 0.0)
                    .map(|(&a, &w)| (a, w))
                    .collect();
                display.insert(corner, w);
            }
        }
    }
    if display.len() != replaced.len() {
        return Err(faces_err(
            set,
            "a replaced surface node is no element corner",
        ));
    }
    Ok(Enrichment {
        face_set: set.to_string(),
        n_mesh_nodes: mesh.n_nodes(),
        extra_coords,
        cells,
        cell_index,
        replaced,
        pseudo_nodes,
        display: display.into_iter().collect(),
        exact,
        smooth_deviation: None,
        interpolated_reference: false,
        tied: Vec::new(),
        tied_index: vec![None; mesh.n_cells()],
    })
}

fn cluster(values: &mut Vec<f64>, tol: f64) {
    values.sort_by(f64::total_cmp);
    values.dedup_by(|a, b| (*a - *b).abs() <= tol);
}

/// A structured grid of contact faces on an exact surface: what the 3D layer is built from.
struct FaceGrid {
    /// The exact geometry at its lowest order (a bilinear plane, the biquadratic hemisphere).
    base: NurbsSurface,
    /// Faces per direction.
    nu: usize,
    nv: usize,
    /// Parameters of the interior grid lines: [nu - 1], [nv - 1].
    xu: Vec<f64>,
    xv: Vec<f64>,
    /// Cell of face `(i, j)`: [nv][nu].
    face_of: Vec<usize>,
    /// Mesh node of grid point `(i, j)`: [nv + 1][nu + 1]; coincident points share one node.
    node_of: Vec<u32>,
    /// Absolute tolerance for "the same point".
    tol: f64,
    /// No exact geometry: `base` is the bicubic interpolant of the nodes ([`free_grid`]).
    free: bool,
}

fn build_3d(
    mesh: &mut Mesh,
    set: &str,
    cells: &[usize],
    family: ElementFamily,
    smooth: bool,
) -> Result<Enrichment, EnrichError> {
    let ElementFamily::Q1N { p, t } = family else {
        return Err(unsupported(set, format!("{family} is 2D only")));
    };
    for &c in cells {
        if mesh.cell_kind[c] != CellKind::Hex8 {
            return Err(faces_err(set, format!("cell {c} is not a Hex8")));
        }
    }
    let grid =
        match mesh.exact_surfaces.get(set) {
            Some(patch) => exact_grid(mesh, set, cells, patch)?,
            None => match plane_grid(mesh, set, cells)? {
                Some(g) => g,
                None if smooth => free_grid(mesh, set, cells)?,
                None => return Err(unsupported(
                    set,
                    "the surface nodes are not on a plane (within 1e-10) and the mesh generator \
                     gave no exact surface (e.g. `hemisphere_nurbs`); a curved face set on a \
                     structured grid of faces can be enriched with enriched_geometry = \
                     \"smooth\" (a smooth fit through its nodes)",
                )),
            },
        };
    build_3d_on_grid(mesh, set, p as usize, t as usize, grid, smooth)
}

/// The face grid of a generator-provided exact surface, checked against the mesh: face set entry
/// `i + nu j` must be the cell whose face 0 has the grid corners of face `(i, j)`, and every grid
/// node must lie on the surface at its parameters.
fn exact_grid(
    mesh: &Mesh,
    set: &str,
    cells: &[usize],
    patch: &ExactPatch,
) -> Result<FaceGrid, EnrichError> {
    let (nu, nv) = patch.n_faces();
    if nu * nv != cells.len() || patch.nodes.len() != (nu + 1) * (nv + 1) {
        return Err(faces_err(
            set,
            format!(
                "the exact surface has {nu} x {nv} faces but the set has {}",
                cells.len()
            ),
        ));
    }
    let g = |i: usize, j: usize| patch.nodes[i + (nu + 1) * j];
    for (e, &c) in cells.iter().enumerate() {
        let (i, j) = (e % nu, e / nu);
        if mesh.cell(c)[..4] != [g(i, j), g(i + 1, j), g(i + 1, j + 1), g(i, j + 1)] {
            return Err(faces_err(
                set,
                format!("cell {c} is not face ({i}, {j}) of the exact surface's grid"),
            ));
        }
    }
    let o = mesh.node(patch.nodes[0]).to_vec();
    let size = patch
        .nodes
        .iter()
        .map(|&n| dist(mesh.node(n), &o))
        .fold(0.0, f64::max);
    let tol = GEOMETRY_TOL * size.max(1.0);
    for j in 0..=nv {
        for i in 0..=nu {
            let x = patch.surface.point(patch.params_u[i], patch.params_v[j]);
            let d = dist(mesh.node(g(i, j)), &x);
            if d > tol {
                return Err(unsupported(
                    set,
                    format!(
                        "node {} is {d:e} away from the exact surface at its grid point ({i}, {j})",
                        g(i, j)
                    ),
                ));
            }
        }
    }
    Ok(FaceGrid {
        base: patch.surface.clone(),
        nu,
        nv,
        xu: patch.params_u[1..nu].to_vec(),
        xv: patch.params_v[1..nv].to_vec(),
        face_of: cells.to_vec(),
        node_of: patch.nodes.clone(),
        tol,
        free: false,
    })
}

/// The face grid of a planar rectangular patch, recognised from the nodes; `None` when the nodes
/// are not on a plane.
fn plane_grid(mesh: &Mesh, set: &str, cells: &[usize]) -> Result<Option<FaceGrid>, EnrichError> {
    let geo = |source| EnrichError::Geometry {
        set: set.to_string(),
        source,
    };
    let x = |n: u32| -> [f64; 3] {
        let v = mesh.node(n);
        [v[0], v[1], v[2]]
    };
    let sub = |a: [f64; 3], b: [f64; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let norm = |a: [f64; 3]| {
        let l = dot(a, a).sqrt();
        [a[0] / l, a[1] / l, a[2] / l]
    };
    // frame of the first face: xi along node 0 -> 1, eta along node 0 -> 3
    let c0 = mesh.cell(cells[0]);
    let o = x(c0[0]);
    let e1 = norm(sub(x(c0[1]), o));
    let v = sub(x(c0[3]), o);
    let d = dot(v, e1);
    let e2 = norm([v[0] - d * e1[0], v[1] - d * e1[1], v[2] - d * e1[2]]);
    let nrm = [
        e1[1] * e2[2] - e1[2] * e2[1],
        e1[2] * e2[0] - e1[0] * e2[2],
        e1[0] * e2[1] - e1[1] * e2[0],
    ];
    let surf: BTreeSet<u32> = cells
        .iter()
        .flat_map(|&c| mesh.cell(c)[..4].to_vec())
        .collect();
    let size = surf
        .iter()
        .map(|&n| dot(sub(x(n), o), sub(x(n), o)).sqrt())
        .fold(0.0, f64::max);
    let tol = GEOMETRY_TOL * size.max(1.0);
    if surf.iter().any(|&n| dot(sub(x(n), o), nrm).abs() > tol) {
        return Ok(None);
    }
    let st = |n: u32| (dot(sub(x(n), o), e1), dot(sub(x(n), o), e2));
    let (mut su, mut sv): (Vec<f64>, Vec<f64>) = surf.iter().map(|&n| st(n)).unzip();
    cluster(&mut su, tol);
    cluster(&mut sv, tol);
    let (nu, nv) = (su.len() - 1, sv.len() - 1);
    let index = |s: f64, vals: &[f64]| vals.iter().position(|&q| (q - s).abs() <= tol);
    let grid_err = || {
        unsupported(
            set,
            "the faces do not form a structured rectangular grid (only rectangular planar \
             patches are supported in 3D)",
        )
    };
    if nu * nv != cells.len() {
        return Err(grid_err());
    }
    // face (i, j) -> cell, and grid node (i, j) -> mesh node
    let mut face_of = vec![usize::MAX; nu * nv];
    let mut node_of = vec![u32::MAX; (nu + 1) * (nv + 1)];
    for &c in cells {
        let cn = mesh.cell(c);
        let ij: Vec<(usize, usize)> = cn[..4]
            .iter()
            .map(|&n| {
                let (s, tt) = st(n);
                Ok((
                    index(s, &su).ok_or_else(grid_err)?,
                    index(tt, &sv).ok_or_else(grid_err)?,
                ))
            })
            .collect::<Result<_, EnrichError>>()?;
        let (i, j) = ij[0];
        if i >= nu
            || j >= nv
            || ij[1] != (i + 1, j)
            || ij[2] != (i + 1, j + 1)
            || ij[3] != (i, j + 1)
        {
            return Err(grid_err());
        }
        if face_of[i + nu * j] != usize::MAX {
            return Err(grid_err());
        }
        face_of[i + nu * j] = c;
        for (k, &(a, b)) in ij.iter().enumerate() {
            node_of[a + (nu + 1) * b] = cn[k];
        }
    }
    let (lu, lv) = (su[nu] - su[0], sv[nv] - sv[0]);
    let origin = [
        o[0] + su[0] * e1[0] + sv[0] * e2[0],
        o[1] + su[0] * e1[1] + sv[0] * e2[1],
        o[2] + su[0] * e1[2] + sv[0] * e2[2],
    ];
    let base = plane_patch(origin, e1.map(|c| c * lu), e2.map(|c| c * lv)).map_err(geo)?;
    Ok(Some(FaceGrid {
        base,
        nu,
        nv,
        xu: su[1..nu].iter().map(|s| (s - su[0]) / lu).collect(),
        xv: sv[1..nv].iter().map(|s| (s - sv[0]) / lv).collect(),
        face_of,
        node_of,
        tol,
        free: false,
    }))
}

/// The face grid of a curved face set without known geometry (`enriched_geometry = "smooth"`
/// only), recovered from the faces' connectivity, and the bicubic interpolant of its nodes as the
/// reference surface the layer is fitted to.
///
/// Supported topology: a structured grid of `nu x nv` quadrilateral faces (`nu, nv >= 2`) forming
/// one open patch: exactly four nodes lie in one face only (the corners), every boundary node in
/// two, every interior node in four, and walking across shared edges from a corner reaches every
/// face at a distinct grid position. Closed surfaces (a full cylinder), collapsed edges and
/// unstructured face sets are reported. Each cell is turned about its surface face so that its
/// local node 0 is the face's grid corner `(i, j)` (see [`Mesh::rotate_about_face0`]).
///
/// The interpolant: grid parameters by chord length averaged over the rows (columns), each row
/// interpolated by the C^2 cubic of [`interpolate_cubic`], then each column of the rows' control
/// points: a tensor-product bicubic B-spline through every node.
fn free_grid(mesh: &mut Mesh, set: &str, cells: &[usize]) -> Result<FaceGrid, EnrichError> {
    let geo = |source| EnrichError::Geometry {
        set: set.to_string(),
        source,
    };
    let topo = |msg: String| {
        unsupported(
            set,
            format!(
                "no exact geometry known and {msg}: a smooth fit needs a structured grid of \
                 faces (one open four-sided patch, four faces at every interior node)"
            ),
        )
    };
    let quad = |mesh: &Mesh, c: usize| -> [u32; 4] {
        let n = mesh.cell(c);
        [n[0], n[1], n[2], n[3]]
    };
    let mut valence: BTreeMap<u32, usize> = BTreeMap::new();
    let mut edges: BTreeMap<(u32, u32), Vec<usize>> = BTreeMap::new();
    for (f, &c) in cells.iter().enumerate() {
        let q = quad(mesh, c);
        for k in 0..4 {
            *valence.entry(q[k]).or_default() += 1;
            let (a, b) = (q[k], q[(k + 1) % 4]);
            edges.entry((a.min(b), a.max(b))).or_default().push(f);
        }
    }
    let corners: Vec<u32> = valence
        .iter()
        .filter(|&(_, &v)| v == 1)
        .map(|(&n, _)| n)
        .collect();
    if corners.len() != 4 {
        return Err(topo(format!(
            "{} of its nodes lie in one face only (a four-sided patch has 4 corners)",
            corners.len()
        )));
    }
    if let Some((n, v)) = valence.iter().find(|&(_, &v)| v > 4) {
        return Err(topo(format!("node {n} lies in {v} faces")));
    }
    let other = |f: usize, a: u32, b: u32| -> Option<usize> {
        edges[&(a.min(b), a.max(b))]
            .iter()
            .copied()
            .find(|&g| g != f)
    };
    // grid node (i, j) -> mesh node, face (i, j) -> (face index, quarter turns), faces placed
    #[derive(Default)]
    struct Walk {
        node_at: BTreeMap<(usize, usize), u32>,
        placed: BTreeMap<(usize, usize), (usize, usize)>,
        used: BTreeSet<usize>,
    }
    let mut w = Walk::default();
    let place =
        |w: &mut Walk, f: usize, i: usize, j: usize, corner: u32| -> Result<(), EnrichError> {
            let q = quad(mesh, cells[f]);
            let k = q
                .iter()
                .position(|&n| n == corner)
                .ok_or_else(|| topo(format!("cell {} does not continue the grid", cells[f])))?;
            if !w.used.insert(f) {
                return Err(topo(format!(
                    "cell {} is reached twice (a closed surface?)",
                    cells[f]
                )));
            }
            for (d, (di, dj)) in [(0, 0), (1, 0), (1, 1), (0, 1)].into_iter().enumerate() {
                let n = q[(k + d) % 4];
                match w.node_at.insert((i + di, j + dj), n) {
                    Some(m) if m != n => {
                        return Err(topo(format!(
                            "cell {} does not fit the grid at ({}, {})",
                            cells[f],
                            i + di,
                            j + dj
                        )))
                    }
                    _ => {}
                }
            }
            w.placed.insert((i, j), (f, k));
            Ok(())
        };
    let c0 = corners[0];
    let f0 = (0..cells.len())
        .find(|&f| quad(mesh, cells[f]).contains(&c0))
        .ok_or_else(|| topo("no face holds a corner".into()))?;
    place(&mut w, f0, 0, 0, c0)?;
    // first row along u, then each next row from the row below
    let mut nu = 1;
    loop {
        let (a, b) = (w.node_at[&(nu, 0)], w.node_at[&(nu, 1)]);
        let f = w.placed[&(nu - 1, 0)].0;
        match other(f, a, b) {
            Some(g) => {
                place(&mut w, g, nu, 0, a)?;
                nu += 1;
            }
            None => break,
        }
    }
    let mut nv = 1;
    loop {
        let mut found = 0;
        for i in 0..nu {
            let (a, b) = (w.node_at[&(i, nv)], w.node_at[&(i + 1, nv)]);
            let f = w.placed[&(i, nv - 1)].0;
            if let Some(g) = other(f, a, b) {
                place(&mut w, g, i, nv, a)?;
                found += 1;
            }
        }
        if found == 0 {
            break;
        }
        if found != nu {
            return Err(topo(format!("row {nv} of the grid is incomplete")));
        }
        nv += 1;
    }
    if nu * nv != cells.len() {
        return Err(topo(format!(
            "a grid of {nu} x {nv} faces from a corner, but the set has {} faces",
            cells.len()
        )));
    }
    if nu < 2 || nv < 2 {
        return Err(topo(format!(
            "a grid of {nu} x {nv} faces (the cubic interpolant needs at least 2 per direction)"
        )));
    }
    let mut seen = BTreeSet::new();
    if let Some(n) = w.node_at.values().find(|&&n| !seen.insert(n)) {
        return Err(topo(format!(
            "node {n} sits at two grid points (a closed surface?)"
        )));
    }
    let mut face_of = vec![0usize; nu * nv];
    for (&(i, j), &(f, k)) in &w.placed {
        mesh.rotate_about_face0(cells[f], k)
            .map_err(|e| faces_err(set, e.to_string()))?;
        face_of[i + nu * j] = cells[f];
    }
    let node_of: Vec<u32> = (0..=nv)
        .flat_map(|j| (0..=nu).map(move |i| (i, j)))
        .map(|ij| w.node_at[&ij])
        .collect();
    let x = |i: usize, j: usize| -> [f64; 3] {
        let v = mesh.node(node_of[i + (nu + 1) * j]);
        [v[0], v[1], v[2]]
    };
    // chord-length parameters averaged over the rows (columns)
    let params = |n: usize, m: usize, at: &dyn Fn(usize, usize) -> [f64; 3]| -> Vec<f64> {
        let mut t = vec![0.0; n + 1];
        for r in 0..=m {
            let mut cum = vec![0.0];
            for k in 0..n {
                cum.push(cum[k] + dist(&at(k, r), &at(k + 1, r)));
            }
            for k in 0..=n {
                t[k] += cum[k] / cum[n] / (m + 1) as f64;
            }
        }
        (t[0], t[n]) = (0.0, 1.0);
        t
    };
    let tu = params(nu, nv, &|k, r| x(k, r));
    let tv = params(nv, nu, &|k, r| x(r, k));
    if tu.windows(2).chain(tv.windows(2)).any(|w| w[1] <= w[0]) {
        return Err(faces_err(set, "faces of zero length along the grid"));
    }
    let rows: Vec<NurbsCurve> = (0..=nv)
        .map(|j| {
            let q: Vec<[f64; 3]> = (0..=nu).map(|i| x(i, j)).collect();
            interpolate_cubic(&q, &tu, 3)
        })
        .collect::<Result<_, _>>()
        .map_err(geo)?;
    let ncu = rows[0].n_ctrl();
    let mut ctrl = Vec::new();
    let mut kv = None;
    let mut cols = Vec::with_capacity(ncu);
    for a in 0..ncu {
        let q: Vec<[f64; 3]> = rows
            .iter()
            .map(|r| [r.ctrl[3 * a], r.ctrl[3 * a + 1], r.ctrl[3 * a + 2]])
            .collect();
        let c = interpolate_cubic(&q, &tv, 3).map_err(geo)?;
        kv.get_or_insert_with(|| c.knots.clone());
        cols.push(c);
    }
    let ncv = cols[0].n_ctrl();
    for b in 0..ncv {
        for c in &cols {
            ctrl.extend_from_slice(&c.ctrl[3 * b..3 * b + 3]);
        }
    }
    let ku = rows[0].knots.clone();
    let kv = kv.ok_or_else(|| faces_err(set, "empty grid"))?;
    let base = NurbsSurface::new(ku, kv, ctrl, vec![1.0; ncu * ncv]).map_err(geo)?;
    let size = node_of
        .iter()
        .map(|&n| dist(mesh.node(n), mesh.node(node_of[0])))
        .fold(0.0, f64::max);
    Ok(FaceGrid {
        base,
        nu,
        nv,
        xu: tu[1..nu].to_vec(),
        xv: tv[1..nv].to_vec(),
        face_of,
        node_of,
        tol: GEOMETRY_TOL * size.max(1.0),
        free: true,
    })
}

/// Refines the grid's exact surface to Q1Np.t (section 3.3: elevate to `p`, insert the grid lines
/// not yet knots, so each face is one element of continuity C^{p-1} except at the base's own C^0
/// joints, then elevate `t`) and numbers its control points: the four patch corners are the mesh's
/// corner nodes (they interpolate), and control points that coincide on the patch boundary (a
/// collapsed edge of a degenerate patch) are one node, like the mesh's merged nodes there, so the
/// surface cannot tear; every other grid node becomes a display node.
fn build_3d_on_grid(
    mesh: &Mesh,
    set: &str,
    p: usize,
    t: usize,
    g: FaceGrid,
    smooth: bool,
) -> Result<Enrichment, EnrichError> {
    let geo = |source| EnrichError::Geometry {
        set: set.to_string(),
        source,
    };
    let (nu, nv) = (g.nu, g.nv);
    let (du, dv) = (g.base.knots_u.degree(), g.base.knots_v.degree());
    let fit = smooth && (g.base.knots_u.n_elements() > 1 || g.base.knots_v.n_elements() > 1);
    if fit && p < 2 {
        return Err(unsupported(
            set,
            "enriched_geometry = \"smooth\" needs an order p >= 2 (Q1N1 is C^0)",
        ));
    }
    if !fit && p < du.max(dv) {
        return Err(unsupported(
            set,
            format!(
                "Q1N{p} cannot represent this surface exactly (its exact NURBS has order {})",
                du.max(dv)
            ),
        ));
    }
    let new_knots = |x: &[f64], kv: &KnotVector| -> Vec<f64> {
        let knots = kv.unique_with_multiplicity();
        x.iter()
            .copied()
            .filter(|&u| knots.iter().all(|&(k, _)| (k - u).abs() > 1e-12))
            .collect()
    };
    let mut deviation = None;
    let s = if fit {
        let (fit, d) = smooth_surface(&g, p).map_err(geo)?;
        deviation = Some(d);
        fit.elevate(Direction::U, t)
            .and_then(|s| s.elevate(Direction::V, t))
            .map_err(geo)?
    } else {
        let e = g
            .base
            .elevate(Direction::U, p - du)
            .and_then(|s| s.elevate(Direction::V, p - dv))
            .map_err(geo)?;
        let (xu, xv) = (new_knots(&g.xu, &e.knots_u), new_knots(&g.xv, &e.knots_v));
        e.insert_knots(Direction::U, &xu)
            .and_then(|s| s.insert_knots(Direction::V, &xv))
            .and_then(|s| s.elevate(Direction::U, t))
            .and_then(|s| s.elevate(Direction::V, t))
            .map_err(geo)?
    };
    if s.knots_u.n_elements() != nu || s.knots_v.n_elements() != nv {
        return Err(faces_err(
            set,
            format!(
                "refined surface has {} x {} elements for {nu} x {nv} faces",
                s.knots_u.n_elements(),
                s.knots_v.n_elements()
            ),
        ));
    }
    let data = EnrichedElementData::elements_from_surface(&s)
        .map_err(|e| faces_err(set, e.to_string()))?;
    let (ncu, ncv) = s.n_ctrl();
    let n_mesh = mesh.n_nodes();
    let node_of = &g.node_of;
    let corner_nodes = [
        node_of[0],
        node_of[nu],
        node_of[(nu + 1) * nv],
        node_of[nu + (nu + 1) * nv],
    ];
    let ctrl = |a: usize| -> &[f64] { &s.ctrl[3 * a..3 * a + 3] };
    // boundary control points already numbered: (coordinates, node)
    let mut boundary: Vec<([f64; 3], u32)> = [
        (0, corner_nodes[0]),
        (ncu - 1, corner_nodes[1]),
        (ncu * (ncv - 1), corner_nodes[2]),
        (ncu * ncv - 1, corner_nodes[3]),
    ]
    .iter()
    .map(|&(a, n)| ([ctrl(a)[0], ctrl(a)[1], ctrl(a)[2]], n))
    .collect();
    let mut extra = Vec::new();
    let mut ids = Vec::with_capacity(ncu * ncv);
    for j in 0..ncv {
        for i in 0..ncu {
            let a = i + ncu * j;
            let on_boundary = i == 0 || j == 0 || i + 1 == ncu || j + 1 == ncv;
            let x = ctrl(a);
            let same = on_boundary
                .then(|| boundary.iter().find(|(y, _)| dist(x, y) <= g.tol))
                .flatten()
                .map(|&(_, n)| n);
            let id = same.unwrap_or_else(|| {
                extra.extend_from_slice(x);
                (n_mesh + extra.len() / 3 - 1) as u32
            });
            if on_boundary && same.is_none() {
                boundary.push(([x[0], x[1], x[2]], id));
            }
            ids.push(id);
        }
    }
    let corners_kept: BTreeSet<u32> = corner_nodes.into_iter().collect();
    let replaced: Vec<u32> = node_of
        .iter()
        .copied()
        .filter(|n| !corners_kept.contains(n))
        .collect();
    let mut out_cells = Vec::with_capacity(nu * nv);
    for (e, d) in data.into_iter().enumerate() {
        let c = g.face_of[e];
        let cn = mesh.cell(c);
        let mut nodes: Vec<u32> = d.ctrl_ids.iter().map(|&a| ids[a]).collect();
        let n_position = nodes.len();
        nodes.extend_from_slice(&cn[4..8]);
        out_cells.push(EnrichedCell {
            cell: c,
            nodes,
            n_position,
            corners: cn[..4].to_vec(),
            basis: EnrichedBasis::Nurbs(d),
        });
    }
    finish(
        mesh,
        set,
        extra,
        out_cells,
        replaced,
        Vec::new(),
        ExactSurface::Surface(s),
    )
    .map(|e| Enrichment {
        smooth_deviation: deviation,
        interpolated_reference: g.free,
        ..e
    })
}

/// The smooth tensor-product fit of order `p` of the grid's exact surface (see
/// [`crate::geometry::fit`]), one span per face, and its largest distance from the exact surface.
/// Each direction is parametrised by arc length along the surface's middle iso-line (for the
/// hemisphere: the angles of latitude and rotation, in which the sphere is analytic); the corners
/// are interpolated and a collapsed edge (the hemisphere's rim points) stays one point.
fn smooth_surface(g: &FaceGrid, p: usize) -> Result<(NurbsSurface, f64), GeometryError> {
    let base = &g.base;
    let interior = |kv: &KnotVector| -> Vec<f64> {
        let u = kv.unique_with_multiplicity();
        u[1..u.len() - 1].iter().map(|k| k.0).collect()
    };
    let norm = |a: [f64; 3]| (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
    let speed_u = |u: f64| norm(base.eval(u, 0.5).1);
    let speed_v = |v: f64| norm(base.eval(0.5, v).2);
    let au = ArcLength::new(&speed_u, &interior(&base.knots_u))?;
    let av = ArcLength::new(&speed_v, &interior(&base.knots_v))?;
    let bu: Vec<f64> = g.xu.iter().map(|&u| au.length_to(u) / au.total()).collect();
    let bv: Vec<f64> = g.xv.iter().map(|&v| av.length_to(v) / av.total()).collect();
    let fit = fit_surface(
        p,
        &bu,
        &bv,
        &|s| au.param_at(s),
        &|t| av.param_at(t),
        &|u, v| base.point(u, v),
    )?;
    let samples = |b: &[f64]| -> Vec<f64> {
        let mut e = vec![0.0];
        e.extend_from_slice(b);
        e.push(1.0);
        let mut out = vec![0.0];
        for w in e.windows(2) {
            out.extend(
                (1..=DEVIATION_SAMPLES)
                    .map(|k| w[0] + (w[1] - w[0]) * k as f64 / DEVIATION_SAMPLES as f64),
            );
        }
        out
    };
    let (su, sv) = (samples(&bu), samples(&bv));
    let (uu, vv): (Vec<f64>, Vec<f64>) = (
        su.iter().map(|&s| au.param_at(s)).collect(),
        sv.iter().map(|&t| av.param_at(t)).collect(),
    );
    let mut dev: f64 = 0.0;
    for (j, &t) in sv.iter().enumerate() {
        for (i, &s) in su.iter().enumerate() {
            dev = dev.max(distance_to_surface(base, fit.point(s, t), uu[i], vv[j]));
        }
    }
    Ok((fit, dev))
}
