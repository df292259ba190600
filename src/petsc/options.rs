//! Checking the solver options: PETSc's own message for what it rejects, tolerances read back and
//! checked, and the options PETSc never used.

use super::error::{call, PetscError};
use super::{sys, Ksp, Petsc, PetscInt, Snes};
use std::ffi::{c_char, c_int, c_void, CStr};

impl Petsc {
    /// Removes PETSc's signal handler (which turns SIGTERM into an abort), so the program's own
    /// handlers decide.
    pub fn pop_signal_handler(&self) -> Result<(), PetscError> {
        // SAFETY: pops the handler PetscInitialize pushed; with the stack empty PETSc restores the
        // default dispositions.
        unsafe { call!(PetscPopSignalHandler()) }
    }

    /// Options in the database that no PETSc object has read so far: `(-name, value)`.
    pub fn options_left(&self) -> Result<Vec<(String, Option<String>)>, PetscError> {
        let mut n: PetscInt = 0;
        let mut names: *mut *mut c_char = std::ptr::null_mut();
        let mut values: *mut *mut c_char = std::ptr::null_mut();
        let mut out = Vec::new();
        // SAFETY: null options means the global database; PETSc allocates the two arrays of `n`
        // pointers (into its own strings, a value may be null) and frees them in the restore call.
        unsafe {
            call!(PetscOptionsLeftGet(
                std::ptr::null_mut(),
                &mut n,
                &mut names,
                &mut values
            ))?;
            for i in 0..n.max(0) as usize {
                let name = *names.add(i);
                if name.is_null() {
                    continue;
                }
                let name = CStr::from_ptr(name).to_string_lossy();
                let value = *values.add(i);
                let value = (!value.is_null())
                    .then(|| CStr::from_ptr(value).to_string_lossy().into_owned());
                let dash = if name.starts_with('-') { "" } else { "-" };
                out.push((format!("{dash}{name}"), value));
            }
            call!(PetscOptionsLeftRestore(
                std::ptr::null_mut(),
                &mut n,
                &mut names,
                &mut values
            ))?;
        }
        Ok(out)
    }
}

/// PETSc error handler that keeps the first specific message (e.g. `Unknown PC type: bogus`)
/// instead of printing a traceback.
unsafe extern "C" fn record_message(
    _comm: sys::MPI_Comm,
    _line: c_int,
    _func: *const c_char,
    _file: *const c_char,
    code: sys::PetscErrorCode,
    kind: sys::PetscErrorType,
    message: *const c_char,
    ctx: *mut c_void,
) -> sys::PetscErrorCode {
    // SAFETY: `ctx` is the `Option<String>` that `quiet_errors` keeps alive while the handler is
    // pushed; `message` is a NUL-terminated string or null.
    let slot = unsafe { &mut *(ctx as *mut Option<String>) };
    if slot.is_none() && kind == sys::PetscErrorType::PETSC_ERROR_INITIAL && !message.is_null() {
        let m = unsafe { CStr::from_ptr(message) }.to_string_lossy();
        let m = m.trim();
        if !m.is_empty() {
            *slot = Some(m.to_string());
        }
    }
    code
}

/// Runs `f` with PETSc's traceback silenced; an error of `f` carries PETSc's specific message (the
/// first one raised) in place of the generic text of its code.
pub fn quiet_errors<T>(f: impl FnOnce() -> Result<T, PetscError>) -> Result<T, PetscError> {
    let mut slot: Box<Option<String>> = Box::new(None);
    let ctx = &mut *slot as *mut Option<String> as *mut c_void;
    // SAFETY: the handler only writes into `slot`, which outlives the push/pop pair.
    unsafe { call!(PetscPushErrorHandler(Some(record_message), ctx))? };
    let r = f();
    // SAFETY: pops the handler pushed above.
    unsafe { call!(PetscPopErrorHandler())? };
    r.map_err(|mut e| {
        if let Some(m) = slot.take() {
            e.message = m;
        }
        e
    })
}

/// Tolerances of a nonlinear solver, as PETSc holds them after the options were applied.
#[derive(Debug, Clone, Copy)]
pub struct SnesTolerances {
    pub atol: f64,
    pub rtol: f64,
    pub stol: f64,
    pub max_it: PetscInt,
    pub max_funcs: PetscInt,
}

/// Tolerances of a linear solver.
#[derive(Debug, Clone, Copy)]
pub struct KspTolerances {
    pub rtol: f64,
    pub atol: f64,
    pub dtol: f64,
    pub max_it: PetscInt,
}

