//! Running a case end to end: case file -> model -> partition -> numbering -> assembler -> SNES load
//! stepping -> results. `main.rs` only parses the command line and calls [`run_main`] or [`check_main`].

use crate::assembly::{
    constrained_flags, prescribed_values, Assembler, DofMap, DofMapError, GlobalDof, NodeOffsets,
    SkewRows,
};
use crate::contact::system::POINT_RECORD;
use crate::contact::ContactSystem;
use crate::io::{self, FieldData, GridDef, HistoryRow, HistoryWriter, ResultsWriter, Summary};
use crate::model::{Model, ModelError};
use crate::parallel::partition_cells;
use crate::petsc::{
    options_missing_values, quiet_errors, tolerance_problems, Matrix, Petsc, PetscError, PetscInt,
    Scatter, Snes, Vector,
};
use crate::scene::{load_case, validate, Case, OutputField, SceneError};
use crate::solver::{
    run_load_steps_from, AfterStep, LoadPosition, SolverError, StepControl, StepRecord,
};
use mpi::collective::SystemOperation;
use mpi::datatype::PartitionMut;
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;
use std::io::IsTerminal;
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
    /// Boundary conditions that contradict each other.
    #[error("{}: {source}", .file.display())]
    Conflict {
        /// The case file.
        file: PathBuf,
        /// Which conditions.
        source: crate::assembly::ConflictError,
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
    for w in &model.warnings {
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
    SkewRows::new(&model.skews, &dofs, &model.coords, &constrained)
        .map_err(|e| Error::Usage(format!("{}: {e}", case.file.display())))?;
    let sets = model.element_sets(&case.file, &part, 0)?;
    {
        let universe = mpi::initialize().ok_or(Error::Mpi)?;
        let petsc = Petsc::init(&universe.world(), &petsc_args)?;
        check_solver_options(&petsc, &case, &model, &petsc_args)?;
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
    let model = Model::build(&case)?;
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
                source,
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
    if matches!(result, Ok(()) | Err(Error::Solver { .. })) {
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

/// The distinct error messages of all ranks, on rank 0 (empty elsewhere), each prefixed with the
/// ranks that hold it when they differ between ranks.
///
/// Collective.
fn gather_errors(world: &SimpleCommunicator, result: &Result<(), Error>) -> Vec<String> {
    let text = match result {
        Err(e) if !matches!(e, Error::OtherRank) => e.to_string(),
        _ => String::new(),
    };
    // A leading tag byte keeps every contribution non-empty: Open MPI rejects a Gatherv whose
    // buffers are all empty (MPI_ERR_ARG), which is the all-ranks-succeeded case.
    let mut bytes = vec![u8::from(!text.is_empty())];
    bytes.extend(text.into_bytes());
    let root = world.process_at_rank(0);
    let len = bytes.len() as i32;
    if world.rank() != 0 {
        root.gather_into(&len);
        root.gather_varcount_into(&bytes[..]);
        return Vec::new();
    }
    let size = world.size() as usize;
    let mut lens = vec![0i32; size];
    root.gather_into_root(&len, &mut lens[..]);
    let displs: Vec<i32> = lens
        .iter()
        .scan(0, |acc, &l| {
            let d = *acc;
            *acc += l;
            Some(d)
        })
        .collect();
    let mut buf = vec![0u8; lens.iter().sum::<i32>() as usize];
    {
        let mut part = PartitionMut::new(&mut buf[..], &lens[..], &displs[..]);
        root.gather_varcount_into_root(&bytes[..], &mut part);
    }
    let mut distinct: Vec<(String, Vec<usize>)> = Vec::new();
    for r in 0..size {
        let (a, b) = (displs[r] as usize + 1, (displs[r] + lens[r]) as usize);
        if buf[a - 1] == 0 {
            continue;
        }
        let m = String::from_utf8_lossy(&buf[a..b]).into_owned();
        match distinct.iter_mut().find(|(t, _)| *t == m) {
            Some((_, ranks)) => ranks.push(r),
            None => distinct.push((m, vec![r])),
        }
    }
    if distinct.len() <= 1 {
        return distinct.into_iter().map(|(m, _)| m).collect();
    }
    distinct
        .into_iter()
        .map(|(m, ranks)| format!("[rank {ranks:?}] {m}"))
        .collect()
}

/// The rows of every rank concatenated on rank 0 (empty elsewhere). Collective.
fn gather_rows(comm: &SimpleCommunicator, rows: &[f64]) -> Vec<f64> {
    let root = comm.process_at_rank(0);
    let len = rows.len() as i32;
    if comm.rank() != 0 {
        root.gather_into(&len);
        root.gather_varcount_into(rows);
        return Vec::new();
    }
    let mut lens = vec![0i32; comm.size() as usize];
    root.gather_into_root(&len, &mut lens[..]);
    let displs: Vec<i32> = lens
        .iter()
        .scan(0, |acc, &l| {
            let d = *acc;
            *acc += l;
            Some(d)
        })
        .collect();
    let mut buf = vec![0.0; lens.iter().sum::<i32>() as usize];
    {
        let mut part = PartitionMut::new(&mut buf[..], &lens[..], &displs[..]);
        root.gather_varcount_into_root(rows, &mut part);
    }
    buf
}

/// With `--restart DIR`: the last checkpoint in DIR and its state, after checking that the case
/// may continue it. Every rank reads it. Collective.
fn read_checkpoint(
    petsc: &Petsc,
    opts: &RunOptions,
    case: &Case,
) -> Result<Option<(PathBuf, crate::checkpoint::State)>, Error> {
    let Some(dir) = &opts.restart else {
        return Ok(None);
    };
    let read = || -> Result<(PathBuf, crate::checkpoint::State), Error> {
        let ckpt = crate::checkpoint::latest(dir).map_err(Error::Restart)?;
        let state = crate::checkpoint::read_state(&ckpt)?;
        let started = crate::checkpoint::stages_started(&state.position);
        crate::checkpoint::compare_cases(&state.case_toml, &case.to_toml_string()?, started)
            .and_then(|()| {
                crate::checkpoint::compare_meshes(
                    &state.log.mesh_hashes,
                    &crate::checkpoint::mesh_hashes(case),
                )
            })
            .map_err(|m| {
                Error::Restart(format!(
                    "{}: cannot continue the checkpoint {}: {m}",
                    case.file.display(),
                    ckpt.display()
                ))
            })?;
        Ok((ckpt, state))
    };
    let r = agree(petsc.comm(), read())?;
    log(comm_rank(petsc), opts.verbosity, Verbosity::Normal, || {
        format!(
            "restart from {} (step {}, load {:.6}, written on {} rank{})",
            r.0.display(),
            r.1.position.step,
            r.1.position.lambda,
            r.1.ranks,
            if r.1.ranks == 1 { "" } else { "s" }
        )
    });
    Ok(Some(r))
}

/// Puts a checkpoint's state into the solver: displacement (owned unknowns, from the node values),
/// element history (from the cell values), contact state (from the point rows). Collective.
fn restore(
    petsc: &Petsc,
    model: &Model,
    solver: &mut Solver,
    state: &crate::checkpoint::State,
) -> Result<(), Error> {
    let dim = model.dim;
    let mismatch = |what: &str, got: usize, expected: usize| {
        Err(Error::Restart(format!(
            "the checkpoint's {what} has {got} values, the model needs {expected}"
        )))
    };
    if state.displacement.len() != model.n_nodes() * dim {
        return mismatch(
            "displacement",
            state.displacement.len(),
            model.n_nodes() * dim,
        );
    }
    let w = state.element_history_width;
    if state.element_history.len() != model.n_cells() * w {
        return mismatch(
            "element history",
            state.element_history.len(),
            model.n_cells() * w,
        );
    }
    let dofs = &solver.asm.dofs;
    let (lo, hi) = dofs.owned_range();
    {
        let mut xw = solver.x.write()?;
        for n in 0..model.n_nodes() {
            for c in 0..dim {
                if let Some(g) = dofs.global(n as u32, c).filter(|g| (lo..hi).contains(&g.0)) {
                    xw[(g.0 - lo) as usize] = state.displacement[n * dim + c];
                }
            }
        }
    }
    let cell_offset: Vec<usize> = model.bodies.iter().map(|b| b.cell_offset).collect();
    let mut local = Ok(());
    for set in &mut solver.asm.sets {
        let hw = set.history_width();
        if hw == 0 {
            continue;
        }
        if hw > w {
            local = mismatch("element history per cell", w, hw);
            break;
        }
        for e in 0..set.len() {
            let (body, cell) = set.cell_id(e);
            let g = cell_offset[body] + cell;
            set.set_history(e, &state.element_history[g * w..g * w + hw]);
        }
    }
    if !state.contact_pattern.is_empty() {
        let all: Vec<crate::contact::Coupling> = state
            .contact_pattern
            .chunks_exact(3)
            .map(|r| (r[0] as u32, r[1] as u32, r[2] as u32))
            .collect();
        solver.asm.preset_contact_pattern(&all);
    }
    if local.is_ok() {
        if let Some(c) = solver.asm.contact_mut() {
            local = c
                .import_points(&state.contact_points)
                .map_err(|m| Error::Restart(format!("the checkpoint's contact state: {m}")));
        }
    }
    agree(petsc.comm(), local)
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
    let (case, model, out_dir) = build_model(petsc, opts)?;
    let restart = read_checkpoint(petsc, opts, &case)?;
    let numbered = number_and_partition(petsc, &case, &model)?;
    let mut solver = set_up_solver(petsc, opts, &case, &model, numbered)?;
    if let Some((_, state)) = &restart {
        restore(petsc, &model, &mut solver, state)?;
    }
    let points = gather_points(&solver.asm);
    let output = Output::new(
        petsc,
        &model,
        &case,
        &solver.asm.dofs,
        &out_dir,
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
    let result = solver.load_loop(&model, &mut observer, start);
    let solve_wall = t_solve.elapsed().as_secs_f64();
    let observer_signal = observer.interrupted;
    finish_and_report(petsc, &case, &model, &solver, observer, &result, solve_wall)?;
    // Pictures of what happened (rank 0, from the files just finished): a failed run's too, for
    // the steps it converged; an interrupted run stops at once.
    let pictures = if case.output.plots
        && rank0(petsc)
        && !matches!(result, Err(SolverError::Interrupted { .. }))
    {
        let t_plots = Instant::now();
        match io::plots::write_plots(&out_dir) {
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

/// Phase 1: every rank reads and builds the same model; rank 0 claims the output directory.
///
/// Collective.
fn build_model(petsc: &Petsc, opts: &RunOptions) -> Result<(Case, Model, PathBuf), Error> {
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
    for n in &model.notes {
        log(rank, opts.verbosity, Verbosity::Normal, || n.clone());
    }
    // The case name is a plain name (validated), so the default stays inside out/. Rank 0 claims
    // the directory before any work: created, or an earlier run's, or refused (unless --overwrite).
    let out_dir = opts
        .out
        .clone()
        .or_else(|| opts.restart.clone())
        .unwrap_or_else(|| PathBuf::from("out").join(&case.case.name));
    // a restart without a checkpoint is refused before the directory is claimed
    if let Some(dir) = &opts.restart {
        agree(comm, crate::checkpoint::latest(dir).map_err(Error::Restart))?;
    }
    agree(
        comm,
        if rank == 0 {
            io::claim_output_dir(&out_dir, opts.overwrite).map_err(Error::from)
        } else {
            Ok(())
        },
    )?;
    Ok((case, model, out_dir))
}

/// What [`number_and_partition`] produces: the cell partition, this rank's numbering and element
/// sets.
struct Numbered {
    part: Vec<u32>,
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
    if size > 1 {
        let r0 = if rank == 0 {
            partition_cells(&model.combined_mesh(), size).map_err(Error::from)
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

/// The solver's state: unknowns, assembler (with contact), Jacobian, SNES and step control.
struct Solver<'p> {
    /// Bodies that the conditions may leave free.
    suspects: Vec<String>,
    x: Vector<'p>,
    asm: Assembler<'p>,
    jac: Matrix<'p>,
    snes: Snes<'p>,
    control: StepControl,
}

/// Phase 3: the assembler (and contact system), the PETSc options, the Jacobian and SNES.
///
/// Collective.
fn set_up_solver<'p>(
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
        asm.set_contact(sys, &x, case.solver.contact_pattern_ring)?;
        asm.set_contact_freeze_after(case.solver.contact_freeze_after);
    }
    if !model.couplings.is_empty() {
        let offsets = NodeOffsets::new(&model.couplings, &asm.dofs.rep, &model.coords, model.dim);
        asm.set_couplings(offsets);
        let overlap = match asm.coupled_contact_node() {
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
fn command_line_options(petsc_args: &[String]) -> String {
    petsc_args
        .iter()
        .skip(1)
        .cloned()
        .collect::<Vec<_>>()
        .join(" ")
}

/// Inserts the case's PETSc options, then the command line's (which take precedence), after
/// checking that every option that needs a value has one (PETSc would ignore it silently).
fn insert_solver_options(
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
fn snes_from_options<'p>(
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
fn check_solver_options(
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
fn warn_unused_options(petsc: &Petsc) {
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
const CODE_DEFAULT_OPTIONS: [&str; 2] = ["-mat_mumps_icntl_24", "-snes_linesearch_type"];

/// The case's `solver.petsc_options`, after the defaults that depend on the case.
fn case_petsc_options(case: &Case, model: &Model) -> String {
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
    fn load_loop(
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

/// Watches the load loop: Newton statistics, the step log, history rows and results of every
/// converged step, progress.
struct StepObserver<'c, 'p> {
    rank: i32,
    v: Verbosity,
    case: &'c Case,
    output: Output<'p>,
    bar: Option<indicatif::ProgressBar>,
    t_start: Instant,
    n_stages: f64,
    total_steps: usize,
    newton: io::NewtonStats,
    step_log: Vec<io::StepLog>,
    /// Wall time spent recording steps (s).
    t_output: f64,
    /// The signal that stopped the run, agreed by all ranks.
    interrupted: Option<i32>,
    /// Checkpoint after every this many steps.
    checkpoint_every: Option<usize>,
    /// Wall time of the run before a restart (s).
    wall_offset: f64,
    /// Restarts of this run so far (this process's included).
    restarts: usize,
    /// The mesh files this run read, hashed when it started (for its checkpoints).
    mesh_hashes: Vec<(String, String, String)>,
}

impl<'c, 'p> StepObserver<'c, 'p> {
    fn new(
        petsc: &Petsc,
        v: Verbosity,
        case: &'c Case,
        output: Output<'p>,
        t_start: Instant,
        checkpoint_every: Option<usize>,
        resumed: Option<&crate::checkpoint::RunLog>,
    ) -> Self {
        let rank = comm_rank(petsc);
        let total_steps: usize = case.stages.iter().map(|s| s.steps).sum();
        let bar =
            (rank == 0 && v == Verbosity::Normal && std::io::stderr().is_terminal()).then(|| {
                let b = indicatif::ProgressBar::new(total_steps as u64);
                b.set_style(
                    indicatif::ProgressStyle::with_template(
                        "{elapsed_precise} [{bar:30}] load {msg}",
                    )
                    .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
                );
                b
            });
        StepObserver {
            rank,
            v,
            case,
            output,
            bar,
            t_start,
            n_stages: case.stages.len() as f64,
            total_steps,
            newton: resumed.map(|l| l.newton).unwrap_or_default(),
            step_log: resumed.map(|l| l.steps.clone()).unwrap_or_default(),
            t_output: 0.0,
            interrupted: None,
            checkpoint_every,
            wall_offset: resumed.map_or(0.0, |l| l.wall_time),
            restarts: resumed.map_or(0, |l| l.restarts + 1),
            mesh_hashes: if rank == 0 && checkpoint_every.is_some() {
                crate::checkpoint::mesh_hashes(case)
            } else {
                Vec::new()
            },
        }
    }

    /// Records one converged step. Collective.
    fn observe(
        &mut self,
        model: &Model,
        rec: &StepRecord,
        x: &Vector,
        asm: &mut Assembler,
    ) -> Result<AfterStep, String> {
        let t0 = Instant::now();
        // A signal on any rank stops every rank after this step, which is then written whatever
        // the output schedule says.
        self.interrupted = crate::interrupt::agreed(asm.comm());
        self.newton
            .record(rec.iterations as u32, rec.failed_iterations as u64);
        self.step_log.push(io::StepLog {
            step: rec.step,
            load: rec.load,
            iterations: rec.iterations as u32,
            cutbacks: rec.cutbacks as u32,
            residual_history: rec.residual_history.clone(),
            failed_attempts: rec.failed_attempts.clone(),
            pseudo_steps: rec.pseudo_steps,
            failed_iterations: rec.failed_iterations,
        });
        let reactions: Vec<f64> = model
            .reactions
            .iter()
            .flat_map(|(_, nodes)| asm.reaction(nodes))
            .collect();
        let mut extra_columns = Vec::new();
        for (_, nodes, center) in &model.reaction_moments {
            let m = asm
                .reaction_moment(nodes, x, &model.coords, *center)
                .map_err(|e| e.to_string())?;
            if model.dim == 2 {
                extra_columns.push(m[2]);
            } else {
                extra_columns.extend_from_slice(&m);
            }
        }
        extra_columns.extend(contact_history(asm, model.dim));
        let last = (rec.load - self.n_stages).abs() < 1e-12;
        let scheduled = last || rec.step.is_multiple_of(self.case.output.every);
        self.output
            .step(
                rec,
                &reactions,
                &extra_columns,
                self.wall_offset + self.t_start.elapsed().as_secs_f64(),
                scheduled,
                x,
                asm,
            )
            .map_err(|e| e.to_string())?;
        if let Some(every) = self.checkpoint_every {
            if rec.step.is_multiple_of(every) || self.interrupted.is_some() {
                // before the interrupt's extra output step below: the checkpoint's copy of the
                // results holds the scheduled steps only, so a restart from it writes what an
                // uninterrupted run writes
                self.checkpoint(model, rec, x, asm)
                    .map_err(|e| format!("checkpoint: {e}"))?;
            }
        }
        if self.interrupted.is_some() && !scheduled {
            // the interrupted run's results end with its last converged step, whatever the schedule
            self.output
                .results_step(rec, x, asm, Ok(()))
                .map_err(|e| e.to_string())?;
        }
        self.t_output += t0.elapsed().as_secs_f64();
        self.progress(rec);
        Ok(match self.interrupted {
            Some(_) => AfterStep::Stop,
            None => AfterStep::Continue,
        })
    }

    /// Writes a checkpoint of the converged step `rec`: the state gathered to rank 0 in global
    /// numbering, written there with copies of the output so far. Collective.
    fn checkpoint(
        &mut self,
        model: &Model,
        rec: &StepRecord,
        x: &Vector,
        asm: &mut Assembler,
    ) -> Result<(), Error> {
        let t0 = Instant::now();
        let root = self.rank == 0;
        let out = &mut self.output;
        out.gather.gather(x, &mut out.u_root)?;
        let displacement = if root {
            out.u_root.read()?.to_vec()
        } else {
            Vec::new()
        };
        let comm = asm.comm();
        // element history per cell, each rank filling its own cells, summed on rank 0
        let local_width = asm
            .sets
            .iter()
            .map(|s| s.history_width())
            .max()
            .unwrap_or(0);
        let mut width = 0usize;
        comm.all_reduce_into(&local_width, &mut width, SystemOperation::max());
        let n_cells = model.n_cells();
        let mut history = vec![0.0; n_cells * width];
        for set in &asm.sets {
            let hw = set.history_width();
            for e in 0..set.len() {
                let (body, cell) = set.cell_id(e);
                let g = out.cell_offset[body] + cell;
                history[g * width..g * width + hw].copy_from_slice(set.history(e));
            }
        }
        let mut element_history = vec![0.0; if root { history.len() } else { 0 }];
        if width > 0 {
            let r = comm.process_at_rank(0);
            if root {
                r.reduce_into_root(
                    &history[..],
                    &mut element_history[..],
                    SystemOperation::sum(),
                );
            } else {
                r.reduce_into(&history[..], SystemOperation::sum());
            }
        }
        let contact_points = match asm.contact() {
            Some(c) => gather_rows(comm, &c.export_points()),
            None => Vec::new(),
        };
        // the contact sparsity pattern, if every rank has a current one
        let pattern = asm.contact_pattern();
        let (have, mut all) = (i32::from(pattern.is_some()), 0i32);
        comm.all_reduce_into(&have, &mut all, SystemOperation::min());
        let contact_pattern = if asm.contact().is_some() && all == 1 {
            let rows: Vec<f64> = pattern
                .unwrap_or_default()
                .iter()
                .flat_map(|&(p, e, l)| [p as f64, e as f64, l as f64])
                .collect();
            gather_rows(comm, &rows)
        } else {
            Vec::new()
        };
        let local = if root {
            let state = crate::checkpoint::State {
                case_toml: out.case_toml.clone(),
                position: rec.position,
                displacement,
                element_history,
                element_history_width: width,
                contact_points,
                contact_pattern,
                ranks: comm.size() as usize,
                log: crate::checkpoint::RunLog {
                    newton: self.newton,
                    steps: self.step_log.clone(),
                    wall_time: self.wall_offset + self.t_start.elapsed().as_secs_f64(),
                    results_layout: out.results.as_ref().map(|r| r.layout()).unwrap_or_default(),
                    restarts: self.restarts,
                    mesh_hashes: self.mesh_hashes.clone(),
                },
            };
            let results = match &out.results {
                Some(r) => {
                    r.flush()?;
                    Some(r.partial_file().to_path_buf())
                }
                None => None,
            };
            let history_file = out.out_dir.join("history.csv");
            crate::checkpoint::write(&out.out_dir, &state, results.as_deref(), &history_file)
                .map_err(Error::from)
        } else {
            Ok((PathBuf::new(), 0))
        };
        let (dir, bytes) = agree(comm, local)?;
        let secs = t0.elapsed().as_secs_f64();
        self.t_output += secs;
        log(self.rank, self.v, Verbosity::Verbose, || {
            format!(
                "checkpoint after step {}: {} ({:.3} MB) in {secs:.3} s",
                rec.step,
                dir.display(),
                bytes as f64 / 1e6
            )
        });
        Ok(())
    }

    /// The progress bar, or without one (not a terminal, or -v) one plain line per step; with -v
    /// the line also carries the Newton residual history of the step, after a line per cutback.
    fn progress(&self, rec: &StepRecord) {
        let (rank, v) = (self.rank, self.v);
        if let Some(b) = &self.bar {
            b.set_position(((rec.load / self.n_stages) * self.total_steps as f64).round() as u64);
            b.set_message(format!(
                "{:.4} | step {} | {} it | |F| {:.2e}",
                rec.load, rec.step, rec.iterations, rec.residual
            ));
        }
        for (load, why) in &rec.failed_attempts {
            log(rank, v, Verbosity::Verbose, || {
                format!("  cutback: load {load:.6} failed: {why}")
            });
        }
        if self.bar.is_none() {
            log(rank, v, Verbosity::Normal, || {
                let mut line = format!(
                    "step {:4}  stage {}  load {:.6}  newton {:2}  |F| {:.3e}  cutbacks {}",
                    rec.step, rec.stage, rec.load, rec.iterations, rec.residual, rec.cutbacks
                );
                if rec.pseudo_steps > 0 {
                    line += &format!("  (rescued by {} damped pseudo-steps)", rec.pseudo_steps);
                }
                if v >= Verbosity::Verbose {
                    let h: Vec<String> = rec
                        .residual_history
                        .iter()
                        .map(|r| format!("{r:.2e}"))
                        .collect();
                    line += &format!("  history [{}]", h.join(" "));
                }
                line
            });
        }
    }
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
        contact_pattern: asm.contact_pattern_stats().map(|(ring, missing)| {
            let mut total = 0usize;
            comm.all_reduce_into(&missing, &mut total, SystemOperation::sum());
            io::ContactPatternStats {
                rebuilds: t.pattern_rebuilds,
                missing_blocks: total,
                ring,
            }
        }),
        steps: observer.step_log,
        status,
    };
    observer.output.finish(&summary)
}

/// `history.csv` columns after the reaction forces: reaction moments `M_<body>_<set>[_<x|y|z>]`
/// (2D: about z), then the contact columns.
fn history_extra_labels(model: &Model) -> Vec<String> {
    let mut out = Vec::new();
    for (label, _, _) in &model.reaction_moments {
        if model.dim == 2 {
            out.push(format!("M_{label}"));
        } else {
            out.extend(["x", "y", "z"].map(|a| format!("M_{label}_{a}")));
        }
    }
    out.extend(contact_history_labels(model));
    out
}

/// `history.csv` columns of the contact pairs, per pair and half-pass (named after the integrated
/// surface): resultant force `P_<pair>_<surface>_<x|y|z>` on that surface's body, moment of the
/// contact forces about the pair's moment point `M_<pair>_<surface>[_<x|y|z>]` (2D: about z),
/// active quadrature points and largest penetration; with friction, the resultant tangential force
/// `Pt_<pair>_<surface>_<x|y|z>` and the sticking and slipping points `stick_`/`slip_<pair>_<surface>`.
fn contact_history_labels(model: &Model) -> Vec<String> {
    let dim = model.dim;
    let mut out = Vec::new();
    for pair in &model.contact_pairs {
        for (k, _) in &pair.passes {
            let tag = format!("{}_{}", pair.name, model.contact_surfaces[*k].name);
            for a in &["x", "y", "z"][..dim] {
                out.push(format!("P_{tag}_{a}"));
            }
            if dim == 2 {
                out.push(format!("M_{tag}"));
            } else {
                for a in ["x", "y", "z"] {
                    out.push(format!("M_{tag}_{a}"));
                }
            }
            out.push(format!("active_{tag}"));
            out.push(format!("penetration_{tag}"));
            if pair.friction.is_some() {
                for a in &["x", "y", "z"][..dim] {
                    out.push(format!("Pt_{tag}_{a}"));
                }
                out.push(format!("stick_{tag}"));
                out.push(format!("slip_{tag}"));
            }
        }
    }
    out
}

/// Values of [`contact_history_labels`] at the last residual evaluation, summed (maximum for the
/// penetration) over ranks.
///
/// Collective.
fn contact_history(asm: &Assembler, dim: usize) -> Vec<f64> {
    let Some(c) = asm.contact() else {
        return Vec::new();
    };
    let (mut sums, mut maxes) = (Vec::new(), Vec::new());
    // per half-pass: the columns summed before its penetration and after it
    let mut layout = Vec::new();
    for ((_, passes), frictional) in c.results().into_iter().zip(c.frictional()) {
        for r in passes {
            let first = sums.len();
            sums.extend_from_slice(&r.force[..dim]);
            if dim == 2 {
                sums.push(r.moment[2]);
            } else {
                sums.extend_from_slice(&r.moment);
            }
            sums.push(r.n_active as f64);
            let mid = sums.len();
            if frictional {
                sums.extend_from_slice(&r.tangential[..dim]);
                sums.push(r.n_stick as f64);
                sums.push(r.n_slip as f64);
            }
            layout.push((first, mid, sums.len()));
            maxes.push(r.max_penetration);
        }
    }
    let comm = asm.comm();
    let (mut s, mut m) = (vec![0.0; sums.len()], vec![0.0; maxes.len()]);
    comm.all_reduce_into(&sums[..], &mut s[..], SystemOperation::sum());
    comm.all_reduce_into(&maxes[..], &mut m[..], SystemOperation::max());
    let mut out = Vec::new();
    for (&(first, mid, end), mx) in layout.iter().zip(&m) {
        out.extend_from_slice(&s[first..mid]);
        out.push(*mx);
        out.extend_from_slice(&s[mid..end]);
    }
    out
}

/// The contact fields on rank 0 as (name, components, nodal values [n_nodes * components]): the
/// contact pressure (per current area), the nominal contact pressure (per reference area) and the
/// normal gap, and with friction the tangential traction (`dim` components, on the surface's body)
/// and the fractions of sticking and slipping contact; all L2 projections of the pointwise values
/// on each contact surface's own interpolation (Sauer 2013; [`ContactSystem::l2_rhs`],
/// [`ContactSystem::l2_rhs_friction`]). `None` without contact or off rank 0. A node shared by two
/// contact surfaces shows the last surface's value.
///
/// Collective.
fn contact_fields(
    asm: &Assembler,
    n_nodes: usize,
    root: bool,
) -> Option<Vec<(&'static str, usize, Vec<f64>)>> {
    let c = asm.contact()?;
    let (fp, fg) = c.l2_rhs();
    let frictional = c.frictional().iter().any(|&f| f);
    let ff = if frictional {
        c.l2_rhs_friction()
    } else {
        Vec::new()
    };
    let comm = asm.comm();
    let sum = |f: &[f64]| {
        let mut s = vec![0.0; f.len()];
        comm.all_reduce_into(f, &mut s[..], SystemOperation::sum());
        s
    };
    let (sp, sg, sf) = (sum(&fp), sum(&fg), sum(&ff));
    if !root {
        return None;
    }
    let nt = c.n_table();
    let dim = asm.dofs.dim;
    let mut out = vec![
        ("contact_pressure", 1, vec![0.0; n_nodes]),
        ("contact_pressure_nominal", 1, vec![0.0; n_nodes]),
        ("contact_gap", 1, vec![0.0; n_nodes]),
    ];
    if frictional {
        out.push(("tangential_traction", dim, vec![0.0; n_nodes * dim]));
        out.push(("stick_fraction", 1, vec![0.0; n_nodes]));
        out.push(("slip_fraction", 1, vec![0.0; n_nodes]));
    }
    let nb = dim + 2;
    for s in 0..c.surfaces().len() {
        // (field in `out`, component, projection)
        let (ps, gs) = (&sp[s * nt..(s + 1) * nt], &sg[s * nt..(s + 1) * nt]);
        let mut proj = vec![
            (0, 0, c.l2_project(s, ps, false)),
            (1, 0, c.l2_project(s, ps, true)),
            (2, 0, c.l2_project(s, gs, false)),
        ];
        if frictional {
            // blocks of `sf` per surface: the traction's components, stick, slip
            for b in 0..nb {
                let (field, comp) = match b {
                    _ if b < dim => (3, b),
                    _ if b == dim => (4, 0),
                    _ => (5, 0),
                };
                let f = &sf[(s * nb + b) * nt..(s * nb + b + 1) * nt];
                proj.push((field, comp, c.l2_project(s, f, false)));
            }
        }
        for t in c.surface_nodes(s) {
            let node = c.table()[t as usize] as usize;
            for (field, comp, v) in &proj {
                let (_, w, vals) = &mut out[*field];
                vals[node * *w + comp] = v[t as usize];
            }
        }
    }
    Some(out)
}

/// The contact quadrature points of all ranks on rank 0, [`POINT_RECORD`] values each (see
/// [`ContactSystem::point_records`]), sorted by their key so that the order does not depend on the
/// partition; `None` on the other ranks and without contact.
///
/// Collective.
fn gather_points(asm: &Assembler) -> Option<Vec<f64>> {
    let c = asm.contact()?;
    let comm = asm.comm();
    // a leading entry keeps every contribution non-empty (Open MPI rejects an all-empty Gatherv)
    let mut buf = vec![0.0];
    buf.extend(c.point_records());
    let root = comm.process_at_rank(0);
    let len = buf.len() as i32;
    if comm.rank() != 0 {
        root.gather_into(&len);
        root.gather_varcount_into(&buf[..]);
        return None;
    }
    let mut lens = vec![0i32; comm.size() as usize];
    root.gather_into_root(&len, &mut lens[..]);
    let displs: Vec<i32> = lens
        .iter()
        .scan(0, |acc, &l| {
            let d = *acc;
            *acc += l;
            Some(d)
        })
        .collect();
    let mut all = vec![0.0; lens.iter().sum::<i32>() as usize];
    {
        let mut part = PartitionMut::new(&mut all[..], &lens[..], &displs[..]);
        root.gather_varcount_into_root(&buf[..], &mut part);
    }
    let mut recs: Vec<&[f64]> = Vec::new();
    for (d, l) in displs.iter().zip(&lens) {
        let (a, b) = (*d as usize + 1, (*d + *l) as usize);
        recs.extend(all[a..b].chunks_exact(POINT_RECORD));
    }
    recs.sort_by(|a, b| a[..3].partial_cmp(&b[..3]).expect("integer keys"));
    Some(recs.concat())
}

/// Results of a run on rank 0 (the other ranks only take part in the gathers).
/// Sample points per enriched element edge in the "surface" output grid.
const SURFACE_SAMPLES: usize = 8;

struct Output<'p> {
    root: bool,
    dim: usize,
    n_nodes: usize,
    n_cells: usize,
    out_dir: PathBuf,
    fields: Vec<OutputField>,
    results: Option<ResultsWriter>,
    history: Option<HistoryWriter>,
    /// Gathers the whole displacement on rank 0, in node order.
    gather: Scatter<'p>,
    u_root: Vector<'p>,
    /// Nodes that carry no unknowns (display nodes, nodes in no cell): zeroed after the gather,
    /// before display nodes are interpolated. [n_nodes]
    without_unknowns: Vec<bool>,
    /// Cells of each body start here in the global cell numbering.
    cell_offset: Vec<usize>,
    case_toml: String,
    /// Display nodes of enriched surfaces (global id, interpolation from element nodes).
    display: Vec<(u32, Vec<(u32, f64)>)>,
    /// Enriched-surface grids ("surface", "control_net") written beside "bulk".
    sampled: Vec<crate::model::SampledGrid>,
    /// Reference positions of the contact quadrature points ("contact_points" grid, rank 0;
    /// empty without contact) [n][dim].
    point_ref: Vec<f64>,
}

impl<'p> Output<'p> {
    #[allow(clippy::too_many_arguments)]
    fn new(
        petsc: &'p Petsc,
        model: &Model,
        case: &Case,
        dofs: &DofMap,
        out_dir: &Path,
        root: bool,
        resume: Option<(&Path, &crate::checkpoint::RunLog)>,
        points: Option<&[f64]>,
    ) -> Result<Self, Error> {
        let (dim, n_nodes) = (model.dim, model.n_nodes());
        let point_ref: Vec<f64> = points
            .unwrap_or_default()
            .chunks_exact(POINT_RECORD)
            .flat_map(|r| r[3..3 + dim].to_vec())
            .collect();
        // Rank 0 asks for every unknown in node order; nodes outside every cell read entry 0 and are
        // zeroed after the gather.
        let without_unknowns: Vec<bool> = (0..n_nodes as u32)
            .map(|n| dofs.global(n, 0).is_none())
            .collect();
        let idx: Vec<PetscInt> = if root {
            (0..n_nodes as u32)
                .flat_map(|n| (0..dim).map(move |c| (n, c)))
                .map(|(n, c)| dofs.global(n, c).map_or(0, |g: GlobalDof| g.0))
                .collect()
        } else {
            Vec::new()
        };
        let u_root = Vector::new_seq(petsc, idx.len())?;
        let template = Vector::new_mpi(petsc, dofs.n_owned())?;
        let gather = Scatter::new(petsc, &template, &u_root, &idx)?;
        let mut out = Output {
            root,
            dim,
            n_nodes,
            n_cells: model.n_cells(),
            out_dir: out_dir.to_path_buf(),
            fields: case.output.fields.clone(),
            results: None,
            history: None,
            gather,
            u_root,
            cell_offset: model.bodies.iter().map(|b| b.cell_offset).collect(),
            case_toml: case.to_toml_string()?,
            without_unknowns: Vec::new(),
            display: model.display_interpolation(),
            sampled: [model.surface_grid(SURFACE_SAMPLES), model.control_net()]
                .into_iter()
                .flatten()
                .collect(),
            point_ref,
        };
        let created = if root {
            out.create_files(model, case, out_dir, resume)
        } else {
            Ok(())
        };
        agree(petsc.comm(), created)?;
        out.without_unknowns = without_unknowns;
        Ok(out)
    }

    /// Rank 0: the output directory and writers; results of an earlier run there are removed first,
    /// so a rerun that dies cannot leave an old summary beside its new history.
    fn create_files(
        &mut self,
        model: &Model,
        case: &Case,
        out_dir: &Path,
        resume: Option<(&Path, &crate::checkpoint::RunLog)>,
    ) -> Result<(), Error> {
        let dim = self.dim;
        let out = self;
        {
            std::fs::create_dir_all(out_dir).map_err(|source| io::IoError::File {
                path: out_dir.to_path_buf(),
                op: "create the output directory",
                source,
            })?;
            for stale in ["summary.json", "case.toml"] {
                let p = out_dir.join(stale);
                if p.exists() {
                    std::fs::remove_file(&p).map_err(|source| io::IoError::File {
                        path: p.clone(),
                        op: "remove the result of an earlier run",
                        source,
                    })?;
                }
            }
            // linear parents; on enriched surfaces their corners are display nodes
            let conn = model.parent_connectivity();
            let kind = if dim == 2 {
                io::CellKind::Quadrilateral
            } else {
                io::CellKind::Hexahedron
            };
            let grid = GridDef {
                name: "bulk",
                dim,
                coords: &model.coords,
                kind,
                connectivity: &conn,
            };
            let mut grids = vec![grid];
            grids.extend(out.sampled.iter().map(|g| GridDef {
                name: g.name,
                dim,
                coords: &g.coords,
                kind: g.kind,
                connectivity: &g.connectivity,
            }));
            let n_points = out.point_ref.len() / dim;
            let point_conn: Vec<usize> = (0..n_points).collect();
            if n_points > 0 {
                grids.push(GridDef {
                    name: "contact_points",
                    dim,
                    coords: &out.point_ref,
                    kind: io::CellKind::Polyvertex,
                    connectivity: &point_conn,
                });
            }
            out.results = Some(match resume {
                Some((ckpt, log)) => ResultsWriter::resume(
                    out_dir,
                    &ckpt.join("results.h5"),
                    &grids,
                    &log.results_layout,
                )?,
                None => ResultsWriter::create(out_dir, &grids)?,
            });
            let labels: Vec<(&str, &str)> = case
                .output
                .reactions
                .iter()
                .map(|r| (r.body.as_str(), r.set.as_str()))
                .collect();
            let extra = history_extra_labels(model);
            out.history = Some(match resume {
                Some((ckpt, _)) => {
                    HistoryWriter::resume(out_dir, &ckpt.join("history.csv"), dim, &labels, &extra)?
                }
                None => HistoryWriter::create(out_dir, dim, &labels, &extra)?,
            });
        }
        Ok(())
    }

    /// Records one converged step (history row; results when `write`). Collective.
    #[allow(clippy::too_many_arguments)]
    fn step(
        &mut self,
        rec: &StepRecord,
        reactions: &[f64],
        extra: &[f64],
        wall: f64,
        write: bool,
        x: &Vector,
        asm: &mut Assembler,
    ) -> Result<(), Error> {
        // Rank-local failures (a full disk on rank 0) are kept until every rank has been through the
        // collectives below, then agreed, so that all ranks stop together.
        let mut local: Result<(), Error> = Ok(());
        if let Some(h) = &mut self.history {
            local = h
                .write_row(&HistoryRow {
                    step: rec.step,
                    stage: rec.stage,
                    load_factor: rec.load,
                    newton_iterations: rec.iterations as u32,
                    residual: rec.residual,
                    cutbacks: rec.cutbacks as u32,
                    reactions,
                    extra,
                    wall_time: wall,
                })
                .map_err(Error::from);
        }
        if write {
            self.results_step(rec, x, asm, local)
        } else {
            agree(asm.comm(), local)
        }
    }

    /// Writes one output step of results.h5 (`local`: an earlier rank-local failure of this step,
    /// agreed with the others at the end). Collective.
    fn results_step(
        &mut self,
        rec: &StepRecord,
        x: &Vector,
        asm: &mut Assembler,
        mut local: Result<(), Error>,
    ) -> Result<(), Error> {
        self.gather.gather(x, &mut self.u_root)?;
        // Element measures: each rank fills its cells, a sum-reduction assembles them on rank 0.
        let measures = asm.stress_measures(x)?;
        let comm = asm.comm();
        let mut cells = vec![0.0; 3 * self.n_cells];
        let rank = comm.rank() as f64;
        for (body, cell, tr, vm) in measures {
            let g = self.cell_offset[body] + cell;
            cells[g] = tr;
            cells[self.n_cells + g] = vm;
            cells[2 * self.n_cells + g] = rank;
        }
        let root_proc = comm.process_at_rank(0);
        let contact = contact_fields(asm, self.n_nodes, self.root);
        let points = gather_points(asm);
        if self.root {
            let mut global = vec![0.0; 3 * self.n_cells];
            root_proc.reduce_into_root(&cells[..], &mut global[..], SystemOperation::sum());
            if local.is_ok() {
                local = self.write_results(
                    rec.load,
                    &global,
                    contact.as_ref(),
                    points.as_deref(),
                    asm.offsets(),
                );
            }
        } else {
            root_proc.reduce_into(&cells[..], SystemOperation::sum());
        }
        agree(asm.comm(), local)
    }

    /// Rank 0: writes one output step from the gathered displacement and cell measures.
    fn write_results(
        &mut self,
        load: f64,
        cell_measures: &[f64],
        contact: Option<&Vec<(&'static str, usize, Vec<f64>)>>,
        points: Option<&[f64]>,
        offsets: &NodeOffsets,
    ) -> Result<(), Error> {
        let mut u = self.u_root.read()?.to_vec();
        // rigidly coupled nodes: the representative's displacement plus the rotation's offset
        for s in 0..offsets.len() {
            let n = offsets.node(s) as usize;
            for c in 0..self.dim {
                u[n * self.dim + c] += offsets.value(s, c);
            }
        }
        for (n, _) in self.without_unknowns.iter().enumerate().filter(|(_, &w)| w) {
            u[n * self.dim..(n + 1) * self.dim].fill(0.0);
        }
        crate::model::apply_display(&self.display, self.dim, &mut u);
        let sampled_u: Vec<Vec<f64>> = self
            .sampled
            .iter()
            .map(|g| g.interpolate(self.dim, &u))
            .collect();
        let (i1, rest) = cell_measures.split_at(self.n_cells);
        let (vm, ranks) = rest.split_at(self.n_cells);
        let mut fields = Vec::new();
        for f in &self.fields {
            fields.push(match f {
                OutputField::Displacement => {
                    FieldData::node_vector("bulk", "displacement", self.dim, &u)
                }
                OutputField::I1 => FieldData::cell_scalar("bulk", "I1", i1),
                OutputField::VonMises => FieldData::cell_scalar("bulk", "von_mises", vm),
                OutputField::Rank => FieldData::cell_scalar("bulk", "rank", ranks),
            });
        }
        for (g, v) in self.sampled.iter().zip(&sampled_u) {
            fields.push(FieldData::node_vector(g.name, "displacement", self.dim, v));
        }
        // contact pressure, gap and friction: nodal values of the L2 projections on the contact
        // surfaces' own interpolation, shown on the bulk grid (display nodes interpolated) and the
        // sampled grids
        let mut contact_nodal = Vec::new();
        for (name, w, v) in contact.into_iter().flatten() {
            let mut v = v.clone();
            crate::model::apply_display(&self.display, *w, &mut v);
            let sampled: Vec<Vec<f64>> =
                self.sampled.iter().map(|g| g.interpolate(*w, &v)).collect();
            contact_nodal.push((*name, *w, v, sampled));
        }
        for (name, w, v, sampled) in &contact_nodal {
            fields.push(FieldData::node_vector("bulk", name, *w, v));
            for (g, sv) in self.sampled.iter().zip(sampled) {
                fields.push(FieldData::node_vector(g.name, name, *w, sv));
            }
        }
        // the contact quadrature points: displacement from the reference position, pressure, gap,
        // half-pass, and with friction the state (0 none, 1 stick, 2 slip), tangential traction
        // and tangential gap to the anchor
        let dim = self.dim;
        let recs: Vec<&[f64]> = points
            .unwrap_or_default()
            .chunks_exact(POINT_RECORD)
            .collect();
        let pf = |f: &dyn Fn(&[f64]) -> Vec<f64>| -> Vec<f64> {
            recs.iter().flat_map(|r| f(r)).collect()
        };
        let point_fields: Vec<(&str, usize, Vec<f64>)> = if recs.is_empty() {
            Vec::new()
        } else {
            vec![
                (
                    "displacement",
                    dim,
                    pf(&|r| (0..dim).map(|c| r[6 + c] - r[3 + c]).collect()),
                ),
                ("half_pass", 1, pf(&|r| vec![r[0]])),
                ("contact_pressure", 1, pf(&|r| vec![r[9]])),
                ("contact_gap", 1, pf(&|r| vec![r[10]])),
                ("friction_state", 1, pf(&|r| vec![r[11]])),
                (
                    "tangential_traction",
                    dim,
                    pf(&|r| r[12..12 + dim].to_vec()),
                ),
                ("tangential_gap", dim, pf(&|r| r[15..15 + dim].to_vec())),
            ]
        };
        for (name, w, v) in &point_fields {
            fields.push(FieldData::node_vector("contact_points", name, *w, v));
        }
        debug_assert_eq!(u.len(), self.n_nodes * self.dim);
        if let Some(r) = &mut self.results {
            r.write_step(load, &fields)?;
        }
        Ok(())
    }

    /// Finalises results (renamed into place) and writes the summary. Collective for nothing.
    fn finish(mut self, summary: &Summary) -> Result<(), Error> {
        if !self.root {
            return Ok(());
        }
        if let Some(r) = self.results.take() {
            r.finish()?;
        }
        // history.csv is flushed row by row under its final name: nothing to finish.
        self.history.take();
        io::write_atomic(&self.out_dir.join("case.toml"), self.case_toml.as_bytes())?;
        io::write_summary(&self.out_dir, summary)?;
        Ok(())
    }
}
