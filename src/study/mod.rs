//! `nurbs-contact study STUDY.toml`: a refinement study — one base case run over every combination
//! of a few axes (element family, mesh level, any `--set` key), metrics computed from each run's
//! `history.csv`, and tables and plots of every metric against the mesh level and the wall time.
//!
//! # The study file
//! ```toml
//! name = "ironing_table2"            # default: the file name without .toml
//! description = "Table 2 of the paper"
//! case = "../ironing_2d.toml"        # the base case, relative to this file
//! jobs = 2                           # runs executed at once (default 1)
//! ranks = 1                          # MPI ranks per run: `mpirun --oversubscribe -np ranks`; 1 runs directly
//! timeout = 3600                     # seconds; a run past it is stopped and recorded as failed (default none)
//! set = ["stages.1.steps=160"]       # overrides of every run, applied before the axes'
//! series = "family"                  # axis of the plot series and table columns (default: the first)
//! level = "mesh"                     # axis on the abscissa of metric-against-level plots
//!                                    # (default: the other axis when there are exactly two)
//! reference = "Q1N2"                 # series value that study.md gives every metric relative to
//!
//! [[axes]]                           # a value axis: each value is set to every key
//! name = "family"
//! keys = ["bodies.block.element", "bodies.cylinder.element"]
//! values = ["Q1N2", "Q1N3"]
//!
//! [[axes]]                           # a level axis: named bundles of overrides
//! name = "mesh"
//! levels = [
//!   { name = "mesh4", value = 4, set = ["meshes.block.divisions=[40,8]"] },
//!   { name = "mesh8", value = 8, set = ["meshes.block.divisions=[80,16]"] },
//! ]
//!
//! [[metrics]]
//! name = "dPx_ece"
//! kind = "range_ece"
//! columns = ["P_ironing_cylinder_arc_x", "-P_ironing_block_top_x"]
//! window = { column = "load_factor", min = 1.25 }
//!
//! [plot]
//! curves = ["P_ironing_cylinder_arc_x", "-P_ironing_block_top_x"]   # drawn for each run
//! x = "load_factor"                                                  # their abscissa (default)
//!
//! [slurm]                            # only read by --launcher slurm; every key optional
//! time = "04:00:00"                  # per array task (default: timeout + 1 min, else the estimate)
//! mem_per_rank = "2G"                # --mem-per-cpu (default: the estimate)
//! partition = "compute"
//! account = "proj42"
//! max_running = 4                    # array tasks at once (--array=...%4)
//! stop_before = 300                  # seconds before the limit: one SIGTERM to the runs
//! mpi = "pmix"                       # srun --mpi= (default pmix)
//! sbatch = ["--qos=short"]           # further #SBATCH lines
//! ```
//! Every combination of the axes' values is one run (the first axis varies slowest), named by its
//! values joined with `_` (`Q1N2_mesh4`); a value's label is the string itself, a level's `name`, or
//! the TOML text of any other value. Unknown keys are errors, as are axes, series, levels or
//! metrics that refer to something not declared; messages name the file and the key.
//!
//! # Metrics
//! A metric reads one `column` or several `columns` of `history.csv` (a leading `-` negates a
//! column: the two half-passes' forces act on different bodies and have opposite signs), keeps the
//! rows whose `window.column` lies in `[window.min, window.max]` (both optional and inclusive, with
//! a tolerance of 1e-9 relative; default all rows) and computes, with c the columns and i the rows:
//! - `range`: max over c, i minus min over c, i: eq. (22) of the paper, DeltaP = max(P1, P2) - min(P1, P2).
//! - `range_ece`: max over c of (max over i minus min over i): eq. (23), DeltaP_ece = max(DeltaP1, DeltaP2).
//! - `mean`, `sum`, `last`: of the row-wise mean of the columns (mean over rows, sum over rows, last row).
//! - `max`, `min`, `max_abs`: over c and i.
//! - `min_slope`: the steepest slope min over c, i of (v[i+1] - v[i]) / (x[i+1] - x[i]) between
//!   consecutive window rows (negative for the steepest descent), x the column `x` (default: the
//!   window's column, else `load_factor`); rows with equal x are skipped.
//! - `oscillation`: the oscillation amplitude, peak to peak: for each column, the least-squares
//!   polynomial of degree `detrend` (default 1) in x over the window is subtracted, and the amplitude
//!   is max minus min of what is left; the largest over the columns. `detrend = 0` gives `range_ece`.
//!
//! - `field_max` (with `field`, optional `grids`, default `["surface", "bulk"]`; no columns or
//!   window): the largest value of that results.h5 field at the last written step, on the first grid
//!   that has it (e.g. the peak contact pressure).
//! - `hertz_p0` (with one `column`, the load, and `hertz = { shape, radius, E, nu, load_scale }`):
//!   Hertz's peak pressure for `load_scale` times the column's last window value
//!   ([`metrics::HertzSpec`]).
//!
//! `scale` multiplies the value (e.g. 1 / (E L0^2)); `relative_to = "other"` divides it by the
//! metric `other` of the same run (which must not itself be relative).
//!
//! # Running, resuming, failures
//! Each run is `nurbs-contact run CASE --out OUT/<run> -q --set ...` (plus the study command's own
//! PETSc options), on `ranks` ranks; its stdout and stderr go to `OUT/logs/<run>.out|.err`. A run
//! whose directory already holds a `summary.json` with status `converged` and a `case.toml` equal to
//! the run's resolved case (the case after its overrides, as `run` writes it) is not run again, so
//! an interrupted study resumes where it stopped, and a changed study or case reruns exactly what
//! changed (`ranks` and PETSc options are not part of the comparison). A run that fails (its case
//! does not resolve, the solver stops, the timeout is reached) is recorded with its reason (the
//! summary's reason and the tail of its stderr) and the study goes on; `study` exits non-zero when
//! any run failed, after writing its outputs. A run stopped by the timeout gets SIGTERM (mpirun
//! passes it to its ranks), then SIGKILL (with every process it started) 10 s later. SIGINT or
//! SIGTERM to `study` stops the runs in progress the same way and starts no further run ([`stop`]).
//! Run directory names are plain and distinct by construction (checked by [`spec`]); the study's
//! folder is locked while `study` writes into it ([`crate::io::DirLock`]).
//!
//! # Outputs (in OUT, default `out/study/<name>`)
//! - `study.csv`: one row per run: `run`, the axis labels, `status` (`converged`, `failed`, and with
//!   `--collect` `missing`), `skipped` (1: finished by an earlier invocation, not run again; with
//!   `--collect`: in no recorded Slurm submission), `unknowns`, `steps`, `last_load`, `newton_total`,
//!   `newton_max_per_step`, `cutbacks`, `wall_time` (s, summary.json's total), every metric, `reason`.
//! - `study.md`: the runs table, then one table per metric with the series values as columns and
//!   the other axes as rows, each value also in percent of the reference's.
//! - `plots/*.svg` (and the same as `*.png`): `run_<run>.svg` (the `[plot]` curves of each run), `curve_<column>.svg` (one
//!   curve of all runs), `<metric>_vs_level.svg` (each metric against the level axis' values, one
//!   series per combination of the other axes) and `<metric>_vs_wall_time.svg` (the same series
//!   against wall time: speed against error). Logarithmic axes when all values are positive and
//!   span more than a factor 20.
//!
//! `nurbs-contact study --check STUDY.toml` validates the file, resolves every run's case and runs
//! `check` on it (model, sets, numbering), without solving.
//!
//! # On a cluster: `--launcher slurm`, `--collect`
//! `--launcher slurm` writes `OUT/study.sbatch`, one Slurm job array with a task per run that has
//! no converged result of its current case (and is not still queued in an earlier submission):
//! each task runs `srun --mpi=pmix --ntasks=ranks` followed by the local launcher's command (the
//! same arguments, with absolute paths), its output in the same `OUT/logs/<run>.out|.err`, into
//! the same run folder. It submits the script with `sbatch --parsable`, prints the job id and
//! records which task holds which run in `OUT/slurm-jobs.json`; `--dry-run` only writes the script
//! (and prints its path). Time and memory per task come from `[slurm]`, else from the size estimate
//! of the largest run (see [`slurm::resources`]).
//! `--collect` builds `study.csv`, `study.md` and the plots from the run folders as they are, runs
//! nothing, and can be repeated: a run is `converged` (with the same resolved case), `failed` (its
//! summary's reason, or a Slurm task that ended without a summary) or `missing`
//! (`status` column; with what `squeue` says: `pending (Resources) in Slurm job 12_3`, running, not
//! submitted). `--collect` with no result at all is an error naming every run's state.
//!
//! - [`spec`]: the file's schema and the runs it resolves to; [`metrics`]: metric kinds;
//!   [`exec`]: launching, resuming, collecting; [`slurm`]: the job script, sbatch, squeue;
//!   [`report`]: `study.csv`, `study.md`; [`svg`]: the plots.

