//! `nurbs-contact study --launcher slurm` and `--collect`: the generated job script, the errors
//! (sbatch missing, a bad `[slurm]` key, `--collect` before anything ran, misused options), and a
//! 2-run study end to end on a real single-node Slurm cluster that `ci/slurm-cluster.sh` starts
//! (munged + slurmctld + slurmd of Debian's slurm-wlm) and stops again, also when the test fails;
//! then a run stopped by its time limit.
//!
//! The end-to-end test needs the Slurm and munge daemons installed (`ci/slurm-cluster.sh install`).
//! Without them it fails when `NURBS_CONTACT_SLURM=require` (ci/test.sh sets it: CI expects Slurm)
//! and otherwise prints that it did not run and passes.

mod common;
use common::*;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::{Duration, Instant};

const LONG: Duration = Duration::from_secs(300);

/// `nurbs-contact study ARGS` with extra environment variables.
fn study_env(args: &[&str], env: &[(&str, &str)]) -> Output {
    let mut a = vec!["study"];
    a.extend_from_slice(args);
    run_with_env(1, &a, None, LONG, env).expect("nurbs-contact study did not finish")
}

fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// A 2-run study of the Hertz case (Q1C1 and Q1N2 on one coarse mesh, 2 load steps) on `ranks`
/// ranks, with `extra` appended (e.g. a `[slurm]` table).
fn write_study(dir: &Path, ranks: usize, extra: &str) -> PathBuf {
    let f = dir.join("study.toml");
    let text = format!(
        "case = \"{}\"\nranks = {ranks}\nset = [\"stages.0.steps=2\"]\n\
         [[axes]]\nname = \"family\"\nkeys = [\"bodies.disk.element\"]\nvalues = [\"Q1C1\", \"Q1N2\"]\n\
         [[axes]]\nname = \"mesh\"\nlevels = [ {{ name = \"m16\", value = 16, set = [\"meshes.disk.n_arc=16\", \"meshes.disk.n_radial=4\"] }} ]\n\
         [[metrics]]\nname = \"Pmax\"\nkind = \"max\"\ncolumn = \"P_flat_disk_arc_y\"\n{extra}",
        case("hertz_2d.toml").display()
    );
    std::fs::write(&f, text).expect("write study");
    f
}

/// The shell words of a script line, as bash splits them.
fn shell_words(line: &str) -> Vec<String> {
    let out = Command::new("bash")
        .arg("-c")
        .arg(format!("printf '%s\\n' {line}"))
        .output()
        .expect("bash");
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(String::from)
        .collect()
}

