//! The acceptance checks of a load step: a solve's state is accepted only when its tangent holds
//! every rigid motion (translation probes, MUMPS's null pivots) and no element is folded over
//! (`Assembler::find_tangled`).

use super::{SolverError, System};
use crate::petsc::{Matrix, PetscError, SolveOutcome, Vector};

/// A rigid translation that only contact may hold (a body pressed onto a frictionless plane is
/// free along it): `rows` are this rank's owned unknowns that move with it.
///
/// MUMPS's null-pivot count catches a singular tangent only when roundoff leaves the pivot below
/// its threshold, which depends on the factorisation and on the BLAS kernels. A free translation
/// `t` is in the kernel of the tangent `K` exactly (the internal forces do not change under a
/// translation, nor does a contact that cannot hold it), so `|K t| / (|K|_inf |t|)` is at
/// roundoff level (1e-16) when nothing holds it, and at least the share of the contact rows when
/// contact does (1e-4 and more in the shipped cases): [`FREE_TRANSLATION_TOL`] between the two.
#[derive(Debug, Clone, PartialEq)]
pub struct TranslationProbe {
    /// What moves, e.g. "body `disk`".
    pub what: String,
    /// The axis (0: x, 1: y, 2: z).
    pub axis: usize,
    /// Owned global rows of the unknowns along `axis` of the nodes that move.
    pub rows: Vec<crate::petsc::PetscInt>,
}

/// The largest `|K t| / (|K|_inf |t|)` of a translation `t` that the tangent is taken not to
/// resist (see [`TranslationProbe`]).
pub const FREE_TRANSLATION_TOL: f64 = 1e-10;

/// `|K t| / (|K|_inf |t|)` for the probe's translation `t` on the assembled tangent `jac`; `like`
/// gives the vector layout.
///
/// Collective.
pub fn translation_resistance<'p>(
    jac: &Matrix<'p>,
    like: &Vector<'p>,
    probe: &TranslationProbe,
) -> Result<f64, PetscError> {
    let mut t = like.duplicate()?;
    t.set(0.0)?;
    let (lo, _) = t.ownership_range()?;
    {
        let mut w = t.write()?;
        for &g in &probe.rows {
            w[(g - lo) as usize] = 1.0;
        }
    }
    let t_norm = t.norm2()?;
    if t_norm == 0.0 {
        return Ok(f64::INFINITY);
    }
    let mut kt = like.duplicate()?;
    jac.mult(&t, &mut kt)?;
    let scale = jac.norm_inf()? * t_norm;
    Ok(if scale > 0.0 {
        kt.norm2()? / scale
    } else {
        0.0
    })
}

/// The checks after each Newton solve of a step. A singular tangent (a body nothing holds) would
/// give an arbitrary answer: a translation that only contact could hold is checked on the tangent
/// itself (exact, whatever the factorisation's roundoff); any other rigid motion through MUMPS's
/// null-pivot count (`-mat_mumps_icntl_24 1`) in the last factorisation. (Not in every
/// factorisation of the attempt: the first tangent of a step is singular wherever contact holds a
/// body only once it closes during the step, e.g. a disk pressed into a cradle, and Newton goes
/// on correctly from MUMPS's treatment of the null pivot.) The kernel saw `det F > 0` at the
/// quadrature points only: a converged state folded over between them is no equilibrium of the
/// body and is refused like a failed attempt (cut back).
#[derive(Debug)]
pub(super) struct Acceptance<'c> {
    probes: &'c [TranslationProbe],
    /// The last attempt of this step that converged to a folded state: (load, where).
    pub(super) tangled: Option<(f64, String)>,
    /// Print every probe's ratio (`NURBS_CONTACT_DEBUG_PROBES`).
    debug: bool,
}

impl<'c> Acceptance<'c> {
    /// The checks with these translation probes.
    pub(super) fn new(probes: &'c [TranslationProbe], debug: bool) -> Self {
        Acceptance {
            probes,
            tangled: None,
            debug,
        }
    }

    /// A new step: no fold seen yet.
    pub(super) fn begin_step(&mut self) {
        self.tangled = None;
    }

    /// After the solve `out` of step `step` (0-based) at `target`: `Err` for a singular tangent
    /// (the run stops); true when the state is converged and accepted; false when not converged,
    /// or converged but folded over ([`tangled`](Self::tangled) says where).
    ///
    /// Collective.
    pub(super) fn accepts(
        &mut self,
        sys: &mut System<'_, '_>,
        out: &SolveOutcome,
        step: usize,
        target: f64,
    ) -> Result<bool, SolverError> {
        if out.converged {
            for probe in self.probes {
                let ratio = translation_resistance(sys.jac, sys.x, probe)?;
                if self.debug {
                    eprintln!(
                        "probe: step {} translation {} of {}: |K t| / (|K| |t|) = {ratio:.3e}",
                        step + 1,
                        ["x", "y", "z"][probe.axis],
                        probe.what
                    );
                }
                free_translation(probe, ratio, step, target)?;
            }
        }
        null_pivots(sys.snes.null_pivots()?, step, target)?;
        if !out.converged {
            return Ok(false);
        }
        match sys.asm.find_tangled(sys.x)? {
            None => Ok(true),
            Some(fold) => {
                self.tangled = Some((target, fold));
                Ok(false)
            }
        }
    }
}

/// The run stops when the tangent of step `step` (0-based) at `load` does not resist the probe's
/// translation (`ratio`: [`translation_resistance`]).
fn free_translation(
    probe: &TranslationProbe,
    ratio: f64,
    step: usize,
    load: f64,
) -> Result<(), SolverError> {
    if ratio <= FREE_TRANSLATION_TOL {
        return Err(SolverError::FreeTranslation {
            step: step + 1,
            load,
            what: probe.what.clone(),
            axis: probe.axis,
            ratio,
        });
    }
    Ok(())
}

/// The run stops when MUMPS found null pivots in the last factorisation of step `step` (0-based)
/// at `load` (`None`: not factored by MUMPS).
fn null_pivots(pivots: Option<i32>, step: usize, load: f64) -> Result<(), SolverError> {
    if let Some(pivots) = pivots.filter(|&p| p > 0) {
        return Err(SolverError::Singular {
            step: step + 1,
            load,
            pivots: pivots as usize,
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_free_translation_or_a_null_pivot_stops_the_run_naming_the_step() {
        let probe = TranslationProbe {
            what: "body `disk`".into(),
            axis: 1,
            rows: Vec::new(),
        };
        // roundoff level: nothing holds it
        match free_translation(&probe, 1e-16, 4, 0.5) {
            Err(SolverError::FreeTranslation {
                step, what, axis, ..
            }) => assert_eq!((step, what.as_str(), axis), (5, "body `disk`", 1)),
            other => panic!("{other:?}"),
        }
        // the share of the contact rows: contact holds it
        assert!(free_translation(&probe, 1e-4, 4, 0.5).is_ok());
        assert!(null_pivots(None, 4, 0.5).is_ok());
        assert!(null_pivots(Some(0), 4, 0.5).is_ok());
        match null_pivots(Some(3), 4, 0.5) {
            Err(SolverError::Singular { step, pivots, .. }) => assert_eq!((step, pivots), (5, 3)),
            other => panic!("{other:?}"),
        }
    }
}