pub mod exec;
pub mod metrics;
pub mod png;
pub mod report;
pub mod slurm;
pub mod spec;
pub mod stop;
pub mod svg;

use crate::io::write_atomic;
use exec::Outcome;
use report::Row;
use spec::Study;
use std::path::{Path, PathBuf};
use svg::{suits_log, Plot, Series};

/// Errors of the `study` command (a failed run is not one: it is recorded in the study's outputs).
#[derive(Debug, thiserror::Error)]
pub enum StudyError {
    #[error("{}{}: {message}", .file.display(), .line.map_or(String::new(), |l| format!(":{l}")))]
    Syntax {
        file: PathBuf,
        line: Option<usize>,
        message: String,
    },
    #[error("{}: `{key}`: {message}", .file.display())]
    Invalid {
        file: PathBuf,
        key: String,
        message: String,
    },
    #[error("{}: cannot {op}: {source}", .path.display())]
    Io {
        path: PathBuf,
        op: &'static str,
        #[source]
        source: std::io::Error,
    },
    #[error(transparent)]
    Output(#[from] crate::io::IoError),
    /// Submitting to Slurm failed (sbatch missing or refusing the job).
    #[error("{message}")]
    Slurm { message: String },
    /// `--collect` found no run with a result.
    #[error("{}: nothing to collect: {detail}", .out.display())]
    NothingToCollect { out: PathBuf, detail: String },
    /// Runs failed (each reported above); the study's outputs were written.
    #[error("{failed} of {total} runs failed (listed above); study.csv, study.md and plots/ in {}", .out.display())]
    RunsFailed {
        failed: usize,
        total: usize,
        out: PathBuf,
    },
    /// A signal stopped the study after the runs in progress were stopped; the process should
    /// exit with [`crate::interrupt::exit_code`] of `signal`.
    #[error("stopped by {}: the runs in progress were stopped, no further run started; run the study again to continue (converged runs are not run again); study.csv, study.md and plots/ in {}", crate::interrupt::signal_name(*.signal), .out.display())]
    Interrupted { signal: i32, out: PathBuf },
    /// `--check` found runs whose case does not pass: one line per run.
    #[error("{}: {count} of {total} runs do not pass check:\n{lines}", .file.display())]
    Check {
        file: PathBuf,
        count: usize,
        total: usize,
        lines: String,
    },
}

/// How the runs of a study are started.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Launcher {
    /// Subprocesses on this machine, `jobs` at a time (`mpirun` for more than one rank).
    #[default]
    Local,
    /// One Slurm job array, a task per run, each under `srun` (see [`slurm`]).
    Slurm,
}