impl Snes<'_> {
    /// The tolerances in force (`-snes_rtol` etc. applied).
    pub fn tolerances(&self) -> Result<SnesTolerances, PetscError> {
        let mut t = SnesTolerances {
            atol: 0.0,
            rtol: 0.0,
            stol: 0.0,
            max_it: 0,
            max_funcs: 0,
        };
        // SAFETY: valid handle; writes five scalars.
        unsafe {
            call!(SNESGetTolerances(
                self.as_raw(),
                &mut t.atol,
                &mut t.rtol,
                &mut t.stol,
                &mut t.max_it,
                &mut t.max_funcs
            ))?
        };
        Ok(t)
    }
}

impl Snes<'_> {
    /// The nonlinear solver's type in force: `newtonls` unless `-snes_type` chose another.
    pub fn type_name(&self) -> Result<String, PetscError> {
        let mut t: *const c_char = std::ptr::null();
        // SAFETY: valid handle; PETSc returns a pointer to its own string (null when unset).
        unsafe { call!(SNESGetType(self.as_raw(), &mut t))? };
        Ok(if t.is_null() {
            String::new()
        } else {
            // SAFETY: a NUL-terminated string owned by PETSc, copied at once.
            unsafe { CStr::from_ptr(t) }.to_string_lossy().into_owned()
        })
    }
}

impl Snes<'_> {
    /// The factor matrix of the linear solver's PC when it is an LU or Cholesky factorisation by
    /// MUMPS that has been factored (or attempted); `None` otherwise.
    fn mumps_factor(&mut self) -> Result<Option<sys::Mat>, PetscError> {
        let mut ksp = std::ptr::null_mut();
        let mut pc = std::ptr::null_mut();
        let mut pc_type: *const c_char = std::ptr::null();
        // SAFETY: valid handles borrowed from the SNES; PETSc returns pointers to its own strings.
        unsafe {
            call!(SNESGetKSP(self.as_raw(), &mut ksp))?;
            call!(KSPGetPC(ksp, &mut pc))?;
            call!(PCGetType(pc, &mut pc_type))?;
            if pc_type.is_null() {
                return Ok(None);
            }
            let t = CStr::from_ptr(pc_type).to_string_lossy();
            if t != "lu" && t != "cholesky" {
                return Ok(None);
            }
            let mut solver: *const c_char = std::ptr::null();
            call!(PCFactorGetMatSolverType(pc, &mut solver))?;
            if solver.is_null() || CStr::from_ptr(solver).to_bytes() != b"mumps" {
                return Ok(None);
            }
        }
        let factor = quiet_errors(|| {
            let mut f = std::ptr::null_mut();
            // SAFETY: valid PC; fails (quietly) when nothing was factored yet.
            unsafe { call!(PCFactorGetMatrix(pc, &mut f))? };
            Ok(f)
        });
        Ok(factor.ok().filter(|f| !f.is_null()))
    }

    /// Null pivots MUMPS found in the last factorisation (`INFOG(28)`, with `-mat_mumps_icntl_24 1`);
    /// `None` when the linear solver is not an LU or Cholesky factorisation by MUMPS, or nothing
    /// was factored yet.
    pub fn null_pivots(&mut self) -> Result<Option<i32>, PetscError> {
        let Some(f) = self.mumps_factor()? else {
            return Ok(None);
        };
        let mut v: PetscInt = 0;
        // SAFETY: `f` is the MUMPS factor of the PC; writes one integer.
        unsafe { call!(MatMumpsGetInfog(f, 28, &mut v))? };
        Ok(Some(v as i32))
    }

    /// Why the last linear solve failed, for a Newton solve that stopped with
    /// `DIVERGED_LINEAR_SOLVE`: the KSP and PC types, the KSP's reason and iteration count, and for
    /// a MUMPS factorisation its error code (`INFOG(1)`, `INFOG(2)`; -9 and -13 mean it ran out of
    /// memory, -19 that it needs more than `-mat_mumps_icntl_23` allows), e.g. `gmres + gamg: DIVERGED_ITS after 400 iterations` or
    /// `preonly + lu (MUMPS): DIVERGED_PC_FAILED, MUMPS INFOG(1) = -13, INFOG(2) = 2400`.
    ///
    /// Collective.
    pub fn linear_failure_detail(&mut self) -> Result<String, PetscError> {
        let mut ksp = std::ptr::null_mut();
        let mut pc = std::ptr::null_mut();
        let mut ksp_type: *const c_char = std::ptr::null();
        let mut pc_type: *const c_char = std::ptr::null();
        let mut reason = sys::KSPConvergedReason(0);
        let mut text: *const c_char = std::ptr::null();
        let mut its: PetscInt = 0;
        // SAFETY: valid handles borrowed from the SNES; PETSc returns pointers to its own static
        // strings (null when unset).
        let (kt, pt, why) = unsafe {
            call!(SNESGetKSP(self.as_raw(), &mut ksp))?;
            call!(KSPGetPC(ksp, &mut pc))?;
            call!(KSPGetType(ksp, &mut ksp_type))?;
            call!(PCGetType(pc, &mut pc_type))?;
            call!(KSPGetConvergedReason(ksp, &mut reason))?;
            call!(KSPGetConvergedReasonString(ksp, &mut text))?;
            call!(KSPGetIterationNumber(ksp, &mut its))?;
            let s = |p: *const c_char| {
                if p.is_null() {
                    "?".to_string()
                } else {
                    CStr::from_ptr(p).to_string_lossy().into_owned()
                }
            };
            (s(ksp_type), s(pc_type), s(text))
        };
        let why = if text.is_null() {
            reason.0.to_string()
        } else {
            why
        };
        let mut detail = format!("{kt} + {pt}");
        let mumps = self.mumps_factor()?;
        if mumps.is_some() {
            detail.push_str(" (MUMPS)");
        }
        detail.push_str(&format!(": {why}"));
        if kt != "preonly" {
            detail.push_str(&format!(" after {its} iterations"));
            // the true residual at the limit, when the accepting test computed it
            let limit = self.ksp()?.limit_state()?;
            if let Some((_, rel)) = limit.filter(|&(_, r)| r.is_finite()) {
                if why == "DIVERGED_ITS" {
                    detail.push_str(&format!(", true residual {rel:.1e} of |b|"));
                }
            }
        }
        if let Some(f) = mumps {
            let (mut e1, mut e2): (PetscInt, PetscInt) = (0, 0);
            // SAFETY: `f` is the MUMPS factor of the PC; each call writes one integer.
            unsafe {
                call!(MatMumpsGetInfog(f, 1, &mut e1))?;
                call!(MatMumpsGetInfog(f, 2, &mut e2))?;
            }
            if e1 != 0 {
                detail.push_str(&format!(", MUMPS INFOG(1) = {e1}, INFOG(2) = {e2}"));
                if matches!(e1, -9 | -13 | -19) {
                    detail.push_str(" (out of memory)");
                }
            }
        }
        Ok(detail)
    }
}

