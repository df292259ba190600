//! The solver and its PETSc options: the case's and the code's defaults, the command line's, and
//! the check and warning about options that were not used.

use super::observer::StepObserver;
use super::{agree, log, Error, Numbered, RunOptions, Verbosity};
use crate::assembly::{constrained_flags, Assembler, NodeOffsets, SkewRows};
use crate::contact::ContactSystem;
use crate::model::Model;
use crate::petsc::{
    options_missing_values, quiet_errors, tolerance_problems, Matrix, Petsc, PetscError, Snes,
    Vector,
};
use crate::scene::Case;
use crate::solver::{run_load_steps_from, LoadPosition, SolverError, StepControl, StepRecord};
use mpi::traits::*;

/// The solver's state: unknowns, assembler (with contact), Jacobian, SNES and step control.
pub(super) struct Solver<'p> {
    /// Bodies that the conditions may leave free.
    pub(super) suspects: Vec<String>,
    pub(super) x: Vector<'p>,
    pub(super) asm: Assembler<'p>,
    pub(super) jac: Matrix<'p>,
    pub(super) snes: Snes<'p>,
    pub(super) control: StepControl,
}

/// Phase 3: the assembler (and contact system), the PETSc options, the Jacobian and SNES.
///
/// Collective.
pub(super) fn set_up_solver<'p>(
    petsc: &'p Petsc,
    opts: &RunOptions,
    case: &Case,
    model: &Model,
    numbered: Numbered,
) -> Result<Solver<'p>, Error> {
    let comm = petsc.comm();
    let (rank, size) = (comm.rank(), comm.size() as usize);
    let Numbered {
        part,
        dofs,
        sets,
        suspects,
        probes,
    } = numbered;
    let (n_global, n_owned) = (dofs.n_global(), dofs.n_owned());
    log(rank, opts.verbosity, Verbosity::Normal, || {
        format!(
            "{}: {} elements, {} unknowns on {} rank{}",
            case.case.name,
            model.n_cells(),
            n_global,
            size,
            if size > 1 { "s" } else { "" }
        )
    });

    let constrained = constrained_flags(&model.bcs, &dofs);
    let mut x = Vector::new_mpi(petsc, n_owned)?;
    x.set(0.0)?;
    let skew = SkewRows::new(&model.skews, &dofs, &model.coords, &constrained)
        .map_err(|e| Error::Usage(format!("{}: {e}", case.file.display())))?;
    let mut asm = Assembler::new(petsc, &x, dofs, sets, constrained)?;
    if !skew.is_empty() {
        asm.set_skew(skew);
    }
    if opts.matsetvalues {
        if !model.contact_pairs.is_empty() {
            return Err(Error::Usage(
                "--matsetvalues does not support contact pairs yet: the COO path rebuilds the contact coupling pattern".into(),
            ));
        }
        if !model.skews.is_empty() {
            return Err(Error::Usage(
                "--matsetvalues does not support `radial` or `sliding` conditions: drop --matsetvalues".into(),
            ));
        }
        asm.use_preallocated(model.cell_offsets.clone(), model.cell_nodes.clone());
    }
    if !model.contact_pairs.is_empty() {
        let sys = agree(
            comm,
            ContactSystem::new(
                model.dim,
                model.contact_surfaces.clone(),
                model.contact_pairs.clone(),
                &model.coords,
                &asm.dofs,
                &part,
                rank as usize,
            )
            .map_err(|msg| Error::Usage(format!("{}: contact: {msg}", case.file.display()))),
        )?;
        asm.set_coupling_set(Box::new(sys), &x, case.solver.contact_pattern_ring)?;
        asm.set_freeze_after(case.solver.contact_freeze_after);
    }
    if !model.couplings.is_empty() {
        let offsets = NodeOffsets::new(&model.couplings, &asm.dofs.rep, &model.coords, model.dim);
        asm.set_couplings(offsets);
        let overlap = match asm.rigidly_coupled_loaded_node() {
            Some(n) => Err(Error::Usage(format!(
                "{}: node {n} at {:?} moves with a free-translation rotation and carries contact points; the set's reaction moment would miss their force: keep the contact points off it (a contact `region`)",
                case.file.display(),
                &model.coords[n as usize * model.dim..(n as usize + 1) * model.dim]
            ))),
            None => Ok(()),
        };
        agree(comm, overlap)?;
    }
    // Options: code defaults (in Snes::new), then the case's petsc_options, then the command line;
    // inserted before any object reads them (the matrix reads -mat_* at creation).
    insert_solver_options(petsc, case, model, &opts.petsc_args)?;
    let jac = Matrix::new_aij(petsc, n_owned)?;
    let snes = snes_from_options(petsc, case, model, &opts.petsc_args)?;

    let control = StepControl {
        stage_steps: case.stages.iter().map(|s| s.steps).collect(),
        max_cutbacks: case.steps.max_cutbacks as usize,
        growth: case.steps.growth,
        easy_iterations: case.steps.easy_iterations as usize,
        pseudo_steps: case.steps.pseudo_steps as usize,
        translation_probes: probes,
    };
    Ok(Solver {
        suspects,
        x,
        asm,
        jac,
        snes,
        control,
    })
}

