//! An exact NURBS surface attached to a face set of a [`Mesh`](super::Mesh): a generator that knows
//! the exact geometry of a contact surface hands it to the enriched layer (`crate::model::enrich`),
//! which would otherwise have to recognise it from the nodes (lines, arcs and planes only).
use crate::geometry::nurbs::NurbsSurface;

/// The exact surface of a face set whose faces form a structured `n_u x n_v` grid in the surface's
/// parameters: face set entry `i + n_u j` is face `(i, j)`, whose local face 0 has the corners
/// `(i, j), (i+1, j), (i+1, j+1), (i, j+1)` of the grid in its reference order.
#[derive(Debug, Clone, PartialEq)]
pub struct ExactPatch {
    /// The exact geometry at its lowest order (the enriched layer elevates and refines it itself,
    /// so that the continuity of Table 1 of Corbett & Sauer 2014 is reached for every family).
    pub surface: NurbsSurface,
    /// Parameters of the grid lines in u, increasing: [n_u + 1].
    pub params_u: Vec<f64>,
    /// Parameters of the grid lines in v, increasing: [n_v + 1].
    pub params_v: Vec<f64>,
    /// Mesh node at grid point `(i, j)`, i fastest: [(n_v + 1)][(n_u + 1)]. Grid points that
    /// coincide (a collapsed edge of a degenerate patch) share one node.
    pub nodes: Vec<u32>,
}

impl ExactPatch {
    /// Number of faces per direction `(n_u, n_v)`.
    pub fn n_faces(&self) -> (usize, usize) {
        (
            self.params_u.len().saturating_sub(1),
            self.params_v.len().saturating_sub(1),
        )
    }

    /// Shifts the surface by `offset` [3] (NURBS are affinely invariant: move the control points).
    pub fn translate(&mut self, offset: &[f64]) {
        for x in self.surface.ctrl.chunks_mut(3) {
            x.iter_mut().zip(offset).for_each(|(a, b)| *a += b);
        }
    }

    /// Scales the surface about the origin by `factor`.
    pub fn scale(&mut self, factor: f64) {
        self.surface.ctrl.iter_mut().for_each(|x| *x *= factor);
    }
}