/// What `nurbs-contact study` was asked to do.
#[derive(Debug, Clone)]
pub struct StudyOptions {
    pub file: PathBuf,
    /// Output folder (default `out/study/<name>`).
    pub out: Option<PathBuf>,
    /// Validate and resolve only.
    pub check: bool,
    /// Overrides the file's `jobs`.
    pub jobs: Option<usize>,
    pub quiet: bool,
    /// PETSc options of the command line, passed to every run.
    pub petsc_args: Vec<String>,
    pub launcher: Launcher,
    /// With [`Launcher::Slurm`]: write the job script, do not submit it.
    pub dry_run: bool,
    /// Build the outputs from the run folders as they are, running nothing.
    pub collect: bool,
}

/// `nurbs-contact study`.
pub fn study_main(opts: &StudyOptions) -> Result<(), StudyError> {
    let mut study = Study::load(&opts.file)?;
    let usage = |key: &str, message: &str| StudyError::Invalid {
        file: opts.file.clone(),
        key: key.into(),
        message: message.into(),
    };
    if let Some(j) = opts.jobs {
        if j == 0 {
            return Err(usage("jobs", "--jobs must be at least 1"));
        }
        if opts.launcher == Launcher::Slurm {
            return Err(usage(
                "jobs",
                "--jobs sets how many runs this machine starts at once; with --launcher slurm \
                 Slurm decides (limit it with [slurm] max_running)",
            ));
        }
        study.spec.jobs = j;
    }
    if opts.dry_run && opts.launcher != Launcher::Slurm {
        return Err(usage(
            "dry-run",
            "--dry-run writes a Slurm job script without submitting it: give it with --launcher slurm",
        ));
    }
    let exe = std::env::current_exe().map_err(|source| StudyError::Io {
        path: PathBuf::from("nurbs-contact"),
        op: "find this program's own path",
        source,
    })?;
    // PETSc options are passed on without the program name that leads the list.
    let petsc: Vec<String> = opts.petsc_args.iter().skip(1).cloned().collect();
    // Signals reach the study only while it runs its runs locally (see [`stop`]).
    let stop = if opts.launcher == Launcher::Local && !opts.check && !opts.collect {
        stop::Stop::install().map_err(|source| StudyError::Io {
            path: opts.file.clone(),
            op: "install the signal handlers of the study",
            source,
        })?
    } else {
        Default::default()
    };
    let launch = exec::Launch {
        exe,
        petsc_args: &petsc,
        quiet: opts.quiet,
        stop: &stop,
    };
    if opts.check {
        return check(&study, &launch);
    }
    let out = opts
        .out
        .clone()
        .unwrap_or_else(|| Path::new("out/study").join(&study.name));
    // one writer of the study's folder at a time, for as long as this command runs
    if opts.collect {
        let _lock = match out.is_dir() {
            true => Some(crate::io::DirLock::exclusive(&out)?),
            false => None,
        };
        return collect(&study, &out, opts);
    }
    std::fs::create_dir_all(&out).map_err(|source| StudyError::Io {
        path: out.clone(),
        op: "create the study's output folder",
        source,
    })?;
    let _lock = crate::io::DirLock::exclusive(&out)?;
    if opts.launcher == Launcher::Slurm {
        return submit_slurm(&mut study, &out, &launch, opts);
    }
    create_logs(&out)?;
    if !opts.quiet {
        eprintln!(
            "study {}: {} runs, {} at once on {} rank(s) each, results in {}",
            study.name,
            study.runs.len(),
            study.spec.jobs,
            study.spec.ranks,
            out.display()
        );
    }
    let outcomes = exec::execute(&study, &out, &launch);
    let command = format!("nurbs-contact study {}", opts.file.display());
    let rows = write_outputs(&study, &out, &outcomes, &command)?;
    report_rows(&study, &rows, &out, opts.quiet);
    if let Some(signal) = stop.requested() {
        return Err(StudyError::Interrupted { signal, out });
    }
    failed_runs(&rows, &out)
}

