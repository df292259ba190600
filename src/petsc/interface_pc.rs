//! The iterative route's contact-interface correction: a `PCSHELL` that applies GAMG to the whole
//! tangent `A` and then solves exactly (LU by MUMPS) on the unknowns `I` of the contact
//! interface,
//!
//! ```text
//! z = AMG(r);   z += P_I A_II^{-1} P_I^T (r - A z)
//! ```
//!
//! (a multiplicative composition, as in AMGF by Petrides et al.), optionally followed by
//! `z += AMG(r - A z)` (the symmetric form). `I` is the set the nonlinear
//! problem names after each Jacobian ([`crate::petsc::NonlinearProblem::interface_dofs`]) and
//! one layer of matrix neighbours around it (`MatIncreaseOverlap`); each rank holds the rows of `I`
//! it owns, and `A_II` is a parallel submatrix, so the interface solve is exact on any number of
//! ranks. An empty `I` (no contact yet) leaves GAMG alone.
//!
//! Set-ups on the same matrix (the Newton iterations and load steps between two contact pattern
//! rebuilds) keep GAMG's aggregates and interpolation and recompute only its Galerkin coarse
//! operators (`-pc_gamg_reuse_interpolation 0`: a new hierarchy at every set-up); the interface
//! block keeps its symbolic factorisation while `I` and the matrix are unchanged and is only
//! factorised numerically again. `NURBS_CONTACT_DEBUG_LINEAR` reports both counts at the end.

use super::error::{call, PetscError};
use super::scatter::{scatter_add_back, scatter_forward};
use super::{sys, PetscInt};
use std::ffi::c_void;

/// PETSc's code for "error in user callback" (PETSC_ERR_USER in petscerror.h).
const PETSC_ERR_USER: sys::PetscErrorCode = 83;

/// The shell's state: the inner GAMG, the interface set and its factorised block. Owned by the
/// [`crate::petsc::Snes`] that installs it (its address is the shell's context).
pub(crate) struct InterfaceCorrection {
    /// Global unknowns the problem names as the interface (any rank's rows, not yet widened).
    pub(crate) requested: Vec<PetscInt>,
    /// Layers of matrix neighbours added around `requested`.
    layers: PetscInt,
    gamg: sys::PC,
    /// The operator the work vectors were made for and the apply multiplies by (a new matrix,
    /// after a pattern rebuild, makes them anew).
    gamg_mat: sys::Mat,
    /// The owned rows of `I` the blocks below were built for, and the matrix they came from.
    rows: Vec<PetscInt>,
    rows_mat: sys::Mat,
    is: sys::IS,
    a_ii: sys::Mat,
    solver: sys::KSP,
    scatter: sys::VecScatter,
    r_i: sys::Vec,
    y_i: sys::Vec,
    work: sys::Vec,
    /// Global size of `I` at the last set-up (0: no correction).
    size: PetscInt,
    /// A second GAMG sweep after the interface solve (the symmetric form).
    post_sweep: bool,
    post: sys::Vec,
    /// Keep GAMG's interpolation while the operator is the same matrix (until a new sparsity
    /// pattern) and recompute only its Galerkin coarse operators: on unless
    /// `-pc_gamg_reuse_interpolation 0` (read at each new GAMG).
    reuse: bool,
    /// Set-ups that built GAMG's hierarchy and that only recomputed its coarse operators, and
    /// the interface blocks factorised with a new symbolic analysis and with the old one.
    counts: SetUpCounts,
}

/// How the interface correction's set-ups went (see [`InterfaceCorrection::counts`]).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
struct SetUpCounts {
    /// GAMG hierarchies built from scratch (aggregation, interpolation, coarse operators).
    hierarchies: usize,
    /// GAMG set-ups that kept the interpolation and recomputed the coarse operators.
    galerkin_only: usize,
    /// Interface blocks built for a new set `I` (symbolic and numeric factorisation).
    new_blocks: usize,
    /// Interface blocks refreshed in place (numeric factorisation only).
    refreshed_blocks: usize,
}