impl Ksp<'_> {
    /// Sets the solver up for its operators (for a direct solver: the factorisation, which reads the
    /// factor package's options).
    ///
    /// Collective.
    pub fn set_up(&mut self) -> Result<(), PetscError> {
        // SAFETY: valid handle.
        unsafe { call!(KSPSetUp(self.as_raw())) }
    }

    /// The tolerances in force (`-ksp_rtol` etc. applied).
    pub fn tolerances(&self) -> Result<KspTolerances, PetscError> {
        let mut t = KspTolerances {
            rtol: 0.0,
            atol: 0.0,
            dtol: 0.0,
            max_it: 0,
        };
        // SAFETY: valid handle; writes four scalars.
        unsafe {
            call!(KSPGetTolerances(
                self.as_raw(),
                &mut t.rtol,
                &mut t.atol,
                &mut t.dtol,
                &mut t.max_it
            ))?
        };
        Ok(t)
    }
}

/// What is wrong with the tolerances in force: one line per value out of range, naming the option
/// that sets it. PETSc 3.18 stores `-snes_rtol -5` without a check.
pub fn tolerance_problems(snes: &SnesTolerances, ksp: &KspTolerances) -> Vec<String> {
    let mut out = Vec::new();
    let mut need = |ok: bool, option: &str, value: String, range: &str| {
        if !ok {
            out.push(format!("`{option}` is {value}; it must be {range}"));
        }
    };
    let finite = |x: f64| x.is_finite();
    need(
        finite(snes.rtol) && (0.0..1.0).contains(&snes.rtol),
        "-snes_rtol",
        snes.rtol.to_string(),
        "in [0, 1)",
    );
    need(
        finite(snes.atol) && snes.atol >= 0.0,
        "-snes_atol",
        snes.atol.to_string(),
        ">= 0",
    );
    need(
        finite(snes.stol) && snes.stol >= 0.0,
        "-snes_stol",
        snes.stol.to_string(),
        ">= 0",
    );
    need(
        snes.max_it >= 0,
        "-snes_max_it",
        snes.max_it.to_string(),
        ">= 0",
    );
    need(
        snes.max_funcs >= -1,
        "-snes_max_funcs",
        snes.max_funcs.to_string(),
        ">= 0 (or -1 for no limit)",
    );
    need(
        finite(ksp.rtol) && (0.0..1.0).contains(&ksp.rtol),
        "-ksp_rtol",
        ksp.rtol.to_string(),
        "in [0, 1)",
    );
    need(
        finite(ksp.atol) && ksp.atol >= 0.0,
        "-ksp_atol",
        ksp.atol.to_string(),
        ">= 0",
    );
    need(
        !ksp.dtol.is_nan() && ksp.dtol > 0.0,
        "-ksp_divtol",
        ksp.dtol.to_string(),
        "> 0",
    );
    need(
        ksp.max_it >= 0,
        "-ksp_max_it",
        ksp.max_it.to_string(),
        ">= 0",
    );
    out
}

