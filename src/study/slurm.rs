//! `nurbs-contact study FILE --launcher slurm`: the study's runs as one Slurm job array, one array
//! task per run, each task running under `srun` exactly the `nurbs-contact run` command the local
//! launcher starts, into the same run folder and logs; `--collect` later builds the study's outputs
//! from the folders (see [`crate::study::exec::collect_one`]).
//!
//! - [`SlurmSpec`]: the study file's optional `[slurm]` table;
//! - [`resources`]: time and memory per task, from the table or from the case's size estimate
//!   ([`crate::scene::size::CaseSize`], the one `check` refuses too-large cases with);
//! - [`script`]: the `sbatch` script; [`submit`]: `sbatch --parsable`;
//! - [`Submissions`]: `OUT/slurm-jobs.json`, which job holds which run, and [`queue`]: which of those
//!   tasks `squeue` still lists, so that `--collect` can tell a queued run from a lost one.
//!
//! Ranks are launched with `srun --mpi=pmix`: Debian 12's Open MPI 4.1 talks PMIx to Slurm's
//! `mpi_pmix` plugin; with `--mpi=pmi2` or `none` its `MPI_Init` aborts (it has no PMI-1/2 client),
//! also for one rank (it sees the Slurm environment and looks for a PMI server).

use crate::scene::schema::Case;
use crate::scene::size::CaseSize;
use crate::study::spec::Study;
use crate::study::StudyError;
use serde::{Deserialize, Serialize};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

/// `[slurm]`: what the generated job script asks Slurm for. Every key is optional.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SlurmSpec {
    /// Time limit of each array task, in Slurm's format (`"90"` minutes, `"02:00:00"`,
    /// `"1-12:00:00"`). Default: the study's `timeout` plus one minute, else the estimate.
    #[serde(default)]
    pub time: Option<String>,
    /// Memory of each rank (`--mem-per-cpu`), a number with an optional unit `K`, `M` (default), `G`
    /// or `T`: `"2G"`. Default: the estimate.
    #[serde(default)]
    pub mem_per_rank: Option<String>,
    /// `--partition`.
    #[serde(default)]
    pub partition: Option<String>,
    /// `--account`.
    #[serde(default)]
    pub account: Option<String>,
    /// Array tasks running at once (`--array=...%N`). Default: as many as Slurm allows.
    #[serde(default)]
    pub max_running: Option<usize>,
    /// Seconds before the time limit at which each run gets one SIGTERM (`--signal=TERM@N`), so
    /// that it stops at its next Newton (iterative route: Krylov) iteration and writes `summary.json`
    /// as interrupted. Default: a tenth of
    /// the time limit, within 60..600 s (Slurm sends it up to 60 s early).
    #[serde(default)]
    pub stop_before: Option<u64>,
    /// srun's `--mpi` plugin. Default `pmix` (what Debian's Open MPI needs; see the module doc).
    #[serde(default)]
    pub mpi: Option<String>,
    /// Further `sbatch` options, one per `#SBATCH` line: `["--qos=short", "--constraint=avx2"]`.
    #[serde(default)]
    pub sbatch: Vec<String>,
}

impl SlurmSpec {
    /// Checks the values; `Err((key, message))` with the key below `slurm.`.
    pub fn validate(&self) -> Result<(), (String, String)> {
        let bad = |k: &str, m: String| Err((format!("slurm.{k}"), m));
        if let Some(t) = &self.time {
            if time_minutes(t).is_none() {
                return bad(
                    "time",
                    format!(
                        "`{t}` is not a Slurm time limit: minutes, MM:SS, HH:MM:SS, D-HH, D-HH:MM \
                         or D-HH:MM:SS, above zero"
                    ),
                );
            }
        }
        if let Some(m) = &self.mem_per_rank {
            if mem_mib(m).is_none() {
                return bad(
                    "mem_per_rank",
                    format!(
                        "`{m}` is not a memory size: a whole number above zero with an optional \
                         unit K, M, G or T (`2G`, `500M`)"
                    ),
                );
            }
        }
        for (k, v) in [
            ("partition", &self.partition),
            ("account", &self.account),
            ("mpi", &self.mpi),
        ] {
            if let Some(v) = v {
                if v.is_empty() || !v.chars().all(|c| c.is_ascii_graphic() && c != '\'') {
                    return bad(
                        k,
                        format!("`{v}`: a name without spaces, quotes or control characters"),
                    );
                }
            }
        }
        if self.max_running == Some(0) {
            return bad("max_running", "must be at least 1".into());
        }
        if self.stop_before == Some(0) {
            return bad("stop_before", "must be at least 1 (seconds)".into());
        }
        for (i, line) in self.sbatch.iter().enumerate() {
            if !line.starts_with('-') || line.chars().any(char::is_control) {
                return bad(
                    &format!("sbatch.{i}"),
                    format!(
                        "`{line}`: one sbatch option per entry, starting with `-` (`--qos=short`)"
                    ),
                );
            }
            let opt = line.split(['=', ' ']).next().unwrap_or("");
            if matches!(
                opt,
                "--array" | "-a" | "--ntasks" | "-n" | "--output" | "-o" | "--error" | "-e"
            ) {
                return bad(
                    &format!("sbatch.{i}"),
                    format!(
                        "`{opt}` is set by the study itself (one array task per run, `ranks` tasks \
                         each, logs in OUT/logs)"
                    ),
                );
            }
        }
        Ok(())
    }
}