/// The study's verdict: an error when any run failed (its outputs are written by then).
fn failed_runs(rows: &[Row], out: &Path) -> Result<(), StudyError> {
    let failed = rows.iter().filter(|r| r.status() == "failed").count();
    if failed == 0 {
        return Ok(());
    }
    Err(StudyError::RunsFailed {
        failed,
        total: rows.len(),
        out: out.to_path_buf(),
    })
}

/// `study.csv`, `study.md` and the plots from the outcomes; the rows.
fn write_outputs(
    study: &Study,
    out: &Path,
    outcomes: &[Outcome],
    command: &str,
) -> Result<Vec<Row>, StudyError> {
    let rows = report::rows(study, outcomes);
    write_atomic(&out.join("study.csv"), report::csv(study, &rows).as_bytes())?;
    write_atomic(
        &out.join("study.md"),
        report::markdown(study, &rows, command).as_bytes(),
    )?;
    write_plots(study, &rows, outcomes, &out.join("plots"))?;
    Ok(rows)
}

/// Prints the failed and missing runs and a closing line.
fn report_rows(study: &Study, rows: &[Row], out: &Path, quiet: bool) {
    for r in rows.iter().filter(|r| r.converged && !r.reason.is_empty()) {
        eprintln!("warning: {}: {}", r.run, r.reason);
    }
    for r in rows.iter().filter(|r| !r.converged) {
        eprintln!("{}: {}: {}", r.status(), r.run, r.reason);
    }
    if !quiet {
        let count = |s: &str| rows.iter().filter(|r| r.status() == s).count();
        let missing = count("missing");
        eprintln!(
            "study {}: {} converged ({} not run again), {} failed{}; study.csv, study.md and plots/ in {}",
            study.name,
            count("converged"),
            rows.iter().filter(|r| r.converged && r.skipped).count(),
            count("failed"),
            if missing > 0 {
                format!(", {missing} missing (collect again when they have run)")
            } else {
                String::new()
            },
            out.display()
        );
    }
}

