//! Index sets and scatters: how a rank gathers the (ghosted) entries its elements need.

use super::error::{call, PetscError};
use super::vec::petsc_int;
use super::{handle, sys, Petsc, PetscInt, Vector};
use mpi::ffi::RSMPI_COMM_SELF;
use std::marker::PhantomData;

/// A PETSc `IS` (index set) on this rank.
pub struct IndexSet<'p> {
    raw: sys::IS,
    owned: bool,
    _petsc: PhantomData<&'p Petsc>,
}
handle!(IndexSet, sys::IS, sys::ISDestroy);

impl<'p> IndexSet<'p> {
    /// A sequential index set holding a copy of `indices`.
    pub fn new(_petsc: &'p Petsc, indices: &[PetscInt]) -> Result<Self, PetscError> {
        let mut raw = std::ptr::null_mut();
        // SAFETY: PETSC_COPY_VALUES makes PETSc keep its own copy.
        unsafe {
            call!(ISCreateGeneral(
                RSMPI_COMM_SELF,
                petsc_int(indices.len())?,
                indices.as_ptr(),
                sys::PetscCopyMode::PETSC_COPY_VALUES,
                &mut raw
            ))?
        };
        Ok(IndexSet {
            raw,
            owned: true,
            _petsc: PhantomData,
        })
    }
}

/// A `VecScatter` from a distributed vector to a sequential "local" vector holding the listed global
/// entries (owned and ghost) in the listed order; run in reverse it adds local contributions back.
pub struct Scatter<'p> {
    raw: sys::VecScatter,
    owned: bool,
    _petsc: PhantomData<&'p Petsc>,
}
handle!(Scatter, sys::VecScatter, sys::VecScatterDestroy);

impl<'p> Scatter<'p> {
    /// Builds the gather of `global[indices[k]]` into `local[k]`.
    ///
    /// Collective.
    pub fn new(
        petsc: &'p Petsc,
        global: &Vector,
        local: &Vector<'p>,
        indices: &[PetscInt],
    ) -> Result<Self, PetscError> {
        let from = IndexSet::new(petsc, indices)?;
        let mut raw = std::ptr::null_mut();
        // SAFETY: valid vectors and index set; a null target IS means "all of local, in order".
        unsafe {
            call!(VecScatterCreate(
                global.as_raw(),
                from.as_raw(),
                local.as_raw(),
                std::ptr::null_mut(),
                &mut raw
            ))?
        };
        Ok(Scatter {
            raw,
            owned: true,
            _petsc: PhantomData,
        })
    }

    /// `local[k] = global[indices[k]]`. Collective.
    pub fn gather(&self, global: &Vector, local: &mut Vector) -> Result<(), PetscError> {
        let (g, l) = (global.as_raw(), local.as_raw());
        // SAFETY: the vectors are the layouts the scatter was built for.
        unsafe {
            call!(VecScatterBegin(
                self.raw,
                g,
                l,
                sys::InsertMode::INSERT_VALUES,
                sys::ScatterMode::SCATTER_FORWARD
            ))?;
            call!(VecScatterEnd(
                self.raw,
                g,
                l,
                sys::InsertMode::INSERT_VALUES,
                sys::ScatterMode::SCATTER_FORWARD
            ))
        }
    }

    /// `global[indices[k]] += local[k]`. Collective.
    pub fn add_back(&self, local: &Vector, global: &mut Vector) -> Result<(), PetscError> {
        let (g, l) = (global.as_raw(), local.as_raw());
        // SAFETY: as in gather, in reverse.
        unsafe {
            call!(VecScatterBegin(
                self.raw,
                l,
                g,
                sys::InsertMode::ADD_VALUES,
                sys::ScatterMode::SCATTER_REVERSE
            ))?;
            call!(VecScatterEnd(
                self.raw,
                l,
                g,
                sys::InsertMode::ADD_VALUES,
                sys::ScatterMode::SCATTER_REVERSE
            ))
        }
    }
}