impl InterfaceCorrection {
    /// A correction that widens the problem's interface by `layers` matrix neighbours, with a
    /// second GAMG sweep after the interface solve when `post_sweep`.
    pub(crate) fn new(layers: usize, post_sweep: bool) -> Self {
        InterfaceCorrection {
            requested: Vec::new(),
            layers: layers as PetscInt,
            gamg: std::ptr::null_mut(),
            gamg_mat: std::ptr::null_mut(),
            rows: Vec::new(),
            rows_mat: std::ptr::null_mut(),
            is: std::ptr::null_mut(),
            a_ii: std::ptr::null_mut(),
            solver: std::ptr::null_mut(),
            scatter: std::ptr::null_mut(),
            r_i: std::ptr::null_mut(),
            y_i: std::ptr::null_mut(),
            work: std::ptr::null_mut(),
            size: 0,
            post_sweep,
            post: std::ptr::null_mut(),
            reuse: false,
            counts: SetUpCounts::default(),
        }
    }

    /// Frees the interface block and its solver (kept: GAMG).
    fn drop_interface(&mut self) -> Result<(), PetscError> {
        // SAFETY: each handle is null or one this struct created; the destroy calls null them.
        unsafe {
            call!(VecScatterDestroy(&mut self.scatter))?;
            call!(VecDestroy(&mut self.r_i))?;
            call!(VecDestroy(&mut self.y_i))?;
            call!(KSPDestroy(&mut self.solver))?;
            call!(MatDestroy(&mut self.a_ii))?;
            call!(ISDestroy(&mut self.is))?;
        }
        self.rows.clear();
        self.rows_mat = std::ptr::null_mut();
        Ok(())
    }

    /// Lets go of everything built from the current matrix (before a new sparsity pattern is
    /// built beside it); the next set-up builds it again.
    pub(crate) fn release(&mut self) -> Result<(), PetscError> {
        self.drop_interface()?;
        // SAFETY: handles created by this struct or null.
        unsafe {
            call!(VecDestroy(&mut self.work))?;
            call!(VecDestroy(&mut self.post))?;
            call!(PCDestroy(&mut self.gamg))?;
        }
        self.gamg_mat = std::ptr::null_mut();
        self.size = 0;
        Ok(())
    }

