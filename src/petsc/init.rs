//! The PETSc initialisation guard.

use super::error::{call, PetscError};
use super::sys;
use mpi::raw::AsRaw;
use mpi::topology::Communicator;
use mpi::topology::SimpleCommunicator;
use std::ffi::{c_char, c_int, CString};

/// Owns PETSc's initialisation: created after MPI (rsmpi), finalised on drop before MPI is.
///
/// PETSc runs on a duplicate of the world communicator, so its messages never mix with ours.
/// Every option given in `args` (e.g. `-snes_monitor`, `-ksp_view`, `-log_view`) reaches PETSc's
/// options database unchanged.
pub struct Petsc {
    // PETSc keeps the argv pointer it is given for the whole run: keep the storage alive.
    _args: Vec<CString>,
    _argv: Vec<*mut c_char>,
    comm: SimpleCommunicator,
}

impl Petsc {
    /// Initialises PETSc on a duplicate of `world`. `args[0]` is the program name.
    ///
    /// Collective.
    pub fn init(world: &SimpleCommunicator, args: &[String]) -> Result<Petsc, PetscError> {
        let comm = world.duplicate();
        let c_args: Vec<CString> = args
            .iter()
            .map(|a| CString::new(a.as_str()).unwrap_or_default())
            .collect();
        let mut argv: Vec<*mut c_char> = c_args.iter().map(|a| a.as_ptr() as *mut c_char).collect();
        argv.push(std::ptr::null_mut());
        let mut argc = c_int::try_from(c_args.len()).unwrap_or(0);
        let mut argv_ptr = argv.as_mut_ptr();
        // SAFETY: MPI is initialised by rsmpi (the caller holds a communicator); PETSC_COMM_WORLD must be
        // set before PetscInitialize; argv outlives PETSc because it is stored in the guard.
        unsafe {
            sys::PETSC_COMM_WORLD = comm.as_raw();
            call!(PetscInitialize(
                &mut argc,
                &mut argv_ptr,
                std::ptr::null(),
                std::ptr::null()
            ))?;
            // Track the peak resident set size for the run summary and benchmarks.
            call!(PetscMemorySetGetMaximumUsage())?;
        }
        Ok(Petsc {
            _args: c_args,
            _argv: argv,
            comm,
        })
    }

    /// The communicator PETSc objects live on.
    pub fn comm(&self) -> &SimpleCommunicator {
        &self.comm
    }

    /// Inserts a string of options (from a case file) into the database; command-line options given
    /// at initialisation are inserted again afterwards so they keep precedence.
    pub fn insert_options(&self, options: &str, command_line: &str) -> Result<(), PetscError> {
        for s in [options, command_line] {
            if s.trim().is_empty() {
                continue;
            }
            let c = CString::new(s).unwrap_or_default();
            // SAFETY: null options means the global database; `c` is a valid C string.
            unsafe { call!(PetscOptionsInsertString(std::ptr::null_mut(), c.as_ptr()))? };
        }
        Ok(())
    }

    /// Peak resident memory of this process as PETSc measured it (bytes), if PETSc tracks it.
    pub fn max_memory_bytes(&self) -> f64 {
        let mut m = 0.0;
        // SAFETY: writes one double.
        let _ = unsafe { sys::PetscMemoryGetMaximumUsage(&mut m) };
        m
    }
}

impl Drop for Petsc {
    fn drop(&mut self) {
        // SAFETY: every handle borrows the guard, so all PETSc objects are already destroyed.
        let ierr = unsafe { sys::PetscFinalize() };
        if ierr != 0 {
            eprintln!("warning: PetscFinalize failed with error {ierr}");
        }
    }
}
