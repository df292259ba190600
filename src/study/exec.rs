//! Executing the runs of a study: resolving each run's case, skipping runs finished earlier with the
//! same resolved case, launching the others (`jobs` at a time, each on `ranks` MPI ranks), and
//! collecting what each left behind; [`collect_one`] reads the same from the run folders alone, for runs
//! that another launcher (Slurm) started.

use crate::io::{RunStatus, Summary};
use crate::study::metrics::Table;
use crate::study::spec::{RunSpec, Study};
use crate::study::stop;
use std::ffi::OsString;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::{Duration, Instant};

/// How a run of the study ended.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Status {
    Converged,
    /// The run stopped (or its case could not be resolved): the reason.
    Failed(String),
    /// `--collect` found no result of the run yet (queued, running, never submitted): why.
    Missing(String),
}

/// What one run of the study left: its status and results.
#[derive(Debug, Clone)]
pub struct Outcome {
    pub status: Status,
    /// Not run by this invocation: an earlier one finished it with the same resolved case.
    pub skipped: bool,
    pub summary: Option<Summary>,
    pub history: Option<Table>,
    /// The run's output directory.
    pub dir: PathBuf,
}

/// Where the logs of a run go (beside, not inside, its output directory, which the run claims).
pub fn log_paths(out: &Path, run: &RunSpec) -> (PathBuf, PathBuf) {
    let logs = out.join("logs");
    (
        logs.join(format!("{}.out", run.name)),
        logs.join(format!("{}.err", run.name)),
    )
}

/// The case of a run after its overrides, as `run` writes it to `case.toml`.
pub fn resolved_case(study: &Study, run: &RunSpec) -> Result<String, String> {
    let case = crate::scene::load_case(&study.case, &run.sets).map_err(|e| e.to_string())?;
    case.to_toml_string().map_err(|e| e.to_string())
}

/// Whether `dir` holds a converged run of exactly `case_toml`.
pub fn finished_earlier(dir: &Path, case_toml: &str) -> Option<Summary> {
    let written = std::fs::read_to_string(dir.join("case.toml")).ok()?;
    if written != case_toml {
        return None;
    }
    let summary = read_summary(dir)?;
    matches!(summary.status, RunStatus::Converged).then_some(summary)
}

/// The summary of `dir` if the run there was of exactly `case_toml` (converged or not).
fn summary_of_case(dir: &Path, case_toml: &str) -> Option<Summary> {
    let written = std::fs::read_to_string(dir.join("case.toml")).ok()?;
    (written == case_toml).then(|| read_summary(dir)).flatten()
}

/// Whether `dir` holds a converged `summary.json` written at or after `t`.
fn converged_since(dir: &Path, t: std::time::SystemTime) -> bool {
    let written = std::fs::metadata(dir.join("summary.json")).and_then(|m| m.modified());
    written.is_ok_and(|w| w >= t)
        && read_summary(dir).is_some_and(|s| matches!(s.status, RunStatus::Converged))
}

fn read_summary(dir: &Path) -> Option<Summary> {
    let text = std::fs::read_to_string(dir.join("summary.json")).ok()?;
    serde_json::from_str(&text).ok()
}

fn read_history(dir: &Path) -> Option<Table> {
    let p = dir.join("history.csv");
    let text = std::fs::read_to_string(&p).ok()?;
    Table::parse(&text, &p.display().to_string()).ok()
}

/// Settings of the launch shared by all runs.
pub struct Launch<'a> {
    /// The solver binary (this program).
    pub exe: PathBuf,
    /// PETSc options of the study's command line, passed on to every run.
    pub petsc_args: &'a [String],
    pub quiet: bool,
    /// Signals to the study: passed on to the runs in progress; no run starts after one.
    pub stop: &'a crate::study::stop::Stop,
}

/// `f(i)` for `i` in `0..n`, `jobs` at a time; results in order.
pub fn parallel<T: Send>(n: usize, jobs: usize, f: impl Fn(usize) -> T + Sync) -> Vec<T> {
    let next = AtomicUsize::new(0);
    let results: Mutex<Vec<Option<T>>> = Mutex::new((0..n).map(|_| None).collect());
    std::thread::scope(|scope| {
        for _ in 0..jobs.min(n).max(1) {
            scope.spawn(|| loop {
                let i = next.fetch_add(1, Ordering::SeqCst);
                if i >= n {
                    break;
                }
                let r = f(i);
                results.lock().expect("no worker panics")[i] = Some(r);
            });
        }
    });
    results
        .into_inner()
        .expect("no worker panics")
        .into_iter()
        .map(|o| o.expect("every index done"))
        .collect()
}