/// Minutes of a Slurm time limit (`M`, `M:S`, `H:M:S`, `D-H`, `D-H:M`, `D-H:M:S`), if it is one and
/// above zero.
pub fn time_minutes(t: &str) -> Option<f64> {
    let num = |s: &str| -> Option<f64> {
        (!s.is_empty() && s.len() <= 9 && s.chars().all(|c| c.is_ascii_digit()))
            .then(|| s.parse::<f64>().ok())
            .flatten()
    };
    let (days, rest) = match t.split_once('-') {
        Some((d, r)) => (Some(num(d)?), r),
        None => (None, t),
    };
    let parts: Vec<f64> = rest.split(':').map(num).collect::<Option<_>>()?;
    let minutes = match (days, parts.as_slice()) {
        (None, [m]) => *m,
        (None, [m, s]) => m + s / 60.0,
        (None, [h, m, s]) => 60.0 * h + m + s / 60.0,
        (Some(d), [h]) => 1440.0 * d + 60.0 * h,
        (Some(d), [h, m]) => 1440.0 * d + 60.0 * h + m,
        (Some(d), [h, m, s]) => 1440.0 * d + 60.0 * h + m + s / 60.0,
        _ => return None,
    };
    (minutes > 0.0).then_some(minutes)
}

/// MiB of a Slurm memory size (`500`, `500M`, `2G`, `1T`, `800000K`), if it is one and above zero.
pub fn mem_mib(m: &str) -> Option<f64> {
    let (digits, unit) = match m.find(|c: char| !c.is_ascii_digit()) {
        Some(i) => m.split_at(i),
        None => (m, ""),
    };
    if digits.is_empty() || digits.len() > 12 {
        return None;
    }
    let n: f64 = digits.parse().ok()?;
    let f = match unit {
        "" | "M" | "m" => 1.0,
        "K" | "k" => 1.0 / 1024.0,
        "G" | "g" => 1024.0,
        "T" | "t" => 1024.0 * 1024.0,
        _ => return None,
    };
    (n > 0.0).then_some(n * f)
}

/// What each array task asks for, and where the numbers came from (a comment in the script).
#[derive(Debug, Clone, PartialEq)]
pub struct Resources {
    /// `--time`, Slurm's format.
    pub time: String,
    /// `--mem-per-cpu` (one CPU per rank).
    pub mem_per_rank: String,
    /// Seconds before the limit at which the runs get SIGTERM (`--signal=TERM@N`).
    pub stop_before: u64,
    /// One line per choice: given, from the timeout, or the estimate and its inputs.
    pub basis: Vec<String>,
}