    /// Sets up GAMG on `a` and the exact interface solve on `A_II`. Collective.
    fn set_up(&mut self, a: sys::Mat, comm: sys::MPI_Comm) -> Result<(), PetscError> {
        // SAFETY: `a` is the PC's live operator; every handle below is created here or null.
        unsafe {
            if !(self.reuse && self.gamg_mat == a && !self.gamg.is_null()) {
                // a new GAMG on a new matrix or without reuse: one set up again on new values
                // without reusing its interpolation resets its levels, whose solvers may keep
                // operators of the old coarse sizes ("Cannot change local size of Amat after
                // use"); with reuse, the same matrix keeps its pattern and the coarse sizes
                call!(PCDestroy(&mut self.gamg))?;
                call!(PCCreate(comm, &mut self.gamg))?;
                call!(PCSetType(self.gamg, sys::PCGAMG.as_ptr()))?;
                // reuse by default; `-pc_gamg_reuse_interpolation 0` turns it off
                call!(PCGAMGSetReuseInterpolation(self.gamg, sys::PetscBool(1)))?;
                // the `-pc_gamg_*` and `-mg_*` options the iterative route sets for its PC
                call!(PCSetFromOptions(self.gamg))?;
                self.reuse = reuse_interpolation_option()?;
                if self.gamg_mat != a {
                    call!(VecDestroy(&mut self.work))?;
                    call!(MatCreateVecs(a, std::ptr::null_mut(), &mut self.work))?;
                    call!(VecDestroy(&mut self.post))?;
                    call!(MatCreateVecs(a, std::ptr::null_mut(), &mut self.post))?;
                    self.gamg_mat = a;
                }
                self.counts.hierarchies += 1;
            } else {
                self.counts.galerkin_only += 1;
            }
            call!(PCSetOperators(self.gamg, a, a))?;
            call!(PCSetUp(self.gamg))?;
        }
        let rows = self.owned_rows(a)?;
        let mut is: sys::IS = std::ptr::null_mut();
        let mut size: PetscInt = 0;
        // SAFETY: `rows` outlives the call, which copies it; the IS's global size is reduced
        // over the communicator at its creation.
        unsafe {
            call!(ISCreateGeneral(
                comm,
                rows.len() as PetscInt,
                rows.as_ptr(),
                sys::PetscCopyMode::PETSC_COPY_VALUES,
                &mut is
            ))?;
            call!(ISGetSize(is, &mut size))?;
        }
        self.size = size;
        if std::env::var_os("NURBS_CONTACT_DEBUG_LINEAR").is_some() && !rows.is_empty() {
            let mut n: PetscInt = 0;
            // SAFETY: `a` is the live operator.
            unsafe { call!(MatGetSize(a, &mut n, std::ptr::null_mut()))? };
            eprintln!("interface correction: {size} of {n} unknowns in the interface block");
        }
        // the same rows of the same matrix on every rank: refresh the block's values in place
        let same_here =
            PetscInt::from(self.rows_mat == a && self.rows == rows && !self.is.is_null());
        let mut same_all: PetscInt = 0;
        // SAFETY: `is` was created above; the reduction runs on the PC's communicator.
        unsafe {
            if size == 0 {
                call!(ISDestroy(&mut is))?;
                return self.drop_interface();
            }
            // the ranks whose rows changed, counted as the global size of an IS with one entry
            // on each of them
            let mut ones: sys::IS = std::ptr::null_mut();
            call!(ISCreateStride(comm, 1 - same_here, 0, 1, &mut ones))?;
            call!(ISGetSize(ones, &mut same_all))?;
            call!(ISDestroy(&mut ones))?;
        }
        if same_all == 0 {
            self.counts.refreshed_blocks += 1;
            // SAFETY: the block was built from this matrix with this IS on every rank.
            unsafe {
                call!(ISDestroy(&mut is))?;
                call!(MatCreateSubMatrix(
                    a,
                    self.is,
                    self.is,
                    sys::MatReuse::MAT_REUSE_MATRIX,
                    &mut self.a_ii
                ))?;
            }
        } else {
            self.counts.new_blocks += 1;
            self.drop_interface()?;
            self.rows = rows;
            self.is = is;
            // SAFETY: handles created here from the live operator and the IS above.
            unsafe {
                call!(MatCreateSubMatrix(
                    a,
                    self.is,
                    self.is,
                    sys::MatReuse::MAT_INITIAL_MATRIX,
                    &mut self.a_ii
                ))?;
                call!(MatCreateVecs(self.a_ii, &mut self.y_i, &mut self.r_i))?;
                call!(VecScatterCreate(
                    self.work,
                    self.is,
                    self.r_i,
                    std::ptr::null_mut(),
                    &mut self.scatter
                ))?;
                call!(KSPCreate(comm, &mut self.solver))?;
                call!(KSPSetType(self.solver, sys::KSPPREONLY.as_ptr()))?;
                let mut pc: sys::PC = std::ptr::null_mut();
                call!(KSPGetPC(self.solver, &mut pc))?;
                call!(PCSetType(pc, sys::PCLU.as_ptr()))?;
                call!(PCFactorSetMatSolverType(pc, c"mumps".as_ptr()))?;
            }
            self.rows_mat = a;
        }
        // SAFETY: live handles created above.
        unsafe {
            call!(KSPSetOperators(self.solver, self.a_ii, self.a_ii))?;
            call!(KSPSetUp(self.solver))?;
        }
        Ok(())
    }