/// The PETSc options of the command line (after the program name), as one string.
pub(super) fn command_line_options(petsc_args: &[String]) -> String {
    petsc_args
        .iter()
        .skip(1)
        .cloned()
        .collect::<Vec<_>>()
        .join(" ")
}

/// Inserts the case's PETSc options, then the command line's (which take precedence), after
/// checking that every option that needs a value has one (PETSc would ignore it silently).
pub(super) fn insert_solver_options(
    petsc: &Petsc,
    case: &Case,
    model: &Model,
    petsc_args: &[String],
) -> Result<(), Error> {
    let cmdline = command_line_options(petsc_args);
    let mut problems = Vec::new();
    for (text, source) in [
        (&case.solver.petsc_options, "`solver.petsc_options`"),
        (&cmdline, "the command line"),
    ] {
        for o in options_missing_values(text) {
            problems.push(format!("`{o}` (in {source}) needs a value"));
        }
    }
    if !problems.is_empty() {
        return Err(Error::SolverOptions {
            file: case.file.clone(),
            message: problems.join("; "),
        });
    }
    petsc.insert_options(&case_petsc_options(case, model), &cmdline)?;
    Ok(())
}

/// The Newton solver with the code's defaults, then the options database applied: PETSc's own
/// message for an option it rejects (no traceback), and tolerances read back and checked (PETSc
/// 3.18 takes `-snes_rtol -5` without a word).
///
/// Collective.
pub(super) fn snes_from_options<'p>(
    petsc: &'p Petsc,
    case: &Case,
    model: &Model,
    petsc_args: &[String],
) -> Result<Snes<'p>, Error> {
    let cmdline = command_line_options(petsc_args);
    let in_case = case_petsc_options(case, model);
    let source = |option: &str| {
        let names = |s: &str| s.split_whitespace().any(|t| t == option);
        if names(&cmdline) {
            "set on the command line"
        } else if names(&in_case) {
            "set in `solver.petsc_options`"
        } else {
            "as the options left it"
        }
    };
    let rejected = |e: PetscError| Error::SolverOptions {
        file: case.file.clone(),
        message: format!("PETSc rejects them ({}): {}", e.function, e.message),
    };
    let mut snes = Snes::new(petsc)?;
    snes.set_tolerances(1e-11, 1e-10, 1e-14, 30)?;
    snes.set_stagnation_window(case.solver.stagnation_window);
    quiet_errors(|| snes.set_from_options()).map_err(rejected)?;
    let ksp = snes.ksp()?.tolerances()?;
    let problems: Vec<String> = tolerance_problems(&snes.tolerances()?, &ksp)
        .into_iter()
        .map(|p| {
            let option = p.split('`').nth(1).unwrap_or("").to_string();
            format!("{p} ({})", source(&option))
        })
        .collect();
    if !problems.is_empty() {
        return Err(Error::SolverOptions {
            file: case.file.clone(),
            message: problems.join("; "),
        });
    }
    Ok(snes)
}

