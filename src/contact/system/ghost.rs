//! The ghost layer: which surface elements this rank holds current
//! positions of, so that the gather before every evaluation carries only their nodes.
//!
//! A rank holds its *own* elements (those of the cells of its bulk partition, on every surface),
//! the elements that hold the points it integrates (own and mortar halo), their cohesive pairings,
//! and the *ghosts*: partner elements within reach of its points. Reach is decided on boxes
//! ([`element_box`], the global search's): a partner element `f` is a ghost of a rank when
//! `box(f)` grown by the margin `d` (a quarter of the largest search distance) meets the box of one of its
//! point-holding elements grown by the largest search distance plus `2 d`. The boxes are those of the state of the last refresh; as long as no
//! surface node has moved by more than `d / c` since (`c` bounds how far a box moves with its
//! nodes: 1 for NURBS with positive weights and linear faces, which lie in the convex hull of their
//! nodes; 4 for the sampled boxes of Lagrange and Hermite faces), every element whose search box
//! holds one of the rank's points is held, so the global search sees the same candidates on any
//! number of ranks (the results are the same to round-off).
//!
//! A refresh (collective, driven by the assembler, see `CouplingSet::ghost_status`) happens when
//! a surface node moved past the margin anywhere, or when this rank needed an element it does
//! not hold: a projection's walk, a friction anchor or a cohesive pairing reached outside the layer
//! (`requests`; such an update is discarded and repeated after the refresh, never used). Each rank
//! sends the boxes of its points' reach (a few per half-pass: an all-gather of boxes only); each
//! rank answers every other rank with its own elements inside that reach (element ids:
//! point-to-point), and the gather's scatter is rebuilt on the new node table.
//!
//! This stage keeps the surfaces' *topology* (elements, neighbours, basis and extraction data) and
//! the reference coordinates of every surface node replicated on every rank: only current positions
//! and the gathered displacement are limited to the held elements. The next stage sends the
//! topology and extraction data of the ghosts with their ids and keeps only own + ghost elements
//! (renumbered locally; the coupling keys and checkpoints keep global element ids), which needs the
//! walk to stop at the layer's edge by itself, the mortar halo and cohesive pairings found from
//! exchanged data, and the output's L2 projection assembled by the elements' owners (as it is now).

use super::ContactSystem;
use crate::contact::pair::{Anchor, Partner};
use crate::contact::projection::{element_box, Positions};
use crate::contact::search::Aabb;

/// Values per reach box in [`ContactSystem::ghost_reach`]: partner surface, lower and upper corner.
const REACH: usize = 7;

/// Most reach boxes per half-pass (its point-holding elements, in Morton order of their boxes'
/// centres, are merged into this many boxes: fewer boxes to send, a thicker layer).
const MAX_REACH_BOXES: usize = 64;

/// The Morton (Z-order) key of each box's centre on a 1024-cell grid per axis over all of them.
fn morton_keys(dim: usize, boxes: &[Aabb]) -> Vec<u64> {
    let mut all = Aabb::EMPTY;
    let centre = |b: &Aabb| {
        [0, 1, 2].map(|k| {
            if k < dim {
                0.5 * (b.lo[k] + b.hi[k])
            } else {
                0.0
            }
        })
    };
    for b in boxes {
        all.grow(&centre(b)[..dim]);
    }
    boxes
        .iter()
        .map(|b| {
            let c = centre(b);
            let mut key = 0u64;
            for k in 0..dim {
                let w = all.hi[k] - all.lo[k];
                let q = if w > 0.0 {
                    ((c[k] - all.lo[k]) / w * 1023.0).round() as u64
                } else {
                    0
                };
                for bit in 0..10 {
                    key |= ((q >> bit) & 1) << (bit * dim + k);
                }
            }
            key
        })
        .collect()
}

