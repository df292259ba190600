//! Nothing lost, nothing written outside: one writer per output directory (a second run, restart or
//! study into a directory in use is refused at once, naming the holder, and changes nothing of its
//! files), no output written through a symbolic link, a failed restart that leaves the finished run
//! it continues as it was, and studies whose run directories are plain and distinct, that fail when
//! a run fails, and that stop their runs on SIGTERM and resume.

mod common;
use common::*;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// The frictional block pushed in so many steps that it runs until it is stopped.
const ENDLESS: &[&str] = &[
    "--set",
    "stages.1.steps=100000",
    "--set",
    "output.plots=false",
];

/// Processes of this program whose command line names `dir` (mpirun's ranks included).
fn writers_of(dir: &Path) -> Vec<u32> {
    let dir = dir.to_string_lossy().into_owned();
    let mut out = Vec::new();
    for e in std::fs::read_dir("/proc").unwrap().flatten() {
        let Some(pid) = e.file_name().to_str().and_then(|n| n.parse::<u32>().ok()) else {
            continue;
        };
        let Ok(cmd) = std::fs::read(e.path().join("cmdline")) else {
            continue;
        };
        let args: Vec<String> = cmd
            .split(|&b| b == 0)
            .map(|a| String::from_utf8_lossy(a).into_owned())
            .collect();
        if args.first().is_some_and(|a| a == bin())
            && args.iter().any(|a| a.contains(&dir))
            && alive(pid)
        {
            out.push(pid);
        }
    }
    out
}

/// Kills, when dropped (a failed assertion included), every process of this program that works
/// in the scratch directory `0`.
struct Reaper(PathBuf);

impl Drop for Reaper {
    fn drop(&mut self) {
        for pid in writers_of(&self.0) {
            let _ = Command::new("kill")
                .args(["-s", "KILL", &pid.to_string()])
                .status();
        }
    }
}

/// Starts `nurbs-contact args...` on `np` ranks in the background, its stderr into `err`.
fn spawn(np: usize, args: &[&str], err: &Path) -> Child {
    let mut cmd = if np == 1 {
        Command::new(bin())
    } else {
        let mut c = Command::new("mpirun");
        c.args(["--oversubscribe", "-np", &np.to_string(), bin()]);
        c
    };
    cmd.args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(std::fs::File::create(err).unwrap());
    mpi_env(&mut cmd);
    cmd.spawn().expect("start nurbs-contact")
}