/// Runs (or skips) every run of the study, `jobs` at a time; outcomes in run order.
pub fn execute(study: &Study, out: &Path, launch: &Launch<'_>) -> Vec<Outcome> {
    let n = study.runs.len();
    let done = AtomicUsize::new(0);
    parallel(n, study.spec.jobs, |i| {
        let run = &study.runs[i];
        let t0 = Instant::now();
        let outcome = execute_one(study, run, out, launch);
        let k = done.fetch_add(1, Ordering::SeqCst) + 1;
        if !launch.quiet {
            eprintln!(
                "[{k}/{n}] {}: {}",
                run.name,
                describe(&outcome, t0.elapsed())
            );
        }
        outcome
    })
}

/// `nurbs-contact check` on every run's case (each in its own process: `check` initialises MPI and
/// PETSc), `jobs` at a time: `Err(message)` for the runs that do not pass.
pub fn check_all(study: &Study, launch: &Launch<'_>) -> Vec<Result<(), String>> {
    parallel(study.runs.len(), study.spec.jobs, |i| {
        let run = &study.runs[i];
        let mut cmd = Command::new(&launch.exe);
        cmd.arg("check").arg(&study.case);
        for s in &run.sets {
            cmd.arg("--set").arg(s);
        }
        cmd.args(launch.petsc_args);
        mpi_env(&mut cmd);
        let out = cmd
            .stdin(Stdio::null())
            .output()
            .map_err(|e| format!("cannot start {:?}: {e}", cmd.get_program()))?;
        if out.status.success() {
            Ok(())
        } else {
            let err = String::from_utf8_lossy(&out.stderr);
            let msg: Vec<&str> = err.lines().filter(|l| !l.trim().is_empty()).collect();
            Err(msg.join(" | "))
        }
    })
}

/// The environment the test suite and ci/env.sh give mpirun: runs that share cores yield instead of
/// busy-polling; as root, Open MPI must be told that this is intended.
fn mpi_env(cmd: &mut Command) {
    if std::env::var_os("OMPI_MCA_mpi_yield_when_idle").is_none() {
        cmd.env("OMPI_MCA_mpi_yield_when_idle", "1");
    }
    if running_as_root() && std::env::var_os("OMPI_ALLOW_RUN_AS_ROOT").is_none() {
        cmd.env("OMPI_ALLOW_RUN_AS_ROOT", "1")
            .env("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1");
    }
}

fn describe(o: &Outcome, elapsed: Duration) -> String {
    match (&o.status, o.skipped) {
        (Status::Converged, true) => "finished earlier with the same case, not run again".into(),
        (Status::Converged, false) => {
            let s = o.summary.as_ref();
            format!(
                "converged in {:.1} s ({} unknowns, {} Newton iterations)",
                elapsed.as_secs_f64(),
                s.map_or(0, |s| s.unknowns),
                s.map_or(0, |s| s.newton.total_iterations)
            )
        }
        (Status::Failed(r), _) => format!("FAILED: {}", r.lines().next().unwrap_or("")),
        (Status::Missing(r), _) => format!("missing: {r}"),
    }
}

fn execute_one(study: &Study, run: &RunSpec, out: &Path, launch: &Launch<'_>) -> Outcome {
    let dir = out.join(&run.name);
    let failed = |reason: String, dir: &Path| Outcome {
        status: Status::Failed(reason),
        skipped: false,
        summary: read_summary(dir),
        history: read_history(dir),
        dir: dir.to_path_buf(),
    };
    let case_toml = match resolved_case(study, run) {
        Ok(t) => t,
        Err(e) => return failed(format!("case: {e}"), &dir),
    };
    if let Some(summary) = finished_earlier(&dir, &case_toml) {
        return Outcome {
            status: Status::Converged,
            skipped: true,
            summary: Some(summary),
            history: read_history(&dir),
            dir,
        };
    }
    if let Some(sig) = launch.stop.requested() {
        return Outcome {
            status: Status::Missing(format!(
                "not started: the study was stopped by {}",
                crate::interrupt::signal_name(sig)
            )),
            skipped: false,
            summary: None,
            history: None,
            dir,
        };
    }
    match launch_run(study, run, &dir, out, launch) {
        Err(reason) => failed(reason, &dir),
        Ok(()) => match read_summary(&dir) {
            Some(s) if matches!(s.status, RunStatus::Converged) => Outcome {
                status: Status::Converged,
                skipped: false,
                summary: Some(s),
                history: read_history(&dir),
                dir,
            },
            _ => failed(
                "the run exited successfully but left no converged summary.json".into(),
                &dir,
            ),
        },
    }
}