/// Fixed memory of one rank (program, MPI, PETSc, HDF5, and what the estimate's terms miss on
/// small cases), MiB. Measured: 60-83 MB peak for the smallest cases (`summary.json`
/// `peak_memory_mb`); 384 so that the 3D contact scene at 1.2e4 unknowns is covered (below).
const BASE_MIB: f64 = 384.0;
/// Peak memory above [`BASE_MIB`] over `check`'s estimate (mesh arrays + matrix + the linear
/// solver of the route that runs, [`CaseSize`]), measured on the 3D contact scene
/// (`cases/hemisphere_twist_scale_3d.toml`, 1 rank, docs/performance/scale.md):
/// 1.9 (1.2e4 unknowns, MUMPS), 1.3 (1.2e4, GMRES + GAMG), 2.1 (1.0e5, MUMPS), 1.0 (1.0e5,
/// GMRES + GAMG), 1.0 (1.0e6, GMRES + GAMG); the largest with a fifth added. The request is then
/// 1.1 to 2.4 times these peaks. The test `the_memory_request_covers_the_scale_scenes_
/// measured_peaks` holds the measurements.
const MEM_FACTOR: f64 = 2.5;
/// Newton iterations per load step assumed (measured: 3-6 on the shipped cases), for cutbacks.
const ITERATIONS_PER_STEP: f64 = 10.0;
/// Time limit over the time estimate.
const TIME_FACTOR: f64 = 3.0;
/// Shortest estimated time limit, minutes: start-up and output for small runs.
const MIN_MINUTES: f64 = 15.0;

/// Seconds of one Newton iteration (assembly, contact, MUMPS factorisation) on one rank, fitted to
/// runs on this project's 2-core test machine (shared, so on the slow side): 2D Hertz contact
/// 0.115 s at 1.26e4 and 0.57 s at 4.97e4 unknowns; 3D block 1.4 s at 1.47e4 and 11 s at 4.69e4
/// unknowns. Against the paper's studies (docs/verification/paper.md) the resulting estimate
/// is high: ironing mesh 16 (1.2e4 unknowns, 660 steps) 766 s estimated, 100-111 s measured;
/// twisting mesh 8 on 2 ranks 98 s estimated, 48 s measured.
///
/// On the iterative route in 3D (GMRES + GAMG), the 3D contact scene on 1 rank: 1.05 s at 1.2e4
/// and 49.4 s at 1.01e6 unknowns (docs/performance/scale.md, the 10^6 size's one command), the
/// fit through them rounded up to the exponent 0.9 (the Krylov iterations per Newton iteration
/// grow from 35 to 128; at `check`'s unknown counts, which are 2 % low); it gives 7.4 s at 1.03e5,
/// where 6.05 s was measured.
fn seconds_per_iteration(dim: usize, unknowns: f64, iterative: bool) -> f64 {
    match (dim, iterative) {
        (3, true) => 1.05 * (unknowns / 1.18e4).powf(0.9),
        (3, false) => 11.0 * (unknowns / 4.69e4).powf(1.8),
        _ => 0.57 * (unknowns / 4.97e4).powf(1.15),
    }
}

/// Estimated wall time of a run, seconds: `ITERATIONS_PER_STEP` iterations per load step, each
/// [`seconds_per_iteration`] (of the route that runs) divided by `sqrt(ranks)` (the measured
/// speed-up of 2 ranks is 1.5x).
pub fn estimated_seconds(size: &CaseSize, steps: usize, ranks: usize) -> f64 {
    let per_it = seconds_per_iteration(size.total.dim, size.total.unknowns(), size.iterative);
    steps as f64 * ITERATIONS_PER_STEP * per_it / (ranks as f64).sqrt()
}

/// Estimated peak memory of one rank, MiB: the mesh arrays (every rank holds them) and its share of
/// the matrix and of the linear solver (MUMPS's factors, or the Krylov vectors and AMG
/// hierarchy), times [`MEM_FACTOR`], plus [`BASE_MIB`].
pub fn estimated_mib(size: &CaseSize, ranks: usize) -> f64 {
    let bytes = size.mesh_bytes + (size.matrix_bytes + size.linear_bytes) / ranks as f64;
    BASE_MIB + MEM_FACTOR * bytes / (1024.0 * 1024.0)
}

/// `H:MM:SS`-style limit of `minutes` (whole minutes), with days when needed.
fn format_minutes(minutes: f64) -> String {
    let m = minutes.ceil().max(1.0) as u64;
    let (d, h, mm) = (m / 1440, (m % 1440) / 60, m % 60);
    if d > 0 {
        format!("{d}-{h:02}:{mm:02}:00")
    } else {
        format!("{h:02}:{mm:02}:00")
    }
}

