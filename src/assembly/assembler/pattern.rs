//! The sparsity pattern: element blocks, the coupling set's blocks, the diagonal block and skew
//! rows' entries, preallocated exactly (COO, or per-row counts for the classic path).

use super::{Assembler, MatrixAssembly};
use crate::assembly::skew::{SkewRow, SkewRows};
use crate::assembly::{BlockScatter, MatrixSink};
use crate::petsc::{Matrix, PetscError, PetscInt};
use std::time::Instant;

/// Where an element row `gi` goes in the pattern: dropped (constrained), itself, or (a skew row)
/// its node's first other row, with the constraint.
pub(super) fn row_target<'a>(
    constrained: &[bool],
    skew: &'a SkewRows,
    gi: PetscInt,
) -> (PetscInt, Option<&'a SkewRow>) {
    if gi < 0 || !constrained[gi as usize] {
        return (gi, None);
    }
    match skew.of(gi) {
        Some(r) if !r.others.is_empty() => (r.others[0].0, Some(r)),
        _ => (-1, None),
    }
}

/// Pattern bookkeeping of a skew row's entry at COO index `idx`, column `gj`: its weight on the
/// first other row, and entries for the further ones (pushed later as `extra`).
fn note_skew(
    r: &SkewRow,
    idx: usize,
    gj: PetscInt,
    scale: &mut Vec<(usize, f64)>,
    extra: &mut Vec<(PetscInt, PetscInt, usize, f64)>,
) {
    scale.push((idx, r.others[0].1));
    for &(o, a) in &r.others[1..] {
        extra.push((o, gj, idx, a));
    }
}

/// A COO entry's index as the region map stores it.
fn coo_index(i: usize) -> Result<u32, PetscError> {
    u32::try_from(i).map_err(|_| PetscError {
        code: 0,
        function: "build_pattern",
        message: format!(
            "the Jacobian's pattern has {i} entries on one rank, beyond the 2^32 its coupling \
             regions can address: run on more ranks"
        ),
    })
}

/// The non-negative entries of `lists`, sorted and unique.
fn sorted_union<'a>(lists: impl Iterator<Item = &'a [PetscInt]>) -> Vec<PetscInt> {
    let mut u: Vec<PetscInt> = lists.flatten().copied().filter(|&g| g >= 0).collect();
    u.sort_unstable();
    u.dedup();
    u
}

