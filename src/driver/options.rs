//! The solver and its PETSc options: the case's and the code's defaults, the command line's, and
//! the check and warning about options that were not used.

use super::observer::StepObserver;
use super::{agree, log, Error, Numbered, RunOptions, Verbosity};
use crate::assembly::{constrained_flags, Assembler, NodeOffsets, SkewRows};
use crate::contact::ContactSystem;
use crate::model::Model;
use crate::petsc::{
    options_missing_values, quiet_errors, tolerance_problems, Matrix, Petsc, PetscError, Snes,
    StopQuery, Vector,
};
use crate::scene::schema::{LinearSolver, Preconditioner};
use crate::scene::Case;
use crate::solver::judge::{NEWTON_ATOL, NEWTON_MAX_IT, NEWTON_RTOL, NEWTON_STOL};
use crate::solver::linear::rigid_body_null_space;
use crate::solver::{
    run_load_steps_from, LoadPosition, SolverError, StepControl, StepEvent, StepRecord,
};
use mpi::traits::*;

/// The solver's state: unknowns, assembler (with contact), Jacobian, SNES and step control.
pub(super) struct Solver<'p> {
    /// Bodies that the conditions may leave free.
    pub(super) suspects: Vec<String>,
    pub(super) x: Vector<'p>,
    /// The converged state before `x`'s, from a checkpoint (the secant predictor's `u_{n-1}`).
    pub(super) x_before: Option<Vector<'p>>,
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
        ..
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
    let skew = SkewRows::new(&model.skews, &dofs, &model.coords, &constrained, &|n| {
        model.node_label(n)
    })
    .map_err(|e| Error::Usage(format!("{}: {e}", case.file.display())))?;
    let mut asm = Assembler::new(petsc, &x, dofs, sets, constrained.clone())?;
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
        asm.set_max_penetration(case.solver.max_penetration);
    }
    if !model.couplings.is_empty() {
        let offsets = NodeOffsets::new(&model.couplings, &asm.dofs.rep, &model.coords, model.dim);
        asm.set_couplings(offsets);
        let overlap = match asm.rigidly_coupled_loaded_node() {
            Some(n) => Err(Error::Usage(format!(
                "{}: {} moves with a free-translation rotation and carries contact points; the set's reaction moment would miss their force: keep the contact points off it (a contact `region`)",
                case.file.display(),
                model.node_label(n)
            ))),
            None => Ok(()),
        };
        agree(comm, overlap)?;
    }
    // Options: code defaults (in Snes::new), then the case's petsc_options, then the command line;
    // inserted before any object reads them (the matrix reads -mat_* at creation).
    let route = case.solver.linear_setting().resolve(n_global as f64);
    log(rank, opts.verbosity, Verbosity::Verbose, || {
        format!(
            "linear solver: {}{}",
            route.name(),
            if case.solver.linear == Some(LinearSolver::Auto) {
                " (chosen by `auto`)"
            } else {
                ""
            }
        )
    });
    insert_solver_options(petsc, case, model, route, &opts.petsc_args)?;
    let jac = Matrix::new_aij(petsc, n_owned)?;
    let mut snes = snes_from_options(petsc, case, model, route, &opts.petsc_args)?;
    if route == LinearSolver::Iterative {
        // GAMG's coarse spaces from each body's rigid-body modes, attached to every Jacobian
        // (the contact pattern rebuild makes new matrices); a failed Krylov solve retries the
        // step with MUMPS (load stepping).
        let space = rigid_body_null_space(
            petsc,
            &x,
            model,
            &asm.dofs,
            &constrained,
            ZERO_CONSTRAINED_MODES
                ^ std::env::var_os("NURBS_CONTACT_FLIP_CONSTRAINED_MODES").is_some(),
        )?;
        snes.set_near_null_space(space);
        snes.set_iterative(true);
        match case.solver.preconditioner {
            Preconditioner::Gamg => {}
            Preconditioner::GamgInterface => {
                snes.set_interface_correction(INTERFACE_LAYERS, false);
            }
            Preconditioner::GamgInterfaceSymmetric => {
                snes.set_interface_correction(INTERFACE_LAYERS, true);
            }
        }
        // a solve stopped by `-ksp_max_it` that has reduced its residual enough is an inexact
        // Newton direction, not a failure (`[solver] krylov_accept`); a signal to stop the run
        // ends a Krylov solve at its next iteration (one all-reduce per iteration), so that a
        // long solve at 10^6 unknowns does not outlast `[slurm] stop_before` or MPI's kill delay
        let accept = (case.solver.krylov_accept > 0.0).then_some(case.solver.krylov_accept);
        let comm = asm.comm().duplicate();
        let stop: StopQuery = Box::new(move || crate::interrupt::agreed(&comm).is_some());
        snes.ksp()?.set_convergence_test(accept, Some(stop))?;
    }

    let control = StepControl {
        stage_steps: case.stages.iter().map(|s| s.steps).collect(),
        max_cutbacks: case.steps.max_cutbacks as usize,
        growth: case.steps.growth,
        easy_iterations: case.steps.easy_iterations as usize,
        pseudo_steps: case.steps.pseudo_steps as usize,
        translation_probes: probes,
        secant_predictor: case.solver.predictor == crate::scene::Predictor::Secant,
        newton_overrides: newton_overrides(&snes, case, model, route, &opts.petsc_args)?,
    };
    Ok(Solver {
        suspects,
        x,
        x_before: None,
        asm,
        jac,
        snes,
        control,
    })
}