/// An absolute form of `p` (the job script runs elsewhere, from another folder).
fn absolute(p: &Path) -> Result<PathBuf, StudyError> {
    std::path::absolute(p).map_err(|source| StudyError::Io {
        path: p.to_path_buf(),
        op: "make the path absolute",
        source,
    })
}

/// `--launcher slurm`: writes `OUT/study.sbatch`, a job array of the runs that have no result of
/// their current case yet (and are not queued in an earlier submission), and submits it unless
/// `--dry-run`; records the job in `OUT/slurm-jobs.json`.
fn submit_slurm(
    study: &mut Study,
    out: &Path,
    launch: &exec::Launch<'_>,
    opts: &StudyOptions,
) -> Result<(), StudyError> {
    let out = absolute(out)?;
    study.case = absolute(&study.case)?;
    let logs = create_logs(&out)?;
    let mut subs = slurm::Submissions::load(&out)?;
    // runs of earlier submissions that are still queued or running are not submitted twice
    let queued = if subs.jobs.is_empty() {
        Default::default()
    } else {
        slurm::queue(&subs).unwrap_or_else(|e| {
            eprintln!(
                "warning: cannot tell which runs of earlier submissions are still queued: {e}"
            );
            Default::default()
        })
    };
    let mut tasks = Vec::new();
    let mut cases = Vec::new();
    let (mut finished, mut waiting) = (Vec::new(), Vec::new());
    for (i, run) in study.runs.iter().enumerate() {
        let dir = out.join(&run.name);
        let case = match crate::scene::load_case(&study.case, &run.sets) {
            Ok(c) => c,
            Err(e) => {
                eprintln!("failed: {}: case: {e}", run.name);
                continue;
            }
        };
        let Ok(case_toml) = case.to_toml_string() else {
            eprintln!("failed: {}: case cannot be written back as TOML", run.name);
            continue;
        };
        if exec::finished_earlier(&dir, &case_toml).is_some() {
            finished.push(run.name.clone());
            continue;
        }
        if let Some((job, idx)) = subs.latest_for(&run.name) {
            if let Some(state) = queued.get(&(job.to_string(), idx)) {
                waiting.push(format!("{} ({} in job {job}_{idx})", run.name, state));
                continue;
            }
        }
        let (out_log, err_log) = exec::log_paths(&out, run);
        let mut command = vec![launch.exe.to_string_lossy().into_owned()];
        command.extend(
            exec::run_args(study, run, &dir, launch)
                .iter()
                .map(|a| a.to_string_lossy().into_owned()),
        );
        tasks.push(slurm::Task {
            index: i,
            run: run.name.clone(),
            command,
            out_log,
            err_log,
        });
        cases.push((run.name.clone(), case));
    }
    if !opts.quiet {
        if !finished.is_empty() {
            eprintln!(
                "not submitted, finished earlier with the same case: {}",
                finished.join(", ")
            );
        }
        if !waiting.is_empty() {
            eprintln!(
                "not submitted, still in an earlier job: {}",
                waiting.join(", ")
            );
        }
    }
    if tasks.is_empty() {
        eprintln!(
            "study {}: nothing to submit; collect the results with `nurbs-contact study {} --out {} --collect`",
            study.name,
            opts.file.display(),
            out.display()
        );
        return Ok(());
    }
    let named: Vec<(&str, &crate::scene::schema::Case)> =
        cases.iter().map(|(n, c)| (n.as_str(), c)).collect();
    let res = slurm::resources(study, &named);
    let script_path = out.join("study.sbatch");
    write_atomic(
        &script_path,
        slurm::script(study, &out, &tasks, &res).as_bytes(),
    )?;
    let what = format!(
        "{} array task(s) of {} rank(s), --time={} --mem-per-cpu={}",
        tasks.len(),
        study.spec.ranks,
        res.time,
        res.mem_per_rank
    );
    if opts.dry_run {
        println!("{}", script_path.display());
        if !opts.quiet {
            eprintln!(
                "study {}: wrote {} ({what}); not submitted (--dry-run). A job submitted by hand \
                 is not recorded: --collect then cannot tell a queued run from a lost one.",
                study.name,
                script_path.display()
            );
        }
        return Ok(());
    }
    let job_id = slurm::submit(&script_path)?;
    subs.jobs.push(slurm::Submission {
        job_id: job_id.clone(),
        submitted: std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_secs()),
        script: script_path.clone(),
        tasks: tasks.iter().map(|t| (t.index, t.run.clone())).collect(),
    });
    subs.save(&out)?;
    println!("{job_id}");
    if !opts.quiet {
        eprintln!(
            "study {}: submitted Slurm job {job_id}: {what}; logs in {}; collect the results with \
             `nurbs-contact study {} --out {} --collect`",
            study.name,
            logs.display(),
            opts.file.display(),
            out.display()
        );
    }
    Ok(())
}

