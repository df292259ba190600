//! Where element matrices go: a trait that a dense test matrix and PETSc's COO arrays both implement,
//! so that kernels and assembly loops are tested without MPI (dolfinx `la::MatSet`).

/// Receives one element matrix at a time, in a fixed element order (`slot` counts elements over all
/// sets, so a COO sink knows where its values go without searching).
pub trait MatrixSink {
    /// Adds `k_e` [dofs.len()][dofs.len()] at global indices `dofs` (negative: dropped row/column).
    fn add(&mut self, slot: usize, dofs: &[i32], k_e: &[f64]);
    /// Adds a rectangular block `k` [rows.len()][cols.len()] (contact couplings: rows of one
    /// element, columns of it and of its partner).
    fn add_block(&mut self, slot: usize, rows: &[i32], cols: &[i32], k: &[f64]);
    /// Adds `k` [rows.len()][cols.len()] at global `rows` x `cols` that are the rows of coupling
    /// block `row_slot` from its row `row_from` on and the columns of coupling block `col_slot`
    /// from its column `col_from` on, two blocks of one shared region (contact's one-pass mortar
    /// gap: master rows of one block times the columns of another). Sinks that place values by
    /// their global indices add it as any block.
    fn add_cross(
        &mut self,
        (row_slot, _row_from): (usize, usize),
        (_col_slot, _col_from): (usize, usize),
        rows: &[i32],
        cols: &[i32],
        k: &[f64],
    ) {
        self.add_block(row_slot, rows, cols, k);
    }
}

/// Where the elements' matrices go in the COO values: element `slot`'s `n_e^2` entries (row-major)
/// are `map[offsets[slot]..offsets[slot + 1]]`, each the COO entry it adds into (`DROPPED`: a
/// dropped row, or a column without an unknown). Elements that reach the same matrix entry add
/// into one COO entry.
#[derive(Debug, Clone, Copy)]
pub struct CellMap<'a> {
    /// Start of each element's entries in `map`. [n_elements + 1]
    pub offsets: &'a [usize],
    /// The COO entry of each element entry.
    pub map: &'a [u32],
}

/// Values laid out in the order of a COO pattern, which the sink adds into (they start at zero):
/// elements (slots below `first_scattered`) through their [`CellMap`]; slots from
/// `first_scattered` on are coupling blocks, added through `scattered` into entries they share
/// with other blocks.
pub struct CooSink<'a> {
    /// Where each element's entries go.
    pub cells: CellMap<'a>,
    /// The COO value array handed to `MatSetValuesCOO`.
    pub values: &'a mut [f64],
    /// Where the rows of coupling block `slot - first_scattered` go.
    pub scattered: &'a [BlockScatter],
    /// The column patterns of the coupling blocks' rows.
    pub runs: &'a CouplingRuns,
    /// The slot of the first coupling block.
    pub first_scattered: usize,
    /// Where each column of the block being added is in its row's run (scratch).
    positions: Vec<u32>,
}

impl<'a> CooSink<'a> {
    /// A sink over `values`, the elements' entries placed through `cells`, with the coupling
    /// blocks from slot `first_scattered` on placed through `scattered` and `runs`.
    pub fn new(
        cells: CellMap<'a>,
        values: &'a mut [f64],
        scattered: &'a [BlockScatter],
        runs: &'a CouplingRuns,
        first_scattered: usize,
    ) -> Self {
        CooSink {
            cells,
            values,
            scattered,
            runs,
            first_scattered,
            positions: Vec::new(),
        }
    }

    /// Adds `k` [rows.len()][cols.len()], block row `a` into the run `rows[a]`, at the entries of
    /// the global columns `cols` (negative: dropped).
    fn add_runs(&mut self, rows: &[(u32, u32)], cols: &[i32], k: &[f64]) {
        let runs = self.runs;
        let nc = cols.len();
        // the rows of a node share their column pattern: their columns are looked up once
        let mut looked_up = u32::MAX;
        for (a, &(pattern, start)) in rows.iter().enumerate() {
            if pattern == DROPPED {
                continue;
            }
            if pattern != looked_up {
                runs.positions(pattern, cols, &mut self.positions);
                looked_up = pattern;
            }
            let run = &mut self.values[start as usize..];
            for (&o, &v) in self.positions.iter().zip(&k[a * nc..(a + 1) * nc]) {
                if o != DROPPED {
                    run[o as usize] += v;
                }
            }
        }
    }
}

