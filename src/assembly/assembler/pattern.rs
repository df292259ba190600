//! The sparsity pattern: the cells' merged entries ([`super::cells`]), the coupling set's blocks,
//! the diagonal block and skew rows' entries, preallocated exactly (COO, or per-row counts for the
//! classic path).

use super::cells::CellPattern;
use super::{Assembler, MatrixAssembly};
use crate::assembly::skew::{SkewRow, SkewRows};
use crate::assembly::{BlockScatter, CouplingRuns, MatrixSink, DROPPED};
use crate::petsc::{Matrix, PetscError, PetscInt};
use mpi::collective::SystemOperation;
use mpi::traits::*;
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
pub(super) fn note_skew(
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

/// A COO entry's index as the cells' map and the coupling rows' runs store it (`u32::MAX` is
/// `DROPPED`).
pub(super) fn coo_index(i: usize) -> Result<u32, PetscError> {
    u32::try_from(i)
        .ok()
        .filter(|&k| k != DROPPED)
        .ok_or_else(|| PetscError {
            code: 0,
            function: "build_pattern",
            message: format!(
                "the Jacobian's pattern has {i} entries on one rank, beyond the 2^32 - 1 its \
                 index maps can address: run on more ranks"
            ),
        })
}

/// Fault injection for the test of a pattern that one rank cannot build: with
/// `NURBS_CONTACT_FAIL_PATTERN_ON_RANK=r` in the environment, rank `r`'s part of every pattern
/// fails as one beyond the index maps' reach does (`tests/mpi.rs` runs a case so on 2 ranks).
fn injected_failure(rank: i32) -> bool {
    static AT: std::sync::OnceLock<Option<i32>> = std::sync::OnceLock::new();
    *AT.get_or_init(|| {
        std::env::var("NURBS_CONTACT_FAIL_PATTERN_ON_RANK")
            .ok()?
            .trim()
            .parse()
            .ok()
    }) == Some(rank)
}

/// The non-negative entries of `lists`, sorted and unique.
fn sorted_union<'a>(lists: impl Iterator<Item = &'a [PetscInt]>) -> Vec<PetscInt> {
    let mut u: Vec<PetscInt> = lists.flatten().copied().filter(|&g| g >= 0).collect();
    u.sort_unstable();
    u.dedup();
    u
}

/// The coupling blocks' regions as the pattern lays them out: blocks that share a region (the
/// union of their rows times the union of their columns) are added together.
#[derive(Default)]
struct Regions {
    /// Per region: its rows that reach the matrix, its columns, its first row over all regions.
    regions: Vec<(Vec<PetscInt>, Vec<PetscInt>, usize)>,
    /// Per block: its region's first row, and the row of the region of each block row
    /// (`DROPPED`: the row does not reach the matrix).
    block_rows: Vec<(usize, Vec<u32>)>,
    /// Rows of all regions.
    n_rows: usize,
    /// Entries of all regions (rows that reach the matrix times columns).
    entries: usize,
}

impl Regions {
    /// Adds a region shared by the blocks whose (rows, columns) are `dofs` (negative: no
    /// unknown); `keep` says which rows reach the matrix.
    fn add(&mut self, dofs: &[(Vec<PetscInt>, Vec<PetscInt>)], keep: impl Fn(PetscInt) -> bool) {
        let all_rows = sorted_union(dofs.iter().map(|d| &d.0[..]));
        let all_cols = sorted_union(dofs.iter().map(|d| &d.1[..]));
        let kept: Vec<PetscInt> = all_rows.into_iter().filter(|&gi| keep(gi)).collect();
        for (r, _) in dofs {
            let pos = |g: &PetscInt| kept.binary_search(g).map_or(DROPPED, |p| p as u32);
            self.block_rows
                .push((self.n_rows, r.iter().map(pos).collect()));
        }
        self.entries += kept.len() * all_cols.len();
        let n = kept.len();
        self.regions.push((kept, all_cols, self.n_rows));
        self.n_rows += n;
    }

