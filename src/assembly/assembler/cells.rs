//! The cells' part of the COO pattern: one COO entry per matrix entry that this rank's cells reach,
//! and for every entry of every element matrix the COO entry it adds into.
//!
//! Neighbouring cells share most of their matrix entries (a trilinear hex's 576 entries are shared
//! with up to 7 other cells, 2.4 element entries per matrix entry on a hex mesh), so handing PETSc
//! one COO entry per element entry would make it hold, sort and sum each matrix entry once per cell
//! that reaches it, and the COO arrays, not the matrix, would set the memory peak. The pattern
//! depends only on the cells, the constrained rows and the skew rows, so it is built once and kept
//! across the contact pattern's rebuilds, which only append entries after it.

use super::pattern::{coo_index, note_skew, row_target};
use super::Restriction;
use crate::assembly::skew::SkewRows;
use crate::assembly::DROPPED;
use crate::petsc::{PetscError, PetscInt};

/// The cells' COO entries and where each element entry goes.
#[derive(Debug, Clone, Default)]
pub(super) struct CellPattern {
    /// Start of each cell's entries in `map`, over the element sets in order. [n_cells + 1]
    pub offsets: Vec<usize>,
    /// Per element entry (row-major, the element's unknowns in order): the COO entry it adds into,
    /// or `DROPPED` (its row is constrained, or its column or row has no unknown).
    pub map: Vec<u32>,
    /// The distinct rows of the merged entries, ascending.
    rows: Vec<PetscInt>,
    /// Start of each of those rows' columns in `cols`. [rows.len() + 1]
    start: Vec<usize>,
    /// Each merged row's columns, ascending: the merged entries are `(rows[i], cols[k])` for `k` in
    /// `start[i]..start[i + 1]`, in that order, COO entries `0..cols.len()`.
    cols: Vec<PetscInt>,
    /// Element entries of skew rows, each its own COO entry after the merged ones (their values
    /// are scaled onto the node's other rows one by one): (matrix row, column).
    skew_entries: Vec<(PetscInt, PetscInt)>,
    /// The skew entries' weights on their first other row: (COO entry, weight).
    pub skew_scale: Vec<(usize, f64)>,
    /// Entries on a skew row's further other rows: (row, column, source COO entry, weight).
    pub skew_extra: Vec<(PetscInt, PetscInt, usize, f64)>,
}

impl CellPattern {
    /// The pattern of the cells of `restrict`: rows that `constrained` marks are dropped, skew
    /// rows go to their node's other rows ([`row_target`]); `n_global` bounds the unknowns.
    pub fn build(
        restrict: &[Restriction],
        constrained: &[bool],
        skew: &SkewRows,
        n_global: usize,
    ) -> Result<Self, PetscError> {
        let target = |gi: PetscInt| row_target(constrained, skew, gi);
        // each element's unknowns, over the sets
        let elements = || {
            restrict
                .iter()
                .flat_map(|r| r.offsets.windows(2).map(move |w| &r.global[w[0]..w[1]]))
        };
        // the merged rows (not skew, not dropped), ascending, and a compact index for each
        let mut row_of = vec![DROPPED; n_global];
        let mut rows = Vec::new();
        for g in elements() {
            for &gi in g {
                let (row, sk) = target(gi);
                if row >= 0 && sk.is_none() && row_of[row as usize] == DROPPED {
                    row_of[row as usize] = 0;
                    rows.push(row);
                }
            }
        }
        rows.sort_unstable();
        for (i, &r) in rows.iter().enumerate() {
            row_of[r as usize] = i as u32;
        }
        // every merged row's columns, with repeats, then sorted and made unique in place
        let mut start = vec![0usize; rows.len() + 1];
        for g in elements() {
            let n_cols = g.iter().filter(|&&gj| gj >= 0).count();
            for &gi in g {
                let (row, sk) = target(gi);
                if row >= 0 && sk.is_none() {
                    start[row_of[row as usize] as usize + 1] += n_cols;
                }
            }
        }
        for i in 0..rows.len() {
            start[i + 1] += start[i];
        }
        let mut fill = start.clone();
        let mut cols = vec![0 as PetscInt; start[rows.len()]];
        for g in elements() {
            for &gi in g {
                let (row, sk) = target(gi);
                if row < 0 || sk.is_some() {
                    continue;
                }
                let at = &mut fill[row_of[row as usize] as usize];
                for &gj in g.iter().filter(|&&gj| gj >= 0) {
                    cols[*at] = gj;
                    *at += 1;
                }
            }
        }
        drop(fill);
        let mut kept = 0;
        for i in 0..rows.len() {
            let (a, b) = (start[i], start[i + 1]);
            cols[a..b].sort_unstable();
            start[i] = kept;
            let mut last = None;
            for k in a..b {
                if last != Some(cols[k]) {
                    last = Some(cols[k]);
                    cols[kept] = cols[k];
                    kept += 1;
                }
            }
        }
        start[rows.len()] = kept;
        cols.truncate(kept);
        cols.shrink_to_fit();
        coo_index(kept)?;
        // where each element entry goes
        let mut p = CellPattern {
            offsets: vec![0],
            rows,
            start,
            cols,
            ..Default::default()
        };
        let n_entries: usize = elements().map(|g| g.len() * g.len()).sum();
        p.map.reserve_exact(n_entries);
        for g in elements() {
            for &gi in g {
                let (row, sk) = target(gi);
                if row < 0 {
                    p.map.extend(std::iter::repeat_n(DROPPED, g.len()));
                    continue;
                }
                if let Some(sr) = sk {
                    for &gj in g {
                        if gj < 0 {
                            p.map.push(DROPPED);
                            continue;
                        }
                        let idx = p.cols.len() + p.skew_entries.len();
                        p.map.push(coo_index(idx)?);
                        note_skew(sr, idx, gj, &mut p.skew_scale, &mut p.skew_extra);
                        p.skew_entries.push((row, gj));
                    }
                    continue;
                }
                let i = row_of[row as usize] as usize;
                let (a, b) = (p.start[i], p.start[i + 1]);
                let run = &p.cols[a..b];
                for &gj in g {
                    p.map.push(if gj < 0 {
                        DROPPED
                    } else {
                        // every column of the element is in its rows' runs (built from them)
                        (a + run
                            .binary_search(&gj)
                            .expect("a cell column outside its row")) as u32
                    });
                }
            }
            p.offsets.push(p.map.len());
        }
        Ok(p)
    }

