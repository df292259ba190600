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
        assert_eq!(
            rows.len(),
            cols.len(),
            "COO row and column lists differ in length"
        );
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
        // SAFETY: `values` has the length given at preallocation (checked by the caller's pattern).
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
        // SAFETY: arrays have one entry per local row; PETSc ignores the call that does not match the type.
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
        debug_assert_eq!(vals.len(), rows.len() * cols.len());
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

    /// `y = A x`.
    pub fn mult(&self, x: &super::Vector, y: &mut super::Vector) -> Result<(), PetscError> {
        // SAFETY: valid handles with compatible layouts (checked by PETSc).
        unsafe { call!(MatMult(self.raw, x.as_raw(), y.as_raw())) }
    }
}
