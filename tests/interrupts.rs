//! Clean interrupts: a SIGINT or SIGTERM during a run stops it at the next Newton iteration, the
//! step in progress given up; every converged step is in valid results, `summary.json` says
//! `interrupted`, the exit code is the signal's (130, 143), and on 2 ranks all ranks agree on where
//! to stop.

mod common;
use common::*;
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// Many small steps (a few ms each), so the signal lands in the middle of the run; results every
/// 50 steps, so the step written because of the interrupt is visible.
const CASE: &str = r#"
[case]
name = "interrupt_block"
dim = 3

[meshes.block]
generator = "box"
origin = [0.0, 0.0, 0.0]
size = [1.0, 1.0, 1.0]
divisions = [4, 4, 4]

[bodies.block]
mesh = "block"
element = "Q1C1"
[bodies.block.material]
model = "neo_hookean"
E = 1.0
nu = 0.3

[[bcs]]
body = "block"
set = "zmin"
kind = "fixed"

[[bcs]]
body = "block"
set = "zmax"
kind = "displacement"
components = ["z"]
value = [[-0.2]]

[[stages]]
name = "compress"
steps = 2000

[output]
every = 50
"#;

const EVERY: usize = 50;

/// Starts a run of the case text `case` in `dir` on `np` ranks (1: the binary itself, else under
/// mpirun), with `extra` arguments after `run case.toml --out out`.
fn start_case(dir: &Path, np: usize, case: &str, extra: &[&str]) -> Child {
    std::fs::write(dir.join("case.toml"), case).unwrap();
    let mut cmd = if np == 1 {
        Command::new(bin())
    } else {
        let mut c = Command::new("mpirun");
        c.args(["--oversubscribe", "-np", &np.to_string(), bin()]);
        c
    };
    cmd.args(["run", "case.toml", "--out", "out"])
        .args(extra)
        .current_dir(dir)
        .stdout(Stdio::null())
        .stderr(Stdio::piped());
    mpi_env(&mut cmd);
    cmd.spawn().expect("start nurbs-contact")
}

/// Starts a run of [`CASE`] in `dir` on `np` ranks.
fn start(dir: &Path, np: usize) -> Child {
    start_case(dir, np, CASE, &[])
}

/// Waits until history.csv holds at least one converged step.
fn wait_for_first_step(dir: &Path, child: &mut Child) {
    let t0 = Instant::now();
    let history = dir.join("out/history.csv");
    loop {
        let rows = std::fs::read_to_string(&history)
            .map(|t| t.lines().count().saturating_sub(1))
            .unwrap_or(0);
        if rows >= 1 {
            return;
        }
        assert!(
            child.try_wait().unwrap().is_none(),
            "the run ended before its first step"
        );
        assert!(t0.elapsed() < Duration::from_secs(120), "no first step");
        std::thread::sleep(Duration::from_millis(10));
    }
}

fn kill(sig: &str, pid: u32) {
    let st = Command::new("kill")
        .args([&format!("-{sig}"), &pid.to_string()])
        .status()
        .unwrap();
    assert!(st.success(), "kill -{sig} {pid}");
}

/// The ranks mpirun started (its child processes).
fn ranks_of(mpirun: u32) -> Vec<u32> {
    let out = Command::new("pgrep")
        .args(["-P", &mpirun.to_string()])
        .output()
        .unwrap();
    String::from_utf8_lossy(&out.stdout)
        .split_whitespace()
        .map(|p| p.parse().unwrap())
        .collect()
}

/// Waits for the end (at most 2 minutes); exit code and stderr.
fn finish(mut child: Child) -> (Option<i32>, String) {
    use std::io::Read;
    let t0 = Instant::now();
    let status = loop {
        if let Some(st) = child.try_wait().unwrap() {
            break st;
        }
        if t0.elapsed() > Duration::from_secs(120) {
            let _ = child.kill();
            panic!("the interrupted run did not stop");
        }
        std::thread::sleep(Duration::from_millis(10));
    };
    let mut err = String::new();
    let _ = child.stderr.take().unwrap().read_to_string(&mut err);
    (status.code(), err)
}

/// The interrupted run's output is complete and consistent: status, converged steps in summary,
/// history and results (every 50th and the last), no partial files.
fn assert_interrupted(out: &Path, signal: &str, err: &str) {
    let s = summary(out);
    assert_eq!(s["status"], "interrupted", "{s}\n{err}");
    assert_eq!(s["signal"], signal, "{err}");
    let n = s["converged_steps"].as_u64().unwrap() as usize;
    assert!((1..2000).contains(&n), "converged steps {n}");
    assert_eq!(s["steps"].as_array().unwrap().len(), n);
    let loads = history_col(out, "load_factor");
    assert_eq!(loads.len(), n);
    assert!((loads[n - 1] - n as f64 / 2000.0).abs() < 1e-12);
    assert!(!out.join("results.h5.partial").exists());
    assert_eq!(
        h5_steps(out),
        n / EVERY + usize::from(!n.is_multiple_of(EVERY))
    );
    assert_eq!(h5_last(out, "bulk", "displacement").len(), 125 * 3);
    assert!(err.contains("interrupted by"), "{err}");
    assert!(!err.contains("results in"), "{err}");
}

#[test]
fn sigint_and_sigterm_on_one_rank_stop_the_run_with_their_codes() {
    for (sig, code) in [("INT", 130), ("TERM", 143)] {
        let dir = scratch(&format!("interrupt/np1-{sig}"));
        let mut child = start(&dir, 1);
        wait_for_first_step(&dir, &mut child);
        kill(sig, child.id());
        let (rc, err) = finish(child);
        assert_eq!(rc, Some(code), "{err}");
        assert_interrupted(&dir.join("out"), &format!("SIG{sig}"), &err);
    }
}

