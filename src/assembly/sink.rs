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

/// Values laid out in the order of a COO pattern: element `slot` owns `n_e^2` consecutive entries
/// starting at `offsets[slot]`; slots from `first_scattered` on are coupling blocks, added
/// through `scattered` into entries they share with other blocks.
pub struct CooSink<'a> {
    /// Start of each element's block in `values`. [n_elements + 1]
    pub offsets: &'a [usize],
    /// The COO value array handed to `MatSetValuesCOO`.
    pub values: &'a mut [f64],
    /// Where the entries of coupling block `slot - first_scattered` go.
    pub scattered: &'a [BlockScatter],
    /// The COO entry of each entry of the coupling blocks' regions.
    pub region_map: &'a [u32],
    /// The slot of the first coupling block.
    pub first_scattered: usize,
}

/// Where a coupling block's entries go in the COO values: blocks that share rows (contact: those
/// of one surface element) share one dense `[rows][stride]` region from `base`, the union of their
/// rows and columns, in the region map, which holds the COO entry of each region entry (regions
/// that hold the same matrix entry map it to one COO entry). Entry `(a, b)` of the block is added
/// at COO entry `region_map[base + rows[a] * stride + cols[b]]`; `u32::MAX` drops a row
/// (constrained, or no unknown) or a column (no unknown).
#[derive(Debug, Clone, Default)]
pub struct BlockScatter {
    /// First COO entry of the shared region.
    pub base: usize,
    /// Columns of the shared region.
    pub stride: usize,
    /// Row of the shared region of each block row.
    pub rows: Vec<u32>,
    /// Column of the shared region of each block column.
    pub cols: Vec<u32>,
}