/// `check`'s part of the solver: the options inserted and applied as `run` does, and the linear
/// solver set up on a system of one unknown (which makes the factor package read its options).
pub(super) fn check_solver_options(
    petsc: &Petsc,
    case: &Case,
    model: &Model,
    petsc_args: &[String],
) -> Result<(), Error> {
    insert_solver_options(petsc, case, model, petsc_args)?;
    let mut a = Matrix::new_aij(petsc, 1)?;
    a.preallocate_aij(&[1], &[0])?;
    a.add_values(&[0], &[0], &[1.0])?;
    a.assemble()?;
    let mut snes = snes_from_options(petsc, case, model, petsc_args)?;
    let mut ksp = snes.ksp()?;
    ksp.set_operators(&a)?;
    quiet_errors(|| ksp.set_up()).map_err(|e| Error::SolverOptions {
        file: case.file.clone(),
        message: format!(
            "PETSc rejects them setting up the linear solver ({}): {}",
            e.function, e.message
        ),
    })?;
    Ok(())
}

/// Rank 0: a warning naming the options PETSc never read (a misspelt or misplaced option does
/// nothing otherwise).
pub(super) fn warn_unused_options(petsc: &Petsc) {
    let left = match petsc.options_left() {
        Ok(l) => l,
        Err(e) => {
            eprintln!("warning: could not list the unused PETSc options: {e}");
            return;
        }
    };
    // the code's own defaults (case_petsc_options) are not the user's
    let left: Vec<_> = left
        .into_iter()
        .filter(|(n, _)| !CODE_DEFAULT_OPTIONS.contains(&n.as_str()))
        .collect();
    if left.is_empty() || petsc.comm().rank() != 0 {
        return;
    }
    let names: Vec<String> = left
        .iter()
        .map(|(n, v)| match v {
            Some(v) => format!("{n} {v}"),
            None => n.clone(),
        })
        .collect();
    eprintln!(
        "warning: PETSc never used {} option{}: {}",
        names.len(),
        if names.len() == 1 { "" } else { "s" },
        names.join(", ")
    );
}

/// Options [`case_petsc_options`] adds; not reported as unused (they need not apply to every
/// linear solver).
pub(super) const CODE_DEFAULT_OPTIONS: [&str; 2] = ["-mat_mumps_icntl_24", "-snes_linesearch_type"];

/// The case's `solver.petsc_options`, after the defaults that depend on the case.
pub(super) fn case_petsc_options(case: &Case, model: &Model) -> String {
    // With contact, PETSc's backtracking line search creeps where the penalty switches points between
    // active and inactive, and full steps invert elements that a cutback must then repair; the l2
    // line search (a secant minimisation of |F|^2 along the step) does best (BENCHMARKS.md: ironing_2d
    // 454 Newton iterations and no cutbacks vs 506 with bt and 663 + 35 cutbacks with full steps;
    // hertz_2d 10 vs 36 with bt). The case or the command line can override it.
    // MUMPS counts null pivots (INFOG(28)) instead of failing or pivoting around them, so a
    // singular tangent is reported with the free body's name (load stepping checks the count).
    let null_pivots = "-mat_mumps_icntl_24 1";
    if model.contact_pairs.is_empty() {
        format!("{null_pivots} {}", case.solver.petsc_options)
    } else {
        format!(
            "{null_pivots} -snes_linesearch_type l2 {}",
            case.solver.petsc_options
        )
    }
}

impl<'p> Solver<'p> {
    /// Phase 4: steps the load through all stages, handing every converged step to `observer`.
    ///
    /// Collective.
    pub(super) fn load_loop(
        &mut self,
        model: &Model,
        observer: &mut StepObserver<'_, 'p>,
        start: Option<LoadPosition>,
    ) -> Result<Vec<StepRecord>, SolverError> {
        let result = run_load_steps_from(
            &mut self.asm,
            &mut self.snes,
            &mut self.x,
            &mut self.jac,
            &model.bcs,
            &model.coords,
            &self.control,
            start,
            &mut |rec, x, asm| observer.observe(model, rec, x, asm),
        );
        if let Some(b) = &observer.bar {
            b.finish_and_clear();
        }
        result
    }
}