/// Time and memory of each task: `[slurm]`'s values where given; else the time from the study's
/// `timeout` (plus a minute, so that the run's own limit is what stops it), and otherwise both from
/// the size estimate of the largest run (all tasks of an array ask for the same). `cases` are the
/// resolved cases of the runs to submit, by run name.
pub fn resources(study: &Study, cases: &[(&str, &Case)]) -> Resources {
    let spec = study.spec.slurm.clone().unwrap_or_default();
    let ranks = study.spec.ranks;
    let mut basis = Vec::new();
    // the largest estimate over the runs
    let mut est: Option<(f64, f64, String)> = None;
    for (name, case) in cases {
        let Some(size) = CaseSize::of(case) else {
            continue;
        };
        let steps: usize = case.stages.iter().map(|s| s.steps).sum();
        let (t, m) = (
            estimated_seconds(&size, steps, ranks),
            estimated_mib(&size, ranks),
        );
        let e = est.get_or_insert((0.0, 0.0, String::new()));
        if t > e.0 || m > e.1 {
            e.2 = format!(
                "largest run {name}: {:.3e} unknowns ({}D), {steps} load steps",
                size.total.unknowns(),
                size.total.dim
            );
        }
        e.0 = e.0.max(t);
        e.1 = e.1.max(m);
    }
    let all_sized = cases.iter().all(|(_, c)| CaseSize::of(c).is_some());
    if let Some((_, _, what)) = &est {
        basis.push(format!("size estimate: {what}"));
    }
    let time = match (&spec.time, study.spec.timeout, &est) {
        (Some(t), _, _) => {
            basis.push("time: [slurm] time".into());
            t.clone()
        }
        (None, Some(s), _) => {
            basis.push(format!("time: the study's timeout of {s} s, plus a minute"));
            format_minutes(s / 60.0 + 1.0)
        }
        (None, None, Some((secs, _, _))) if all_sized => {
            let minutes = (TIME_FACTOR * secs / 60.0).max(MIN_MINUTES);
            // whole 5 minutes
            let minutes = (minutes / 5.0).ceil() * 5.0;
            basis.push(format!(
                "time: {TIME_FACTOR} x the estimated {secs:.1} s ({ITERATIONS_PER_STEP} Newton \
                 iterations per load step), at least {MIN_MINUTES} min"
            ));
            format_minutes(minutes)
        }
        (None, None, _) => {
            basis.push(
                "time: 1 hour, a default (a mesh read from a file has no size estimate; set [slurm] time)"
                    .into(),
            );
            "01:00:00".into()
        }
    };
    let mem_per_rank = match (&spec.mem_per_rank, &est) {
        (Some(m), _) => {
            basis.push("memory: [slurm] mem_per_rank".into());
            m.clone()
        }
        (None, Some((_, mib, _))) if all_sized => {
            let mib = (mib / 64.0).ceil() * 64.0;
            basis.push(format!(
                "memory per rank: {BASE_MIB} MiB + {MEM_FACTOR} x (mesh arrays + (matrix + linear \
                 solver) / ranks)"
            ));
            format!("{mib:.0}M")
        }
        (None, _) => {
            basis.push(
                "memory: 2 GiB per rank, a default (a mesh read from a file has no size estimate; \
                 set [slurm] mem_per_rank)"
                    .into(),
            );
            "2G".into()
        }
    };
    let stop_before = spec.stop_before.unwrap_or_else(|| {
        let limit = time_minutes(&time).unwrap_or(60.0) * 60.0;
        (limit / 10.0).clamp(60.0, 600.0) as u64
    });
    Resources {
        time,
        mem_per_rank,
        stop_before,
        basis,
    }
}

/// `s` as one shell word: single-quoted unless it is plainly safe.
pub fn shell_quote(s: &str) -> String {
    if !s.is_empty()
        && s.chars()
            .all(|c| c.is_ascii_alphanumeric() || "-_./=:,+@%".contains(c))
    {
        s.to_string()
    } else {
        format!("'{}'", s.replace('\'', "'\\''"))
    }
}

/// One array task of the script: the run it executes and how.
#[derive(Debug, Clone)]
pub struct Task {
    /// Array index: the run's position in the study.
    pub index: usize,
    pub run: String,
    /// `nurbs-contact run ...` as the local launcher gives it (program first), absolute paths.
    pub command: Vec<String>,
    pub out_log: PathBuf,
    pub err_log: PathBuf,
}

