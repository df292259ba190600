//! Distributed and sequential PETSc vectors, with array views that restore on drop.

use super::error::{call, PetscError};
use super::{handle, sys, Petsc, PetscInt};
use mpi::ffi::RSMPI_COMM_SELF;
use std::marker::PhantomData;

/// A PETSc `Vec`. Owned vectors are destroyed on drop; borrowed ones (handed to us by SNES) are not.
pub struct Vector<'p> {
    raw: sys::Vec,
    owned: bool,
    _petsc: PhantomData<&'p Petsc>,
}
handle!(Vector, sys::Vec, sys::VecDestroy);

impl<'p> Vector<'p> {
    /// A distributed vector with `n_local` entries owned by this rank.
    ///
    /// Collective.
    pub fn new_mpi(petsc: &'p Petsc, n_local: usize) -> Result<Self, PetscError> {
        use mpi::raw::AsRaw;
        let mut raw = std::ptr::null_mut();
        // SAFETY: valid communicator from the guard; PETSC_DETERMINE lets PETSc sum the global size.
        unsafe {
            call!(VecCreateMPI(
                petsc.comm().as_raw(),
                petsc_int(n_local)?,
                sys::PETSC_DETERMINE,
                &mut raw
            ))?
        };
        Ok(Self::own(raw))
    }

    /// A sequential vector on this rank only.
    pub fn new_seq(_petsc: &'p Petsc, n: usize) -> Result<Self, PetscError> {
        let mut raw = std::ptr::null_mut();
        // SAFETY: RSMPI_COMM_SELF is a valid communicator once MPI is initialised.
        unsafe { call!(VecCreateSeq(RSMPI_COMM_SELF, petsc_int(n)?, &mut raw))? };
        Ok(Self::own(raw))
    }

    fn own(raw: sys::Vec) -> Self {
        Vector {
            raw,
            owned: true,
            _petsc: PhantomData,
        }
    }

    /// Wraps a vector owned by PETSc (e.g. a SNES work vector) without taking ownership.
    ///
    /// # Safety
    /// `raw` must be a valid `Vec` that stays alive while the wrapper is used.
    pub(crate) unsafe fn borrowed(raw: sys::Vec) -> Self {
        Vector {
            raw,
            owned: false,
            _petsc: PhantomData,
        }
    }

    /// A new vector with the same layout (values not copied).
    pub fn duplicate(&self) -> Result<Vector<'p>, PetscError> {
        let mut raw = std::ptr::null_mut();
        // SAFETY: self.raw is valid.
        unsafe { call!(VecDuplicate(self.raw, &mut raw))? };
        Ok(Self::own(raw))
    }

    /// Copies the values of `self` into `dst` (same layout).
    pub fn copy_to(&self, dst: &mut Vector) -> Result<(), PetscError> {
        // SAFETY: both valid; PETSc checks the layouts.
        unsafe { call!(VecCopy(self.raw, dst.raw)) }
    }

    /// Sets every entry to `v`.
    pub fn set(&mut self, v: f64) -> Result<(), PetscError> {
        // SAFETY: valid handle.
        unsafe { call!(VecSet(self.raw, v)) }
    }

    /// `self += a * x`.
    pub fn axpy(&mut self, a: f64, x: &Vector) -> Result<(), PetscError> {
        // SAFETY: valid handles.
        unsafe { call!(VecAXPY(self.raw, a, x.raw)) }
    }

    /// Euclidean norm. Collective.
    pub fn norm2(&self) -> Result<f64, PetscError> {
        let mut n = 0.0;
        // SAFETY: valid handle.
        unsafe { call!(VecNorm(self.raw, sys::NormType::NORM_2, &mut n))? };
        Ok(n)
    }

    /// The half-open range of global indices owned by this rank.
    pub fn ownership_range(&self) -> Result<(PetscInt, PetscInt), PetscError> {
        let (mut lo, mut hi) = (0, 0);
        // SAFETY: valid handle.
        unsafe { call!(VecGetOwnershipRange(self.raw, &mut lo, &mut hi))? };
        Ok((lo, hi))
    }

    /// Read-only view of the locally owned entries.
    pub fn read(&self) -> Result<VecRead<'_>, PetscError> {
        let mut ptr: *const f64 = std::ptr::null();
        let mut n = 0;
        // SAFETY: valid handle; the view restores the array on drop.
        unsafe {
            call!(VecGetLocalSize(self.raw, &mut n))?;
            call!(VecGetArrayRead(self.raw, &mut ptr))?;
        }
        Ok(VecRead {
            vec: self.raw,
            ptr,
            len: n as usize,
            _life: PhantomData,
        })
    }

    /// Writable view of the locally owned entries.
    pub fn write(&mut self) -> Result<VecWrite<'_>, PetscError> {
        let mut ptr: *mut f64 = std::ptr::null_mut();
        let mut n = 0;
        // SAFETY: valid handle, exclusive borrow; the view restores the array on drop.
        unsafe {
            call!(VecGetLocalSize(self.raw, &mut n))?;
            call!(VecGetArray(self.raw, &mut ptr))?;
        }
        Ok(VecWrite {
            vec: self.raw,
            ptr,
            len: n as usize,
            _life: PhantomData,
        })
    }
}

pub(crate) fn petsc_int(n: usize) -> Result<PetscInt, PetscError> {
    PetscInt::try_from(n).map_err(|_| PetscError {
        code: 63,
        function: "index conversion",
        message: format!(
            "{n} does not fit PETSc's 32-bit PetscInt (build PETSc with 64-bit indices)"
        ),
    })
}

/// A read-only view of a vector's local array; restored on drop.
pub struct VecRead<'a> {
    vec: sys::Vec,
    ptr: *const f64,
    len: usize,
    _life: PhantomData<&'a ()>,
}

impl std::ops::Deref for VecRead<'_> {
    type Target = [f64];
    fn deref(&self) -> &[f64] {
        if self.len == 0 {
            return &[];
        }
        // SAFETY: PETSc gave us `len` contiguous entries valid until restore.
        unsafe { std::slice::from_raw_parts(self.ptr, self.len) }
    }
}

impl Drop for VecRead<'_> {
    fn drop(&mut self) {
        // SAFETY: restores exactly the array obtained in `read`.
        let _ = unsafe { sys::VecRestoreArrayRead(self.vec, &mut self.ptr) };
    }
}

/// A writable view of a vector's local array; restored on drop.
pub struct VecWrite<'a> {
    vec: sys::Vec,
    ptr: *mut f64,
    len: usize,
    _life: PhantomData<&'a mut ()>,
}

impl std::ops::Deref for VecWrite<'_> {
    type Target = [f64];
    fn deref(&self) -> &[f64] {
        if self.len == 0 {
            return &[];
        }
        // SAFETY: PETSc gave us `len` contiguous entries valid until restore.
        unsafe { std::slice::from_raw_parts(self.ptr, self.len) }
    }
}

impl std::ops::DerefMut for VecWrite<'_> {
    fn deref_mut(&mut self) -> &mut [f64] {
        if self.len == 0 {
            return &mut [];
        }
        // SAFETY: as in deref, and the view holds the vector's exclusive borrow.
        unsafe { std::slice::from_raw_parts_mut(self.ptr, self.len) }
    }
}

impl Drop for VecWrite<'_> {
    fn drop(&mut self) {
        // SAFETY: restores exactly the array obtained in `write`.
        let _ = unsafe { sys::VecRestoreArray(self.vec, &mut self.ptr) };
    }
}