/// Whether this process runs as root (Open MPI then needs to be told that this is intended).
fn running_as_root() -> bool {
    use std::os::unix::fs::MetadataExt;
    std::fs::metadata("/proc/self").is_ok_and(|m| m.uid() == 0)
}

/// Starts `nurbs-contact run` for one run and waits for it; `Err(reason)` when it fails.
fn launch_run(
    study: &Study,
    run: &RunSpec,
    dir: &Path,
    out: &Path,
    launch: &Launch<'_>,
) -> Result<(), String> {
    let (out_log, err_log) = log_paths(out, run);
    let open =
        |p: &Path| crate::io::create_nofollow(p).map_err(|e| format!("cannot create the log: {e}"));
    let (out_file, err_file) = (open(&out_log)?, open(&err_log)?);
    let args = run_args(study, run, dir, launch);
    let mut cmd = if study.spec.ranks == 1 {
        Command::new(&launch.exe)
    } else {
        let mut c = Command::new("mpirun");
        c.args(["--oversubscribe", "-np", &study.spec.ranks.to_string()])
            .arg(&launch.exe);
        c
    };
    cmd.args(args);
    mpi_env(&mut cmd);
    // A process group of its own: a terminal's Ctrl-C reaches the study only, which passes it on
    // (mpirun would otherwise receive it twice and kill its ranks instead of stopping them).
    {
        use std::os::unix::process::CommandExt;
        cmd.process_group(0);
    }
    cmd.stdin(Stdio::null())
        .stdout(Stdio::from(out_file))
        .stderr(Stdio::from(err_file));
    let started = std::time::SystemTime::now();
    let mut child = cmd
        .spawn()
        .map_err(|e| format!("cannot start {:?}: {e}", cmd.get_program()))?;
    let t0 = Instant::now();
    let limit = study.spec.timeout.map(Duration::from_secs_f64);
    let pid = child.id();
    // when the study's stop was passed on to the run
    let mut stopping: Option<Instant> = None;
    let status = loop {
        match child.try_wait() {
            Ok(Some(st)) => break st,
            Ok(None) => {}
            Err(e) => return Err(format!("waiting for the run failed: {e}")),
        }
        if let Some(sig) = launch.stop.requested() {
            match stopping {
                // SIGINT/SIGTERM to the run (or mpirun, which passes it on to its ranks): it stops
                // after its load step and records its converged steps
                None => {
                    stop::signal_process(pid, stop::kill_name(sig));
                    stopping = Some(Instant::now());
                }
                Some(t) if launch.stop.forced() || t.elapsed() > stop::GRACE => {
                    stop::kill_tree(pid);
                    let _ = child.kill();
                    let _ = child.wait();
                    return Err(format!(
                        "killed: the study was stopped by {}{}",
                        crate::interrupt::signal_name(sig),
                        tail_suffix(&err_log)
                    ));
                }
                Some(_) => {}
            }
        }
        if stopping.is_none() && limit.is_some_and(|l| t0.elapsed() > l) {
            // SIGTERM first, so that mpirun can take its ranks down with it.
            stop::signal_process(pid, "TERM");
            let t1 = Instant::now();
            let mut ended = false;
            while !ended && t1.elapsed() < stop::GRACE {
                ended = matches!(child.try_wait(), Ok(Some(_)));
                std::thread::sleep(Duration::from_millis(100));
            }
            if !ended {
                // not yet reaped, so `pid` is still this run's
                stop::kill_tree(pid);
                let _ = child.kill();
                let _ = child.wait();
            }
            return Err(format!(
                "stopped after the study's timeout of {} s{}",
                study.spec.timeout.unwrap_or(0.0),
                tail_suffix(&err_log)
            ));
        }
        std::thread::sleep(Duration::from_millis(50));
    };
    if status.success() {
        return Ok(());
    }
    // The study's stop reached a run that had already finished: it wrote its converged summary
    // (the last file it writes) and was tearing down (mpirun exits non-zero on the signal then).
    if stopping.is_some() && converged_since(dir, started) {
        return Ok(());
    }
    Err(format!(
        "{}{}",
        read_summary(dir)
            .and_then(|s| failure_of(&s))
            .unwrap_or_else(|| format!("exited with {status}")),
        tail_suffix(&err_log)
    ))
}