/// Layers of matrix neighbours `[solver] preconditioner = "gamg_interface"` adds around the
/// contact couplings' unknowns.
const INTERFACE_LAYERS: usize = 1;

/// The linear solver that runs: `[solver] linear`, with `"auto"` resolved for the unknowns.
pub(super) fn linear_route(case: &Case, dofs: &crate::assembly::DofMap) -> LinearSolver {
    case.solver.linear_setting().resolve(dofs.n_global() as f64)
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
    route: LinearSolver,
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
    if let Some(message) = route_contradiction(case, route, &cmdline) {
        return Err(Error::SolverOptions {
            file: case.file.clone(),
            message,
        });
    }
    petsc.insert_options(&case_petsc_options(case, model, route), &cmdline)?;
    Ok(())
}

/// The value of `option` in force and where it was set: the command line over
/// `solver.petsc_options`, the last occurrence in each (as PETSc reads them).
fn option_value<'a>(
    option: &str,
    in_case: &'a str,
    cmdline: &'a str,
) -> Option<(&'a str, &'static str)> {
    let last = |text: &'a str| {
        let tokens: Vec<&str> = text.split_whitespace().collect();
        tokens
            .iter()
            .rposition(|t| *t == option)
            .map(|i| tokens.get(i + 1).copied().unwrap_or(""))
    };
    last(cmdline)
        .map(|v| (v, "on the command line"))
        .or_else(|| last(in_case).map(|v| (v, "in `solver.petsc_options`")))
}