/// mpirun turns a SIGINT into SIGTERM for every rank (and SIGKILL 1 s later,
/// `odls_base_sigkill_timeout`), and exits with its own code.
#[test]
fn sigint_to_mpirun_stops_both_ranks_cleanly() {
    let dir = scratch("interrupt/np2-mpirun");
    let mut child = start(&dir, 2);
    wait_for_first_step(&dir, &mut child);
    kill("INT", child.id());
    let (rc, err) = finish(child);
    assert!(rc.is_some_and(|c| c != 0), "exit {rc:?}\n{err}");
    assert_interrupted(&dir.join("out"), "SIGTERM", &err);
}

/// A signal that reaches one rank only (a scheduler signalling one task) stops both at the same
/// step: the flag is reduced over the ranks at each step boundary.
#[test]
fn sigint_to_one_rank_stops_both_at_the_same_step() {
    let dir = scratch("interrupt/np2-one-rank");
    let mut child = start(&dir, 2);
    wait_for_first_step(&dir, &mut child);
    let ranks = ranks_of(child.id());
    assert_eq!(ranks.len(), 2, "ranks {ranks:?}");
    kill("INT", ranks[1]);
    let (rc, err) = finish(child);
    assert_eq!(rc, Some(130), "{err}");
    assert_interrupted(&dir.join("out"), "SIGINT", &err);
}

/// [`CASE`] in three load steps of a few hundred Newton iterations each (full steps damped to a
/// tenth: the residual falls by about 0.9 per iteration) on a finer block, results every step, so
/// that a signal sent as soon as the first step is in history.csv lands long before the second
/// converges.
fn slow_steps() -> String {
    let case = CASE
        .replace("divisions = [4, 4, 4]", "divisions = [6, 6, 6]")
        .replace("value = [[-0.2]]", "value = [[-0.1]]")
        .replace("steps = 2000", "steps = 3")
        .replace("every = 50", "every = 1");
    assert!(
        !case.contains("2000") && case.contains("[6, 6, 6]"),
        "{case}"
    );
    case + "\n[solver]\npetsc_options = \"-snes_linesearch_type basic -snes_linesearch_damping 0.1 -snes_max_it 5000\"\n"
}

/// Runs [`slow_steps`] in `dir/out` on `np` ranks with checkpoints never scheduled, signals it
/// (`to_one_rank`: the second rank only) once step 1 is in history.csv, and checks that it stopped
/// within step 2: one converged step, in the history, the results and a checkpoint.
fn stop_within_a_step(dir: &Path, np: usize, to_one_rank: bool) {
    let mut child = start_case(dir, np, &slow_steps(), &["--checkpoint-every", "100"]);
    wait_for_first_step(dir, &mut child);
    if to_one_rank {
        let ranks = ranks_of(child.id());
        assert_eq!(ranks.len(), 2, "ranks {ranks:?}");
        kill("INT", ranks[1]);
    } else {
        kill("INT", child.id());
    }
    let (rc, err) = finish(child);
    assert_eq!(rc, Some(130), "{err}");
    let out = dir.join("out");
    let s = summary(&out);
    assert_eq!(s["status"], "interrupted", "{s}\n{err}");
    assert_eq!(s["signal"], "SIGINT", "{err}");
    // under the old rule (stop after the step in progress) step 2 would have converged
    assert_eq!(s["converged_steps"], 1, "{err}");
    assert_eq!(history_col(&out, "load_factor").len(), 1);
    assert!(
        err.contains("interrupted by SIGINT after 1 converged load steps"),
        "{err}"
    );
    assert!(!out.join("results.h5.partial").exists());
    // the step's results are written although `output.every` (default 1) would have anyway;
    // and the checkpoint of step 1, which the schedule (every 100) did not ask for
    assert_eq!(h5_steps(&out), 1);
    assert_eq!(h5_last(&out, "bulk", "displacement").len(), 343 * 3);
    let ckpt: Vec<String> = std::fs::read_dir(out.join("checkpoints"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(ckpt, vec!["step-000001".to_string()], "{err}");
}

/// A signal within a long step stops the run at the next Newton iteration instead of after the
/// step (at 10^6 unknowns a step takes minutes, a Newton iteration under one); the restart from the
/// checkpoint it writes ends like the uninterrupted run.
#[test]
fn a_signal_within_a_step_stops_at_the_next_newton_iteration() {
    let dir = scratch("interrupt/within-step-np1");
    stop_within_a_step(&dir, 1, false);
    let whole = dir.join("whole");
    run_ok(
        1,
        &[
            "run",
            dir.join("case.toml").to_str().unwrap(),
            "--out",
            whole.to_str().unwrap(),
            "-q",
        ],
    );
    let out = dir.join("out");
    run_ok(
        1,
        &[
            "run",
            dir.join("case.toml").to_str().unwrap(),
            "--restart",
            out.to_str().unwrap(),
            "-q",
        ],
    );
    assert_eq!(summary(&out)["status"], "converged");
    let h = rel_diff(&history_values(&whole), &history_values(&out));
    assert!(h < 1e-12, "history, restarted against uninterrupted: {h:e}");
    let d = rel_diff(
        &h5_last(&whole, "bulk", "displacement"),
        &h5_last(&out, "bulk", "displacement"),
    );
    assert!(d < 1e-12, "restarted against uninterrupted: {d:e}");
    assert_eq!(
        history_col(&whole, "newton_iterations"),
        history_col(&out, "newton_iterations")
    );
}

/// On 2 ranks a signal to one rank stops both within the same step.
#[test]
fn a_signal_to_one_rank_within_a_step_stops_both_there() {
    stop_within_a_step(&scratch("interrupt/within-step-np2"), 2, true);
}