    /// Pushes the regions' COO entries onto `rows` and `cols` and returns where each block's rows
    /// go. A matrix row's entries are merged over the regions into one run of consecutive
    /// entries, in the order the regions first reach its columns; a skew row keeps a run per
    /// region (its scaling noted in `scale` and `extra`). `target` says where a row goes
    /// ([`row_target`]); `n_global` bounds the columns.
    #[allow(clippy::type_complexity)]
    fn runs<'a>(
        &self,
        target: impl Fn(PetscInt) -> (PetscInt, Option<&'a SkewRow>),
        n_global: usize,
        (rows, cols): (&mut Vec<PetscInt>, &mut Vec<PetscInt>),
        (scale, extra): (
            &mut Vec<(usize, f64)>,
            &mut Vec<(PetscInt, PetscInt, usize, f64)>,
        ),
    ) -> Result<(Vec<BlockScatter>, CouplingRuns), PetscError> {
        // the run of each region row: its column pattern and its first COO entry
        let mut run_of = vec![(DROPPED, 0u32); self.n_rows];
        let mut runs = CouplingRuns::new();
        // (matrix row, region, row of the region) of the rows merged
        let mut merged: Vec<(PetscInt, u32, u32)> = Vec::new();
        for (ri, (kept, all_cols, first)) in self.regions.iter().enumerate() {
            // the region's skew rows share a pattern, its columns in order
            let mut skew_pattern = DROPPED;
            for (a, &gi) in kept.iter().enumerate() {
                let (row, sk) = target(gi);
                let Some(sr) = sk else {
                    merged.push((row, ri as u32, a as u32));
                    continue;
                };
                if skew_pattern == DROPPED {
                    skew_pattern = runs.push(all_cols);
                }
                run_of[first + a] = (skew_pattern, coo_index(rows.len())?);
                for &gj in all_cols {
                    note_skew(sr, rows.len(), gj, scale, extra);
                    rows.push(row);
                    cols.push(gj);
                }
            }
        }
        merged.sort_unstable();
        // whether a column is in the current row's run yet
        let mut in_run = vec![false; n_global];
        // the last merged run: its first COO entry, its end, its pattern
        let mut last: Option<(usize, usize, u32)> = None;
        let mut i = 0;
        while i < merged.len() {
            let row = merged[i].0;
            let j = i + merged[i..].iter().take_while(|m| m.0 == row).count();
            let run_start = rows.len();
            for &(_, ri, _) in &merged[i..j] {
                for &gj in &self.regions[ri as usize].1 {
                    let seen = &mut in_run[gj as usize];
                    if !*seen {
                        *seen = true;
                        rows.push(row);
                        cols.push(gj);
                    }
                }
            }
            for &g in &cols[run_start..] {
                in_run[g as usize] = false;
            }
            // the unknowns of a node have the same columns in the same order
            let pattern = match last {
                Some((s, e, p)) if cols[s..e] == cols[run_start..] => p,
                _ => runs.push(&cols[run_start..]),
            };
            last = Some((run_start, rows.len(), pattern));
            let at = coo_index(run_start)?;
            coo_index(rows.len())?;
            for &(_, ri, a) in &merged[i..j] {
                run_of[self.regions[ri as usize].2 + a as usize] = (pattern, at);
            }
            i = j;
        }
        let scattered = self
            .block_rows
            .iter()
            .map(|(first, rr)| BlockScatter {
                rows: rr
                    .iter()
                    .map(|&a| {
                        if a == DROPPED {
                            (DROPPED, 0)
                        } else {
                            run_of[first + a as usize]
                        }
                    })
                    .collect(),
            })
            .collect();
        Ok((scattered, runs))
    }
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
                // Every rank builds its entries before the collective preallocation: a rank that
                // cannot (too many entries for the index maps) stops every rank, which would
                // otherwise wait in `MatSetPreallocationCOO` for it.
                let local = self.coo_pattern(lo, hi);
                let failed = i32::from(local.is_err());
                let mut any = 0i32;
                self.comm()
                    .all_reduce_into(&failed, &mut any, SystemOperation::max());
                let (mut rows, mut cols) = match local {
                    Err(e) => return Err(e),
                    Ok(_) if any != 0 => {
                        return Err(PetscError {
                            code: 0,
                            function: "build_pattern",
                            message: "another rank could not build its part of the Jacobian's \
                                      pattern (its own message says why)"
                                .into(),
                        })
                    }
                    Ok(p) => p,
                };
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

