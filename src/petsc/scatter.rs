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
        // SAFETY: the vectors are the layouts the scatter was built for.
        unsafe { scatter_forward(self.raw, global.as_raw(), local.as_raw()) }
    }

    /// `global[indices[k]] += local[k]`. Collective.
    pub fn add_back(&self, local: &Vector, global: &mut Vector) -> Result<(), PetscError> {
        // SAFETY: as in gather, in reverse.
        unsafe { scatter_add_back(self.raw, local.as_raw(), global.as_raw()) }
    }
}

/// Runs `scatter` forward, inserting: `to[k] = from[indices[k]]`. Collective.
///
/// # Safety
/// `scatter`, `from` and `to` must be live handles, `from` and `to` of the layouts `scatter` was
/// built for (source and target).
pub(crate) unsafe fn scatter_forward(
    scatter: sys::VecScatter,
    from: sys::Vec,
    to: sys::Vec,
) -> Result<(), PetscError> {
    // SAFETY: as the caller promises.
    unsafe {
        call!(VecScatterBegin(
            scatter,
            from,
            to,
            sys::InsertMode::INSERT_VALUES,
            sys::ScatterMode::SCATTER_FORWARD
        ))?;
        call!(VecScatterEnd(
            scatter,
            from,
            to,
            sys::InsertMode::INSERT_VALUES,
            sys::ScatterMode::SCATTER_FORWARD
        ))
    }
}

/// Runs `scatter` in reverse, adding: `to[indices[k]] += from[k]`. Collective.
///
/// # Safety
/// As [`scatter_forward`], with `from` of the scatter's target layout and `to` of its source.
pub(crate) unsafe fn scatter_add_back(
    scatter: sys::VecScatter,
    from: sys::Vec,
    to: sys::Vec,
) -> Result<(), PetscError> {
    // SAFETY: as the caller promises.
    unsafe {
        call!(VecScatterBegin(
            scatter,
            from,
            to,
            sys::InsertMode::ADD_VALUES,
            sys::ScatterMode::SCATTER_REVERSE
        ))?;
        call!(VecScatterEnd(
            scatter,
            from,
            to,
            sys::InsertMode::ADD_VALUES,
            sys::ScatterMode::SCATTER_REVERSE
        ))
    }
}