/// `--collect`: the study's outputs from the run folders as they are, running nothing. Runs without
/// a result are `missing`, with what Slurm says of them; an error when no run has a result.
fn collect(study: &Study, out: &Path, opts: &StudyOptions) -> Result<(), StudyError> {
    if !out.is_dir() {
        return Err(StudyError::NothingToCollect {
            out: out.to_path_buf(),
            detail: format!(
                "the folder does not exist: run or submit the study first (`nurbs-contact study {} \
                 --launcher slurm`), with the same --out",
                opts.file.display()
            ),
        });
    }
    let subs = slurm::Submissions::load(out)?;
    // squeue before the folders: a task that ends in between has then left its summary
    let states = if subs.jobs.is_empty() {
        Ok(Default::default())
    } else {
        slurm::queue(&subs)
    };
    let mut outcomes = Vec::new();
    let mut any = false;
    for run in &study.runs {
        let latest = subs.latest_for(&run.name);
        let queue = match (latest, &states) {
            (None, _) => exec::Queue::NotSubmitted,
            (Some(_), Err(e)) => exec::Queue::Unknown(e.clone()),
            (Some((job, idx)), Ok(states)) => match states.get(&(job.to_string(), idx)) {
                Some(state) => exec::Queue::Listed {
                    task: format!("{job}_{idx}"),
                    state: state.clone(),
                },
                None => exec::Queue::Ended {
                    task: format!("{job}_{idx}"),
                    log: out.join("logs").join(format!("slurm-{job}_{idx}.out")),
                },
            },
        };
        let (o, ran) = exec::collect_one(study, run, out, &queue, latest.is_some());
        any |= ran;
        outcomes.push(o);
    }
    if !any {
        let lines: Vec<String> = study
            .runs
            .iter()
            .zip(&outcomes)
            .map(|(r, o)| match &o.status {
                exec::Status::Failed(m) | exec::Status::Missing(m) => {
                    format!("\n  {}: {m}", r.name)
                }
                exec::Status::Converged => String::new(),
            })
            .collect();
        return Err(StudyError::NothingToCollect {
            out: out.to_path_buf(),
            detail: format!(
                "none of the {} runs has a result yet:{}",
                study.runs.len(),
                lines.concat()
            ),
        });
    }
    let command = format!("nurbs-contact study {} --collect", opts.file.display());
    let rows = write_outputs(study, out, &outcomes, &command)?;
    report_rows(study, &rows, out, opts.quiet);
    failed_runs(&rows, out)
}