#[test]
fn dry_run_writes_one_srun_task_per_run_with_the_local_command() {
    let d = scratch("slurm-dry-run");
    let file = write_study(
        &d,
        2,
        "[slurm]\ntime = \"1-02:00:00\"\npartition = \"compute\"\naccount = \"proj42\"\n\
         max_running = 1\nsbatch = [\"--qos=short\", \"--constraint=avx2\"]\n",
    );
    let out = d.join("out");
    let o = study_env(
        &[
            file.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--launcher",
            "slurm",
            "--dry-run",
            "-snes_rtol",
            "1e-9",
        ],
        &[],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let path = out.join("study.sbatch");
    assert_eq!(stdout(&o).trim(), path.to_str().unwrap());
    let script = std::fs::read_to_string(&path).expect("script written");
    for line in [
        "#SBATCH --array=0,1%1",
        "#SBATCH --ntasks=2",
        "#SBATCH --cpus-per-task=1",
        "#SBATCH --time=1-02:00:00",
        "#SBATCH --signal=TERM@600",
        "#SBATCH --partition=compute",
        "#SBATCH --account=proj42",
        "#SBATCH --qos=short",
        "#SBATCH --constraint=avx2",
        "# time: [slurm] time",
    ] {
        assert!(
            script.lines().any(|l| l == line),
            "no `{line}` in\n{script}"
        );
    }
    // memory from the size estimate: 384 MiB + a little for 230 unknowns, in whole 64 MiB
    assert!(
        script.lines().any(|l| l == "#SBATCH --mem-per-cpu=448M"),
        "{script}"
    );
    assert!(
        script.contains(&format!(
            "#SBATCH --output={}",
            out.join("logs/slurm-%A_%a.out").display()
        )),
        "{script}"
    );
    let check = Command::new("bash").arg("-n").arg(&path).output().unwrap();
    assert!(check.status.success(), "bash -n: {}", stderr(&check));
    // each task: srun, then exactly the local launcher's `nurbs-contact run` (absolute paths), its
    // output in the run's logs
    for (i, fam) in ["Q1C1", "Q1N2"].iter().enumerate() {
        let run = format!("{fam}_m16");
        let start = script
            .find(&format!("  {i}) # {run}\n"))
            .unwrap_or_else(|| panic!("no task {i} in\n{script}"));
        let body = &script[start..];
        let cmd_line = body.lines().nth(1).unwrap().trim_end_matches(" \\").trim();
        let redirect = body.lines().nth(2).unwrap().trim();
        let words = shell_words(cmd_line);
        let dir = out.join(&run);
        let mut want: Vec<String> = [
            "exec",
            "srun",
            "--mpi=pmix",
            "--ntasks=2",
            bin(),
            "run",
            case("hertz_2d.toml").to_str().unwrap(),
            "--out",
            dir.to_str().unwrap(),
            "-q",
            "--set",
            "stages.0.steps=2",
            "--set",
        ]
        .iter()
        .map(|s| s.to_string())
        .collect();
        want.push(format!("bodies.disk.element=\"{fam}\""));
        for s in [
            "--set",
            "meshes.disk.n_arc=16",
            "--set",
            "meshes.disk.n_radial=4",
            "-snes_rtol",
            "1e-9",
        ] {
            want.push(s.into());
        }
        assert_eq!(words, want, "task {i}");
        assert_eq!(
            redirect,
            format!(
                ">{} 2>{} ;;",
                out.join(format!("logs/{run}.out")).display(),
                out.join(format!("logs/{run}.err")).display()
            )
        );
    }
    // nothing was submitted, so nothing is recorded
    assert!(!out.join("slurm-jobs.json").exists());
}

#[test]
fn slurm_errors_name_what_is_wrong() {
    let d = scratch("slurm-errors");
    let out = d.join("out");
    let out_s = out.to_str().unwrap();

    // an unknown key of [slurm]: named with the file
    let file = write_study(&d, 1, "[slurm]\ntme = \"10\"\n");
    let o = study_env(
        &[file.to_str().unwrap(), "--launcher", "slurm", "--dry-run"],
        &[],
    );
    let e = stderr(&o);
    assert!(!o.status.success(), "{e}");
    assert!(
        e.contains("unknown field `tme`") && e.contains("study.toml"),
        "{e}"
    );
    // a bad value: the key and the format
    let file = write_study(&d, 1, "[slurm]\nmem_per_rank = \"2 GB\"\n");
    let o = study_env(
        &[file.to_str().unwrap(), "--launcher", "slurm", "--dry-run"],
        &[],
    );
    let e = stderr(&o);
    assert!(
        !o.status.success() && e.contains("`slurm.mem_per_rank`") && e.contains("study.toml"),
        "{e}"
    );

    let file = write_study(&d, 1, "");
    let f = file.to_str().unwrap();
    // --collect before anything ran: no folder, then a folder without results
    let o = study_env(&[f, "--out", out_s, "--collect"], &[]);
    let e = stderr(&o);
    assert!(
        !o.status.success() && e.contains("nothing to collect") && e.contains("does not exist"),
        "{e}"
    );
    std::fs::create_dir_all(&out).unwrap();
    let o = study_env(&[f, "--out", out_s, "--collect"], &[]);
    let e = stderr(&o);
    assert!(
        !o.status.success()
            && e.contains("none of the 2 runs has a result yet")
            && e.contains("Q1C1_m16: no result, and no recorded Slurm submission"),
        "{e}"
    );
    assert!(!out.join("study.csv").exists());

    // sbatch not on PATH: an error naming it, the script written all the same
    let empty = d.join("empty-bin");
    std::fs::create_dir_all(&empty).unwrap();
    let o = study_env(
        &[f, "--out", out_s, "--launcher", "slurm"],
        &[("PATH", empty.to_str().unwrap())],
    );
    let e = stderr(&o);
    assert!(
        !o.status.success() && e.contains("sbatch not found on PATH") && e.contains("--dry-run"),
        "{e}"
    );
    assert!(out.join("study.sbatch").is_file());
    assert!(!out.join("slurm-jobs.json").exists());

    // options that do not go together
    let o = study_env(&[f, "--out", out_s, "--dry-run"], &[]);
    let e = stderr(&o);
    assert!(
        !o.status.success() && e.contains("--dry-run") && e.contains("--launcher slurm"),
        "{e}"
    );
    let o = study_env(
        &[f, "--out", out_s, "--launcher", "slurm", "--jobs", "2"],
        &[],
    );
    let e = stderr(&o);
    assert!(!o.status.success() && e.contains("max_running"), "{e}");
}

/// The test cluster: started by ci/slurm-cluster.sh, stopped when dropped (also on a failed assert).
struct Cluster {
    dir: PathBuf,
    conf: String,
}

impl Cluster {
    /// `None` (after saying why) when Slurm is not installed and not required here.
    fn start() -> Option<Cluster> {
        let required = std::env::var("NURBS_CONTACT_SLURM").is_ok_and(|v| v == "require");
        let missing: Vec<&str> = [
            "munged",
            "slurmctld",
            "slurmd",
            "sbatch",
            "squeue",
            "scontrol",
        ]
        .into_iter()
        .filter(|b| {
            !Command::new("sh")
                .arg("-c")
                .arg(format!("command -v {b}"))
                .output()
                .is_ok_and(|o| o.status.success())
        })
        .collect();
        if !missing.is_empty() {
            assert!(
                !required,
                "NURBS_CONTACT_SLURM=require but {} not found on PATH (ci/slurm-cluster.sh install)",
                missing.join(", ")
            );
            eprintln!(
                "NOT RUN: the Slurm end-to-end test needs {} (ci/slurm-cluster.sh install; \
                 NURBS_CONTACT_SLURM=require makes this a failure)",
                missing.join(", ")
            );
            return None;
        }
        // fixed folder, so that ci/test.sh can stop a cluster that a killed test left running
        let dir = root().join("target/slurm-cluster");
        let script = root().join("ci/slurm-cluster.sh");
        let cluster = Cluster {
            conf: dir.join("slurm.conf").to_string_lossy().into_owned(),
            dir,
        };
        let o = Command::new(&script)
            .arg("start")
            .arg(&cluster.dir)
            .output()
            .expect("run ci/slurm-cluster.sh");
        assert!(
            o.status.success(),
            "ci/slurm-cluster.sh start failed:\n{}\n{}",
            stdout(&o),
            stderr(&o)
        );
        Some(cluster)
    }

    fn env(&self) -> [(&str, &str); 1] {
        [("SLURM_CONF", self.conf.as_str())]
    }

    fn cmd(&self, program: &str, args: &[&str]) -> Output {
        let o = Command::new(program)
            .args(args)
            .env("SLURM_CONF", &self.conf)
            .output()
            .unwrap_or_else(|e| panic!("{program}: {e}"));
        assert!(o.status.success(), "{program} {args:?}: {}", stderr(&o));
        o
    }

    /// Whether squeue still lists array task `job_idx`.
    fn listed(&self, job: &str, idx: usize) -> bool {
        let o = self.cmd(
            "squeue",
            &["--noheader", "--array", "--me", "--format=%F_%K"],
        );
        stdout(&o)
            .lines()
            .any(|l| l.trim() == format!("{job}_{idx}"))
    }

    /// Releases a held array task and waits until it has left the queue.
    fn release_and_wait(&self, job: &str, idx: usize) {
        self.cmd("scontrol", &["release", &format!("{job}_{idx}")]);
        self.wait(job, idx);
    }

    fn wait(&self, job: &str, idx: usize) {
        let t0 = Instant::now();
        while self.listed(job, idx) {
            assert!(
                t0.elapsed() < Duration::from_secs(180),
                "task {job}_{idx} still queued after 180 s; logs in {}",
                self.dir.display()
            );
            std::thread::sleep(Duration::from_millis(200));
        }
    }
}

impl Drop for Cluster {
    fn drop(&mut self) {
        let _ = Command::new(root().join("ci/slurm-cluster.sh"))
            .arg("stop")
            .arg(&self.dir)
            .status();
    }
}

#[test]
fn a_study_runs_as_a_slurm_job_array_and_is_collected() {
    let Some(cluster) = Cluster::start() else {
        return;
    };
    let t0 = Instant::now();
    let env = cluster.env();
    let d = scratch("slurm-e2e");
    let out = d.join("out");
    let out_s = out.to_str().unwrap();

    // sbatch refusing the job: its own message, non-zero exit, nothing recorded
    let bad = d.join("bad");
    std::fs::create_dir_all(&bad).unwrap();
    let file = write_study(&bad, 2, "[slurm]\npartition = \"nosuch\"\n");
    let o = study_env(
        &[
            file.to_str().unwrap(),
            "--out",
            bad.join("out").to_str().unwrap(),
            "--launcher",
            "slurm",
        ],
        &env,
    );
    let e = stderr(&o);
    assert!(
        !o.status.success() && e.contains("sbatch refused the job") && e.contains("nosuch"),
        "{e}"
    );
    assert!(!bad.join("out/slurm-jobs.json").exists());

    // held at submission, so that the test decides when each task runs; the Q1C1 run's folder
    // holds a foreign file, which the run refuses (it fails under Slurm as it would locally)
    let file = write_study(&d, 2, "[slurm]\nsbatch = [\"--hold\"]\n");
    let f = file.to_str().unwrap();
    std::fs::create_dir_all(out.join("Q1C1_m16")).unwrap();
    std::fs::write(out.join("Q1C1_m16/notes.txt"), "mine").unwrap();
    let o = study_env(&[f, "--out", out_s, "--launcher", "slurm"], &env);
    assert!(o.status.success(), "{}", stderr(&o));
    let job = stdout(&o).trim().to_string();
    assert!(
        !job.is_empty() && job.chars().all(|c| c.is_ascii_digit()),
        "job id `{job}`"
    );
    let script = std::fs::read_to_string(out.join("study.sbatch")).unwrap();
    assert!(script.contains("#SBATCH --array=0,1\n"), "{script}");
    let subs: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("slurm-jobs.json")).unwrap())
            .unwrap();
    assert_eq!(subs["jobs"][0]["job_id"], job.as_str());

    // nothing has run: --collect fails and says where each run stands
    let o = study_env(&[f, "--out", out_s, "--collect"], &env);
    let e = stderr(&o);
    assert!(!o.status.success(), "{e}");
    for i in 0..2 {
        assert!(
            e.contains(&format!("pending (JobHeldUser) in Slurm job {job}_{i}")),
            "{e}"
        );
    }

    // the Q1N2 run (task 1) runs: collected, the other one missing
    cluster.release_and_wait(&job, 1);
    let o = study_env(&[f, "--out", out_s, "--collect"], &env);
    assert!(o.status.success(), "{}", stderr(&o));
    let rows = study_rows(&out);
    let good = &rows["Q1N2_m16"];
    assert_eq!(good["status"], "converged", "{good:?}");
    let dir = out.join("Q1N2_m16");
    let s = summary(&dir);
    assert_eq!(s["ranks"], 2, "srun started 2 ranks of one MPI job");
    assert_eq!(good["unknowns"], s["unknowns"].to_string());
    assert_eq!(good["steps"], "2");
    let p = history_col(&dir, "P_flat_disk_arc_y");
    let pmax: f64 = good["Pmax"].parse().unwrap();
    assert_eq!(pmax, p.iter().copied().fold(f64::MIN, f64::max));
    assert!(pmax > 0.0);
    let waiting = &rows["Q1C1_m16"];
    assert_eq!(waiting["status"], "missing", "{waiting:?}");
    assert!(
        waiting["reason"].contains(&format!("pending (JobHeldUser) in Slurm job {job}_0")),
        "{waiting:?}"
    );
    assert!(stderr(&o).contains("1 missing"), "{}", stderr(&o));
    let md = std::fs::read_to_string(out.join("study.md")).unwrap();
    assert!(md.contains("1 without a result yet"), "{md}");
    assert!(out.join("plots/Pmax_vs_level.svg").is_file());

    // the Q1C1 run (task 0) fails: named with the run's own message
    cluster.release_and_wait(&job, 0);
    let o = study_env(&[f, "--out", out_s, "--collect"], &env);
    // a failed run: the table is written and the study fails
    assert!(!o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("1 of 2 runs failed"), "{}", stderr(&o));
    let rows = study_rows(&out);
    let failed = &rows["Q1C1_m16"];
    assert_eq!(failed["status"], "failed", "{failed:?}");
    assert!(
        failed["reason"].contains(&format!("Slurm task {job}_0 ended without a summary.json"))
            && failed["reason"].contains("--overwrite"),
        "{failed:?}"
    );
    assert!(stderr(&o).contains("failed: Q1C1_m16"), "{}", stderr(&o));
    // collecting is repeatable: the same table
    let csv = std::fs::read_to_string(out.join("study.csv")).unwrap();
    let o = study_env(&[f, "--out", out_s, "--collect"], &env);
    assert!(!o.status.success(), "{}", stderr(&o));
    assert_eq!(std::fs::read_to_string(out.join("study.csv")).unwrap(), csv);

    // fixed and submitted again (not held): only the failed run is in the new array
    std::fs::remove_file(out.join("Q1C1_m16/notes.txt")).unwrap();
    let file = write_study(&d, 2, "");
    let o = study_env(&[f, "--out", out_s, "--launcher", "slurm"], &env);
    assert!(o.status.success(), "{}", stderr(&o));
    let job2 = stdout(&o).trim().to_string();
    assert_ne!(job2, job);
    assert!(
        stderr(&o).contains("finished earlier with the same case: Q1N2_m16"),
        "{}",
        stderr(&o)
    );
    let script = std::fs::read_to_string(out.join("study.sbatch")).unwrap();
    assert!(script.contains("#SBATCH --array=0\n"), "{script}");
    cluster.wait(&job2, 0);
    let o = study_env(&[file.to_str().unwrap(), "--out", out_s, "--collect"], &env);
    assert!(o.status.success(), "{}", stderr(&o));
    let rows = study_rows(&out);
    for run in ["Q1C1_m16", "Q1N2_m16"] {
        let r = &rows[run];
        assert_eq!(r["status"], "converged", "{r:?}");
        assert_eq!(summary(&out.join(run))["ranks"], 2);
        assert!(r["reason"].is_empty(), "{r:?}");
    }
    // the array task's output went where the local launcher puts it
    assert!(out.join("logs/Q1C1_m16.err").is_file());
    assert!(out.join(format!("logs/slurm-{job2}_0.out")).is_file());
    // the Q1N2 result is the one of the first job, unchanged
    assert_eq!(rows["Q1N2_m16"]["Pmax"], good["Pmax"]);

    // a run longer than its time limit: Slurm's one SIGTERM before the limit (--signal) lets it
    // finish its load step and write its summary; --collect reports it interrupted
    let slow = d.join("slow");
    std::fs::create_dir_all(&slow).unwrap();
    let file = slow.join("study.toml");
    std::fs::write(
        &file,
        format!(
            "case = \"{}\"\nset = [\"stages.0.steps=400\", \"meshes.disk.n_arc=256\", \"meshes.disk.n_radial=64\"]\n\
             [[axes]]\nname = \"family\"\nkeys = [\"bodies.disk.element\"]\nvalues = [\"Q1C1\"]\n\
             [slurm]\ntime = \"2\"\nstop_before = 90\n",
            case("hertz_2d.toml").display()
        ),
    )
    .unwrap();
    let slow_out = slow.join("out");
    let (f, so) = (file.to_str().unwrap(), slow_out.to_str().unwrap());
    let o = study_env(&[f, "--out", so, "--launcher", "slurm"], &env);
    assert!(o.status.success(), "{}", stderr(&o));
    let job3 = stdout(&o).trim().to_string();
    let script = std::fs::read_to_string(slow_out.join("study.sbatch")).unwrap();
    assert!(script.contains("#SBATCH --signal=TERM@90\n"), "{script}");
    cluster.wait(&job3, 0);
    let o = study_env(&[f, "--out", so, "--collect"], &env);
    assert!(!o.status.success(), "{}", stderr(&o));
    let r = &study_rows(&slow_out)["Q1C1"];
    assert_eq!(r["status"], "failed", "{r:?}");
    assert!(
        r["reason"].contains("interrupted by SIGTERM after"),
        "{r:?}"
    );
    let dir = slow_out.join("Q1C1");
    assert_eq!(summary(&dir)["status"], "interrupted");
    assert!(
        dir.join("results.h5").is_file(),
        "results renamed into place"
    );
    let steps: usize = r["steps"].parse().unwrap();
    assert!((1..400).contains(&steps), "{r:?}");

    eprintln!(
        "Slurm end-to-end: {:.1} s (cluster start not included)",
        t0.elapsed().as_secs_f64()
    );
}