    /// This rank's COO entries of the pattern (rows, columns) for the owned rows `lo..hi`: the
    /// cells' merged entries, the coupling set's regions, the diagonal block and the skew rows'
    /// entries; records where each part lies for the assembly. Not collective.
    fn coo_pattern(
        &mut self,
        lo: PetscInt,
        hi: PetscInt,
    ) -> Result<(Vec<PetscInt>, Vec<PetscInt>), PetscError> {
        if injected_failure(self.comm().rank()) {
            return Err(PetscError {
                code: 0,
                function: "build_pattern",
                message: format!(
                    "the Jacobian's pattern failed on rank {} (injected by \
                     NURBS_CONTACT_FAIL_PATTERN_ON_RANK)",
                    self.comm().rank()
                ),
            });
        }
        let mut rows: Vec<PetscInt> = Vec::new();
        let mut cols: Vec<PetscInt> = Vec::new();
        // The cells' entries, merged (built once: they do not change with the contact
        // pattern).
        if self.cells.is_none() {
            self.cells = Some(CellPattern::build(
                &self.restrict,
                &self.constrained,
                &self.skew,
                self.dofs.n_global(),
            )?);
        }
        let cells = self.cells.as_ref().expect("built just above");
        cells.push_coo(&mut rows, &mut cols);
        let mut scale = cells.skew_scale.clone();
        let mut extra = cells.skew_extra.clone();
        self.timers.cell_entries = cells.element_entries();
        // The coupling set's blocks (contact: rows of a surface element, columns of it
        // and of its partner). Blocks whose keys share the first two components (contact:
        // the half-pass and the surface element) share one region, the union of their rows
        // times the union of their columns, and the regions' entries are merged before
        // PETSc sees them: each (row, column) of the regions gets one COO entry. The regions
        // of neighbouring surface elements overlap in most of their entries (the weighted
        // gaps' rows reach every column of their control points' supports), and PETSc
        // would otherwise hold, sort and sum each of them once per region. A matrix row's
        // merged entries are one run of consecutive COO entries; a block row finds its
        // columns in its row's run through the run's column pattern (`CouplingRuns`), which
        // the rows of a node share. Skew rows keep a run per region (their values are
        // scaled onto the node's other rows entry by entry).
        if let Some(c) = &mut self.coupled {
            c.blocks = match c.preset.take() {
                Some(p) => p,
                None => c.set.band_blocks(c.ring),
            };
            c.first_slot = cells.offsets.len() - 1;
            let mut regions = Regions::default();
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
                // rows that reach the matrix (not constrained, or skew rows moved)
                regions.add(&dofs, |gi| {
                    row_target(&self.constrained, &self.skew, gi).0 >= 0
                });
                start = end;
            }
            self.timers.region_entries = self.timers.region_entries.max(regions.entries);
            (c.block_scatter, c.runs) = regions.runs(
                |gi| row_target(&self.constrained, &self.skew, gi),
                self.dofs.n_global(),
                (&mut rows, &mut cols),
                (&mut scale, &mut extra),
            )?;
            self.timers.run_columns = self.timers.run_columns.max(c.runs.cols.len());
        }
        // A final block with the diagonal of every owned row: identity rows of the
        // constrained unknowns, the pseudo-transient damping (or zero) on the free ones.
        let diag_start = rows.len();
        for g in lo..hi {
            rows.push(g);
            cols.push(g);
        }
        self.coo_diag = (diag_start, rows.len());
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
        Ok((rows, cols))
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::assembly::{CellMap, CooSink, DenseSink};