/// Endings of option names that PETSc reads as a number or a name: without a value PETSc 3.18
/// ignores such an option silently (it reads only flags without one).
const VALUE_ENDINGS: [&str; 18] = [
    "_type",
    "_rtol",
    "_atol",
    "_stol",
    "_divtol",
    "_dtol",
    "_max_it",
    "_max_funcs",
    "_max_fail",
    "_max_linear_solve_fail",
    "_lag_jacobian",
    "_lag_preconditioner",
    "_restart",
    "_damping",
    "_maxstep",
    "_minlambda",
    "_order",
    "_levels",
];

/// Options in `text` (a `solver.petsc_options` string or the command line) that need a value and
/// have none: a name ending as in [`VALUE_ENDINGS`] or a MUMPS `_icntl_N`/`_cntl_N`, followed by
/// another option or nothing.
pub fn options_missing_values(text: &str) -> Vec<String> {
    let is_option = |t: &str| {
        t.strip_prefix('-')
            .and_then(|r| r.chars().next())
            .is_some_and(|c| c.is_ascii_alphabetic())
    };
    let needs_value = |name: &str| {
        VALUE_ENDINGS.iter().any(|e| name.ends_with(e)) || {
            let stem = name.trim_end_matches(|c: char| c.is_ascii_digit());
            stem.len() < name.len() && (stem.ends_with("_icntl_") || stem.ends_with("_cntl_"))
        }
    };
    let tokens: Vec<&str> = text.split_whitespace().collect();
    let mut out = Vec::new();
    for (i, t) in tokens.iter().enumerate() {
        let next_is_value = tokens.get(i + 1).is_some_and(|n| !is_option(n));
        if is_option(t) && needs_value(t) && !next_is_value {
            out.push(t.to_string());
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn options_without_their_value_are_found() {
        assert_eq!(options_missing_values("-snes_rtol"), vec!["-snes_rtol"]);
        assert_eq!(
            options_missing_values("-snes_rtol -snes_monitor -pc_type lu"),
            vec!["-snes_rtol"]
        );
        assert!(options_missing_values("-snes_rtol -5 -snes_monitor").is_empty());
        assert_eq!(
            options_missing_values("-mat_mumps_icntl_14 -ksp_view"),
            vec!["-mat_mumps_icntl_14"]
        );
        assert!(options_missing_values("-mat_mumps_icntl_14 50 -ksp_type preonly").is_empty());
    }

    #[test]
    fn tolerances_out_of_range_name_their_option() {
        let snes = SnesTolerances {
            atol: 1e-10,
            rtol: -5.0,
            stol: 1e-14,
            max_it: 30,
            max_funcs: 10000,
        };
        let ksp = KspTolerances {
            rtol: 1e-5,
            atol: 1e-50,
            dtol: 1e5,
            max_it: 10000,
        };
        assert_eq!(
            tolerance_problems(&snes, &ksp),
            vec!["`-snes_rtol` is -5; it must be in [0, 1)"]
        );
        let ok = SnesTolerances { rtol: 1e-8, ..snes };
        assert!(tolerance_problems(&ok, &ksp).is_empty());
        let bad_ksp = KspTolerances { max_it: -1, ..ksp };
        assert_eq!(tolerance_problems(&ok, &bad_ksp).len(), 1);
    }
}
