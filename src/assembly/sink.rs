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
    /// The slot of the first coupling block.
    pub first_scattered: usize,
}

/// Where a coupling block's entries go in the COO values: blocks that share rows (contact: those
/// of one surface element) share one dense `[rows][stride]` region from `base`, the union of their
/// rows and columns, so that PETSc receives each of their matrix entries once instead of once per
/// block. Entry `(a, b)` of the block is added at `base + rows[a] * stride + cols[b]`; `u32::MAX`
/// drops a row (constrained, or no unknown) or a column (no unknown).
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
            let out = &mut self.values[s.base + ra as usize * s.stride..][..s.stride];
            for (&cb, &v) in s.cols.iter().zip(&k[a * nc..(a + 1) * nc]) {
                if cb != u32::MAX {
                    out[cb as usize] += v;
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
        let mut sink = CooSink {
            offsets: &offsets,
            values: &mut values,
            scattered: &scattered,
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
}