/// The sbatch script: one array task per entry of `tasks`, each `srun --mpi=pmix --ntasks=ranks`
/// followed by its command, with the command's output in the run's logs (as the local launcher
/// writes them); Slurm's own output of each task in `OUT/logs/slurm-<job>_<task>.out`.
pub fn script(study: &Study, out: &Path, tasks: &[Task], res: &Resources) -> String {
    let spec = study.spec.slurm.clone().unwrap_or_default();
    let ranks = study.spec.ranks;
    let q = |p: &Path| shell_quote(&p.to_string_lossy());
    let indices: Vec<String> = tasks.iter().map(|t| t.index.to_string()).collect();
    let mut s = String::from("#!/bin/bash\n");
    s += &format!(
        "# nurbs-contact study {}: {} of its {} runs as a Slurm job array, one task per run.\n\
         # Written by `nurbs-contact study --launcher slurm`; collect the results with\n\
         # `nurbs-contact study {} --out {} --collect`.\n",
        study.file.display(),
        tasks.len(),
        study.runs.len(),
        study.file.display(),
        out.display()
    );
    for b in &res.basis {
        s += &format!("# {b}\n");
    }
    s += &format!("#SBATCH --job-name={}\n", shell_quote(&study.name));
    s += &format!(
        "#SBATCH --array={}{}\n",
        indices.join(","),
        spec.max_running.map_or(String::new(), |n| format!("%{n}"))
    );
    s += &format!("#SBATCH --ntasks={ranks}\n#SBATCH --cpus-per-task=1\n");
    s += &format!("#SBATCH --time={}\n", res.time);
    s += &format!("#SBATCH --mem-per-cpu={}\n", res.mem_per_rank);
    // One SIGTERM to the runs before the limit: each stops at its next Newton iteration and writes its summary.
    // At the limit itself the run would get two (Slurm's, and srun's when Slurm signals srun) and
    // the second one ends it at once, without a summary.
    s += &format!("#SBATCH --signal=TERM@{}\n", res.stop_before);
    s += &format!(
        "#SBATCH --output={}\n",
        q(&out.join("logs").join("slurm-%A_%a.out"))
    );
    if let Some(p) = &spec.partition {
        s += &format!("#SBATCH --partition={p}\n");
    }
    if let Some(a) = &spec.account {
        s += &format!("#SBATCH --account={a}\n");
    }
    for line in &spec.sbatch {
        s += &format!("#SBATCH {line}\n");
    }
    let mpi = spec.mpi.as_deref().unwrap_or("pmix");
    s += "\nset -euo pipefail\n\
          # Open MPI refuses to run as root unless told that this is intended (as the local launcher does)\n\
          if [ \"$(id -u)\" -eq 0 ]; then\n  \
          export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1\nfi\n\
          case \"$SLURM_ARRAY_TASK_ID\" in\n";
    for t in tasks {
        let cmd: Vec<String> = t.command.iter().map(|a| shell_quote(a)).collect();
        s += &format!(
            "  {}) # {}\n    exec srun --mpi={mpi} --ntasks={ranks} {} \\\n      >{} 2>{} ;;\n",
            t.index,
            t.run,
            cmd.join(" "),
            q(&t.out_log),
            q(&t.err_log)
        );
    }
    s += "  *) echo \"array task $SLURM_ARRAY_TASK_ID is no run of this study\" >&2; exit 1 ;;\nesac\n";
    s
}

/// Submits `script` with `sbatch --parsable`; the job id.
pub fn submit(script: &Path) -> Result<String, StudyError> {
    let out = Command::new("sbatch")
        .arg("--parsable")
        .arg(script)
        .stdin(Stdio::null())
        .output()
        .map_err(|e| StudyError::Slurm {
            message: if e.kind() == std::io::ErrorKind::NotFound {
                format!(
                    "sbatch not found on PATH: submit from a Slurm login node, or write the \
                     script only with --dry-run ({})",
                    script.display()
                )
            } else {
                format!("cannot start sbatch: {e}")
            },
        })?;
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    let lines = |t: &str| -> String {
        t.lines()
            .map(str::trim)
            .filter(|l| !l.is_empty())
            .collect::<Vec<_>>()
            .join(" | ")
    };
    if !out.status.success() {
        return Err(StudyError::Slurm {
            message: format!(
                "sbatch refused the job ({}): {}; the script is {}",
                out.status,
                lines(&stderr),
                script.display()
            ),
        });
    }
    // `--parsable`: `jobid` or `jobid;cluster`
    let id = stdout.trim().split(';').next().unwrap_or("").to_string();
    if id.is_empty() || !id.chars().all(|c| c.is_ascii_digit()) {
        return Err(StudyError::Slurm {
            message: format!(
                "sbatch printed no job id (stdout `{}`, stderr `{}`)",
                lines(&stdout),
                lines(&stderr)
            ),
        });
    }
    Ok(id)
}

