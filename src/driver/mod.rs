//! Running a case end to end: case file -> model -> partition -> numbering -> assembler -> SNES load
//! stepping -> results. `main.rs` only parses the command line and calls [`run_main`] or [`check_main`].

mod claim;
mod gather;
mod observer;
mod options;
mod output;
mod restore;

use gather::{contact_data, gather_errors, rank_times};
use observer::StepObserver;
use options::{check_solver_options, set_up_solver, warn_unused_options, Solver};
use output::{gather_points, Output};
use restore::{read_checkpoint, restore};

use crate::assembly::{constrained_flags, prescribed_values, DofMap, DofMapError, SkewRows};
use crate::io::{self, Summary};
use crate::model::{Model, ModelError};
use crate::parallel::{edge_cut, facing_cut, partition_cells};
use crate::petsc::{Petsc, PetscError};
use crate::scene::{load_case, validate, Case, PartitionKind, SceneError};
use crate::solver::{SolverError, StepRecord};
use mpi::collective::SystemOperation;
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// How much to log.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Verbosity {
    /// Errors only.
    Quiet,
    /// Progress and where the results are.
    Normal,
    /// One line per step and per cutback.
    Verbose,
    /// Also setup details.
    Debug,
}

impl Verbosity {
    /// From the number of `-v` flags.
    pub fn from_count(n: u8) -> Self {
        match n {
            0 => Verbosity::Normal,
            1 => Verbosity::Verbose,
            _ => Verbosity::Debug,
        }
    }
}

/// What `nurbs-contact run` was asked to do.
#[derive(Debug, Clone)]
pub struct RunOptions {
    /// Case file.
    pub case: PathBuf,
    /// Output directory (default `out/<case name>`).
    pub out: Option<PathBuf>,
    /// `--set key=value` overrides.
    pub sets: Vec<String>,
    /// Program name followed by the PETSc options of the command line.
    pub petsc_args: Vec<String>,
    /// Logging.
    pub verbosity: Verbosity,
    /// Use `MatSetValues` instead of COO assembly.
    pub matsetvalues: bool,
    /// Write into an output directory that exists and holds something other than an earlier run.
    pub overwrite: bool,
    /// Write a checkpoint after every this many converged steps (and when a signal stops the run).
    pub checkpoint_every: Option<usize>,
    /// Continue from the last checkpoint in this run directory (the default output directory).
    pub restart: Option<PathBuf>,
}