/// Why `[solver] linear` (resolved to `route`) and the `-ksp_type`/`-pc_type` options in force
/// contradict each other, if they do; a case that does not set `linear` leaves the choice to the
/// options, as before the setting existed (`-ksp_type gmres -pc_type jacobi` still works). The
/// direct route is `-ksp_type preonly` with an LU or
/// Cholesky factorisation, the iterative one a Krylov method (not `preonly`) with a preconditioner
/// that is not a factorisation (`gamg` by default; `hypre`, `jacobi`, `asm`, ... are fine).
pub(super) fn route_contradiction(
    case: &Case,
    route: LinearSolver,
    cmdline: &str,
) -> Option<String> {
    case.solver.linear?;
    let in_case = case.solver.petsc_options.as_str();
    let chosen = if case.solver.linear == Some(LinearSolver::Auto) {
        format!(
            "`solver.linear = \"auto\"` (which chose \"{}\" here)",
            route.name()
        )
    } else {
        format!("`solver.linear = \"{}\"`", route.name())
    };
    let factorisation = |pc: &str| pc == "lu" || pc == "cholesky";
    let mut out = Vec::new();
    if let Some((ksp, at)) = option_value("-ksp_type", in_case, cmdline) {
        match route {
            LinearSolver::Direct if ksp != "preonly" => out.push(format!(
                "{chosen} contradicts `-ksp_type {ksp}` (set {at}): the direct route is one MUMPS solve \
                 (`-ksp_type preonly`); for a Krylov method set `solver.linear = \"iterative\"`"
            )),
            LinearSolver::Iterative if ksp == "preonly" => out.push(format!(
                "{chosen} contradicts `-ksp_type preonly` (set {at}): the iterative route needs a Krylov \
                 method (gmres, cg, ...); for a direct solve set `solver.linear = \"direct\"`"
            )),
            _ => {}
        }
    }
    if let Some((pc, at)) = option_value("-pc_type", in_case, cmdline) {
        match route {
            LinearSolver::Direct if !factorisation(pc) => out.push(format!(
                "{chosen} contradicts `-pc_type {pc}` (set {at}): the direct route is a factorisation \
                 (`lu` or `cholesky`); for a preconditioned Krylov method set `solver.linear = \"iterative\"`"
            )),
            LinearSolver::Iterative if factorisation(pc) => out.push(format!(
                "{chosen} contradicts `-pc_type {pc}` (set {at}): a factorisation is the direct route; \
                 set `solver.linear = \"direct\"`, or choose a preconditioner such as `gamg` or `hypre`"
            )),
            _ => {}
        }
    }
    (!out.is_empty()).then(|| out.join("; "))
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
    route: LinearSolver,
    petsc_args: &[String],
) -> Result<Snes<'p>, Error> {
    let source = option_source(case, model, route, petsc_args);
    let rejected = |e: PetscError| Error::SolverOptions {
        file: case.file.clone(),
        message: format!("PETSc rejects them ({}): {}", e.function, e.message),
    };
    let mut snes = Snes::new(petsc)?;
    snes.set_tolerances(NEWTON_ATOL, NEWTON_RTOL, NEWTON_STOL, NEWTON_MAX_IT)?;
    snes.set_stagnation_window(case.solver.stagnation_window);
    snes.set_first_update(case.solver.first_update);
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

/// Where an option in force was set: "set on the command line", "set in
/// `solver.petsc_options`", or "as the options left it" (an options file, the environment).
fn option_source(
    case: &Case,
    model: &Model,
    route: LinearSolver,
    petsc_args: &[String],
) -> impl Fn(&str) -> &'static str {
    let cmdline = command_line_options(petsc_args);
    let in_case = case_petsc_options(case, model, route);
    move |option: &str| {
        let names = |s: &str| s.split_whitespace().any(|t| t == option);
        if names(&cmdline) {
            "set on the command line"
        } else if names(&in_case) {
            "set in `solver.petsc_options`"
        } else {
            "as the options left it"
        }
    }
}

/// The options in force that change when SNES calls a solve converged, away from the code's
/// defaults: the nonlinear solver's type and its tolerances and iteration limit, each with its
/// value and where it was set, e.g. "`-snes_type ksponly` (set on the command line)". The load
/// stepping names them when a step fails its own check of the residual.
pub(super) fn newton_overrides(
    snes: &Snes,
    case: &Case,
    model: &Model,
    route: LinearSolver,
    petsc_args: &[String],
) -> Result<Vec<String>, Error> {
    let source = option_source(case, model, route, petsc_args);
    let t = snes.tolerances()?;
    let kind = snes.type_name()?;
    let mut out = Vec::new();
    let mut note = |option: &str, value: String| {
        out.push(format!("`{option} {value}` ({})", source(option)));
    };
    if kind != "newtonls" {
        note("-snes_type", kind);
    }
    for (option, value, default) in [
        ("-snes_atol", t.atol, NEWTON_ATOL),
        ("-snes_rtol", t.rtol, NEWTON_RTOL),
        ("-snes_stol", t.stol, NEWTON_STOL),
    ] {
        if value != default {
            note(option, format!("{value:e}"));
        }
    }
    if t.max_it != NEWTON_MAX_IT as crate::petsc::PetscInt {
        note("-snes_max_it", t.max_it.to_string());
    }
    Ok(out)
}