/// A dropped row or column of a coupling block (constrained, or no unknown).
pub const DROPPED: u32 = u32::MAX;

/// Where a coupling block's rows go in the COO values: each row of the coupling blocks that reaches
/// the matrix has a run of COO entries, the merged entries of its matrix row (one per column that
/// any block puts in that row) or, for a skew row, its own entries of its region (their values are
/// scaled onto the node's other rows entry by entry). Entry `(a, b)` of the block is added at the
/// entry of the block's global column `b` in the run of block row `a`.
#[derive(Debug, Clone, Default)]
pub struct BlockScatter {
    /// The run of each block row: its column pattern (`DROPPED`: the row is dropped) and its first
    /// COO entry.
    pub rows: Vec<(u32, u32)>,
}

/// The columns of the coupling blocks' runs, one pattern per distinct run layout (the rows of a
/// node share one): its columns sorted, with where each is in the run. The size follows the COO
/// entries of the coupling blocks, not their regions' entries (neighbouring regions overlap).
#[derive(Debug, Clone)]
pub struct CouplingRuns {
    /// Start of each pattern in `cols` and `offsets`. [n_patterns + 1]
    pub start: Vec<usize>,
    /// Each pattern's columns, sorted ascending.
    pub cols: Vec<i32>,
    /// Where each of them is in the run (from the run's first COO entry).
    pub offsets: Vec<u32>,
}

impl Default for CouplingRuns {
    fn default() -> Self {
        Self::new()
    }
}

impl CouplingRuns {
    /// No patterns.
    pub fn new() -> Self {
        CouplingRuns {
            start: vec![0],
            cols: Vec::new(),
            offsets: Vec::new(),
        }
    }

    /// Adds a pattern from a run's columns in COO order and returns its index.
    pub fn push(&mut self, run_cols: &[i32]) -> u32 {
        let from = self.cols.len();
        let mut pairs: Vec<(i32, u32)> =
            run_cols.iter().zip(0u32..).map(|(&g, o)| (g, o)).collect();
        pairs.sort_unstable();
        self.cols.extend(pairs.iter().map(|p| p.0));
        self.offsets.extend(pairs.iter().map(|p| p.1));
        self.start.push(self.cols.len());
        debug_assert!(self.cols[from..].windows(2).all(|w| w[0] < w[1]));
        (self.start.len() - 2) as u32
    }

    /// Number of patterns.
    pub fn len(&self) -> usize {
        self.start.len().saturating_sub(1)
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Where each of the global columns `cols` is in a run of `pattern` (`DROPPED` for a negative
    /// column), into `out`.
    ///
    /// Panics if a column is not in the pattern (the pattern was built from the blocks' columns).
    pub fn positions(&self, pattern: u32, cols: &[i32], out: &mut Vec<u32>) {
        let p = pattern as usize;
        let (pc, po) = (
            &self.cols[self.start[p]..self.start[p + 1]],
            &self.offsets[self.start[p]..self.start[p + 1]],
        );
        out.clear();
        out.extend(cols.iter().map(|&g| {
            if g < 0 {
                return DROPPED;
            }
            match pc.binary_search(&g) {
                Ok(i) => po[i],
                Err(_) => panic!("column {g} is not in the coupling pattern's row"),
            }
        }));
    }
}

impl CooSink<'_> {
    /// Adds element `slot`'s entries `k` at their COO entries.
    fn add_element(&mut self, slot: usize, k: &[f64]) {
        let start = self.cells.offsets[slot];
        debug_assert_eq!(self.cells.offsets[slot + 1] - start, k.len());
        for (&m, &v) in self.cells.map[start..start + k.len()].iter().zip(k) {
            if m != DROPPED {
                self.values[m as usize] += v;
            }
        }
    }
}

impl MatrixSink for CooSink<'_> {
    fn add(&mut self, slot: usize, _dofs: &[i32], k_e: &[f64]) {
        self.add_element(slot, k_e);
    }
    fn add_block(&mut self, slot: usize, _rows: &[i32], cols: &[i32], k: &[f64]) {
        if slot < self.first_scattered {
            self.add_element(slot, k);
            return;
        }
        let scattered = self.scattered;
        let s = &scattered[slot - self.first_scattered];
        debug_assert_eq!(s.rows.len() * cols.len(), k.len());
        self.add_runs(&s.rows, cols, k);
    }
    fn add_cross(
        &mut self,
        (row_slot, row_from): (usize, usize),
        (_col_slot, _col_from): (usize, usize),
        rows: &[i32],
        cols: &[i32],
        k: &[f64],
    ) {
        let scattered = self.scattered;
        let sr = &scattered[row_slot - self.first_scattered];
        self.add_runs(&sr.rows[row_from..row_from + rows.len()], cols, k);
    }
}