    /// Overlapping regions with a skew row, a constrained row and a column without an unknown:
    /// blocks and a cross block added through the runs, the skew rows' values moved as the
    /// assembler moves them, give the dense matrix's values; the rows of a node share a pattern.
    #[test]
    fn overlapping_regions_with_a_skew_row_give_the_dense_matrix() {
        let n = 8;
        // row 3 is skew (x_3 = 0.5 x_4 + 2 x_5), row 7 constrained
        let sr = SkewRow {
            dep: 3,
            others: vec![(4, 0.5), (5, 2.0)],
        };
        let target = |gi: PetscInt| match gi {
            3 => (4, Some(&sr)),
            7 => (-1, None),
            g => (g, None),
        };
        let blocks: Vec<Vec<(Vec<PetscInt>, Vec<PetscInt>)>> = vec![
            vec![
                (vec![0, 3, 7], vec![0, 3, 7, 1]),
                (vec![0, 3, 7], vec![0, 3, 7, 5, -1, 6]),
            ],
            vec![
                (vec![1, 0, 3], vec![1, 0, 3, 2]),
                (vec![1, 0, 3], vec![1, 0, 3, 6, 5]),
            ],
            vec![(vec![5, 6], vec![5, 6, 2])],
        ];
        let mut regions = Regions::default();
        for dofs in &blocks {
            regions.add(dofs, |gi| target(gi).0 >= 0);
        }
        // entries before the regions' (an element block)
        let (mut rows, mut cols) = (vec![0, 0], vec![0, 1]);
        let (mut scale, mut extra) = (Vec::new(), Vec::new());
        let (scattered, runs) = regions
            .runs(target, n, (&mut rows, &mut cols), (&mut scale, &mut extra))
            .unwrap();
        // a skew pattern in each of the two regions with row 3, one for each of the merged rows
        // 0 and 1, and one that rows 5 and 6 (a node: only in the last region) share
        assert_eq!(runs.len(), 2 + 2 + 1);
        let (r5, r6) = (scattered[4].rows[0], scattered[4].rows[1]);
        assert_eq!(r5.0, r6.0);
        assert_eq!(r6.1, r5.1 + 3);
        let mut copies = Vec::new();
        for (o, gj, src, a) in extra {
            copies.push((src, rows.len(), a));
            rows.push(o);
            cols.push(gj);
        }
        let mut values = vec![0.0; rows.len()];
        let cells = CellMap {
            offsets: &[0, 2],
            map: &[0, 1],
        };
        let mut sink = CooSink::new(cells, &mut values, &scattered, &runs, 1);
        let mut dense = DenseSink::new(n);
        let mut slot = 1;
        let mut next = 1.0;
        for dofs in &blocks {
            for (r, c) in dofs {
                let k: Vec<f64> = (0..r.len() * c.len()).map(|i| next + i as f64).collect();
                next += k.len() as f64;
                sink.add_block(slot, r, c, &k);
                let dense_rows: Vec<_> = r.iter().map(|&g| if g == 7 { -1 } else { g }).collect();
                dense.add_block(slot, &dense_rows, c, &k);
                slot += 1;
            }
        }
        // rows of the first region's second block from its row 1 (3, 7) times the columns of
        // its first block from column 2 (7, 1)
        let k = [100.0, 200.0, 300.0, 400.0];
        sink.add_cross((2, 1), (1, 2), &[3, 7], &[7, 1], &k);
        dense.add_cross((2, 1), (1, 2), &[3, -1], &[7, 1], &k);
        for &(src, dst, a) in &copies {
            values[dst] = a * values[src];
        }
        for &(i, a) in &scale {
            values[i] *= a;
        }
        let mut coo = vec![0.0; n * n];
        for ((&i, &j), &v) in rows.iter().zip(&cols).zip(&values) {
            coo[i as usize * n + j as usize] += v;
        }
        let mut expect = dense.a.clone();
        for j in 0..n {
            let d = expect[3 * n + j];
            expect[4 * n + j] += 0.5 * d;
            expect[5 * n + j] += 2.0 * d;
            expect[3 * n + j] = 0.0;
        }
        for i in 0..n {
            for j in 0..n {
                assert_eq!(coo[i * n + j], expect[i * n + j], "entry ({i}, {j})");
            }
        }
        // a matrix row's entries are merged: each (row, column) of the merged rows at most once
        let mut seen: Vec<_> = rows[2..]
            .iter()
            .zip(&cols[2..])
            .take(rows.len() - 2 - copies.len())
            .filter(|(&i, _)| i != 4)
            .collect();
        let all = seen.len();
        seen.sort_unstable();
        seen.dedup();
        assert_eq!(seen.len(), all);
        assert!(all > 0);
    }
}