/// `OUT/slurm-jobs.json`: every submission of the study, so that `--collect` knows which job ran
/// (or will run) which run.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct Submissions {
    pub jobs: Vec<Submission>,
}

/// One `sbatch` of the study.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Submission {
    pub job_id: String,
    /// Seconds since the Unix epoch.
    pub submitted: u64,
    pub script: PathBuf,
    /// Array task index -> run name.
    pub tasks: Vec<(usize, String)>,
}

impl Submissions {
    pub fn path(out: &Path) -> PathBuf {
        out.join("slurm-jobs.json")
    }

    /// The recorded submissions (none when there is no file).
    pub fn load(out: &Path) -> Result<Submissions, StudyError> {
        let path = Self::path(out);
        match std::fs::read_to_string(&path) {
            Ok(text) => serde_json::from_str(&text).map_err(|e| StudyError::Io {
                path,
                op: "read the record of Slurm submissions",
                source: std::io::Error::other(e),
            }),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(Submissions::default()),
            Err(source) => Err(StudyError::Io {
                path,
                op: "read the record of Slurm submissions",
                source,
            }),
        }
    }

    pub fn save(&self, out: &Path) -> Result<(), StudyError> {
        let text = serde_json::to_string_pretty(self).map_err(|e| StudyError::Io {
            path: Self::path(out),
            op: "write the record of Slurm submissions",
            source: std::io::Error::other(e),
        })?;
        crate::io::write_atomic(&Self::path(out), text.as_bytes())?;
        Ok(())
    }

    /// The latest submission that holds `run`: (job id, array index).
    pub fn latest_for(&self, run: &str) -> Option<(&str, usize)> {
        self.jobs.iter().rev().find_map(|j| {
            j.tasks
                .iter()
                .find(|(_, r)| r == run)
                .map(|(i, _)| (j.job_id.as_str(), *i))
        })
    }
}

