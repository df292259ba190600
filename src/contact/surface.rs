//! Contact surfaces as plain data: per surface element its face basis (linear, NURBS after Bezier
//! extraction, Lagrange or Hermite; `crate::contact::basis`), its global nodes, its orientation and
//! its neighbours across each side, built once from a body's face set and its enriched layer.
//!
//! Sides and their coordinates: 2D side 0 is `xi = -1`, side 1 is `xi = +1`; 3D side 0 is
//! `eta = -1` (corners 0 -> 1), 1 is `xi = +1` (1 -> 2), 2 is `eta = +1` (2 -> 3), 3 is `xi = -1`
//! (3 -> 0), with corners at (xi, eta) = (-1,-1), (1,-1), (1,1), (-1,1). A point leaving an element
//! across a side enters the neighbour across the same linear-parent edge (matched by corner nodes,
//! so C0 joints and element-size changes are crossed as well as smooth joints).
#![allow(clippy::needless_range_loop)]

use crate::contact::basis::FaceBasis;
use crate::fem::enriched::EnrichedBasis;
use crate::mesh::Mesh;

/// Largest number of nodes of one surface element (Q1N4.4 in 3D: 9 x 9).
pub const MAX_FACE_NODES: usize = 81;

/// One element of a contact surface.
#[derive(Debug, Clone, PartialEq)]
pub struct SurfaceElement {
    /// Interpolation of the face.
    pub basis: FaceBasis,
    /// Global node ids in the basis' order. [n_nodes]
    pub nodes: Vec<u32>,
    /// Global cell id of the bulk element the face belongs to (its rank integrates this element).
    pub cell: usize,
    /// +1 or -1: the outward normal is `sign` times the raw normal (2D `(x_xi.y, -x_xi.x)`, 3D
    /// `x_xi x x_eta`), fixed in the reference configuration.
    pub sign: f64,
    /// Linear-parent corner nodes (global): 2 in 2D, 4 in 3D, in side order.
    pub corners: Vec<u32>,
    /// Neighbour across each side: (element, its side, whether the shared edge runs the other way
    /// there). [2] in 2D, [4] in 3D.
    pub neighbours: Vec<Option<(u32, u8, bool)>>,
}

/// A contact surface `body.face_set`.
#[derive(Debug, Clone, PartialEq)]
pub struct ContactSurface {
    /// `body.face_set`.
    pub name: String,
    /// Index of the body in the model.
    pub body: usize,
    /// Spatial dimension.
    pub dim: usize,
    /// The elements in face-set order.
    pub elements: Vec<SurfaceElement>,
    /// Mean element edge length in the reference configuration.
    pub h: f64,
}

/// Why a contact surface cannot be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{0}")]
pub struct SurfaceError(pub String);

/// One cell of a body's enriched layer, as a surface element takes it.
#[derive(Debug, Clone, Copy)]
pub struct LayerCell<'a> {
    /// Body-local id of its linear parent cell.
    pub cell: usize,
    /// Body-local element nodes, the face's nodes first (the face basis takes the leading ones).
    pub nodes: &'a [u32],
    /// The linear parent's surface corners (body-local), in reference order: 2D xi = -1, +1;
    /// 3D (xi,eta) = (-1,-1), (1,-1), (1,1), (-1,1).
    pub corners: &'a [u32],
    /// Reference basis of the enriched element.
    pub basis: &'a EnrichedBasis,
}

/// A body's enriched layer, as contact surfaces take it.
#[derive(Debug, Clone)]
pub struct EnrichedLayer<'a> {
    /// The face set the layer was built on.
    pub face_set: &'a str,
    /// Its cells in face-set order.
    pub cells: Vec<LayerCell<'a>>,
    /// Index into `cells` of each mesh cell, `None` for linear cells. [n_cells]
    pub cell_index: &'a [Option<usize>],
}

/// The body a contact surface is built on: its mesh and face sets, where it starts in the global
/// numbering, and its enriched layer.
#[derive(Debug, Clone)]
pub struct SurfaceBody<'a> {
    /// Index of the body (the surface keeps it, see [`ContactSurface::body`]).
    pub index: usize,
    /// Name of the body.
    pub name: &'a str,
    /// Its mesh (body-local numbering): face sets and linear parent cells.
    pub mesh: &'a Mesh,
    /// Global id of its node 0.
    pub node_offset: u32,
    /// Global id of its cell 0.
    pub cell_offset: usize,
    /// Its enriched layer, if any.
    pub layer: Option<EnrichedLayer<'a>>,
}

/// Number of sides of a face: 2 in 2D, 4 in 3D.
pub fn n_sides(dim: usize) -> usize {
    if dim == 2 {
        2
    } else {
        4
    }
}

