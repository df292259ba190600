//! What the contact system holds on this rank, in bytes (summary.json `contact_data`): the
//! measure of distributed contact surfaces. Every rank holds every contact surface's
//! topology and basis data and every surface node's reference coordinates, the current positions
//! and search grids of the elements it holds (own and ghost layer), and its own points; the counts are the
//! arrays' lengths times their element sizes (what the allocator hands out beyond that, and
//! vector capacity slack, are not counted).

use super::ContactSystem;
use crate::contact::basis::FaceBasis;
use crate::contact::half_pass::{OwnElem, Pass, QPoint};
use crate::contact::projection::BasisAt;
use crate::contact::surface::{ContactSurface, SurfaceElement};
use std::mem::size_of;

/// The bytes of a vector's elements plus its header.
fn vec_bytes<T>(v: &[T]) -> usize {
    size_of::<Vec<T>>() + std::mem::size_of_val(v)
}

/// The bytes of one surface element (its struct, nodes, corners, neighbours and basis data).
fn element_bytes(el: &SurfaceElement) -> usize {
    let basis = match &el.basis {
        FaceBasis::Nurbs(d) => {
            std::mem::size_of_val(&d.extraction[..])
                + std::mem::size_of_val(&d.weights[..])
                + std::mem::size_of_val(&d.ctrl_ids[..])
        }
        _ => 0,
    };
    size_of::<SurfaceElement>()
        + std::mem::size_of_val(&el.nodes[..])
        + std::mem::size_of_val(&el.corners[..])
        + std::mem::size_of_val(&el.neighbours[..])
        + basis
}

/// The bytes of a surface (its elements).
fn surface_bytes(s: &ContactSurface) -> usize {
    size_of::<ContactSurface>() + s.name.len() + s.elements.iter().map(element_bytes).sum::<usize>()
}

/// The bytes of an own (or halo) element's points' basis values and local indices.
fn own_elem_bytes(oe: &OwnElem) -> usize {
    size_of::<OwnElem>()
        + std::mem::size_of_val(&oe.local[..])
        + std::mem::size_of_val(&oe.N[..])
        + std::mem::size_of_val(&oe.dN[..])
}

/// The bytes of a half-pass on this rank: its points, their elements and the mortar net.
fn pass_bytes(p: &Pass) -> usize {
    size_of::<Pass>()
        + p.points.len() * size_of::<QPoint>()
        + p.elems
            .iter()
            .chain(&p.halo)
            .map(own_elem_bytes)
            .sum::<usize>()
        + p.mortar.as_ref().map_or(0, |m| m.heap_bytes())
        + p.bases
            .iter()
            .map(|b| size_of::<BasisAt>() + std::mem::size_of_val(&b.values[..]))
            .sum::<usize>()
}

/// What the contact system holds on this rank, split into the surfaces every rank holds whole and
/// the points this rank integrates.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Footprint {
    /// Surface nodes whose displacement this rank gathers before every evaluation.
    pub table_nodes: usize,
    /// Surface elements this rank holds positions of that other ranks own (the ghost layer).
    pub ghost_elements: usize,
    /// Surfaces (elements, basis data and bases at element centres), the node table, current
    /// positions and search grids.
    pub surface_bytes: usize,
    /// The half-passes' points and elements on this rank (and the mortar nets, and the partner
    /// bases stored at the points' projections).
    pub point_bytes: usize,
}

impl ContactSystem {
    /// What this rank holds for contact (see [`Footprint`]).
    pub fn footprint(&self) -> Footprint {
        let surfaces = self.surfaces.iter().map(surface_bytes).sum::<usize>()
            + vec_bytes(&self.all_nodes)
            + vec_bytes(&self.all_X)
            + vec_bytes(&self.table)
            + vec_bytes(&self.X)
            + self
                .slots
                .iter()
                .flat_map(|s| s.iter().map(|v| vec_bytes(v)))
                .sum::<usize>()
            + self
                .gdofs
                .iter()
                .flat_map(|s| s.iter().map(|v| vec_bytes(v)))
                .sum::<usize>()
            + self
                .pos
                .iter()
                .map(|p| vec_bytes(&p.offsets) + vec_bytes(&p.x))
                .sum::<usize>()
            + self
                .grids
                .iter()
                .flatten()
                .map(|g| g.heap_bytes())
                .sum::<usize>()
            + self
                .centres
                .iter()
                .flat_map(|s| s.iter().map(|v| vec_bytes(v)))
                .sum::<usize>();
        let points = self
            .pairs
            .iter()
            .flat_map(|p| p.passes.iter().map(pass_bytes))
            .sum::<usize>();
        Footprint {
            table_nodes: self.table.len(),
            ghost_elements: self.ghost_elements(),
            surface_bytes: surfaces,
            point_bytes: points,
        }
    }
}
