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
/// starting at `offsets[slot]`.
pub struct CooSink<'a> {
    /// Start of each element's block in `values`. [n_elements + 1]
    pub offsets: &'a [usize],
    /// The COO value array handed to `MatSetValuesCOO`.
    pub values: &'a mut [f64],
}

impl MatrixSink for CooSink<'_> {
    fn add(&mut self, slot: usize, _dofs: &[i32], k_e: &[f64]) {
        let start = self.offsets[slot];
        self.values[start..start + k_e.len()].copy_from_slice(k_e);
    }
    fn add_block(&mut self, slot: usize, _rows: &[i32], _cols: &[i32], k: &[f64]) {
        let start = self.offsets[slot];
        self.values[start..start + k.len()].copy_from_slice(k);
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