/// The along-edge coordinate `t` and the outward overshoot `d >= 0` of `xi` beyond `side`.
pub fn side_coordinates(dim: usize, side: usize, xi: &[f64; 2]) -> (f64, f64) {
    if dim == 2 {
        return match side {
            0 => (0.0, -1.0 - xi[0]),
            _ => (0.0, xi[0] - 1.0),
        };
    }
    match side {
        0 => (xi[0], -1.0 - xi[1]),
        1 => (xi[1], xi[0] - 1.0),
        2 => (-xi[0], xi[1] - 1.0),
        _ => (-xi[1], -1.0 - xi[0]),
    }
}

/// The point at along-edge coordinate `t` and inward depth `d` from `side`.
pub fn side_point(dim: usize, side: usize, t: f64, d: f64) -> [f64; 2] {
    if dim == 2 {
        return match side {
            0 => [-1.0 + d, 0.0],
            _ => [1.0 - d, 0.0],
        };
    }
    match side {
        0 => [t, -1.0 + d],
        1 => [1.0 - d, t],
        2 => [-t, 1.0 - d],
        _ => [-1.0 + d, -t],
    }
}

/// Corner indices of `side` (2D: one corner).
fn side_corners(dim: usize, side: usize) -> (usize, usize) {
    if dim == 2 {
        (side, side)
    } else {
        (side, (side + 1) % 4)
    }
}

/// Point, tangents and raw normal of a surface element from its nodal positions `x` [n][dim].
/// Returns `(point, tangents [m][3], raw normal)`.
#[allow(non_snake_case)]
pub fn frame(
    el: &SurfaceElement,
    dim: usize,
    x: &[f64],
    xi: &[f64; 2],
) -> ([f64; 3], [[f64; 3]; 2], [f64; 3]) {
    let n = el.basis.n_nodes();
    let m = dim - 1;
    let (mut N, mut dN, mut ddN) = (
        [0.0; MAX_FACE_NODES],
        [0.0; 2 * MAX_FACE_NODES],
        [0.0; 4 * MAX_FACE_NODES],
    );
    el.basis.eval(&xi[..m], &mut N, &mut dN, &mut ddN);
    let mut p = [0.0; 3];
    let mut a = [[0.0; 3]; 2];
    for b in 0..n {
        for k in 0..dim {
            let xb = x[b * dim + k];
            p[k] += N[b] * xb;
            for al in 0..m {
                a[al][k] += dN[b * m + al] * xb;
            }
        }
    }
    (p, a, raw_normal(dim, &a))
}

/// Raw (unnormalised, unsigned) normal from the tangents: 2D `(a.y, -a.x)`, 3D `a1 x a2`.
pub fn raw_normal(dim: usize, a: &[[f64; 3]; 2]) -> [f64; 3] {
    if dim == 2 {
        [a[0][1], -a[0][0], 0.0]
    } else {
        [
            a[0][1] * a[1][2] - a[0][2] * a[1][1],
            a[0][2] * a[1][0] - a[0][0] * a[1][2],
            a[0][0] * a[1][1] - a[0][1] * a[1][0],
        ]
    }
}

impl ContactSurface {
    /// Builds the surface on face set `set` of body `b`, whose nodes have the reference
    /// coordinates `coords` [n_global_nodes][dim] in the global numbering. On an enriched body whose
    /// layer is on `set`, the elements carry the enriched face basis; otherwise the faces are
    /// linear (Q1C1), and a face of an enriched cell is refused.
    pub fn build(
        b: &SurfaceBody,
        set: &str,
        coords: &[f64],
    ) -> Result<ContactSurface, SurfaceError> {
        let dim = b.mesh.dim;
        let faces =
            b.mesh.face_sets.get(set).ok_or_else(|| {
                SurfaceError(format!("body `{}` has no face set `{set}`", b.name))
            })?;
        if faces.is_empty() {
            return Err(SurfaceError(format!(
                "face set `{}.{set}` is empty",
                b.name
            )));
        }
        let off = b.node_offset;
        let mut elements = Vec::with_capacity(faces.len());
        match &b.layer {
            Some(en) if en.face_set == set => {
                for ec in &en.cells {
                    let basis = FaceBasis::from(ec.basis);
                    let n = basis.n_nodes();
                    elements.push(SurfaceElement {
                        nodes: ec.nodes[..n].iter().map(|&a| a + off).collect(),
                        basis,
                        cell: b.cell_offset + ec.cell,
                        sign: 1.0,
                        corners: ec.corners.iter().map(|&a| a + off).collect(),
                        neighbours: Vec::new(),
                    });
                }
            }
            _ => {
                for &(c, f) in faces {
                    if b.layer
                        .as_ref()
                        .is_some_and(|en| en.cell_index[c as usize].is_some())
                    {
                        return Err(SurfaceError(format!(
                            "face {f} of cell {c} of `{}.{set}` belongs to an enriched element; a contact surface on an enriched body must be its `enriched_surface`",
                            b.name
                        )));
                    }
                    let nodes: Vec<u32> = b
                        .mesh
                        .face_nodes(c as usize, f)
                        .map_err(|e| SurfaceError(e.to_string()))?
                        .into_iter()
                        .map(|a| a + off)
                        .collect();
                    elements.push(SurfaceElement {
                        basis: if dim == 2 {
                            FaceBasis::Line2
                        } else {
                            FaceBasis::Quad4
                        },
                        corners: nodes.clone(),
                        nodes,
                        cell: b.cell_offset + c as usize,
                        sign: 1.0,
                        neighbours: Vec::new(),
                    });
                }
            }
        }
        let mut s = ContactSurface {
            name: format!("{}.{set}", b.name),
            body: b.index,
            dim,
            elements,
            h: 0.0,
        };
        s.orient(b, coords);
        s.connect();
        let x = coords;
        let (mut sum, mut count) = (0.0, 0);
        for el in &s.elements {
            let k = el.corners.len();
            for i in 0..k {
                let (p, q) = (el.corners[i] as usize, el.corners[(i + 1) % k] as usize);
                let d: f64 = (0..dim)
                    .map(|c| (x[p * dim + c] - x[q * dim + c]).powi(2))
                    .sum::<f64>()
                    .sqrt();
                if d > 0.0 {
                    sum += d;
                    count += 1;
                }
            }
        }
        s.h = if count > 0 { sum / count as f64 } else { 1.0 };
        Ok(s)
    }

