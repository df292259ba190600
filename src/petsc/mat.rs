//! Distributed sparse matrices (MPIAIJ), assembled through PETSc's COO interface.

use super::error::{call, PetscError};
use super::vec::petsc_int;
use super::{handle, sys, Petsc, PetscInt};
use mpi::raw::AsRaw;
use std::marker::PhantomData;

/// A PETSc `Mat` of type AIJ (sequential on one rank, MPIAIJ on several).
pub struct Matrix<'p> {
    raw: sys::Mat,
    owned: bool,
    /// Entries of the last COO preallocation: the length `set_values_coo` must be given.
    coo_len: Option<usize>,
    _petsc: PhantomData<&'p Petsc>,
}
handle!(Matrix, sys::Mat, sys::MatDestroy);

impl<'p> Matrix<'p> {
    /// A square AIJ matrix with `n_local` owned rows (and columns).
    ///
    /// Collective.
    pub fn new_aij(petsc: &'p Petsc, n_local: usize) -> Result<Self, PetscError> {
        let n = petsc_int(n_local)?;
        let mut raw = std::ptr::null_mut();
        // SAFETY: valid communicator; the matrix is destroyed on drop.
        unsafe {
            call!(MatCreate(petsc.comm().as_raw(), &mut raw))?;
            call!(MatSetSizes(
                raw,
                n,
                n,
                sys::PETSC_DETERMINE,
                sys::PETSC_DETERMINE
            ))?;
            call!(MatSetType(raw, sys::MATAIJ.as_ptr()))?;
            // Options prefix lets users pick e.g. -mat_type on the command line.
            call!(MatSetFromOptions(raw))?;
        }
        Ok(Matrix {
            raw,
            owned: true,
            coo_len: None,
            _petsc: PhantomData,
        })
    }

    /// Wraps a matrix handed to us by PETSc (SNES callbacks) without taking ownership.
    ///
    /// # Safety
    /// `raw` must be valid while the wrapper is used.
    pub(crate) unsafe fn borrowed(raw: sys::Mat) -> Self {
        Matrix {
            raw,
            owned: false,
            coo_len: None,
            _petsc: PhantomData,
        }
    }

    /// Sets the nonzero pattern from coordinate lists of global (row, column) pairs. Repeated pairs are
    /// summed; negative indices are ignored (PETSc), which is how constrained rows are left out.
    /// The arrays may be modified by PETSc, hence `&mut`.
    ///
    /// Collective.
    pub fn set_preallocation_coo(
        &mut self,
        rows: &mut [PetscInt],
        cols: &mut [PetscInt],
    ) -> Result<(), PetscError> {
        if rows.len() != cols.len() {
            return Err(size_error(
                "MatSetPreallocationCOO",
                "row and column lists",
                rows.len(),
                cols.len(),
            ));
        }
        self.coo_len = Some(rows.len());
        // SAFETY: both arrays have rows.len() entries; PETSc copies what it needs.
        unsafe {
            call!(MatSetPreallocationCOO(
                self.raw,
                rows.len() as sys::PetscCount,
                rows.as_mut_ptr(),
                cols.as_mut_ptr()
            ))
        }
    }

    /// Sets all values in the order of the last [`set_preallocation_coo`](Self::set_preallocation_coo),
    /// replacing previous values. No separate assembly call is needed.
    ///
    /// Collective.
    pub fn set_values_coo(&mut self, values: &[f64]) -> Result<(), PetscError> {
        match self.coo_len {
            Some(n) if n == values.len() => {}
            Some(n) => return Err(size_error("MatSetValuesCOO", "values", n, values.len())),
            None => {
                return Err(size_error(
                    "MatSetValuesCOO",
                    "values before any COO preallocation",
                    0,
                    values.len(),
                ))
            }
        }
        // SAFETY: `values` has the length given at preallocation (checked just above).
        unsafe {
            call!(MatSetValuesCOO(
                self.raw,
                values.as_ptr(),
                sys::InsertMode::INSERT_VALUES
            ))
        }
    }