/// Waits (at most 2 minutes) until `ready()`, failing if `child` ends first.
fn wait_until(child: &mut Child, what: &str, ready: impl Fn() -> bool) {
    let t0 = Instant::now();
    while !ready() {
        assert!(child.try_wait().unwrap().is_none(), "ended before {what}");
        assert!(t0.elapsed() < Duration::from_secs(120), "no {what}");
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// Rows of `dir/history.csv` after its header.
fn rows(dir: &Path) -> usize {
    std::fs::read_to_string(dir.join("history.csv"))
        .map(|t| t.lines().count().saturating_sub(1))
        .unwrap_or(0)
}

fn kill(sig: &str, pid: u32) {
    let st = Command::new("kill")
        .args(["-s", sig, &pid.to_string()])
        .status()
        .unwrap();
    assert!(st.success(), "kill -s {sig} {pid}");
}

/// Waits (at most 2 minutes) for the end of `child`: its exit code.
fn finish(mut child: Child) -> Option<i32> {
    let t0 = Instant::now();
    loop {
        if let Some(st) = child.try_wait().unwrap() {
            return st.code();
        }
        if t0.elapsed() > Duration::from_secs(120) {
            let _ = child.kill();
            panic!("did not stop");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// Whether the process `pid` is alive (a zombie counts as ended).
fn alive(pid: u32) -> bool {
    std::fs::read_to_string(format!("/proc/{pid}/stat")).is_ok_and(|s| {
        !s.rsplit_once(')')
            .is_some_and(|(_, r)| r.trim_start().starts_with('Z'))
    })
}

/// The pid a directory's lock file records.
fn holder(dir: &Path) -> u32 {
    let text = std::fs::read_to_string(dir.join(".nurbs-contact.lock")).unwrap_or_default();
    text.lines()
        .find_map(|l| l.strip_prefix("pid ")?.parse().ok())
        .unwrap_or(0)
}

/// The bytes of the files a finished run leaves.
fn snapshot(dir: &Path) -> Vec<(String, Vec<u8>)> {
    ["history.csv", "results.h5", "summary.json", "case.toml"]
        .iter()
        .map(|f| (f.to_string(), std::fs::read(dir.join(f)).unwrap()))
        .collect()
}

/// A run, a restart and a 2-rank run into the directory of a run in progress are refused at once,
/// naming the directory and the holder, and its history, results and checkpoint go on; the run
/// then ends with readable results.
fn second_writers_are_refused(holder_ranks: usize) {
    let d = scratch(&format!("safety-lock-np{holder_ranks}"));
    let _reaper = Reaper(d.clone());
    let out = d.join("out");
    let c = case("friction_block_2d.toml");
    let (c, o) = (c.to_str().unwrap(), out.to_str().unwrap());
    let mut args = vec!["run", c, "--out", o, "-q", "--checkpoint-every", "5"];
    args.extend_from_slice(ENDLESS);
    let mut first = spawn(holder_ranks, &args, &d.join("first.err"));
    wait_until(&mut first, "a checkpoint", || {
        out.join("checkpoints").is_dir() && rows(&out) >= 6
    });
    // rank 0 holds the lock
    let pid = holder(&out);
    for (np, args) in [
        (1, vec!["run", c, "--out", o, "-q"]),
        (2, vec!["run", c, "--out", o, "-q"]),
        (1, vec!["run", c, "--restart", o, "-q"]),
        (2, vec!["run", c, "--restart", o, "-q"]),
    ] {
        let before = rows(&out);
        let t0 = Instant::now();
        let r = run(np, &args);
        let e = stderr(&r);
        assert!(!r.status.success(), "{args:?} on {np}: {e}");
        assert!(
            e.contains(&format!("{o}: in use by process {pid} on "))
                && e.contains("friction_block_2d.toml --out")
                && e.contains("--checkpoint-every 5"),
            "{args:?} on {np}: {e}"
        );
        assert_eq!(
            e.matches("in use by").count(),
            1,
            "reported once on {np} ranks: {e}"
        );
        assert!(t0.elapsed() < Duration::from_secs(60));
        // nothing of the first run's was truncated or removed
        assert!(rows(&out) >= before, "{args:?}: history.csv truncated");
        assert!(out.join("results.h5.partial").is_file());
        assert!(out.join("checkpoints").is_dir());
    }
    assert!(first.try_wait().unwrap().is_none(), "the first run stopped");
    kill("TERM", first.id());
    let code = finish(first);
    // mpirun reports its ranks' stop with its own code
    assert!(
        code == Some(143) || holder_ranks > 1 && code != Some(0),
        "{code:?}"
    );
    let s = summary(&out);
    assert_eq!(s["status"], "interrupted", "{s}");
    assert_eq!(
        s["converged_steps"].as_u64(),
        Some(rows(&out) as u64),
        "{s}"
    );
    assert!(h5_steps(&out) >= 1, "results.h5 opens");
}

#[test]
fn a_second_run_or_restart_into_a_running_runs_directory_is_refused() {
    second_writers_are_refused(1);
}

#[test]
fn a_second_writer_is_refused_while_a_two_rank_run_holds_the_directory() {
    second_writers_are_refused(2);
}

#[test]
fn output_is_not_written_through_symbolic_links() {
    let d = scratch("safety-symlinks");
    let outside = d.join("outside.csv");
    std::fs::write(&outside, "someone else's file\n").unwrap();
    let out = d.join("out");
    std::fs::create_dir_all(&out).unwrap();
    std::os::unix::fs::symlink(&outside, out.join("history.csv")).unwrap();
    let c = case("friction_block_2d.toml");
    let (c, o) = (c.to_str().unwrap(), out.to_str().unwrap());
    let r = run(1, &["run", c, "--out", o, "-q", "--overwrite"]);
    let e = stderr(&r);
    assert!(!r.status.success(), "{e}");
    assert!(
        e.contains(&format!("{o}/history.csv: is a symbolic link")),
        "{e}"
    );
    assert_eq!(
        std::fs::read_to_string(&outside).unwrap(),
        "someone else's file\n"
    );

    // a checkpoints folder shared with another run through a link: refused, the other's kept
    let other = d.join("other");
    run_ok(
        1,
        &[
            "run",
            c,
            "--out",
            other.to_str().unwrap(),
            "-q",
            "--checkpoint-every",
            "4",
        ],
    );
    let theirs: Vec<PathBuf> = std::fs::read_dir(other.join("checkpoints"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    assert_eq!(theirs.len(), 1);
    let second = d.join("second");
    std::fs::create_dir_all(&second).unwrap();
    std::os::unix::fs::symlink(other.join("checkpoints"), second.join("checkpoints")).unwrap();
    let s = second.to_str().unwrap();
    let r = run(
        1,
        &[
            "run",
            c,
            "--out",
            s,
            "-q",
            "--overwrite",
            "--checkpoint-every",
            "5",
        ],
    );
    let e = stderr(&r);
    assert!(!r.status.success(), "{e}");
    assert!(
        e.contains(&format!("{s}/checkpoints: is a symbolic link")),
        "{e}"
    );
    assert!(theirs[0].is_dir(), "the other run's checkpoint was pruned");
}

#[test]
fn a_failed_restart_leaves_the_finished_run_as_it_was() {
    for np in [1, 2] {
        let d = scratch(&format!("safety-restart-np{np}"));
        let out = d.join("out");
        let c = case("friction_block_2d.toml");
        let (c, o) = (c.to_str().unwrap(), out.to_str().unwrap());
        run_ok(np, &["run", c, "--out", o, "-q", "--checkpoint-every", "8"]);
        assert_eq!(rows(&out), 12);
        let steps = h5_steps(&out);
        let before = snapshot(&out);
        let r = run(
            np,
            &[
                "run",
                c,
                "--restart",
                o,
                "-q",
                "--set",
                "solver.predictor=none",
                "-snes_max_it",
                "0",
            ],
        );
        let e = stderr(&r);
        assert!(!r.status.success(), "{e}");
        assert!(e.contains("load step 9"), "{e}");
        assert!(
            e.contains(&format!(
                "the restart ended at converged load step 8, not beyond step 12 of the run it continues: that run's results in {o} are unchanged, the restart's are in {o}/restart"
            )),
            "{e}"
        );
        assert!(
            snapshot(&out) == before,
            "np {np}: the finished run changed"
        );
        assert_eq!(h5_steps(&out), steps);
        assert_eq!(summary(&out.join("restart"))["status"], "failed");

        // a restart that gets through replaces the results, as an uninterrupted run writes them
        let history = |dir: &Path| -> Vec<(String, Vec<f64>)> {
            common::history(dir)
                .into_iter()
                .filter(|(h, _)| h != "wall_time")
                .collect()
        };
        let uninterrupted = history(&out);
        run_ok(np, &["run", c, "--restart", o, "-q"]);
        assert_eq!(history(&out), uninterrupted, "np {np}");
        assert_eq!(h5_steps(&out), steps);
        assert_eq!(summary(&out)["status"], "converged");
        assert!(!out.join("restart").exists());
    }
}

/// Writes a study of the frictional block with `body` after its `case` line.
fn write_study(dir: &Path, body: &str) -> PathBuf {
    let f = dir.join("study.toml");
    let text = format!(
        "case = \"{}\"\n{body}",
        case("friction_block_2d.toml").display()
    );
    std::fs::write(&f, text).unwrap();
    f
}

#[test]
fn study_run_directories_are_plain_and_distinct() {
    let d = scratch("safety-study-names");
    let axes = "[[axes]]\nname = \"x\"\nkeys = [\"stages.0.steps\"]\nvalues = [\"a_b\", \"a\"]\n\
                [[axes]]\nname = \"y\"\nkeys = [\"stages.1.steps\"]\nvalues = [\"c\", \"b_c\"]\n";
    let dots =
        "[[axes]]\nname = \"x\"\nlevels = [ { name = \"..\", set = [\"stages.0.steps=2\"] } ]\n";
    let cases: &[(&str, &str)] = &[
        (
            axes,
            "`axes`: the runs of `a_b` + `c` (axes.0.values.0, axes.1.values.0) and of `a` + `b_c` (axes.0.values.1, axes.1.values.1) would share the run directory `a_b_c`",
        ),
        (dots, "`axes.0.levels.0.name`: `..` names a run directory"),
        (
            "name = \"..\"\n[[axes]]\nname = \"x\"\nkeys = [\"stages.0.steps\"]\nvalues = [2]\n",
            "`name`: `..` names the study's folder",
        ),
    ];
    let out = d.join("out");
    for (body, want) in cases {
        let f = write_study(&d, body);
        for mode in [&["--check"][..], &[][..]] {
            let mut args = vec!["study"];
            args.extend_from_slice(mode);
            args.extend([f.to_str().unwrap(), "--out", out.to_str().unwrap()]);
            let r = run(1, &args);
            let e = stderr(&r);
            assert!(!r.status.success() && e.contains(want), "{body}\n{e}");
        }
    }
    // nothing was written, inside or beside
    assert!(!out.exists());
    let entries: Vec<_> = std::fs::read_dir(&d).unwrap().collect();
    assert_eq!(entries.len(), 1, "only the study file");
}

#[test]
fn a_study_whose_runs_all_fail_exits_non_zero_with_its_table() {
    let d = scratch("safety-study-fail");
    let f = write_study(
        &d,
        "[[axes]]\nname = \"x\"\nkeys = [\"meshes.block.n_arc\"]\nvalues = [4, 8]\n",
    );
    let out = d.join("out");
    let r = run(
        1,
        &["study", f.to_str().unwrap(), "--out", out.to_str().unwrap()],
    );
    let e = stderr(&r);
    assert!(!r.status.success(), "{e}");
    assert!(e.contains("2 of 2 runs failed"), "{e}");
    let rows = study_rows(&out);
    assert_eq!(rows.len(), 2);
    assert!(rows.values().all(|r| r["status"] == "failed"), "{rows:?}");
}

/// SIGTERM to a study (a fast run and an endless one, 2 at once, on `ranks` ranks each) stops the
/// endless run and the study with 143; the table lists the fast run converged and the stopped one
/// failed; a second study into the same folder meanwhile is refused; run again, the study skips the
/// converged run and reruns the stopped one.
fn sigterm_stops_a_study_and_its_runs(ranks: usize) {
    let d = scratch(&format!("safety-study-term-np{ranks}"));
    let _reaper = Reaper(d.clone());
    let f = write_study(
        &d,
        &format!(
            "jobs = 2\nranks = {ranks}\nset = [\"output.plots=false\"]\n\
             [[axes]]\nname = \"push\"\nkeys = [\"stages.1.steps\"]\nvalues = [10, 100000]\n"
        ),
    );
    let out = d.join("out");
    let (fs, o) = (f.to_str().unwrap(), out.to_str().unwrap());
    let endless = out.join("100000");
    let mut run_pid = 0;
    for round in 0..2 {
        let mut study = spawn(1, &["study", fs, "--out", o, "-q"], &d.join("study.err"));
        // the second round waits for the rerun of the endless run (a new lock holder)
        let before = run_pid;
        wait_until(&mut study, "the endless run's steps", || {
            (round == 0 || ![0, before].contains(&holder(&endless)))
                && rows(&endless) >= 2
                && out.join("10/summary.json").is_file()
        });
        run_pid = holder(&endless);
        let runs = writers_of(&endless);
        assert_eq!(runs.len(), ranks, "{runs:?}");
        if round == 0 {
            let r = run_with(
                1,
                &["study", fs, "--out", o, "-q"],
                None,
                Duration::from_secs(60),
            )
            .expect("a second study into the folder is refused at once, not run");
            let e = stderr(&r);
            assert!(
                !r.status.success()
                    && e.contains(&format!("{o}: in use by process {}", study.id())),
                "{e}"
            );
        }
        kill("TERM", study.id());
        assert_eq!(finish(study), Some(143));
        let t0 = Instant::now();
        while runs.iter().any(|&p| alive(p)) && t0.elapsed() < Duration::from_secs(15) {
            std::thread::sleep(Duration::from_millis(20));
        }
        assert!(
            runs.iter().all(|&p| !alive(p)),
            "the study's run {runs:?} goes on"
        );
        let e = std::fs::read_to_string(d.join("study.err")).unwrap();
        assert!(e.contains("stopped by SIGTERM"), "{e}");
        let rows = study_rows(&out);
        let (fast, slow) = (&rows["10"], &rows["100000"]);
        assert_eq!(fast["status"], "converged", "{fast:?}");
        assert_eq!(fast["skipped"], if round == 0 { "0" } else { "1" });
        assert_eq!(slow["status"], "failed", "{slow:?}");
        assert!(slow["reason"].contains("SIGTERM"), "{slow:?}");
        assert_ne!(summary(&endless)["status"], "converged");
    }
}

#[test]
fn sigterm_to_a_study_stops_its_runs_and_it_resumes() {
    sigterm_stops_a_study_and_its_runs(1);
}

#[test]
fn sigterm_to_a_study_stops_its_mpirun_runs() {
    sigterm_stops_a_study_and_its_runs(2);
}
