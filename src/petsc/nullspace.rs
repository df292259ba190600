//! Near-null spaces (`MatNullSpace`): the rigid-body modes an algebraic multigrid preconditioner
//! (GAMG) builds its coarse spaces from.

use super::error::{call, PetscError};
use super::{handle, sys, Matrix, Petsc, Vector};
use mpi::raw::AsRaw;
use std::marker::PhantomData;

/// A PETSc `MatNullSpace` spanned by vectors the caller gives (orthonormal: PETSc does not check
/// it in an optimised build, and GAMG relies on it).
pub struct NullSpace<'p> {
    raw: sys::MatNullSpace,
    owned: bool,
    _petsc: PhantomData<&'p Petsc>,
}
handle!(NullSpace, sys::MatNullSpace, sys::MatNullSpaceDestroy);

impl<'p> NullSpace<'p> {
    /// The space spanned by `vectors` (orthonormal, the layout of the operator's rows); PETSc
    /// keeps its own references to them.
    ///
    /// Collective.
    pub fn new(petsc: &'p Petsc, vectors: &[Vector<'p>]) -> Result<Self, PetscError> {
        let raws: Vec<sys::Vec> = vectors.iter().map(|v| v.as_raw()).collect();
        let mut raw = std::ptr::null_mut();
        // SAFETY: valid communicator and vectors; PETSc references the vectors (so they may be
        // dropped here) and the space is destroyed on drop.
        unsafe {
            call!(MatNullSpaceCreate(
                petsc.comm().as_raw(),
                sys::PetscBool(0),
                raws.len() as super::PetscInt,
                raws.as_ptr(),
                &mut raw
            ))?
        };
        Ok(NullSpace {
            raw,
            owned: true,
            _petsc: PhantomData,
        })
    }
}

impl Matrix<'_> {
    /// Attaches `space` as the matrix's near-null space (what GAMG reads at its set-up); the
    /// matrix keeps its own reference. Cheap: call it whenever the matrix may be a new one.
    pub fn set_near_null_space(&mut self, space: &NullSpace) -> Result<(), PetscError> {
        // SAFETY: valid handles; PETSc takes a reference to the space.
        unsafe { call!(MatSetNearNullSpace(self.as_raw(), space.as_raw())) }
    }
}

impl Vector<'_> {
    /// The dot product `self . other`. Collective.
    pub fn dot(&self, other: &Vector) -> Result<f64, PetscError> {
        let mut d = 0.0;
        // SAFETY: valid handles; PETSc checks that the layouts match.
        unsafe { call!(VecDot(self.as_raw(), other.as_raw(), &mut d))? };
        Ok(d)
    }

    /// `self *= a`.
    pub fn scale(&mut self, a: f64) -> Result<(), PetscError> {
        // SAFETY: valid handle.
        unsafe { call!(VecScale(self.as_raw(), a)) }
    }
}