/// The ghost layer's state on this rank.
#[derive(Debug, Default)]
pub(super) struct Ghosts {
    /// Per surface: the elements of this rank's cells, ascending.
    owned: Vec<Vec<u32>>,
    /// Per surface: the elements always held (own, point-holding, cohesive pairings), ascending.
    pinned: Vec<Vec<u32>>,
    /// Per surface: the ghosts of the last refresh, ascending.
    ghosts: Vec<Vec<u32>>,
    /// (surface, element) reached outside the layer since the last refresh that kept its ghosts
    /// (a walk's, an anchor's or a pairing's), held from then on until a refresh after motion.
    extra: Vec<(u32, u32)>,
    /// (surface, element) the last update needed and did not hold.
    pub(super) requests: Vec<(u32, u32)>,
    /// Per surface, per element: held now.
    held: Vec<Vec<bool>>,
    /// The margin `d` (module doc).
    margin: f64,
    /// How far a point's reach extends: the largest search distance of any pair (a partner
    /// surface's search grid is built with the distance of the first pair that searches it) plus
    /// twice the margin.
    reach: f64,
    /// How far a box may move per unit of nodal motion (module doc).
    box_factor: f64,
    /// Displacement of the table at the state of the last refresh (`None`: take the next update's).
    u0: Option<Vec<f64>>,
    /// The last update found a node moved by more than `margin / box_factor` since the refresh.
    moved: bool,
    /// This rank holds every element (one rank): nothing to refresh.
    everything: bool,
}

impl ContactSystem {
    /// Sets the ghost layer up in the reference configuration, where every rank knows every
    /// element's box (the reference coordinates are replicated), so no communication is needed;
    /// then limits the node table to the held elements. `cell_part` and `rank` as in `new`.
    pub(super) fn init_ghosts(&mut self, cell_part: &[u32], rank: usize) {
        let n_s = self.surfaces.len();
        let mut owned = vec![Vec::new(); n_s];
        let mut pinned = vec![Vec::new(); n_s];
        let mut convex = true;
        for (s, surf) in self.surfaces.iter().enumerate() {
            for (e, el) in surf.elements.iter().enumerate() {
                if cell_part[el.cell] as usize == rank {
                    owned[s].push(e as u32);
                }
                convex &= matches!(
                    el.basis,
                    crate::contact::basis::FaceBasis::Nurbs(_)
                        | crate::contact::basis::FaceBasis::Line2
                        | crate::contact::basis::FaceBasis::Quad4
                );
            }
        }
        for pair in &self.pairs {
            for pass in &pair.passes {
                for oe in pass.elems.iter().chain(&pass.halo) {
                    pinned[pass.k].push(oe.e);
                }
                if let Partner::Surface(l) = pass.partner {
                    for q in &pass.points {
                        if let Some((f, _)) = q.pairing {
                            pinned[l].push(f);
                        }
                    }
                }
            }
        }
        for (p, o) in pinned.iter_mut().zip(&owned) {
            p.extend_from_slice(o);
            p.sort_unstable();
            p.dedup();
        }
        let margin = self
            .pairs
            .iter()
            .map(|p| p.def.search_distance)
            .fold(0.0, f64::max);
        let h = self.surfaces.iter().map(|s| s.h).fold(0.0, f64::max);
        // a quarter of the search distance: a layer 1.75 search distances thick around a rank's
        // points, refreshed when a node moved by a quarter (a thicker one costs traffic in every
        // gather, a refresh one all-gather of boxes, one exchange of ids and a repeated update)
        let margin_d = if margin > 0.0 { 0.25 * margin } else { h };
        self.ghost = Ghosts {
            owned,
            pinned,
            ghosts: vec![Vec::new(); n_s],
            margin: margin_d,
            reach: margin + 2.0 * margin_d,
            box_factor: if convex { 1.0 } else { 4.0 },
            ..Default::default()
        };
        // every position is known here: answer the own reach with every element
        let reach = self.ghost_reach();
        let found = self.answer(&reach, true);
        self.adopt(&found, true);
        self.ghost.everything = self.ghost.held.iter().all(|h| h.iter().all(|&b| b));
        self.ghost.u0 = Some(vec![0.0; self.X.len()]);
        self.update_positions(&vec![0.0; self.X.len()]);
    }

    /// Checks the ghost layer at the displacement `u_table` of an update: notes whether a node moved
    /// past the margin since the last refresh.
    pub(super) fn check_motion(&mut self, u_table: &[f64]) {
        let g = &mut self.ghost;
        if g.everything {
            return;
        }
        match &g.u0 {
            Some(u0) if u0.len() == u_table.len() => {
                let m = u0
                    .iter()
                    .zip(u_table)
                    .map(|(a, b)| (a - b).abs())
                    .fold(0.0, f64::max);
                g.moved = g.box_factor * m > g.margin;
            }
            _ => {
                g.u0 = Some(u_table.to_vec());
                g.moved = false;
            }
        }
    }