impl Assembler<'_> {
    /// Builds (or rebuilds, when the coupling set's blocks change) the sparsity pattern of `j` and
    /// preallocates it exactly.
    ///
    /// Collective.
    pub fn build_pattern(&mut self, j: &mut Matrix) -> Result<(), PetscError> {
        let t0 = Instant::now();
        let (lo, hi) = self.dofs.owned_range();
        match self.mode {
            MatrixAssembly::Coo => {
                let mut rows: Vec<PetscInt> = Vec::new();
                let mut cols: Vec<PetscInt> = Vec::new();
                let mut scale = Vec::new();
                let mut extra = Vec::new();
                self.coo_offsets.clear();
                self.coo_offsets.push(0);
                for r in &self.restrict {
                    for e in 0..r.offsets.len() - 1 {
                        let g = &r.global[r.offsets[e]..r.offsets[e + 1]];
                        for &gi in g {
                            let (row, sk) = row_target(&self.constrained, &self.skew, gi);
                            for &gj in g {
                                if let Some(sr) = sk {
                                    note_skew(sr, rows.len(), gj, &mut scale, &mut extra);
                                }
                                rows.push(row);
                                cols.push(gj);
                            }
                        }
                        self.coo_offsets.push(rows.len());
                    }
                }
                // The coupling set's blocks (contact: rows of a surface element, columns of it
                // and of its partner). Blocks whose keys share the first two components (contact:
                // the half-pass and the surface element) share one region, the union of their rows
                // times the union of their columns, and the regions' entries are merged before
                // PETSc sees them: each (row, column) of the regions gets one COO entry, and
                // `region_map` says which. The regions of neighbouring surface elements overlap
                // in most of their entries (the weighted gaps' rows reach every column of their
                // control points' supports), and PETSc would otherwise hold, sort and sum each of
                // them once per region. Skew rows keep an entry per region (their values are
                // scaled onto the node's other rows entry by entry).
                if let Some(c) = &mut self.coupled {
                    c.blocks = match c.preset.take() {
                        Some(p) => p,
                        None => c.set.band_blocks(c.ring),
                    };
                    c.first_slot = self.coo_offsets.len() - 1;
                    c.block_scatter.clear();
                    // per region: its rows that reach the matrix, its columns, its first map entry
                    let mut regions: Vec<(Vec<PetscInt>, Vec<PetscInt>, usize)> = Vec::new();
                    let mut map_len = 0;
                    let mut start = 0;
                    while start < c.blocks.len() {
                        let key = (c.blocks[start].0, c.blocks[start].1);
                        let end = start
                            + c.blocks[start..]
                                .iter()
                                .take_while(|b| (b.0, b.1) == key)
                                .count();
                        let dofs: Vec<_> = c.blocks[start..end]
                            .iter()
                            .map(|b| c.set.block_dofs(b))
                            .collect();
                        let all_rows = sorted_union(dofs.iter().map(|d| &d.0[..]));
                        let all_cols = sorted_union(dofs.iter().map(|d| &d.1[..]));
                        // rows that reach the matrix (not constrained, or skew rows moved)
                        let kept: Vec<PetscInt> = all_rows
                            .into_iter()
                            .filter(|&gi| row_target(&self.constrained, &self.skew, gi).0 >= 0)
                            .collect();
                        let pos = |set: &[PetscInt], g: &i32| {
                            set.binary_search(g).map_or(u32::MAX, |p| p as u32)
                        };
                        for (r, cl) in &dofs {
                            c.block_scatter.push(BlockScatter {
                                base: map_len,
                                stride: all_cols.len(),
                                rows: r.iter().map(|g| pos(&kept, g)).collect(),
                                cols: cl.iter().map(|g| pos(&all_cols, g)).collect(),
                            });
                        }
                        let n = kept.len() * all_cols.len();
                        regions.push((kept, all_cols, map_len));
                        map_len += n;
                        start = end;
                    }
                    self.timers.region_entries = self.timers.region_entries.max(map_len);
                    let mut map = vec![u32::MAX; map_len];
                    // (matrix row, region, row of the region) of the rows merged
                    let mut merged: Vec<(PetscInt, u32, u32)> = Vec::new();
                    for (ri, (kept, all_cols, base)) in regions.iter().enumerate() {
                        for (a, &gi) in kept.iter().enumerate() {
                            let (row, sk) = row_target(&self.constrained, &self.skew, gi);
                            let Some(sr) = sk else {
                                merged.push((row, ri as u32, a as u32));
                                continue;
                            };
                            let at = base + a * all_cols.len();
                            for (b, &gj) in all_cols.iter().enumerate() {
                                note_skew(sr, rows.len(), gj, &mut scale, &mut extra);
                                map[at + b] = coo_index(rows.len())?;
                                rows.push(row);
                                cols.push(gj);
                            }
                        }
                    }
                    merged.sort_unstable();
                    // the COO entry of each column of the current row (`u32::MAX`: none yet)
                    let mut entry_of = vec![u32::MAX; self.dofs.n_global()];
                    let mut touched: Vec<PetscInt> = Vec::new();
                    let mut i = 0;
                    while i < merged.len() {
                        let row = merged[i].0;
                        let j = i + merged[i..].iter().take_while(|m| m.0 == row).count();
                        for &(_, ri, a) in &merged[i..j] {
                            let (_, all_cols, base) = &regions[ri as usize];
                            let at = base + a as usize * all_cols.len();
                            for (b, &gj) in all_cols.iter().enumerate() {
                                let e = &mut entry_of[gj as usize];
                                if *e == u32::MAX {
                                    *e = coo_index(rows.len())?;
                                    touched.push(gj);
                                    rows.push(row);
                                    cols.push(gj);
                                }
                                map[at + b] = *e;
                            }
                        }
                        for g in touched.drain(..) {
                            entry_of[g as usize] = u32::MAX;
                        }
                        i = j;
                    }
                    // (every region's entries lie between the first region's start and here)
                    self.coo_offsets
                        .extend(std::iter::repeat_n(rows.len(), regions.len()));
                    c.region_map = map;
                }
                // A final block with the diagonal of every owned row: identity rows of the
                // constrained unknowns, the pseudo-transient damping (or zero) on the free ones.
                for g in lo..hi {
                    rows.push(g);
                    cols.push(g);
                }
                self.coo_offsets.push(rows.len());
                // Skew constraint rows `x_d - sum a_o x_o`: their off-diagonal entries, then the
                // element entries of skew rows on their further other rows.
                self.skew_tail = rows.len();
                for (d, others) in &self.skew_owned {
                    for &(o, _) in others {
                        rows.push(lo + *d as PetscInt);
                        cols.push(lo + o as PetscInt);
                    }
                }
                self.skew_copy.clear();
                for (o, gj, src, a) in extra {
                    self.skew_copy.push((src, rows.len(), a));
                    rows.push(o);
                    cols.push(gj);
                }
                self.skew_scale = scale;
                self.coo_values = vec![0.0; rows.len()];
                self.timers.coo_entries = self.timers.coo_entries.max(rows.len());
                j.set_preallocation_coo(&mut rows, &mut cols)?;
            }
            MatrixAssembly::Preallocated => {
                let (d_nnz, o_nnz) = self.row_counts();
                j.preallocate_aij(&d_nnz, &o_nnz)?;
            }
        }
        self.pattern_ready = true;
        self.timers.pattern += t0.elapsed().as_secs_f64();
        Ok(())
    }

    /// Exact per-row nonzero counts of the owned rows, split into the diagonal block and the rest.
    /// Owned rows also receive entries from other ranks' elements, so this scans the connectivity of
    /// every cell of the model (`all_cells`, replicated on each rank), a setup cost paid per pattern.
    fn row_counts(&self) -> (Vec<PetscInt>, Vec<PetscInt>) {
        let (lo, hi) = self.dofs.owned_range();
        let n_owned = (hi - lo) as usize;
        let dim = self.dofs.dim;
        let mut cols_of: Vec<Vec<PetscInt>> = vec![Vec::new(); n_owned];
        let (offsets, nodes) = (&self.all_cells.0, &self.all_cells.1);
        let mut g = Vec::new();
        for c in 0..offsets.len().saturating_sub(1) {
            g.clear();
            for &n in &nodes[offsets[c]..offsets[c + 1]] {
                for k in 0..dim {
                    g.push(self.dofs.global(n, k).map_or(-1, |d| d.0));
                }
            }
            for &gi in &g {
                if gi >= lo && gi < hi && !self.constrained[gi as usize] {
                    cols_of[(gi - lo) as usize].extend(g.iter().copied().filter(|&x| x >= 0));
                }
            }
        }
        let mut d = vec![0 as PetscInt; n_owned];
        let mut o = vec![0 as PetscInt; n_owned];
        for (i, c) in cols_of.iter_mut().enumerate() {
            if self.constrained[(lo + i as PetscInt) as usize] {
                d[i] = 1;
                continue;
            }
            c.sort_unstable();
            c.dedup();
            for &col in c.iter() {
                if col >= lo && col < hi {
                    d[i] += 1;
                } else {
                    o[i] += 1;
                }
            }
        }
        (d, o)
    }

    /// Switches to the classic `MatSetValues` path (for comparison with COO in benchmarks); it needs
    /// the connectivity of every cell of the model, `(offsets, global nodes)`, to count row nonzeros.
    pub fn use_preallocated(&mut self, offsets: Vec<usize>, nodes: Vec<u32>) {
        self.mode = MatrixAssembly::Preallocated;
        self.all_cells = (offsets, nodes);
        self.pattern_ready = false;
    }
}

/// Inserts element matrices with `MatSetValues` (the classic path, for comparison with COO).
pub(super) struct PetscSink<'a, 'm, 'p> {
    pub(super) mat: &'m mut Matrix<'p>,
    pub(super) constrained: &'a [bool],
    pub(super) rows: Vec<PetscInt>,
    pub(super) err: Option<PetscError>,
}

impl MatrixSink for PetscSink<'_, '_, '_> {
    fn add(&mut self, slot: usize, dofs: &[i32], k_e: &[f64]) {
        self.add_block(slot, dofs, dofs, k_e);
    }
    fn add_block(&mut self, _slot: usize, rows: &[i32], cols: &[i32], k: &[f64]) {
        self.rows.clear();
        self.rows.extend(rows.iter().map(|&g| {
            if g >= 0 && self.constrained[g as usize] {
                -1
            } else {
                g
            }
        }));
        if let Err(e) = self.mat.add_values(&self.rows, cols, k) {
            self.err.get_or_insert(e);
        }
    }
}