impl MatrixSink for CooSink<'_> {
    fn add(&mut self, slot: usize, _dofs: &[i32], k_e: &[f64]) {
        let start = self.offsets[slot];
        self.values[start..start + k_e.len()].copy_from_slice(k_e);
    }
    fn add_block(&mut self, slot: usize, _rows: &[i32], _cols: &[i32], k: &[f64]) {
        if slot < self.first_scattered {
            let start = self.offsets[slot];
            self.values[start..start + k.len()].copy_from_slice(k);
            return;
        }
        let s = &self.scattered[slot - self.first_scattered];
        let nc = s.cols.len();
        for (a, &ra) in s.rows.iter().enumerate() {
            if ra == u32::MAX {
                continue;
            }
            let at = &self.region_map[s.base + ra as usize * s.stride..][..s.stride];
            for (&cb, &v) in s.cols.iter().zip(&k[a * nc..(a + 1) * nc]) {
                if cb != u32::MAX {
                    self.values[at[cb as usize] as usize] += v;
                }
            }
        }
    }
    fn add_cross(
        &mut self,
        (row_slot, row_from): (usize, usize),
        (col_slot, col_from): (usize, usize),
        rows: &[i32],
        cols: &[i32],
        k: &[f64],
    ) {
        let scattered = self.scattered;
        let first = self.first_scattered;
        let (sr, sc) = (&scattered[row_slot - first], &scattered[col_slot - first]);
        assert!(
            sr.base == sc.base && sr.stride == sc.stride,
            "a cross block spans two regions (slots {row_slot} and {col_slot})"
        );
        let (base, stride) = (sr.base, sr.stride);
        let rmap = &sr.rows[row_from..row_from + rows.len()];
        let cmap = &sc.cols[col_from..col_from + cols.len()];
        let nc = cols.len();
        for (a, &ra) in rmap.iter().enumerate() {
            if ra == u32::MAX {
                continue;
            }
            let at = &self.region_map[base + ra as usize * stride..][..stride];
            for (&cb, &v) in cmap.iter().zip(&k[a * nc..(a + 1) * nc]) {
                if cb != u32::MAX {
                    self.values[at[cb as usize] as usize] += v;
                }
            }
        }
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

    /// Two coupling blocks of one region (rows of an element, columns of it and of two partners
    /// that share an unknown) add up in the COO values as in a dense matrix, a dropped row and
    /// column included.
    #[test]
    fn scattered_blocks_sum_into_their_shared_region() {
        // block 0: rows [0, 1], cols [0, 1, 2, 3]; block 1: rows [0, 1], cols [0, 1, 3, -1]
        let rows = [0, 1];
        let (c0, c1) = ([0, 1, 2, 3], [0, 1, 3, -1]);
        let k0: Vec<f64> = (0..8).map(|i| 1.0 + i as f64).collect();
        let k1: Vec<f64> = (0..8).map(|i| 10.0 * (1.0 + i as f64)).collect();
        // the region: rows [0, 1] x union of columns [0, 1, 2, 3], row 1 dropped (constrained)
        let union = [0, 1, 2, 3];
        let scattered = vec![
            BlockScatter {
                base: 2,
                stride: 4,
                rows: vec![0, u32::MAX],
                cols: vec![0, 1, 2, 3],
            },
            BlockScatter {
                base: 2,
                stride: 4,
                rows: vec![0, u32::MAX],
                cols: vec![0, 1, 3, u32::MAX],
            },
        ];
        let offsets = [0, 2, 6];
        let mut values = vec![0.0; 6];
        // the region's entries are COO entries 2.. in order
        let region_map: Vec<u32> = (0..6).collect();
        let mut sink = CooSink {
            offsets: &offsets,
            values: &mut values,
            scattered: &scattered,
            region_map: &region_map,
            first_scattered: 1,
        };
        sink.add_block(1, &rows, &c0, &k0);
        sink.add_block(2, &rows, &c1, &k1);
        let mut dense = DenseSink::new(4);
        dense.add_block(0, &[0, -1], &c0, &k0);
        dense.add_block(0, &[0, -1], &c1, &k1);
        assert_eq!(&values[..2], &[0.0, 0.0]);
        for (b, &j) in union.iter().enumerate() {
            assert_eq!(values[2 + b], dense.a[j as usize], "column {j}");
        }
    }

    /// Two regions that hold the same matrix entry map it to one COO entry, which receives the
    /// sum of both blocks' values there, as the dense matrix does.
    #[test]
    fn regions_sharing_a_matrix_entry_add_into_one_coo_entry() {
        // region 0: row [0] x cols [0, 1]; region 1: row [0] x cols [1, 2]; matrix entry (0, 1)
        // in both: COO entries 0 (0,0), 1 (0,1), 2 (0,2)
        let scattered = vec![
            BlockScatter {
                base: 0,
                stride: 2,
                rows: vec![0],
                cols: vec![0, 1],
            },
            BlockScatter {
                base: 2,
                stride: 2,
                rows: vec![0],
                cols: vec![0, 1],
            },
        ];
        let region_map = [0, 1, 1, 2];
        let offsets = [0, 3];
        let mut values = vec![0.0; 3];
        let mut sink = CooSink {
            offsets: &offsets,
            values: &mut values,
            scattered: &scattered,
            region_map: &region_map,
            first_scattered: 0,
        };
        sink.add_block(0, &[0], &[0, 1], &[1.0, 2.0]);
        sink.add_block(1, &[0], &[1, 2], &[30.0, 40.0]);
        let mut dense = DenseSink::new(3);
        dense.add_block(0, &[0], &[0, 1], &[1.0, 2.0]);
        dense.add_block(1, &[0], &[1, 2], &[30.0, 40.0]);
        assert_eq!(values, dense.a[..3]);
        assert_eq!(values, [1.0, 32.0, 40.0]);
    }

    /// A cross block (the rows of one block from a row on, the columns of another) lands where
    /// the dense matrix puts it, within the region the two blocks share.
    #[test]
    fn cross_blocks_add_rows_of_one_block_times_columns_of_another() {
        // region rows [0, 1, 2] x cols [0, 1, 2, 3]; block 0: rows [0, 1], cols [0, 1];
        // block 1: rows [0, 1, 2], cols [0, 1, 2, 3] (row 1 constrained)
        let scattered = vec![
            BlockScatter {
                base: 0,
                stride: 4,
                rows: vec![0, u32::MAX],
                cols: vec![0, 1],
            },
            BlockScatter {
                base: 0,
                stride: 4,
                rows: vec![0, u32::MAX, 2],
                cols: vec![0, 1, 2, 3],
            },
        ];
        let offsets = [0, 12];
        let mut values = vec![0.0; 12];
        let region_map: Vec<u32> = (0..12).collect();
        let mut sink = CooSink {
            offsets: &offsets,
            values: &mut values,
            scattered: &scattered,
            region_map: &region_map,
            first_scattered: 0,
        };
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
}