    /// Number of COO entries (the merged ones, then the skew rows').
    pub fn len(&self) -> usize {
        self.cols.len() + self.skew_entries.len()
    }

    /// Number of element entries.
    pub fn element_entries(&self) -> usize {
        self.map.len()
    }

    /// Pushes the COO entries onto `rows` and `cols`, which must be empty (the map's entries
    /// count from 0).
    pub fn push_coo(&self, rows: &mut Vec<PetscInt>, cols: &mut Vec<PetscInt>) {
        debug_assert!(rows.is_empty() && cols.is_empty());
        rows.reserve(self.len());
        cols.reserve(self.len());
        for (i, &r) in self.rows.iter().enumerate() {
            let run = &self.cols[self.start[i]..self.start[i + 1]];
            rows.extend(std::iter::repeat_n(r, run.len()));
            cols.extend_from_slice(run);
        }
        for &(r, c) in &self.skew_entries {
            rows.push(r);
            cols.push(c);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::assembly::skew::SkewRow;

    fn restriction(elements: &[&[PetscInt]]) -> Restriction {
        let mut r = Restriction {
            offsets: vec![0],
            local: Vec::new(),
            global: Vec::new(),
        };
        for g in elements {
            r.global.extend_from_slice(g);
            r.local.extend(g.iter().map(|_| 0));
            r.offsets.push(r.global.len());
        }
        r
    }

    /// Three elements sharing unknowns, a constrained row, an unknown-less entry and a skew row:
    /// the merged entries are distinct, and adding every element entry at its mapped COO entry
    /// (then moving the skew rows' values as the assembler does) gives the dense matrix.
    #[test]
    fn shared_entries_are_merged_and_sum_to_the_dense_matrix() {
        let n = 7;
        let e: [&[PetscInt]; 3] = [&[0, 1, 2], &[1, 2, 3, -1], &[3, 4, 5, 6]];
        let restrict = [restriction(&e[..2]), restriction(&e[2..])];
        // row 6 constrained, row 5 skew: x_5 = 0.5 x_3 + 2 x_4
        let mut constrained = vec![false; n];
        constrained[6] = true;
        constrained[5] = true;
        let skew = SkewRows::from_rows(vec![SkewRow {
            dep: 5,
            others: vec![(3, 0.5), (4, 2.0)],
        }]);
        let p = CellPattern::build(&restrict, &constrained, &skew, n).unwrap();
        let (mut rows, mut cols) = (Vec::new(), Vec::new());
        p.push_coo(&mut rows, &mut cols);
        let merged: Vec<_> = rows.iter().zip(&cols).take(p.cols.len()).collect();
        let mut distinct = merged.clone();
        distinct.dedup();
        assert_eq!(distinct.len(), merged.len());
        assert!(merged.windows(2).all(|w| w[0] < w[1]), "{merged:?}");
        // entries: rows 0-4 merged (row 3 reaches columns 1-6), row 5's 4 skew entries, row 6
        // dropped
        assert_eq!(p.cols.len(), 3 + 4 + 4 + 6 + 4);
        assert_eq!(p.len(), p.cols.len() + 4);
        assert_eq!(p.element_entries(), 9 + 16 + 16);
        let mut values = vec![0.0; p.len()];
        let mut dense = vec![0.0; n * n];
        let mut next = 1.0;
        for (slot, g) in e.iter().enumerate() {
            let m = &p.map[p.offsets[slot]..p.offsets[slot + 1]];
            for (a, &gi) in g.iter().enumerate() {
                for (b, &gj) in g.iter().enumerate() {
                    let v = next;
                    next += 1.0;
                    if m[a * g.len() + b] != DROPPED {
                        values[m[a * g.len() + b] as usize] += v;
                    }
                    if gi >= 0 && gj >= 0 && gi != 6 {
                        dense[gi as usize * n + gj as usize] += v;
                    }
                }
            }
        }
        // the skew row's values onto its other rows
        for &(o, gj, src, a) in &p.skew_extra {
            rows.push(o);
            cols.push(gj);
            values.push(a * values[src]);
        }
        for &(i, a) in &p.skew_scale {
            values[i] *= a;
        }
        for j in 0..n {
            let d = dense[5 * n + j];
            dense[3 * n + j] += 0.5 * d;
            dense[4 * n + j] += 2.0 * d;
            dense[5 * n + j] = 0.0;
        }
        let mut coo = vec![0.0; n * n];
        for ((&i, &j), &v) in rows.iter().zip(&cols).zip(&values) {
            coo[i as usize * n + j as usize] += v;
        }
        for i in 0..n {
            for j in 0..n {
                assert_eq!(coo[i * n + j], dense[i * n + j], "entry ({i}, {j})");
            }
        }
        // every dropped element entry is one of the constrained row or the unknown-less column
        let dropped = p.map.iter().filter(|&&m| m == DROPPED).count();
        assert_eq!(dropped, 4 + 4 + 3);
    }
}