    /// Outward orientation from the reference configuration `coords` of body `body`'s nodes: the
    /// raw normal at the face centre must point away from the centroid of the element's bulk cell.
    fn orient(&mut self, body: &SurfaceBody, coords: &[f64]) {
        let dim = self.dim;
        for el in &mut self.elements {
            let x = reference_positions(coords, dim, &el.nodes);
            let (p, _, nu) = frame(el, dim, &x, &[0.0, 0.0]);
            // centroid of the linear parent (an enriched node list holds control points)
            let parent = body.mesh.cell(el.cell - body.cell_offset);
            let mut c = [0.0; 3];
            for &nd in parent {
                let g = (nd + body.node_offset) as usize;
                for k in 0..dim {
                    c[k] += coords[g * dim + k] / parent.len() as f64;
                }
            }
            let out: f64 = (0..dim).map(|k| nu[k] * (p[k] - c[k])).sum();
            el.sign = if out >= 0.0 { 1.0 } else { -1.0 };
        }
    }

    /// Neighbours across every side, matched by the linear parents' corner nodes.
    fn connect(&mut self) {
        let dim = self.dim;
        let ns = n_sides(dim);
        let mut by_corner: std::collections::HashMap<u32, Vec<u32>> = Default::default();
        for (e, el) in self.elements.iter().enumerate() {
            for &c in &el.corners {
                let v = by_corner.entry(c).or_default();
                if v.last() != Some(&(e as u32)) {
                    v.push(e as u32);
                }
            }
        }
        let mut all = Vec::with_capacity(self.elements.len());
        for (e, el) in self.elements.iter().enumerate() {
            let mut nb = vec![None; ns];
            for s in 0..ns {
                let (i, j) = side_corners(dim, s);
                let (ca, cb) = (el.corners[i], el.corners[j]);
                if dim == 3 && ca == cb {
                    continue; // collapsed edge
                }
                'cand: for &f in &by_corner[&ca] {
                    if f as usize == e {
                        continue;
                    }
                    let other = &self.elements[f as usize];
                    for s2 in 0..ns {
                        let (i2, j2) = side_corners(dim, s2);
                        let (da, db) = (other.corners[i2], other.corners[j2]);
                        if dim == 2 {
                            if da == ca {
                                nb[s] = Some((f, s2 as u8, false));
                                break 'cand;
                            }
                        } else if (da, db) == (cb, ca) {
                            nb[s] = Some((f, s2 as u8, true));
                            break 'cand;
                        } else if (da, db) == (ca, cb) {
                            nb[s] = Some((f, s2 as u8, false));
                            break 'cand;
                        }
                    }
                }
            }
            all.push(nb);
        }
        for (el, nb) in self.elements.iter_mut().zip(all) {
            el.neighbours = nb;
        }
    }
}

/// Positions of `nodes` [n][dim] from the coordinates of every global node `coords`
/// [n_global_nodes][dim] (e.g. the model's reference coordinates).
pub fn reference_positions(coords: &[f64], dim: usize, nodes: &[u32]) -> Vec<f64> {
    nodes
        .iter()
        .flat_map(|&a| coords[a as usize * dim..(a as usize + 1) * dim].to_vec())
        .collect()
}