    /// The rows of `I` this rank owns: the requested unknowns and `layers` layers of `a`'s
    /// neighbours around them, marked in a vector by whichever rank names them. Sorted. Collective.
    fn owned_rows(&mut self, a: sys::Mat) -> Result<Vec<PetscInt>, PetscError> {
        let mut requested = self.requested.clone();
        requested.sort_unstable();
        requested.dedup();
        let mut is: sys::IS = std::ptr::null_mut();
        let mut marker: sys::Vec = std::ptr::null_mut();
        let (mut lo, mut hi): (PetscInt, PetscInt) = (0, 0);
        let mut rows = Vec::new();
        // SAFETY: handles created here and destroyed before returning; `a` is live; the index
        // and array views are restored before their objects are used again.
        unsafe {
            call!(ISCreateGeneral(
                mpi::ffi::RSMPI_COMM_SELF,
                requested.len() as PetscInt,
                requested.as_ptr(),
                sys::PetscCopyMode::PETSC_COPY_VALUES,
                &mut is
            ))?;
            if self.layers > 0 {
                call!(MatIncreaseOverlap(a, 1, &mut is, self.layers))?;
            }
            call!(MatCreateVecs(a, std::ptr::null_mut(), &mut marker))?;
            call!(VecSet(marker, 0.0))?;
            let mut n: PetscInt = 0;
            call!(ISGetLocalSize(is, &mut n))?;
            let mut idx: *const PetscInt = std::ptr::null();
            call!(ISGetIndices(is, &mut idx))?;
            let ones = vec![1.0; n as usize];
            let set = sys::VecSetValues(
                marker,
                n,
                idx,
                ones.as_ptr(),
                sys::InsertMode::INSERT_VALUES,
            );
            call!(ISRestoreIndices(is, &mut idx))?;
            crate::petsc::check(set, "VecSetValues")?;
            call!(VecAssemblyBegin(marker))?;
            call!(VecAssemblyEnd(marker))?;
            call!(VecGetOwnershipRange(marker, &mut lo, &mut hi))?;
            let mut values: *const f64 = std::ptr::null();
            call!(VecGetArrayRead(marker, &mut values))?;
            let m = std::slice::from_raw_parts(values, (hi - lo) as usize);
            rows.extend(
                (0..m.len())
                    .filter(|&i| m[i] != 0.0)
                    .map(|i| lo + i as PetscInt),
            );
            call!(VecRestoreArrayRead(marker, &mut values))?;
            call!(VecDestroy(&mut marker))?;
            call!(ISDestroy(&mut is))?;
        }
        Ok(rows)
    }

    /// `z = AMG(r); z += P_I A_II^{-1} P_I^T (r - A z)`.
    fn apply(&mut self, r: sys::Vec, z: sys::Vec) -> Result<(), PetscError> {
        // SAFETY: handles set up by `set_up` for the operator `gamg_mat`; r and z are the
        // caller's vectors of its layout.
        unsafe {
            call!(PCApply(self.gamg, r, z))?;
            if self.size == 0 {
                return Ok(());
            }
            call!(MatMult(self.gamg_mat, z, self.work))?;
            call!(VecAYPX(self.work, -1.0, r))?;
            scatter_forward(self.scatter, self.work, self.r_i)?;
            call!(KSPSolve(self.solver, self.r_i, self.y_i))?;
            let mut reason = sys::KSPConvergedReason(0);
            call!(KSPGetConvergedReason(self.solver, &mut reason))?;
            if reason.0 < 0 {
                return Err(PetscError {
                    code: PETSC_ERR_USER,
                    function: "interface correction",
                    message: format!(
                        "the interface block's LU solve failed (reason {})",
                        reason.0
                    ),
                });
            }
            scatter_add_back(self.scatter, self.y_i, z)?;
            if self.post_sweep {
                // z += AMG(r - A z): the symmetric form
                call!(MatMult(self.gamg_mat, z, self.work))?;
                call!(VecAYPX(self.work, -1.0, r))?;
                call!(PCApply(self.gamg, self.work, self.post))?;
                call!(VecAXPY(z, 1.0, self.post))?;
            }
        }
        Ok(())
    }
}

impl Drop for InterfaceCorrection {
    fn drop(&mut self) {
        if std::env::var_os("NURBS_CONTACT_DEBUG_LINEAR").is_some() {
            let c = self.counts;
            eprintln!(
                "interface correction set-ups: {} GAMG hierarchies built, {} Galerkin-only; \
                 {} interface blocks built, {} refreshed",
                c.hierarchies, c.galerkin_only, c.new_blocks, c.refreshed_blocks
            );
        }
        let r = self.drop_interface().and_then(|()| {
            // SAFETY: handles created by this struct or null.
            unsafe {
                call!(VecDestroy(&mut self.work))?;
                call!(VecDestroy(&mut self.post))?;
                call!(PCDestroy(&mut self.gamg))
            }
        });
        if let Err(e) = r {
            eprintln!("warning: freeing the interface correction: {e}");
        }
    }
}