    /// Requests the friction anchors' and cohesive pairings' elements of this rank's points that it
    /// does not hold (their positions are read in the evaluation).
    pub(super) fn request_anchors(&mut self) {
        for pair in &self.pairs {
            let frictional = pair.def.friction.is_some();
            for pass in &pair.passes {
                let Partner::Surface(l) = pass.partner else {
                    continue;
                };
                for q in &pass.points {
                    let anchor = match q.committed.anchor {
                        Some(Anchor::Surface(f, _)) if frictional => Some(f),
                        _ => None,
                    };
                    for f in q.pairing.map(|p| p.0).into_iter().chain(anchor) {
                        if !self.pos[l].has(f as usize) {
                            self.ghost.requests.push((l as u32, f));
                        }
                    }
                }
            }
        }
    }

    /// After an update: `[moved, missed]` (see `CouplingSet::ghost_status`).
    pub fn ghost_status(&self) -> [u8; 2] {
        let g = &self.ghost;
        if g.everything {
            return [0, 0];
        }
        let missed = !g.requests.is_empty() || !self.work.absent.is_empty();
        [g.moved as u8, missed as u8]
    }

    /// The reach of this rank's points at the current positions: per half-pass against a surface,
    /// the boxes of its point-holding elements grown by the largest search distance plus twice the
    /// margin,
    /// merged into at most [`MAX_REACH_BOXES`] (chunks of elements close in space); [`REACH`]
    /// values per box.
    pub fn ghost_reach(&self) -> Vec<f64> {
        let dim = self.dim;
        let grow = self.ghost.reach;
        let mut out = Vec::new();
        for pair in &self.pairs {
            for pass in &pair.passes {
                let Partner::Surface(l) = pass.partner else {
                    continue;
                };
                let mut elems: Vec<u32> = pass
                    .elems
                    .iter()
                    .chain(&pass.halo)
                    .filter(|o| o.n > 0)
                    .map(|o| o.e)
                    .collect();
                elems.sort_unstable();
                elems.dedup();
                if elems.is_empty() {
                    continue;
                }
                let boxes: Vec<Aabb> = elems
                    .iter()
                    .map(|&e| element_box(&self.surfaces[pass.k], &self.pos[pass.k], e as usize))
                    .collect();
                // chunks of elements close in space (Morton order of the boxes' centres), so that
                // merging a chunk's boxes adds little
                let mut order: Vec<(u64, usize)> = morton_keys(dim, &boxes)
                    .into_iter()
                    .enumerate()
                    .map(|(i, k)| (k, i))
                    .collect();
                order.sort_unstable();
                let per = elems.len().div_ceil(MAX_REACH_BOXES);
                for chunk in order.chunks(per) {
                    let mut b = Aabb::EMPTY;
                    for &(_, i) in chunk {
                        b.grow(&boxes[i].lo[..dim]);
                        b.grow(&boxes[i].hi[..dim]);
                    }
                    let b = b.inflated(dim, grow);
                    out.push(l as f64);
                    out.extend_from_slice(&b.lo);
                    out.extend_from_slice(&b.hi);
                }
            }
        }
        out
    }

    /// This rank's own elements inside another rank's `reach` ([`ContactSystem::ghost_reach`]'s
    /// boxes) at the current positions, as (surface, element) pairs flattened, ascending.
    pub fn ghost_answer(&self, reach: &[f64]) -> Vec<u32> {
        self.answer(reach, false)
    }

    /// [`ContactSystem::ghost_answer`] over the own elements, or with `all` over every element
    /// (the reference configuration, where every rank knows them all).
    fn answer(&self, reach: &[f64], all: bool) -> Vec<u32> {
        let (dim, d) = (self.dim, self.ghost.margin);
        let mut found: Vec<(u32, u32)> = Vec::new();
        for r in reach.chunks_exact(REACH) {
            let l = r[0] as usize;
            let b = Aabb {
                lo: [r[1], r[2], r[3]],
                hi: [r[4], r[5], r[6]],
            };
            let n_l = self.surfaces[l].elements.len() as u32;
            let elems: Box<dyn Iterator<Item = u32>> = if all {
                Box::new(0..n_l)
            } else {
                Box::new(self.ghost.owned[l].iter().copied())
            };
            for f in elems {
                let fb = element_box(&self.surfaces[l], &self.pos[l], f as usize);
                if !fb.is_empty() && fb.inflated(dim, d).meets(&b, dim) {
                    found.push((l as u32, f));
                }
            }
        }
        found.sort_unstable();
        found.dedup();
        found.into_iter().flat_map(|(l, f)| [l, f]).collect()
    }