/// `check`'s part of the solver: the options inserted and applied as `run` does, and the linear
/// solver set up on a system of one unknown (which makes the factor package read its options).
pub(super) fn check_solver_options(
    petsc: &Petsc,
    case: &Case,
    model: &Model,
    route: LinearSolver,
    petsc_args: &[String],
) -> Result<(), Error> {
    insert_solver_options(petsc, case, model, route, petsc_args)?;
    // an identity of one node's unknowns (the iterative route sets the matrix block size to dim)
    let n = model.dim;
    let mut a = Matrix::new_aij(petsc, n)?;
    a.preallocate_aij(&vec![1; n], &vec![0; n])?;
    for i in 0..n as crate::petsc::PetscInt {
        a.add_values(&[i], &[i], &[1.0])?;
    }
    a.assemble()?;
    let mut snes = snes_from_options(petsc, case, model, route, petsc_args)?;
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
        .filter(|(n, _)| {
            !CODE_DEFAULT_OPTIONS.contains(&n.as_str())
                && n != "-mat_block_size"
                && !ITERATIVE_DEFAULT_OPTIONS
                    .split_whitespace()
                    .any(|t| t == n.as_str())
        })
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

/// The iterative route's defaults (`[solver] linear = "iterative"`), before the case's and the
/// command line's options, which override them. Measured on the 3D block and the 3D contact
/// scene (docs/performance/solver.md, "Direct against iterative"):
/// - unsmoothed aggregation (`-pc_gamg_agg_nsmooths 0`): smoothed aggregation (PETSc's default)
///   keeps the Krylov count flat (16-17 per Newton iteration from 12^3 to 30^3) but its Galerkin
///   products with six modes per aggregate cost 5x more per Newton iteration at 30^3 (14.0 s
///   against 2.6 s) and 12x on the hemisphere scene;
/// - threshold 0.01 (measured with smoothed aggregation only: 0 as fast or faster, 0.05 slower;
///   not re-measured with unsmoothed aggregation);
/// - Chebyshev/Jacobi smoothing (GAMG's own) and its default coarse solve;
/// - `-ksp_rtol 1e-8`: Newton then takes the direct route's iterations (3-4 per step on the
///   block, the same total on the contact cases); Eisenstat-Walker (`-snes_ksp_ew`) did not pay
///   (30^3: 18 Newton iterations and 5 failed against 4, the run 2.2x longer);
/// - GMRES(100) and at most 400 iterations: a solve that needs more is a failure, retried with
///   MUMPS (with contact, no restart before 400: [`CONTACT_ITERATIVE_OPTIONS`]).
pub(super) const ITERATIVE_DEFAULT_OPTIONS: &str = "-ksp_type gmres -ksp_gmres_restart 100 \
     -ksp_rtol 1e-8 -ksp_max_it 400 -pc_type gamg -pc_gamg_agg_nsmooths 0 \
     -pc_gamg_threshold 0.01 -mg_levels_ksp_type chebyshev -mg_levels_pc_type jacobi";

/// The iterative route's defaults added when the case has contact pairs, after
/// [`ITERATIVE_DEFAULT_OPTIONS`] (the case's and the command line's options still override them):
/// GMRES without restart up to `-ksp_max_it` (PETSc allocates its Krylov vectors ten at a time as
/// the iterations need them, so an easy solve costs no more memory). At a deeply penetrated
/// iterate (the first Newton iterate of a press step: the rim's increment moves the shell 0.1 into
/// the undeformed cube, pressure eps_n g = 10 E of the cube) the GAMG-preconditioned contact
/// tangent is indefinite: on the scale scene at 54,252 unknowns 61 of its 162 Ritz values have a
/// negative real part (down to -30), none of the 33 of the contact-free solve before it
/// (the 3D contact scene, docs/performance/scale.md). Restarted GMRES(100) stagnates there
/// (relative true residual 2.8e-2 after 100 iterations, 4.1e-3 after 400: `DIVERGED_ITS`, fallback
/// to MUMPS), GMRES(200) and unrestarted GMRES converge in 162; smoothed aggregation and an
/// FGMRES/GMRES(3) smoother stagnate as GMRES(100) does. At 103,449 unknowns the first two contact
/// solves take 283 and 233 iterations unrestarted.
pub(super) const CONTACT_ITERATIVE_OPTIONS: &str = "-ksp_gmres_restart 400";

/// Rows of constrained unknowns (identity rows of the Jacobian) are zeroed in the rigid-body
/// modes given to GAMG: 35.5 Krylov iterations per Newton iteration against 45.8 with them kept,
/// 2.1 s against 2.6 s (30^3 block, docs/performance/solver.md, "Direct against iterative"); the environment
/// variable `NURBS_CONTACT_FLIP_CONSTRAINED_MODES` flips it, for that measurement.
const ZERO_CONSTRAINED_MODES: bool = true;

/// The case's `solver.petsc_options`, after the defaults that depend on the case and on the
/// linear route.
pub(super) fn case_petsc_options(case: &Case, model: &Model, route: LinearSolver) -> String {
    // GAMG aggregates nodes, not unknowns, only when the matrix has the node's block size (the
    // DofMap numbers a node's `dim` unknowns consecutively; MatSetFromOptions reads it at the
    // creation of every Jacobian): without it, 12^3 block at 4 s per solve instead of 0.35 s.
    let route_defaults = if route == LinearSolver::Iterative {
        let contact = if model.contact_pairs.is_empty() {
            ""
        } else {
            CONTACT_ITERATIVE_OPTIONS
        };
        format!(
            "{ITERATIVE_DEFAULT_OPTIONS} {contact} -mat_block_size {}",
            model.dim
        )
    } else {
        String::new()
    };
    // With contact, PETSc's backtracking line search creeps where the penalty switches points between
    // active and inactive, and full steps invert elements that a cutback must then repair; the l2
    // line search (a secant minimisation of |F|^2 along the step) does best (measured: ironing_2d
    // 454 Newton iterations and no cutbacks vs 506 with bt and 663 + 35 cutbacks with full steps;
    // hertz_2d 10 vs 36 with bt). The case or the command line can override it.
    // MUMPS counts null pivots (INFOG(28)) instead of failing or pivoting around them, so a
    // singular tangent is reported with the free body's name (load stepping checks the count).
    let null_pivots = "-mat_mumps_icntl_24 1";
    if model.contact_pairs.is_empty() {
        format!(
            "{null_pivots} {route_defaults} {}",
            case.solver.petsc_options
        )
    } else {
        format!(
            "{null_pivots} -snes_linesearch_type l2 {route_defaults} {}",
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
            self.x_before.as_ref(),
            &mut |event, rec, x, before, asm| match event {
                StepEvent::Converged => observer.observe(model, rec, x, before, asm),
                StepEvent::StoppedAfter => observer.stopped_after(model, rec, x, before, asm),
            },
        );
        if matches!(result, Err(SolverError::Interrupted { .. })) && observer.interrupted.is_none()
        {
            // stopped within the first step of this run: no step for the observer to see
            observer.interrupted = crate::interrupt::agreed(self.asm.comm());
        }
        if let Some(b) = &observer.bar {
            b.finish_and_clear();
        }
        result
    }
}

#[cfg(test)]
mod tests {
    use super::CONTACT_ITERATIVE_OPTIONS;
    use crate::scene::size::CONTACT_KRYLOV_VECTORS;

    /// `check`'s memory estimate counts as many Krylov vectors with contact as GMRES's restart the
    /// contact defaults set: the two numbers live in two files and must not drift apart.
    #[test]
    fn the_contact_krylov_estimate_follows_the_contact_restart() {
        let mut words = CONTACT_ITERATIVE_OPTIONS.split_whitespace();
        let restart = words
            .by_ref()
            .skip_while(|&w| w != "-ksp_gmres_restart")
            .nth(1)
            .and_then(|v| v.parse::<f64>().ok());
        assert_eq!(restart, Some(CONTACT_KRYLOV_VECTORS));
    }
}