/// `-pc_gamg_reuse_interpolation` as the options database holds it (default: true, unlike
/// PETSc's own GAMG).
fn reuse_interpolation_option() -> Result<bool, PetscError> {
    let mut value = sys::PetscBool(0);
    let mut set = sys::PetscBool(0);
    // SAFETY: the name is a NUL-terminated literal; PETSc writes the two flags.
    unsafe {
        call!(PetscOptionsGetBool(
            std::ptr::null_mut(),
            std::ptr::null(),
            c"-pc_gamg_reuse_interpolation".as_ptr(),
            &mut value,
            &mut set
        ))?;
    }
    Ok(set.0 == 0 || value.0 != 0)
}

/// The shell's context, as PETSc hands it back.
///
/// # Safety
/// `pc` must be a shell installed by [`install`], whose context is a live `InterfaceCorrection`.
unsafe fn context<'a>(pc: sys::PC) -> Result<&'a mut InterfaceCorrection, PetscError> {
    let mut cp: *mut c_void = std::ptr::null_mut();
    // SAFETY: as the caller promises; PETSc writes the context pointer.
    unsafe {
        call!(PCShellGetContext(
            pc,
            &mut cp as *mut *mut c_void as *mut c_void
        ))?;
        Ok(&mut *(cp as *mut InterfaceCorrection))
    }
}

fn report(r: Result<(), PetscError>, what: &str) -> sys::PetscErrorCode {
    match r {
        Ok(()) => 0,
        Err(e) => {
            if std::env::var_os("NURBS_CONTACT_DEBUG_LINEAR").is_some() {
                eprintln!("interface correction {what}: {e}");
            }
            if e.code != 0 {
                e.code
            } else {
                PETSC_ERR_USER
            }
        }
    }
}

unsafe extern "C" fn shell_setup(pc: sys::PC) -> sys::PetscErrorCode {
    // SAFETY: PETSc calls this on the shell `install` made, with its context.
    let r = unsafe {
        context(pc).and_then(|ctx| {
            let mut a: sys::Mat = std::ptr::null_mut();
            let mut p: sys::Mat = std::ptr::null_mut();
            call!(PCGetOperators(pc, &mut a, &mut p))?;
            let mut comm: sys::MPI_Comm = std::mem::zeroed();
            call!(PetscObjectGetComm(pc as sys::PetscObject, &mut comm))?;
            ctx.set_up(a, comm)
        })
    };
    report(r, "set-up")
}

unsafe extern "C" fn shell_apply(pc: sys::PC, r: sys::Vec, z: sys::Vec) -> sys::PetscErrorCode {
    // SAFETY: as in `shell_setup`; r and z are the KSP's vectors for this call.
    let res = unsafe { context(pc).and_then(|ctx| ctx.apply(r, z)) };
    report(res, "apply")
}

/// Makes `pc` the interface-correction shell with `ctx` as its state, unless it is one already.
///
/// # Safety
/// `ctx` must stay at its address and alive while `pc` is a shell using it (the owner frees it
/// only after the PC is destroyed or changes type).
pub(crate) unsafe fn install(pc: sys::PC, ctx: *mut InterfaceCorrection) -> Result<(), PetscError> {
    // SAFETY: as the caller promises; `pc` is a live PC.
    unsafe {
        let mut t: sys::PCType = std::ptr::null();
        call!(PCGetType(pc, &mut t))?;
        if !t.is_null() && std::ffi::CStr::from_ptr(t) == sys::PCSHELL {
            return Ok(());
        }
        call!(PCSetType(pc, sys::PCSHELL.as_ptr()))?;
        call!(PCShellSetContext(pc, ctx as *mut c_void))?;
        call!(PCShellSetName(pc, c"gamg + interface LU (MUMPS)".as_ptr()))?;
        call!(PCShellSetSetUp(pc, Some(shell_setup)))?;
        call!(PCShellSetApply(pc, Some(shell_apply)))?;
    }
    Ok(())
}