    /// Takes the other ranks' answers (flattened (surface, element) pairs) as the new ghosts, with
    /// the elements requested since the last refresh (and, unless a node `moved` past the margin,
    /// those requested before), and rebuilds the node table on the held elements. The next update
    /// starts the motion check afresh.
    pub fn adopt_ghosts(&mut self, answers: &[u32], moved: bool) {
        self.adopt(answers, moved);
    }

    fn adopt(&mut self, answers: &[u32], moved: bool) {
        let g = &mut self.ghost;
        if moved {
            g.extra.clear();
        }
        g.extra.append(&mut g.requests);
        g.extra.append(&mut self.work.absent);
        g.extra.sort_unstable();
        g.extra.dedup();
        for v in &mut g.ghosts {
            v.clear();
        }
        let pairs = answers.chunks_exact(2).map(|p| (p[0], p[1]));
        for (l, f) in pairs.chain(g.extra.iter().copied()) {
            g.ghosts[l as usize].push(f);
        }
        for v in &mut g.ghosts {
            v.sort_unstable();
            v.dedup();
        }
        g.held = self
            .surfaces
            .iter()
            .enumerate()
            .map(|(s, surf)| {
                let mut h = vec![false; surf.elements.len()];
                for &e in g.pinned[s].iter().chain(&g.ghosts[s]) {
                    h[e as usize] = true;
                }
                h
            })
            .collect();
        g.u0 = None;
        g.moved = false;
        self.rebuild_table();
    }

    /// The node table, its reference coordinates and the elements' slots on the held elements (an
    /// element not held has no slots, so no positions).
    fn rebuild_table(&mut self) {
        let dim = self.dim;
        let held = &self.ghost.held;
        let mut table: Vec<u32> = self
            .surfaces
            .iter()
            .enumerate()
            .flat_map(|(s, surf)| {
                surf.elements
                    .iter()
                    .enumerate()
                    .filter(move |(e, _)| held[s][*e])
                    .flat_map(|(_, el)| el.nodes.iter().copied())
            })
            .collect();
        table.sort_unstable();
        table.dedup();
        let mut X = Vec::with_capacity(table.len() * dim);
        for a in &table {
            let i = self.all_nodes.binary_search(a).expect("a surface node");
            X.extend_from_slice(&self.all_X[i * dim..(i + 1) * dim]);
        }
        self.slots = self
            .surfaces
            .iter()
            .enumerate()
            .map(|(s, surf)| {
                surf.elements
                    .iter()
                    .enumerate()
                    .map(|(e, el)| {
                        if held[s][e] {
                            el.nodes
                                .iter()
                                .map(|a| table.binary_search(a).expect("held") as u32)
                                .collect()
                        } else {
                            Vec::new()
                        }
                    })
                    .collect()
            })
            .collect();
        self.work.r_table = vec![0.0; table.len() * dim];
        self.table = table;
        self.X = X;
        self.last_update = None;
        // no element has positions until the next update (that follows every refresh)
        self.pos = vec![Positions::default(); self.surfaces.len()];
        for (s, p) in self.pos.iter_mut().enumerate() {
            p.offsets = vec![0; self.surfaces[s].elements.len() + 1];
        }
        for g in &mut self.grids {
            *g = None;
        }
    }

    /// True when element `e` of surface `s` belongs to one of this rank's cells.
    pub(super) fn owns_element(&self, s: usize, e: usize) -> bool {
        self.ghost.owned[s].binary_search(&(e as u32)).is_ok()
    }

    /// Elements this rank holds positions of that other ranks own (the ghost layer's size).
    pub fn ghost_elements(&self) -> usize {
        let g = &self.ghost;
        g.held
            .iter()
            .enumerate()
            .map(|(s, h)| h.iter().filter(|&&b| b).count() - g.owned[s].len())
            .sum()
    }
}