/// Everything that can stop a run.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// The case file.
    #[error(transparent)]
    Scene(#[from] SceneError),
    /// Building meshes, sets, elements.
    #[error(transparent)]
    Model(#[from] ModelError),
    /// Numbering.
    #[error(transparent)]
    DofMap(#[from] DofMapError),
    /// PETSc.
    #[error(transparent)]
    Petsc(#[from] PetscError),
    /// Load stepping.
    #[error("{}: {source}", .file.display())]
    Solver {
        /// The case file.
        file: PathBuf,
        /// What failed.
        source: SolverError,
    },
    /// Load stepping failed in a case whose contact penalty the set-up found absurd
    /// ([`crate::model::Model::absurd_penalties`]).
    #[error("{}: {message}", .file.display())]
    AbsurdPenalty {
        /// The case file.
        file: PathBuf,
        /// The load stepping's message and the penalties.
        message: String,
    },
    /// Boundary conditions that contradict each other.
    #[error("{}: {message}", .file.display())]
    Conflict {
        /// The case file.
        file: PathBuf,
        /// Which conditions, and the node by its mesh tag.
        message: String,
    },
    /// Writing results.
    #[error(transparent)]
    Io(#[from] io::IoError),
    /// METIS.
    #[error(transparent)]
    Partition(#[from] crate::parallel::PartitionError),
    /// MPI could not be initialised.
    #[error("MPI initialisation failed (already initialised?)")]
    Mpi,
    /// A combination of options or a set-up the run cannot do.
    #[error("{0}")]
    Usage(String),
    /// A checkpoint cannot be written, read or continued.
    #[error("{0}")]
    Restart(String),
    /// Another rank failed and reported its error.
    #[error("stopped because another rank failed")]
    OtherRank,
    /// The error was already printed (by rank 0 of an MPI run); nothing more to say.
    #[error("the error was reported above")]
    Reported,
    /// Different ranks failed differently: their messages, one per line.
    #[error("{0}")]
    Ranks(String),
    /// A signal stopped the run after its converged steps were written; the process should exit
    /// with [`crate::interrupt::exit_code`] of `signal`.
    #[error("{}: interrupted by {} after {steps} converged load steps; their results are in {}", .file.display(), crate::interrupt::signal_name(*.signal), .out_dir.display())]
    Interrupted {
        /// The case file.
        file: PathBuf,
        /// The signal.
        signal: i32,
        /// Converged steps recorded.
        steps: usize,
        /// Where.
        out_dir: PathBuf,
    },
    /// Parts of the model that nothing holds (singular tangent).
    #[error("{}: ill-posed: {message}", .file.display())]
    IllPosed {
        /// The case file.
        file: PathBuf,
        /// Which bodies or parts, one per line.
        message: String,
    },
    /// Solver options PETSc rejects, or values out of range.
    #[error("{}: solver options: {message}", .file.display())]
    SolverOptions {
        /// The case file.
        file: PathBuf,
        /// What is wrong and where the option comes from.
        message: String,
    },
    /// A Dirichlet condition whose set holds no node with unknowns (e.g. only display nodes).
    #[error("{}: `{label}`: set `{set}` of body `{body}` holds no node with unknowns", .file.display())]
    EmptyCondition {
        /// The case file.
        file: PathBuf,
        /// The condition.
        label: String,
        /// Its body.
        body: String,
        /// Its set.
        set: String,
    },
}

/// `nurbs-contact check`: everything but the solve, on one process.
pub fn check_main(case_path: &Path, sets: &[String], petsc_args: Vec<String>) -> Result<(), Error> {
    let (case, model) = load_and_build(case_path, sets)?;
    for w in model.warnings.iter().chain(&model.contact_warnings) {
        eprintln!("warning: {w}");
    }
    for n in &model.notes {
        println!("{n}");
    }
    let part = vec![0u32; model.n_cells()];
    let dofs = number_and_check(&case, &model, &part, 1, 0)?;
    for w in check_holds(&case, &model, &dofs)?.warnings {
        eprintln!("warning: {w}");
    }
    // skew conditions against the prescribed and tied unknowns, as `run` builds them
    let constrained = constrained_flags(&model.bcs, &dofs);
    SkewRows::new(&model.skews, &dofs, &model.coords, &constrained, &|n| {
        model.node_label(n)
    })
    .map_err(|e| Error::Usage(format!("{}: {e}", case.file.display())))?;
    let sets = model.element_sets(&case.file, &part, 0)?;
    // each pair's formulation as resolved (a pair that names none got its default)
    for (i, c) in case.contact.iter().enumerate() {
        let name = c.name.clone().unwrap_or_else(|| format!("contact.{i}"));
        println!("contact `{name}`: {}", c.describe());
    }
    {
        let universe = mpi::initialize().ok_or(Error::Mpi)?;
        let petsc = Petsc::init(&universe.world(), &petsc_args)?;
        let route = case.solver.linear_setting().resolve(dofs.n_global() as f64);
        check_solver_options(&petsc, &case, &model, route, &petsc_args)?;
        let est = crate::model::memory::PeakEstimate::of(
            &model,
            dofs.n_global() as f64,
            route == crate::scene::schema::LinearSolver::Iterative,
        );
        use crate::scene::size::human_bytes;
        println!(
            "estimated peak memory {} on 1 rank (process, mesh and model {} on every rank; \
             matrix {}, of it contact {}; {} linear solver {})",
            human_bytes(est.per_rank_peak(1)),
            human_bytes(est.per_rank),
            human_bytes(est.matrix),
            human_bytes(est.contact),
            if est.iterative { "iterative" } else { "direct" },
            human_bytes(est.linear)
        );
    }
    println!(
        "{}: ok ({} bodies, {} elements in {} sets, {} nodes, {} unknowns, {} stages)",
        case_path.display(),
        model.bodies.len(),
        model.n_cells(),
        sets.len(),
        model.n_nodes(),
        dofs.n_global(),
        case.stages.len()
    );
    Ok(())
}

/// Reads, validates and builds a case: the first thing `check` and `run` do.
fn load_and_build(case_path: &Path, sets: &[String]) -> Result<(Case, Model), Error> {
    let case = load_case(case_path, sets)?;
    validate(&case)?;
    let mut model = Model::build(&case)?;
    model.contact_checks(&case)?;
    Ok((case, model))
}

/// Numbers the unknowns for `part` and checks the Dirichlet conditions against the numbering: no
/// two conditions may prescribe one unknown differently at any stage end, and every condition must
/// reach at least one unknown.
fn number_and_check(
    case: &Case,
    model: &Model,
    part: &[u32],
    size: usize,
    rank: usize,
) -> Result<DofMap, Error> {
    let dofs = DofMap::new(
        model.dim,
        model.n_nodes(),
        &model.cell_offsets,
        &model.cell_nodes,
        part,
        &model.ties,
        size,
        rank,
    )?;
    for s in 1..=case.stages.len() {
        prescribed_values(&model.bcs, &dofs, &model.coords, s as f64).map_err(|source| {
            Error::Conflict {
                file: case.file.clone(),
                message: source.describe(&|n| model.node_label(n)),
            }
        })?;
    }
    check_conditions_have_unknowns(case, model, &dofs)?;
    Ok(dofs)
}

/// Parts of the model that no Dirichlet condition, tie or contact pair holds are an error (the
/// tangent would be singular); the report's warnings are for the caller to print.
fn check_holds(
    case: &Case,
    model: &Model,
    dofs: &DofMap,
) -> Result<crate::model::HoldReport, Error> {
    let report = crate::model::holds(model, |n| dofs.global(n, 0).is_some());
    if !report.errors.is_empty() {
        return Err(Error::IllPosed {
            file: case.file.clone(),
            message: report.errors.join("; "),
        });
    }
    Ok(report)
}

/// A Dirichlet condition on a set none of whose nodes carries unknowns would silently do nothing.
fn check_conditions_have_unknowns(case: &Case, model: &Model, dofs: &DofMap) -> Result<(), Error> {
    for (bc, spec) in model.bcs.iter().zip(&case.bcs) {
        if !bc.nodes.iter().any(|&n| dofs.global(n, 0).is_some()) {
            return Err(Error::EmptyCondition {
                file: case.file.clone(),
                label: bc.label.clone(),
                body: spec.body().to_string(),
                set: spec.set().to_string(),
            });
        }
    }
    Ok(())
}

/// `nurbs-contact run`: initialises MPI and PETSc, runs, and prints the error on the rank that has it.
pub fn run_main(opts: RunOptions) -> Result<(), Error> {
    let universe = mpi::initialize().ok_or(Error::Mpi)?;
    let world = universe.world();
    let rank = world.rank();
    let petsc = Petsc::init(&world, &opts.petsc_args)?;
    // PETSc's own handler would abort on SIGTERM: ours stop the run cleanly instead.
    petsc.pop_signal_handler()?;
    crate::interrupt::install().map_err(|e| Error::Usage(format!("signal handlers: {e}")))?;
    let result = run(&petsc, &opts);
    // Options are only all read once the solver has run; an earlier failure has its own message.
    if matches!(
        result,
        Ok(()) | Err(Error::Solver { .. } | Error::AbsurdPenalty { .. })
    ) {
        warn_unused_options(&petsc);
    }
    drop(petsc);
    // Every rank reaches this point (failures are agreed collectively), so the messages can be
    // gathered: rank 0 reports each distinct one once, the other ranks stay silent.
    let messages = gather_errors(&world, &result);
    let outcome = match result {
        Ok(()) => Ok(()),
        // Every rank agreed on the interrupt: each exits with the signal's code.
        Err(e @ Error::Interrupted { .. }) => Err(e),
        Err(_) if rank != 0 => Err(Error::OtherRank),
        Err(e) if messages.len() <= 1 && !matches!(e, Error::OtherRank) => Err(e),
        Err(_) => Err(Error::Ranks(messages.join("\n"))),
    };
    // Rank 0 prints while every rank still runs: mpirun aborts the whole job as soon as one rank
    // exits with an error, which could otherwise kill rank 0 before its message is out.
    if let Err(e) = &outcome {
        if rank == 0 {
            eprintln!("error: {e}");
            use std::io::Write;
            let _ = std::io::stderr().flush();
        }
    }
    world.barrier();
    outcome.map_err(|e| match e {
        Error::Interrupted { signal, .. } => Error::Interrupted {
            file: PathBuf::new(),
            signal,
            steps: 0,
            out_dir: PathBuf::new(),
        },
        _ => Error::Reported,
    })
}

/// Makes a rank-local failure collective, so no rank waits forever in a collective call.
fn agree<T>(comm: &SimpleCommunicator, r: Result<T, Error>) -> Result<T, Error> {
    let flag = i32::from(r.is_err());
    let mut any = 0;
    comm.all_reduce_into(&flag, &mut any, SystemOperation::max());
    match r {
        Ok(_) if any != 0 => Err(Error::OtherRank),
        r => r,
    }
}

fn log(rank: i32, v: Verbosity, at: Verbosity, msg: impl FnOnce() -> String) {
    if rank == 0 && v >= at {
        eprintln!("{}", msg());
    }
}

/// Solves a case. Collective.
///
/// The run in phases: build the model and claim the output directory; partition and number; set
/// up the solver; step the load with an observer that records every converged step; finish the
/// output and report.
pub fn run(petsc: &Petsc, opts: &RunOptions) -> Result<(), Error> {
    let t_start = Instant::now();
    let (case, model, dirs) = build_model(petsc, opts)?;
    let restart = read_checkpoint(petsc, opts, &case)?;
    let mut numbered = number_and_partition(petsc, &case, &model)?;
    let partition_stats = numbered.partition_stats.take();
    let mut solver = set_up_solver(petsc, opts, &case, &model, numbered)?;
    if let Some((ckpt, state)) = &restart {
        restore(petsc, &model, &mut solver, ckpt, state)?;
    }
    let points = gather_points(&solver.asm);
    let output = Output::new(
        petsc,
        &model,
        &case,
        &solver.asm.dofs,
        &dirs.write,
        &dirs.out,
        rank0(petsc),
        restart.as_ref().map(|(dir, s)| (dir.as_path(), &s.log)),
        points.as_deref(),
    )?;
    let mut observer = StepObserver::new(
        petsc,
        opts.verbosity,
        &case,
        output,
        t_start,
        opts.checkpoint_every,
        restart.as_ref().map(|(_, s)| &s.log),
    );
    let t_solve = Instant::now();
    let start = restart.as_ref().map(|(_, s)| s.position);
    if start.is_none() {
        observer.warn_initial_penetrations(&model, &mut solver.asm);
    }
    let result = solver.load_loop(&model, &mut observer, start);
    let solve_wall = t_solve.elapsed().as_secs_f64();
    let observer_signal = observer.interrupted;
    finish_and_report(
        petsc,
        &case,
        &model,
        &solver,
        observer,
        &result,
        solve_wall,
        partition_stats,
    )?;
    // Pictures of what happened (rank 0, from the files just finished): a failed run's too, for
    // the steps it converged; an interrupted run stops at once.
    let pictures = if case.output.plots
        && rank0(petsc)
        && !matches!(result, Err(SolverError::Interrupted { .. }))
    {
        let t_plots = Instant::now();
        match io::plots::write_plots(&dirs.write) {
            Ok(p) => {
                log(comm_rank(petsc), opts.verbosity, Verbosity::Verbose, || {
                    format!("pictures drawn in {:.2} s", t_plots.elapsed().as_secs_f64())
                });
                p
            }
            Err(e) => {
                eprintln!("warning: no pictures of the run: {e}");
                Vec::new()
            }
        }
    } else {
        Vec::new()
    };
    // A restart into the directory it continues replaces that run's results only now.
    let out_dir = if rank0(petsc) {
        dirs.settle(result.is_ok())?
    } else {
        dirs.out.clone()
    };
    // Only a converged run announces its results: a failed one's error must be the last word.
    if result.is_ok() {
        let pngs: Vec<String> = pictures
            .iter()
            .filter(|p| p.extension().is_some_and(|e| e == "png"))
            .map(|p| p.display().to_string())
            .collect();
        if !pngs.is_empty() {
            log(comm_rank(petsc), opts.verbosity, Verbosity::Normal, || {
                format!("pictures: {}", pngs.join(", "))
            });
        }
        log(comm_rank(petsc), opts.verbosity, Verbosity::Normal, || {
            format!("results in {}", out_dir.display())
        });
    }
    result.map(|_| ()).map_err(|source| match source {
        SolverError::Interrupted { steps, .. } => Error::Interrupted {
            file: case.file.clone(),
            signal: observer_signal.unwrap_or(0),
            steps,
            out_dir,
        },
        source if !model.absurd_penalties.is_empty() => Error::AbsurdPenalty {
            file: case.file.clone(),
            message: format!(
                "{source}; the contact penalty is absurd against the bodies' stiffness, likely \
                 the cause: {} (see the warning before the run)",
                model.absurd_penalties.join(", ")
            ),
        },
        SolverError::Singular { step, load, pivots } if !solver.suspects.is_empty() => {
            Error::IllPosed {
                file: case.file.clone(),
                message: format!(
                    "load step {step} (load {load:.6}): the tangent stiffness is singular (MUMPS found {pivots} null pivots); likely free: body {}",
                    solver
                        .suspects
                        .iter()
                        .map(|b| format!("`{b}`"))
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            }
        }
        source @ SolverError::FreeTranslation { .. } => Error::IllPosed {
            file: case.file.clone(),
            message: source.to_string(),
        },
        source => Error::Solver {
            file: case.file.clone(),
            source,
        },
    })
}

fn comm_rank(petsc: &Petsc) -> i32 {
    petsc.comm().rank()
}

fn rank0(petsc: &Petsc) -> bool {
    comm_rank(petsc) == 0
}

/// Phase 1: every rank reads and builds the same model; rank 0 claims (locks) the output
/// directory, held until the run ends.
///
/// Collective.
fn build_model(petsc: &Petsc, opts: &RunOptions) -> Result<(Case, Model, claim::Dirs), Error> {
    let comm = petsc.comm();
    let rank = comm.rank();
    // A failure is normally the same on all ranks, but a rank that cannot read a file (a node
    // without the shared file system) must not leave the others waiting: agree on the outcome.
    let (case, model) = agree(comm, load_and_build(&opts.case, &opts.sets))?;
    for w in &model.warnings {
        log(rank, opts.verbosity, Verbosity::Normal, || {
            format!("warning: {w}")
        });
    }
    if rank == 0 {
        for w in &model.contact_warnings {
            eprintln!("warning: {w}");
        }
    }
    for n in &model.notes {
        log(rank, opts.verbosity, Verbosity::Normal, || n.clone());
    }
    // The case name is a plain name (validated), so the default stays inside out/. Rank 0 claims
    // the directory before any work: created, or an earlier run's, or refused (unless --overwrite,
    // or while another process writes into it).
    let out_dir = opts
        .out
        .clone()
        .or_else(|| opts.restart.clone())
        .unwrap_or_else(|| PathBuf::from("out").join(&case.case.name));
    let dirs = claim::claim(comm, opts, out_dir)?;
    Ok((case, model, dirs))
}

/// What [`number_and_partition`] produces: the cell partition, this rank's numbering and element
/// sets.
struct Numbered {
    part: Vec<u32>,
    /// The partition's balance and cut (rank 0 on several ranks; `None` elsewhere).
    partition_stats: Option<io::PartitionStats>,
    dofs: DofMap,
    sets: Vec<Box<dyn crate::assembly::ElementSet>>,
    /// Bodies that the conditions may leave free (named if the tangent turns out singular).
    suspects: Vec<String>,
    /// Translations that only contact may hold, checked on the tangent of every converged step.
    probes: Vec<crate::solver::TranslationProbe>,
}

/// Phase 2: partitions the cells (METIS on rank 0, broadcast, so all ranks agree even if METIS
/// were not deterministic), numbers the unknowns and builds this rank's element sets.
///
/// Collective.
fn number_and_partition(petsc: &Petsc, case: &Case, model: &Model) -> Result<Numbered, Error> {
    let comm = petsc.comm();
    let (rank, size) = (comm.rank(), comm.size() as usize);
    let mut part = vec![0u32; model.n_cells()];
    let mut partition_stats = None;
    if size > 1 {
        let r0 = if rank == 0 {
            let points = crate::contact::pair::points_per_cell(
                &model.contact_surfaces,
                &model.contact_pairs,
                model.n_cells(),
            );
            let kind = case.solver.partition;
            let facing = crate::contact::pair::facing_cells(
                &model.contact_surfaces,
                &model.contact_pairs,
                &model.coords,
                model.dim,
            );
            let facing_points = crate::contact::pair::facing_points(&points, &facing);
            let (weights, joined): (&[u32], &[[u32; 2]]) = match kind {
                PartitionKind::Contact => (&facing_points, &facing),
                PartitionKind::Points => (&points, &[]),
                PartitionKind::Cells => (&[], &[]),
            };
            let mesh = model.combined_mesh();
            partition_cells(&mesh, size, weights, joined)
                .inspect(|p| {
                    let mut stats = io::PartitionStats {
                        cells: vec![0; size],
                        contact_points: vec![0; size],
                        facing_points: vec![0; size],
                        cut_faces: edge_cut(&mesh, p) as u64,
                        kind: kind.name().to_string(),
                        facing_pairs: facing.len() as u64,
                        cut_facing_pairs: facing_cut(&facing, p) as u64,
                    };
                    for (c, &r) in p.iter().enumerate() {
                        stats.cells[r as usize] += 1;
                        stats.contact_points[r as usize] += points[c] as u64;
                        stats.facing_points[r as usize] += facing_points[c] as u64;
                    }
                    partition_stats = Some(stats);
                })
                .map_err(Error::from)
        } else {
            Ok(Vec::new())
        };
        let p = agree(comm, r0)?;
        if rank == 0 {
            part = p;
        }
        comm.process_at_rank(0).broadcast_into(&mut part[..]);
    }
    // Deterministic on every rank (same model, same partition): no agreement needed.
    let dofs = number_and_check(case, model, &part, size, rank as usize)?;
    // The same on every rank (same model).
    let holds = check_holds(case, model, &dofs)?;
    for w in &holds.warnings {
        if rank == 0 {
            eprintln!("warning: {w}");
        }
    }
    let probes = translation_probes(&holds.free_translations, &dofs);
    let sets = agree(
        comm,
        model
            .element_sets(&case.file, &part, rank as usize)
            .map_err(Error::from),
    )?;
    Ok(Numbered {
        part,
        partition_stats,
        dofs,
        sets,
        suspects: holds.suspects,
        probes,
    })
}

/// This rank's part of each translation that only contact may hold: its owned rows.
fn translation_probes(
    free: &[crate::model::FreeTranslation],
    dofs: &DofMap,
) -> Vec<crate::solver::TranslationProbe> {
    let (lo, hi) = (dofs.rank_start[dofs.rank], dofs.rank_start[dofs.rank + 1]);
    free.iter()
        .map(|f| {
            let mut rows: Vec<_> = f
                .nodes
                .iter()
                .filter_map(|&n| dofs.global(n, f.axis))
                .map(|g| g.0)
                .filter(|g| (lo..hi).contains(g))
                .collect();
            rows.sort_unstable();
            rows.dedup();
            crate::solver::TranslationProbe {
                what: f.what.clone(),
                axis: f.axis,
                rows,
            }
        })
        .collect()
}

/// Phase 5: the summary (slowest rank's times, peak memory, Newton statistics, status) and the
/// results moved into place.
///
/// Collective.
#[allow(clippy::too_many_arguments)]
fn finish_and_report(
    petsc: &Petsc,
    case: &Case,
    model: &Model,
    solver: &Solver,
    observer: StepObserver,
    result: &Result<Vec<StepRecord>, SolverError>,
    solve_wall: f64,
    partition: Option<io::PartitionStats>,
) -> Result<(), Error> {
    let comm = petsc.comm();
    let asm = &solver.asm;
    let t_output = observer.t_output;
    let assembly = asm.timers.residual + asm.timers.jacobian + asm.timers.pattern;
    let status = match result {
        Ok(_) => io::RunStatus::Converged,
        Err(SolverError::Interrupted { steps, .. }) => io::RunStatus::Interrupted {
            signal: crate::interrupt::signal_name(observer.interrupted.unwrap_or(0)).to_string(),
            converged_steps: *steps,
        },
        Err(e) => io::RunStatus::Failed {
            reason: e.to_string(),
        },
    };
    // Slowest rank's times: that is what the user waits for.
    let t = asm.timers;
    let mut times = [
        assembly,
        (solve_wall - assembly - t_output).max(0.0),
        t_output,
        t.residual,
        t.jacobian,
        t.pattern,
        t.contact,
    ];
    let local = times;
    comm.all_reduce_into(&local[..], &mut times[..], SystemOperation::max());
    let mut peak_memory_mb = 0.0;
    comm.all_reduce_into(
        &(petsc.max_memory_bytes() / 1e6),
        &mut peak_memory_mb,
        SystemOperation::max(),
    );
    let summary = Summary {
        case: case.case.name.clone(),
        git_revision: option_env!("NURBS_CONTACT_GIT_REV")
            .unwrap_or("unknown")
            .to_string(),
        ranks: comm.size() as usize,
        unknowns: asm.dofs.n_global() as u64,
        elements: model.n_cells() as u64,
        newton: observer.newton,
        linear_solver: options::linear_route(case, &asm.dofs).name().to_string(),
        restarts: observer.restarts,
        wall_time: io::PhaseTimes {
            assembly: times[0],
            residual: times[3],
            jacobian: times[4],
            pattern: times[5],
            contact: times[6],
            solve: times[1],
            output: times[2],
            total: observer.wall_offset + observer.t_start.elapsed().as_secs_f64(),
            before_restart: observer.wall_offset,
        },
        peak_memory_mb,
        contact_pattern: asm.coupling_pattern_stats().map(|(ring, missing)| {
            let mut total = 0usize;
            comm.all_reduce_into(&missing, &mut total, SystemOperation::sum());
            let mut coo_entries = 0u64;
            comm.all_reduce_into(
                &(t.coo_entries as u64),
                &mut coo_entries,
                SystemOperation::sum(),
            );
            let mut cell_entries = 0u64;
            comm.all_reduce_into(
                &(t.cell_entries as u64),
                &mut cell_entries,
                SystemOperation::sum(),
            );
            let mut region_entries = 0u64;
            comm.all_reduce_into(
                &(t.region_entries as u64),
                &mut region_entries,
                SystemOperation::sum(),
            );
            let mut run_columns = 0u64;
            comm.all_reduce_into(
                &(t.run_columns as u64),
                &mut run_columns,
                SystemOperation::sum(),
            );
            io::ContactPatternStats {
                rebuilds: t.pattern_rebuilds,
                missing_blocks: total,
                ring,
                coo_entries,
                cell_entries,
                region_entries,
                run_columns,
            }
        }),
        contact_data: contact_data(comm, asm),
        partition,
        rank_times: Some(rank_times(comm, &t)),
        steps: observer.step_log,
        status,
    };
    observer.output.finish(&summary)
}