/// What `squeue` says of the tasks of our jobs: (job id, array index) -> state (`pending`,
/// `running`, `completing`, ...) with the reason when there is one (`pending (Resources)`). `Err`
/// when squeue cannot be asked (not installed, no controller).
pub fn queue(subs: &Submissions) -> Result<HashMap<(String, usize), String>, String> {
    let mut states = HashMap::new();
    if subs.jobs.is_empty() {
        return Ok(states);
    }
    // all of this user's jobs, filtered here: `--jobs` fails on ids that Slurm has forgotten
    let out = Command::new("squeue")
        .args(["--noheader", "--array", "--me", "--format=%F|%K|%T|%r"])
        .stdin(Stdio::null())
        .output()
        .map_err(|e| format!("cannot run squeue: {e}"))?;
    if !out.status.success() {
        return Err(format!(
            "squeue failed ({}): {}",
            out.status,
            String::from_utf8_lossy(&out.stderr).trim()
        ));
    }
    let ours: Vec<&str> = subs.jobs.iter().map(|j| j.job_id.as_str()).collect();
    for line in String::from_utf8_lossy(&out.stdout).lines() {
        let f: Vec<&str> = line.trim().splitn(4, '|').collect();
        if let [job, task, state, reason] = f.as_slice() {
            if let (true, Ok(i)) = (ours.contains(job), task.parse::<usize>()) {
                let state = state.to_lowercase();
                let state = match reason.trim() {
                    "" | "None" => state,
                    r => format!("{state} ({r})"),
                };
                states.insert((job.to_string(), i), state);
            }
        }
    }
    Ok(states)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slurm_time_formats_are_read_as_slurm_reads_them() {
        assert_eq!(time_minutes("90"), Some(90.0));
        assert_eq!(time_minutes("10:30"), Some(10.5));
        assert_eq!(time_minutes("02:00:00"), Some(120.0));
        assert_eq!(time_minutes("1-12"), Some(2160.0));
        assert_eq!(time_minutes("1-00:30"), Some(1470.0));
        assert_eq!(time_minutes("2-01:00:00"), Some(2940.0));
        for bad in [
            "", "0", "1h", "1:2:3:4", "-5", "1-", "a-1", "00:00:00", "1.5",
        ] {
            assert_eq!(time_minutes(bad), None, "{bad}");
        }
        assert_eq!(format_minutes(15.0), "00:15:00");
        assert_eq!(format_minutes(61.2), "01:02:00");
        assert_eq!(format_minutes(1500.0), "1-01:00:00");
        assert_eq!(time_minutes(&format_minutes(1500.0)), Some(1500.0));
    }

    #[test]
    fn memory_sizes_are_read_in_mib() {
        assert_eq!(mem_mib("500"), Some(500.0));
        assert_eq!(mem_mib("2G"), Some(2048.0));
        assert_eq!(mem_mib("1024K"), Some(1.0));
        assert_eq!(mem_mib("1T"), Some(1048576.0));
        for bad in ["", "0", "2GB", "G", "-1", "1.5G", "2 G"] {
            assert_eq!(mem_mib(bad), None, "{bad}");
        }
    }

    #[test]
    fn shell_words_survive_quoting() {
        assert_eq!(shell_quote("meshes.a.n=16"), "meshes.a.n=16");
        assert_eq!(
            shell_quote("bodies.disk.element=\"Q1C1\""),
            "'bodies.disk.element=\"Q1C1\"'"
        );
        assert_eq!(shell_quote("it's"), "'it'\\''s'");
        assert_eq!(shell_quote(""), "''");
        // what bash makes of them
        let words = ["a b", "x=\"y\"", "it's", "[1, 2]", "$HOME", ""];
        let line: Vec<String> = words.iter().map(|w| shell_quote(w)).collect();
        let out = Command::new("bash")
            .arg("-c")
            .arg(format!("printf '%s\\n' {}", line.join(" ")))
            .output()
            .expect("bash");
        let got: Vec<String> = String::from_utf8_lossy(&out.stdout)
            .lines()
            .map(String::from)
            .collect();
        assert_eq!(got, words);
    }

    fn study(case: &str, extra: &str) -> (Study, Vec<Case>) {
        let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("cases/test.toml");
        let text = format!(
            "case = \"{case}\"\nranks = 2\n{extra}\n[[axes]]\nname = \"s\"\nkeys = [\"stages.0.steps\"]\nvalues = [4, 40]\n"
        );
        let s = Study::parse(&text, &file).expect("study");
        let cases = s
            .runs
            .iter()
            .map(|r| crate::scene::load_case(&s.case, &r.sets).expect("case"))
            .collect();
        (s, cases)
    }

    /// The 3D contact scene's measured peaks (`/usr/bin/time -f %M`, 1 rank, MiB) and seconds per
    /// Newton iteration (docs/performance/scale.md; e5 iterative 1,499,880 KB and e6's one command
    /// 11,543,808 KB) lie under the Slurm request and the time estimate, and within 2.5x and 3x
    /// of them: a request below the peak has Slurm kill the run, one far above it waits for nodes
    /// it does not need.
    #[test]
    fn the_memory_request_covers_the_scale_scenes_measured_peaks() {
        let case =
            Path::new(env!("CARGO_MANIFEST_DIR")).join("cases/hemisphere_twist_scale_3d.toml");
        let e5 = [
            "meshes.cube.divisions=[30,30,30]",
            "meshes.shell.n_surface=30",
            "meshes.shell.n_thickness=4",
        ];
        let e6 = [
            "meshes.cube.divisions=[66,66,66]",
            "meshes.shell.n_surface=64",
            "meshes.shell.n_thickness=8",
        ];
        let measured: [(&[&str], &str, f64, f64); 5] = [
            (&[], "direct", 665.0, 0.88),
            (&[], "iterative", 539.0, 1.05),
            (&e5, "direct", 4900.0, 40.2),
            (&e5, "iterative", 1_499_880.0 / 1024.0, 6.05),
            (&e6, "iterative", 11_543_808.0 / 1024.0, 49.4),
        ];
        for (sets, route, peak_mib, s_per_it) in measured {
            let mut sets: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
            sets.push(format!("solver.linear=\"{route}\""));
            let c = crate::scene::load_case(&case, &sets).expect("case");
            let size = CaseSize::of(&c).expect("generated meshes");
            assert_eq!(size.iterative, route == "iterative");
            let what = format!("{:.3e} unknowns, {route}", size.total.unknowns());
            let mib = estimated_mib(&size, 1);
            assert!(
                mib >= peak_mib && mib <= 2.5 * peak_mib,
                "{what}: request {mib:.0} MiB, measured peak {peak_mib:.0} MiB"
            );
            let t = seconds_per_iteration(3, size.total.unknowns(), size.iterative);
            assert!(
                t >= s_per_it && t <= 3.0 * s_per_it,
                "{what}: estimate {t:.2} s per Newton iteration, measured {s_per_it} s"
            );
        }
    }

    #[test]
    fn resources_come_from_the_table_the_timeout_or_the_largest_runs_estimate() {
        let named = |s: &Study, c: &[Case]| -> Resources {
            let v: Vec<(&str, &Case)> = s
                .runs
                .iter()
                .zip(c)
                .map(|(r, c)| (r.name.as_str(), c))
                .collect();
            resources(s, &v)
        };
        let (s, cases) = study("block_compression_3d.toml", "");
        let size = CaseSize::of(&cases[1]).expect("generated mesh");
        let r = named(&s, &cases);
        // the run with 40 steps decides: 3 x its estimate, in whole 5 minutes, at least 15
        let secs = estimated_seconds(&size, 40, 2);
        let want = ((TIME_FACTOR * secs / 60.0).max(MIN_MINUTES) / 5.0).ceil() * 5.0;
        assert_eq!(r.time, format_minutes(want));
        assert!(r.basis[0].contains("largest run 40"), "{:?}", r.basis);
        let mib = estimated_mib(&size, 2);
        assert!(mib > BASE_MIB && mib < BASE_MIB + 64.0, "{mib}");
        assert_eq!(
            r.mem_per_rank,
            format!("{:.0}M", (mib / 64.0).ceil() * 64.0)
        );
        // a finer mesh needs more of both
        let big =
            crate::scene::load_case(&s.case, &["meshes.block.divisions=[30,30,30]".to_string()])
                .expect("case");
        let big_size = CaseSize::of(&big).expect("generated");
        assert!(estimated_mib(&big_size, 2) - BASE_MIB > 8.0 * (mib - BASE_MIB));
        assert!(estimated_seconds(&big_size, 40, 2) > 100.0 * secs);
        // the study's timeout sets the time; the table overrides both
        let (s, cases) = study("block_compression_3d.toml", "timeout = 600");
        assert_eq!(named(&s, &cases).time, "00:11:00");
        let (s, cases) = study(
            "block_compression_3d.toml",
            "timeout = 600\n[slurm]\ntime = \"2:00:00\"\nmem_per_rank = \"3G\"",
        );
        let r = named(&s, &cases);
        assert_eq!(
            (r.time.as_str(), r.mem_per_rank.as_str()),
            ("2:00:00", "3G")
        );
        // the SIGTERM before the limit: a tenth of it within 60..600 s
        assert_eq!(r.stop_before, 600);
        let (s, cases) = study("block_compression_3d.toml", "timeout = 600");
        assert_eq!(named(&s, &cases).stop_before, 66);
        // a mesh file has no estimate: stated defaults
        let (s, cases) = study("block_compression_gmsh_3d.toml", "");
        let r = named(&s, &cases);
        assert_eq!(
            (r.time.as_str(), r.mem_per_rank.as_str()),
            ("01:00:00", "2G")
        );
        assert!(r.basis.iter().any(|b| b.contains("no size estimate")));
    }

    #[test]
    fn bad_slurm_values_name_the_key() {
        let cases: &[(&str, &str)] = &[
            ("time = \"2h\"", "slurm.time"),
            ("mem_per_rank = \"2GB\"", "slurm.mem_per_rank"),
            ("partition = \"a b\"", "slurm.partition"),
            ("max_running = 0", "slurm.max_running"),
            ("stop_before = 0", "slurm.stop_before"),
            ("sbatch = [\"qos=x\"]", "slurm.sbatch.0"),
            ("sbatch = [\"--qos=x\", \"--array=1-3\"]", "slurm.sbatch.1"),
        ];
        for (text, key) in cases {
            let spec: SlurmSpec = toml::from_str(text).expect(text);
            let (k, m) = spec.validate().expect_err(text);
            assert_eq!(&k, key, "{text}: {m}");
        }
        let ok: SlurmSpec = toml::from_str(
            "time = \"1-00:00:00\"\nmem_per_rank = \"4G\"\npartition = \"compute\"\n\
             sbatch = [\"--qos=long\", \"--exclusive\"]",
        )
        .expect("parse");
        assert!(ok.validate().is_ok());
    }
}
