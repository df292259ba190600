//! Pseudo-transient damping `c D (u - u_prev)` on the free rows (the damped rescue of a step),
//! with `D` the assembled diagonal of the stiffness.

use super::{Assembler, ProblemError};
use crate::assembly::MatrixSink;
use crate::petsc::{PetscError, Vector};
use mpi::collective::SystemOperation;
use mpi::traits::*;

/// Collects the diagonal entries of element and coupling matrices by global row. [n_global]
pub(super) struct DiagSink {
    diag: Vec<f64>,
}

impl MatrixSink for DiagSink {
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
                if i == j {
                    self.diag[i as usize] += k[a * m + b];
                }
            }
        }
    }
}

impl Assembler<'_> {
    /// Computes `D`, the assembled diagonal of the stiffness at `x` (elements and couplings), for
    /// [`Assembler::set_damping`]. Entries are floored at `1e-12` of the largest so that `D > 0`.
    ///
    /// Collective.
    pub fn compute_damping_diagonal(&mut self, x: &Vector) -> Result<(), ProblemError> {
        let cu = self.prepare_couplings(x, false);
        self.agree(cu)?;
        let mut sink = DiagSink {
            diag: vec![0.0; self.dofs.n_global()],
        };
        let local = self.guarded_loop(x, Some(&mut sink));
        self.agree(local)?;
        let mut global: Vec<f64> = vec![0.0; sink.diag.len()];
        self.petsc
            .comm()
            .all_reduce_into(&sink.diag[..], &mut global[..], SystemOperation::sum());
        let (lo, hi) = self.dofs.owned_range();
        let max = global.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        self.stab_diag = global[lo as usize..hi as usize]
            .iter()
            .map(|d| d.abs().max(1e-12 * max).max(f64::MIN_POSITIVE))
            .collect();
        Ok(())
    }

    /// Turns the pseudo-transient damping on (`c > 0`, about the state `u_prev`, with the diagonal
    /// of the last [`Assembler::compute_damping_diagonal`]) or off (`c = 0`). The residual gains
    /// `c D_i (u_i - u_prev_i)` and the Jacobian `c D_i` on every free owned row; reactions
    /// (`raw_residual`) do not see it.
    pub fn set_damping(&mut self, c: f64, u_prev: &Vector) -> Result<(), PetscError> {
        self.stab_c = if self.stab_diag.is_empty() { 0.0 } else { c };
        self.stab_prev.clear();
        if self.stab_c > 0.0 {
            self.stab_prev.extend_from_slice(&u_prev.read()?);
        }
        Ok(())
    }

    /// The damping force `|c D (u - u_prev)|` (2-norm over all ranks) at `x`, zero when off.
    ///
    /// Collective.
    pub fn damping_force_norm(&self, x: &Vector) -> Result<f64, PetscError> {
        let mut local = 0.0f64;
        if self.stab_c > 0.0 {
            let xa = x.read()?;
            let (lo, _) = self.dofs.owned_range();
            for i in 0..xa.len() {
                if !self.constrained[lo as usize + i] {
                    let f = self.stab_c * self.stab_diag[i] * (xa[i] - self.stab_prev[i]);
                    local += f * f;
                }
            }
        }
        let mut global = 0.0f64;
        self.petsc
            .comm()
            .all_reduce_into(&local, &mut global, SystemOperation::sum());
        Ok(global.sqrt())
    }
}