/// A dense matrix for tests (row-major, global indices).
pub struct DenseSink {
    /// Matrix size.
    pub n: usize,
    /// Values [n][n].
    pub a: Vec<f64>,
}

impl DenseSink {
    /// A zero matrix of size `n`.
    pub fn new(n: usize) -> Self {
        DenseSink {
            n,
            a: vec![0.0; n * n],
        }
    }
}

impl MatrixSink for DenseSink {
    fn add(&mut self, slot: usize, dofs: &[i32], k_e: &[f64]) {
        self.add_block(slot, dofs, dofs, k_e);
    }
    fn add_block(&mut self, _slot: usize, rows: &[i32], cols: &[i32], k: &[f64]) {
        let m = cols.len();
        for (a, &i) in rows.iter().enumerate() {
            if i < 0 {
                continue;
            }
            for (b, &j) in cols.iter().enumerate() {
                if j >= 0 {
                    self.a[i as usize * self.n + j as usize] += k[a * m + b];
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two coupling blocks of one row's run (rows of an element, columns of it and of two partners
    /// that share an unknown) add up in the COO values as in a dense matrix, a dropped row and
    /// column included; the run's columns are not in ascending order.
    #[test]
    fn scattered_blocks_sum_into_their_rows_runs() {
        // block 0: rows [0, 1], cols [0, 1, 2, 3]; block 1: rows [0, 1], cols [0, 1, 3, -1]
        let rows = [0, 1];
        let (c0, c1) = ([0, 1, 2, 3], [0, 1, 3, -1]);
        let k0: Vec<f64> = (0..8).map(|i| 1.0 + i as f64).collect();
        let k1: Vec<f64> = (0..8).map(|i| 10.0 * (1.0 + i as f64)).collect();
        // row 0's run: COO entries 2.. with columns [2, 0, 3, 1]; row 1 dropped (constrained)
        let run = [2, 0, 3, 1];
        let mut runs = CouplingRuns::new();
        let p = runs.push(&run);
        let scattered = vec![
            BlockScatter {
                rows: vec![(p, 2), (DROPPED, 0)],
            };
            2
        ];
        let cells = CellMap {
            offsets: &[0, 2],
            map: &[0, 1],
        };
        let mut values = vec![0.0; 6];
        let mut sink = CooSink::new(cells, &mut values, &scattered, &runs, 1);
        sink.add_block(1, &rows, &c0, &k0);
        sink.add_block(2, &rows, &c1, &k1);
        let mut dense = DenseSink::new(4);
        dense.add_block(0, &[0, -1], &c0, &k0);
        dense.add_block(0, &[0, -1], &c1, &k1);
        assert_eq!(&values[..2], &[0.0, 0.0]);
        for (o, &j) in run.iter().enumerate() {
            assert_eq!(values[2 + o], dense.a[j as usize], "column {j}");
        }
        assert_eq!(values[2..], [3.0, 11.0, 4.0 + 30.0, 2.0 + 20.0]);
    }

    /// Blocks of two regions that hold the same matrix entries add into one run, and the rows of a
    /// node (same columns in the same order) share one column pattern at their own entries; the
    /// values are those of the dense matrix.
    #[test]
    fn regions_sharing_a_row_add_into_one_run() {
        // region 0: rows [0, 1] x cols [0, 1]; region 1: rows [0, 1] x cols [1, 2]; rows 0 and 1
        // have the runs [0, 1, 2] at COO entries 0.. and 3..
        let mut runs = CouplingRuns::new();
        let p = runs.push(&[0, 1, 2]);
        let scattered = vec![
            BlockScatter {
                rows: vec![(p, 0), (p, 3)],
            };
            2
        ];
        let cells = CellMap {
            offsets: &[0],
            map: &[],
        };
        let mut values = vec![0.0; 6];
        let k0 = [1.0, 2.0, 3.0, 4.0];
        let k1 = [10.0, 20.0, 30.0, 40.0];
        let mut sink = CooSink::new(cells, &mut values, &scattered, &runs, 0);
        sink.add_block(0, &[0, 1], &[0, 1], &k0);
        sink.add_block(1, &[0, 1], &[1, 2], &k1);
        let mut dense = DenseSink::new(3);
        dense.add_block(0, &[0, 1], &[0, 1], &k0);
        dense.add_block(1, &[0, 1], &[1, 2], &k1);
        assert_eq!(values, dense.a[..6]);
        assert_eq!(values, [1.0, 12.0, 20.0, 3.0, 34.0, 40.0]);
    }

    /// A cross block (the rows of one block from a row on, the columns of another) lands where
    /// the dense matrix puts it.
    #[test]
    fn cross_blocks_add_rows_of_one_block_times_columns_of_another() {
        // rows [0, 1, 2] x cols [0, 1, 2, 3], row 1 constrained; runs: row 0 at 0.., row 2 at 8..
        let mut runs = CouplingRuns::new();
        let p = runs.push(&[0, 1, 2, 3]);
        let scattered = vec![
            BlockScatter {
                rows: vec![(p, 0), (DROPPED, 0)],
            },
            BlockScatter {
                rows: vec![(p, 0), (DROPPED, 0), (p, 8)],
            },
        ];
        let cells = CellMap {
            offsets: &[0],
            map: &[],
        };
        let mut values = vec![0.0; 12];
        let mut sink = CooSink::new(cells, &mut values, &scattered, &runs, 0);
        // rows of block 1 from row 1 (global 1, 2), columns of block 1 from column 2 (global 2, 3)
        let k = [1.0, 2.0, 3.0, 4.0];
        sink.add_cross((1, 1), (1, 2), &[1, 2], &[2, 3], &k);
        // rows of block 1 from row 2 (global 2), columns of block 0 (global 0, 1)
        sink.add_cross((1, 2), (0, 0), &[2], &[0, 1], &[5.0, 6.0]);
        let mut dense = DenseSink::new(4);
        dense.add_cross((1, 1), (1, 2), &[-1, 2], &[2, 3], &k);
        dense.add_cross((1, 2), (0, 0), &[2], &[0, 1], &[5.0, 6.0]);
        for (r, &i) in [0, 1, 2].iter().enumerate() {
            for j in 0..4 {
                let coo = if i == 1 { 0.0 } else { values[r * 4 + j] };
                assert_eq!(coo, dense.a[i * 4 + j], "entry ({i}, {j})");
            }
        }
        assert_eq!(&values[8..], &[5.0, 6.0, 3.0, 4.0]);
    }

    /// A column missing from its row's pattern is a bug in the pattern, not a value to drop.
    #[test]
    #[should_panic(expected = "column 5 is not in the coupling pattern's row")]
    fn a_column_outside_the_pattern_panics() {
        let mut runs = CouplingRuns::new();
        let p = runs.push(&[3, 1]);
        let mut out = Vec::new();
        runs.positions(p, &[1, -1, 3], &mut out);
        assert_eq!(out, [1, DROPPED, 0]);
        runs.positions(p, &[5], &mut out);
    }
}