/// `--check`: every run's case resolves and passes `nurbs-contact check`.
fn check(study: &Study, launch: &exec::Launch<'_>) -> Result<(), StudyError> {
    let results = exec::check_all(study, launch);
    let bad: Vec<String> = study
        .runs
        .iter()
        .zip(&results)
        .filter_map(|(run, r)| r.as_ref().err().map(|e| format!("  {}: {e}", run.name)))
        .collect();
    if bad.is_empty() {
        println!(
            "{}: ok ({} runs pass check, {} metrics)",
            study.file.display(),
            study.runs.len(),
            study.spec.metrics.len()
        );
        Ok(())
    } else {
        Err(StudyError::Check {
            file: study.file.clone(),
            count: bad.len(),
            total: study.runs.len(),
            lines: bad.join("\n"),
        })
    }
}

fn file_safe(s: &str) -> String {
    s.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.') {
                c
            } else {
                '_'
            }
        })
        .collect()
}

/// Writes a plot as `<name>.svg` and, rendered from the same SVG, `<name>.png`.
fn write_svg(dir: &Path, name: &str, plot: &Plot) -> Result<(), StudyError> {
    let svg = plot.to_svg();
    let base = file_safe(name);
    write_atomic(&dir.join(format!("{base}.svg")), svg.as_bytes())?;
    let png_path = dir.join(format!("{base}.png"));
    let png = png::svg_to_png(&svg).map_err(|m| StudyError::Io {
        path: png_path.clone(),
        op: "render the plot",
        source: std::io::Error::other(m),
    })?;
    write_atomic(&png_path, &png)?;
    Ok(())
}