/// The arguments of `nurbs-contact` for one run, after the program: `run CASE --out DIR -q --set ...`
/// and the study command's PETSc options. The local launcher starts the program with them (under
/// `mpirun` for more than one rank), the Slurm job script under `srun`.
pub fn run_args(study: &Study, run: &RunSpec, dir: &Path, launch: &Launch<'_>) -> Vec<OsString> {
    let mut a: Vec<OsString> = vec![
        "run".into(),
        study.case.clone().into(),
        "--out".into(),
        dir.into(),
        "-q".into(),
    ];
    for s in &run.sets {
        a.push("--set".into());
        a.push(s.into());
    }
    a.extend(launch.petsc_args.iter().map(OsString::from));
    a
}

/// Why a run whose summary says so did not converge.
fn failure_of(s: &Summary) -> Option<String> {
    match &s.status {
        RunStatus::Failed { reason } => Some(reason.clone()),
        RunStatus::Interrupted {
            signal,
            converged_steps,
        } => Some(format!(
            "interrupted by {signal} after {converged_steps} converged steps"
        )),
        RunStatus::Converged => None,
    }
}

/// Where `--collect` stands on a run without a result: what the scheduler says of it.
#[derive(Debug, Clone)]
pub enum Queue {
    /// Listed by the scheduler: `state` (`pending (Resources)`, `running`, ...) of task `task` (`123_4`).
    Listed { task: String, state: String },
    /// Submitted as task `task`, no longer listed: it ended; `log` is the scheduler's output of it.
    Ended { task: String, log: PathBuf },
    /// In no recorded submission.
    NotSubmitted,
    /// The scheduler could not be asked: why.
    Unknown(String),
}

/// `--collect`'s view of one run, from its folder alone: converged (with the same resolved case),
/// failed (its summary says why, or its Slurm task ended without one), or missing (queued,
/// running, never submitted). `submitted`: the run is in a recorded submission (else `skipped`).
/// Also returns whether the run left any result (a summary, or an ended task).
pub fn collect_one(
    study: &Study,
    run: &RunSpec,
    out: &Path,
    queue: &Queue,
    submitted: bool,
) -> (Outcome, bool) {
    let dir = out.join(&run.name);
    let (_, err_log) = log_paths(out, run);
    let outcome = |status: Status| Outcome {
        status,
        skipped: !submitted,
        summary: read_summary(&dir),
        history: read_history(&dir),
        dir: dir.clone(),
    };
    let case_toml = match resolved_case(study, run) {
        Ok(t) => t,
        Err(e) => return (outcome(Status::Failed(format!("case: {e}"))), false),
    };
    if finished_earlier(&dir, &case_toml).is_some() {
        return (outcome(Status::Converged), true);
    }
    let failure = summary_of_case(&dir, &case_toml).and_then(|s| failure_of(&s));
    match (queue, failure) {
        // listed first: a failed run submitted again is waiting for its second chance
        (Queue::Listed { task, state }, _) => (
            outcome(Status::Missing(format!("{state} in Slurm job {task}"))),
            false,
        ),
        (_, Some(reason)) => (
            outcome(Status::Failed(format!("{reason}{}", tail_suffix(&err_log)))),
            true,
        ),
        (Queue::Ended { task, log }, None) => (
            outcome(Status::Failed(format!(
                "Slurm task {task} ended without a summary.json of this case (stopped at its time \
                 or memory limit, cancelled, or the program did not start){}{}",
                tail_suffix(&err_log),
                tail(log, "slurm")
            ))),
            true,
        ),
        (Queue::NotSubmitted, None) => (
            outcome(Status::Missing(
                "no result, and no recorded Slurm submission holds this run".into(),
            )),
            false,
        ),
        (Queue::Unknown(why), None) => (
            outcome(Status::Missing(format!(
                "no result yet; whether it is still queued is unknown ({why})"
            ))),
            false,
        ),
    }
}

/// `"; stderr: <last lines>"` of a log, or nothing when it is empty.
fn tail_suffix(log: &Path) -> String {
    tail(log, "stderr")
}

/// `"; <label>: <last lines>"` of a log, or nothing when it is empty or missing.
fn tail(log: &Path, label: &str) -> String {
    let text = std::fs::read_to_string(log).unwrap_or_default();
    let lines: Vec<&str> = text.lines().filter(|l| !l.trim().is_empty()).collect();
    if lines.is_empty() {
        return String::new();
    }
    let tail = lines[lines.len().saturating_sub(4)..].join(" | ");
    let tail = if tail.chars().count() > 600 {
        let skip = tail.chars().count() - 600;
        format!("...{}", tail.chars().skip(skip).collect::<String>())
    } else {
        tail
    };
    format!("; {label}: {tail}")
}