    /// Classic path: preallocate from per-row counts of the diagonal and off-diagonal blocks.
    ///
    /// Collective.
    pub fn preallocate_aij(
        &mut self,
        d_nnz: &[PetscInt],
        o_nnz: &[PetscInt],
    ) -> Result<(), PetscError> {
        let (mut m, mut n) = (0, 0);
        // SAFETY: valid handle; writes two integers.
        unsafe { call!(MatGetLocalSize(self.raw, &mut m, &mut n))? };
        let rows = m.max(0) as usize;
        if d_nnz.len() != rows || o_nnz.len() != rows {
            return Err(size_error(
                "MatMPIAIJSetPreallocation",
                "per-row counts",
                rows,
                d_nnz.len().min(o_nnz.len()),
            ));
        }
        // SAFETY: arrays have one entry per local row (checked just above); PETSc ignores the call that does not match the type.
        unsafe {
            call!(MatSeqAIJSetPreallocation(self.raw, 0, d_nnz.as_ptr()))?;
            call!(MatMPIAIJSetPreallocation(
                self.raw,
                0,
                d_nnz.as_ptr(),
                0,
                o_nnz.as_ptr()
            ))?;
            // Any entry outside the preallocated pattern is a bug in our sparsity: make it an error.
            call!(MatSetOption(
                self.raw,
                sys::MatOption::MAT_NEW_NONZERO_ALLOCATION_ERR,
                sys::PetscBool(1)
            ))
        }
    }

    /// Zeroes all stored values (keeps the pattern).
    pub fn zero(&mut self) -> Result<(), PetscError> {
        // SAFETY: valid handle.
        unsafe { call!(MatZeroEntries(self.raw)) }
    }

    /// Adds a dense block `vals` [rows.len()][cols.len()] at global indices (negative indices skipped).
    pub fn add_values(
        &mut self,
        rows: &[PetscInt],
        cols: &[PetscInt],
        vals: &[f64],
    ) -> Result<(), PetscError> {
        if vals.len() != rows.len() * cols.len() {
            return Err(size_error(
                "MatSetValues",
                "values",
                rows.len() * cols.len(),
                vals.len(),
            ));
        }
        // SAFETY: sizes match the slices.
        unsafe {
            call!(MatSetValues(
                self.raw,
                petsc_int(rows.len())?,
                rows.as_ptr(),
                petsc_int(cols.len())?,
                cols.as_ptr(),
                vals.as_ptr(),
                sys::InsertMode::ADD_VALUES
            ))
        }
    }

    /// Finishes assembly after [`add_values`](Self::add_values).
    ///
    /// Collective.
    pub fn assemble(&mut self) -> Result<(), PetscError> {
        // SAFETY: valid handle.
        unsafe {
            call!(MatAssemblyBegin(
                self.raw,
                sys::MatAssemblyType::MAT_FINAL_ASSEMBLY
            ))?;
            call!(MatAssemblyEnd(
                self.raw,
                sys::MatAssemblyType::MAT_FINAL_ASSEMBLY
            ))
        }
    }

    /// Number of mallocs PETSc needed during the last assembly (0 when preallocation was exact).
    pub fn assembly_mallocs(&self) -> Result<f64, PetscError> {
        let mut info = sys::MatInfo::default();
        // SAFETY: writes one MatInfo.
        unsafe {
            call!(MatGetInfo(
                self.raw,
                sys::MatInfoType::MAT_GLOBAL_SUM,
                &mut info
            ))?
        };
        Ok(info.mallocs)
    }

    /// Global number of stored nonzeros.
    pub fn nonzeros(&self) -> Result<f64, PetscError> {
        let mut info = sys::MatInfo::default();
        // SAFETY: writes one MatInfo.
        unsafe {
            call!(MatGetInfo(
                self.raw,
                sys::MatInfoType::MAT_GLOBAL_SUM,
                &mut info
            ))?
        };
        Ok(info.nz_used)
    }

    /// The infinity norm (largest absolute row sum) of the assembled matrix.
    ///
    /// Collective.
    pub fn norm_inf(&self) -> Result<f64, PetscError> {
        let mut n = 0.0;
        // SAFETY: valid, assembled handle; writes one value.
        unsafe { call!(MatNorm(self.raw, sys::NormType::NORM_INFINITY, &mut n))? };
        Ok(n)
    }

    /// `y = A x`.
    ///
    /// Collective.
    pub fn mult(&self, x: &super::Vector, y: &mut super::Vector) -> Result<(), PetscError> {
        // SAFETY: valid handles with compatible layouts (checked by PETSc).
        unsafe { call!(MatMult(self.raw, x.as_raw(), y.as_raw())) }
    }
}

/// PETSc's "nonconforming object sizes" error (PETSC_ERR_ARG_SIZ), raised before calling PETSc.
fn size_error(function: &'static str, what: &str, expected: usize, got: usize) -> PetscError {
    PetscError {
        code: 60,
        function,
        message: format!("{what}: expected {expected} entries, got {got}"),
    }
}