/// The study's plots (see the module doc).
fn write_plots(
    study: &Study,
    rows: &[Row],
    outcomes: &[Outcome],
    dir: &Path,
) -> Result<(), StudyError> {
    std::fs::create_dir_all(dir).map_err(|source| StudyError::Io {
        path: dir.to_path_buf(),
        op: "create the plots folder",
        source,
    })?;
    let x_col = study.spec.plot.x.as_deref().unwrap_or("load_factor");
    let curves = &study.spec.plot.curves;
    let curve_of = |o: &Outcome, c: &str| -> Option<Vec<(f64, f64)>> {
        let t = o.history.as_ref()?;
        let (x, y) = (t.column(x_col).ok()?, t.column(c).ok()?);
        Some(x.into_iter().zip(y).collect())
    };
    if !curves.is_empty() {
        for (run, o) in study.runs.iter().zip(outcomes) {
            let series: Vec<Series> = curves
                .iter()
                .filter_map(|c| {
                    curve_of(o, c).map(|points| Series {
                        name: c.clone(),
                        points,
                    })
                })
                .collect();
            if series.is_empty() {
                continue;
            }
            let plot = Plot {
                title: format!("{}: {}", study.name, run.name),
                x_label: x_col.to_string(),
                y_label: "history.csv columns".into(),
                series,
                log_x: false,
                log_y: false,
                markers: false,
            };
            write_svg(dir, &format!("run_{}", run.name), &plot)?;
        }
        for c in curves {
            let series: Vec<Series> = study
                .runs
                .iter()
                .zip(outcomes)
                .filter_map(|(run, o)| {
                    curve_of(o, c).map(|points| Series {
                        name: run.name.clone(),
                        points,
                    })
                })
                .collect();
            if series.is_empty() {
                continue;
            }
            let plot = Plot {
                title: format!("{}: {c}", study.name),
                x_label: x_col.to_string(),
                y_label: c.clone(),
                series,
                log_x: false,
                log_y: false,
                markers: false,
            };
            write_svg(dir, &format!("curve_{c}"), &plot)?;
        }
    }

    // metric plots: one series per combination of the axes other than the level axis
    let level = study.level;
    let mut groups: Vec<(String, Vec<usize>)> = Vec::new();
    for (i, run) in study.runs.iter().enumerate() {
        let name: Vec<&str> = (0..run.labels.len())
            .filter(|&a| Some(a) != level)
            .map(|a| run.labels[a].as_str())
            .collect();
        let name = name.join("_");
        match groups.iter_mut().find(|(n, _)| *n == name) {
            Some((_, v)) => v.push(i),
            None => groups.push((name, vec![i])),
        }
    }
    for (mi, m) in study.spec.metrics.iter().enumerate() {
        let series_of = |x: &dyn Fn(usize) -> Option<f64>| -> Vec<Series> {
            groups
                .iter()
                .map(|(name, runs)| {
                    let mut points: Vec<(f64, f64, f64)> = runs
                        .iter()
                        .filter_map(|&i| {
                            let v = rows[i].metrics[mi]?;
                            Some((study.runs[i].level_value.unwrap_or(i as f64), x(i)?, v))
                        })
                        .collect();
                    points.sort_by(|a, b| a.0.total_cmp(&b.0));
                    Series {
                        name: name.clone(),
                        points: points.into_iter().map(|(_, x, y)| (x, y)).collect(),
                    }
                })
                .filter(|s| !s.points.is_empty())
                .collect()
        };
        let ys = || rows.iter().filter_map(|r| r.metrics[mi]);
        if let Some(l) = level {
            let series = series_of(&|i| study.runs[i].level_value);
            if !series.is_empty() {
                let xs = study.runs.iter().filter_map(|r| r.level_value);
                let plot = Plot {
                    title: format!("{}: {} against {}", study.name, m.name, study.axis_names[l]),
                    x_label: study.axis_names[l].clone(),
                    y_label: m.name.clone(),
                    log_x: suits_log(xs),
                    log_y: suits_log(ys()),
                    series,
                    markers: true,
                };
                write_svg(dir, &format!("{}_vs_level", m.name), &plot)?;
            }
        }
        let series = series_of(&|i| rows[i].wall_time);
        if !series.is_empty() {
            let plot = Plot {
                title: format!("{}: {} against wall time", study.name, m.name),
                x_label: "wall time (s)".into(),
                y_label: m.name.clone(),
                log_x: suits_log(rows.iter().filter_map(|r| r.wall_time)),
                log_y: suits_log(ys()),
                series,
                markers: true,
            };
            write_svg(dir, &format!("{}_vs_wall_time", m.name), &plot)?;
        }
    }
    Ok(())
}

/// Creates `out/logs` (and `out`), where the runs' output goes.
fn create_logs(out: &Path) -> Result<PathBuf, StudyError> {
    let logs = out.join("logs");
    std::fs::create_dir_all(&logs).map_err(|source| StudyError::Io {
        path: logs.clone(),
        op: "create the study's output folder",
        source,
    })?;
    Ok(logs)
}
