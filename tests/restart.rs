//! Checkpoint and restart: a run killed with SIGKILL after a checkpoint and restarted
//! with `--restart` ends with the same history.csv and results.h5 as a run that was never
//! interrupted (to 1e-12), on 1 and 2 ranks, for a Q1E4 body (enhanced-strain history) and a
//! frictional contact case (anchors, warm starts); a checkpoint written on 2 ranks continues on 1;
//! a case that changed is refused with the key that differs.

mod common;
use common::*;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// A Q1E4 block sheared and compressed in many small steps (so that a kill lands mid-run), with
/// output every 7 steps (the steps written before and after the restart interleave).
const Q1E4: &str = r#"
[case]
name = "restart_q1e4"
dim = 2

[meshes.block]
generator = "rectangle"
origin = [0.0, 0.0]
size = [1.0, 1.0]
divisions = [4, 4]

[bodies.block]
mesh = "block"
element = "Q1E4"
[bodies.block.material]
model = "neo_hookean"
E = 1.0
nu = 0.45

[[bcs]]
body = "block"
set = "bottom"
kind = "fixed"

[[bcs]]
body = "block"
set = "top"
kind = "displacement"
value = [[0.15, -0.1]]

[[stages]]
name = "shear"
steps = 120

[output]
every = 7
reactions = [{ body = "block", set = "top" }]
"#;

/// The frictional block of cases/ in more steps: pressed (frictionless), then pushed sideways
/// through stick into slip.
const FRICTION: &[&str] = &["stages.0.steps=4", "stages.1.steps=60", "output.every=5"];

/// Tolerance of a 2-rank contact run restarted on 1 rank against the uninterrupted 2-rank run: the
/// partition changes the order of the sums, so they agree to the Newton tolerance, not bitwise.
/// (Two uninterrupted 2-rank contact runs used to differ by up to 9.4e-11 with Newton counts off by
/// 1-2: Newton then went on with a stale factorisation when contact blocks left the pattern, fixed
/// on the `perf` branch; since, they repeat bitwise and the 2-rank restart is compared with the
/// iteration counts.)
const TWO_RANK_CONTACT: f64 = 1e-8;

/// Writes the case text (or copies a shipped case) into `dir` and returns its path.
fn case_file(dir: &Path, text: Option<&str>, shipped: &str) -> PathBuf {
    match text {
        Some(t) => {
            let p = dir.join("case.toml");
            std::fs::write(&p, t).unwrap();
            p
        }
        None => case(shipped),
    }
}

fn args<'a>(case: &'a Path, sets: &'a [&'a str], rest: &[&'a str]) -> Vec<&'a str> {
    let mut a = vec!["run", case.to_str().unwrap(), "-q"];
    for s in sets {
        a.extend(["--set", s]);
    }
    a.extend_from_slice(rest);
    a
}

/// Complete checkpoints in a run directory.
fn checkpoints(out: &Path) -> Vec<String> {
    std::fs::read_dir(out.join("checkpoints"))
        .into_iter()
        .flatten()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with("step-") && !n.ends_with(".partial"))
        .collect()
}

/// Starts `case` on `np` ranks with `--checkpoint-every every` into `out`, waits for the first
/// checkpoint and kills every process with SIGKILL; asserts the run had not finished.
fn run_and_kill(np: usize, case: &Path, sets: &[&str], out: &Path, every: &str) {
    let mut a = args(case, sets, &["--out", out.to_str().unwrap()]);
    a.extend(["--checkpoint-every", every]);
    let mut cmd = if np == 1 {
        Command::new(bin())
    } else {
        let mut c = Command::new("mpirun");
        c.args(["--oversubscribe", "-np", &np.to_string(), bin()]);
        c
    };
    cmd.args(&a).stdout(Stdio::null()).stderr(Stdio::null());
    mpi_env(&mut cmd);
    let mut child = cmd.spawn().expect("start nurbs-contact");
    let t0 = Instant::now();
    while checkpoints(out).is_empty() {
        assert!(
            child.try_wait().unwrap().is_none(),
            "the run ended before its first checkpoint"
        );
        assert!(t0.elapsed() < Duration::from_secs(120), "no checkpoint");
        std::thread::sleep(Duration::from_millis(1));
    }
    // the ranks first (mpirun would otherwise pass on a clean signal), then mpirun itself
    let mut pids: Vec<u32> = if np > 1 {
        let o = Command::new("pgrep")
            .args(["-P", &child.id().to_string()])
            .output()
            .unwrap();
        String::from_utf8_lossy(&o.stdout)
            .split_whitespace()
            .map(|p| p.parse().unwrap())
            .collect()
    } else {
        Vec::new()
    };
    pids.push(child.id());
    for p in pids {
        let _ = Command::new("kill")
            .args(["-KILL", &p.to_string()])
            .status();
    }
    let status = child.wait().unwrap();
    assert!(!status.success(), "the run was not killed: {status:?}");
    assert!(
        !out.join("summary.json").exists(),
        "the run finished before it was killed: make it longer"
    );
}

/// Every dataset of every step of results.h5 (path, values) and the steps' load factors.
fn all_results(dir: &Path) -> (Vec<f64>, Vec<(String, Vec<f64>)>) {
    let f = h5_open(dir.join("results.h5")).expect("open results.h5");
    let steps = f.group("steps").expect("steps");
    let mut names = steps.member_names().unwrap();
    names.sort();
    let mut loads = Vec::new();
    let mut data = Vec::new();
    for s in &names {
        let g = steps.group(s).unwrap();
        loads.push(g.attr("load_factor").unwrap().read_scalar::<f64>().unwrap());
        let mut grids = g.member_names().unwrap();
        grids.sort();
        for grid in grids {
            let gg = g.group(&grid).unwrap();
            let mut fields = gg.member_names().unwrap();
            fields.sort();
            for field in fields {
                let v = gg.dataset(&field).unwrap().read_raw::<f64>().unwrap();
                data.push((format!("{s}/{grid}/{field}"), v));
            }
        }
    }
    (loads, data)
}

/// The largest relative difference between two runs' history.csv (every column but wall_time) and
/// results.h5 (every dataset); panics if their shapes differ. With `solver_exact`, the Newton
/// iteration counts and final residual norms count too (a residual norm absolutely: they are
/// round-off sized); without, only the solution and what is computed from it (see
/// [`TWO_RANK_CONTACT`]).
fn compare_runs(a: &Path, b: &Path, solver_exact: bool) -> f64 {
    let (ha, hb) = (history(a), history(b));
    let names = |h: &[(String, Vec<f64>)]| h.iter().map(|(n, _)| n.clone()).collect::<Vec<_>>();
    assert_eq!(names(&ha), names(&hb), "history columns");
    let mut worst = 0.0f64;
    for ((name, x), (_, y)) in ha.iter().zip(&hb) {
        assert_eq!(x.len(), y.len(), "history rows of {name}");
        let solver_column = name == "residual" || name == "newton_iterations";
        if name == "wall_time" || (solver_column && !solver_exact) {
            continue;
        }
        let d = if name == "residual" {
            // converged residual norms: compared against the run's scale of 1
            x.iter()
                .zip(y)
                .fold(0.0f64, |m, (p, q)| m.max((p - q).abs()))
        } else {
            rel_diff(x, y)
        };
        if d > worst {
            eprintln!("history {name}: {d:.3e}");
        }
        worst = worst.max(d);
    }
    let steps = history_col(b, "step");
    let expected: Vec<f64> = (1..=steps.len()).map(|s| s as f64).collect();
    assert_eq!(steps, expected, "history steps are 1, 2, ... without gaps");
    let (la, da) = all_results(a);
    let (lb, db) = all_results(b);
    assert_eq!(la, lb, "results.h5 output steps");
    assert_eq!(da.len(), db.len(), "results.h5 datasets");
    for ((na, x), (nb, y)) in da.iter().zip(&db) {
        assert_eq!(na, nb);
        // `rank` differs by design between rank counts; compared only for the same count
        let d = rel_diff(x, y);
        if d > worst {
            eprintln!("results {na}: {d:.3e}");
        }
        worst = worst.max(d);
    }
    worst
}

/// Uninterrupted run, killed run, restart of the killed run (on `np_restart` ranks); returns the
/// largest difference between the uninterrupted and the restarted run's output.
#[allow(clippy::too_many_arguments)]
fn kill_and_restart(
    tag: &str,
    text: Option<&str>,
    shipped: &str,
    sets: &[&str],
    np: usize,
    np_restart: usize,
    every: &str,
    solver_exact: bool,
) -> (PathBuf, f64) {
    let dir = scratch(&format!("restart/{tag}"));
    let case = case_file(&dir, text, shipped);
    let (whole, killed) = (dir.join("whole"), dir.join("killed"));
    run_ok(np, &args(&case, sets, &["--out", whole.to_str().unwrap()]));
    run_and_kill(np, &case, sets, &killed, every);
    let out = run_ok(
        np_restart,
        &args(&case, sets, &["--restart", killed.to_str().unwrap()]),
    );
    assert_eq!(summary(&killed)["status"], "converged", "{}", stderr(&out));
    assert!(!killed.join("results.h5.partial").exists());
    let d = compare_runs(&whole, &killed, solver_exact);
    eprintln!("{tag}: largest difference restarted vs uninterrupted {d:.3e}");
    (killed, d)
}

/// The Q1E4 local solve converges from any warm start to round-off, so the end-to-end comparison
/// cannot tell a lost enhanced-strain history (measured: identical results with the restore
/// disabled); the checkpoint is checked to hold it, 4 values per cell, not all zero.
#[test]
fn q1e4_killed_and_restarted_equals_an_uninterrupted_run_on_1_rank() {
    let (killed, d) = kill_and_restart("q1e4-np1", Some(Q1E4), "", &[], 1, 1, "10", true);
    assert!(d <= 1e-12, "difference {d:e}");
    let ckpt = killed.join("checkpoints").join(&checkpoints(&killed)[0]);
    let f = h5_open(ckpt.join("state.h5")).unwrap();
    let h = f
        .dataset("element_history")
        .unwrap()
        .read_raw::<f64>()
        .unwrap();
    assert_eq!(h.len(), 16 * 4);
    assert!(h.iter().any(|a| a.abs() > 1e-8), "{h:?}");
}

#[test]
fn q1e4_killed_and_restarted_equals_an_uninterrupted_run_on_2_ranks() {
    let (_, d) = kill_and_restart("q1e4-np2", Some(Q1E4), "", &[], 2, 2, "10", true);
    assert!(d <= 1e-12, "difference {d:e}");
}

#[test]
fn friction_killed_and_restarted_equals_an_uninterrupted_run_on_1_rank() {
    let (_, d) = kill_and_restart(
        "friction-np1",
        None,
        "friction_block_2d.toml",
        FRICTION,
        1,
        1,
        "8",
        true,
    );
    assert!(d <= 1e-12, "difference {d:e}");
}

#[test]
fn friction_killed_and_restarted_equals_an_uninterrupted_run_on_2_ranks() {
    let (_, d) = kill_and_restart(
        "friction-np2",
        None,
        "friction_block_2d.toml",
        FRICTION,
        2,
        2,
        "8",
        true,
    );
    // measured: history.csv and every results.h5 field bitwise equal, Newton counts equal, except
    // the contact points' trial tangential gap (up to 4e-12 relative in one step; not found why)
    assert!(d <= 1e-10, "difference {d:e}");
}

/// The state is in global numbering: a checkpoint of 2 ranks continues on 1. Against the
/// uninterrupted 2-rank run the answer agrees to the Newton tolerance (a different partition sums
/// in a different order); the `rank` output field is left out of the comparison.
#[test]
fn a_checkpoint_written_on_2_ranks_restarts_on_1() {
    let dir = scratch("restart/np2-to-np1");
    let case = case_file(&dir, None, "friction_block_2d.toml");
    let (whole, killed) = (dir.join("whole"), dir.join("killed"));
    let sets: Vec<&str> = FRICTION
        .iter()
        .copied()
        .chain(["output.fields=[\"displacement\"]"])
        .collect();
    run_ok(2, &args(&case, &sets, &["--out", whole.to_str().unwrap()]));
    run_and_kill(2, &case, &sets, &killed, "8");
    let out = run_ok(
        1,
        &args(&case, &sets, &["--restart", killed.to_str().unwrap()]),
    );
    assert!(
        stderr(&out).is_empty() || !stderr(&out).contains("error"),
        "{}",
        stderr(&out)
    );
    let d = compare_runs(&whole, &killed, false);
    eprintln!("np2 -> np1: largest difference {d:.3e}");
    assert!(d <= TWO_RANK_CONTACT, "difference {d:e}");
}

/// A 3D contact case with the distributed contact surface: a checkpoint written on 2
/// ranks continues on 4 (oversubscribed). Each rank rebuilds its own surface pieces and ghost
/// layer from the global state, and the answer agrees with the uninterrupted 2-rank run to the
/// Newton tolerance, as for 2 -> 1 above.
#[test]
fn a_3d_contact_checkpoint_written_on_2_ranks_restarts_on_4() {
    let dir = scratch("restart/np2-to-np4-3d");
    let case = case_file(&dir, None, "hemisphere_block_3d.toml");
    let (whole, killed) = (dir.join("whole"), dir.join("killed"));
    let sets = [
        "stages.0.steps=24",
        "output.fields=[\"displacement\"]",
        "output.plots=false",
    ];
    run_ok(2, &args(&case, &sets, &["--out", whole.to_str().unwrap()]));
    run_and_kill(2, &case, &sets, &killed, "2");
    let out = run_ok(
        4,
        &args(&case, &sets, &["--restart", killed.to_str().unwrap()]),
    );
    assert_eq!(summary(&killed)["status"], "converged", "{}", stderr(&out));
    assert_eq!(summary(&killed)["ranks"], 4);
    assert!(summary(&killed)["restarts"].as_u64().unwrap_or(0) >= 1);
    // forces and moments against the largest of the run (the ones that vanish by symmetry are
    // round-off, 1e-16, on either rank count), the displacement against its own largest
    let (a, b) = (history(&whole), history(&killed));
    assert_eq!(a.len(), b.len(), "history columns");
    let forces = |h: &[(String, Vec<f64>)]| -> Vec<(String, Vec<f64>)> {
        h.iter()
            .filter(|(n, _)| ["R_", "P_", "M_"].iter().any(|p| n.starts_with(p)))
            .cloned()
            .collect()
    };
    let (fa, fb) = (forces(&a), forces(&b));
    assert!(fa.len() >= 6, "{fa:?}");
    let scale = fa
        .iter()
        .flat_map(|(_, v)| v.iter())
        .fold(0.0f64, |m, x| m.max(x.abs()));
    assert!(scale > 0.1, "the press carries load: {scale}");
    let mut worst = 0.0f64;
    for ((name, x), (_, y)) in fa.iter().zip(&fb) {
        assert_eq!(x.len(), y.len(), "rows of {name}");
        let d = x
            .iter()
            .zip(y)
            .fold(0.0f64, |m, (p, q)| m.max((p - q).abs()))
            / scale;
        worst = worst.max(d);
    }
    let u = rel_diff(
        &h5_last(&whole, "bulk", "displacement"),
        &h5_last(&killed, "bulk", "displacement"),
    );
    eprintln!("3D np2 -> np4: forces {worst:.3e}, displacement {u:.3e}");
    assert!(worst <= TWO_RANK_CONTACT, "forces differ by {worst:e}");
    assert!(u <= TWO_RANK_CONTACT, "displacement differs by {u:e}");
}

/// A restart with a changed material value is refused, naming the key; the run directory is left
/// as it was. Output and solver settings may change.
#[test]
fn a_restart_with_a_changed_material_is_refused_with_the_key() {
    let dir = scratch("restart/changed");
    let case = case_file(&dir, Some(Q1E4), "");
    let killed = dir.join("killed");
    run_and_kill(1, &case, &[], &killed, "10");
    let before = std::fs::read(killed.join("history.csv")).unwrap();
    let out = run(
        1,
        &args(
            &case,
            &["bodies.block.material.E=2.0"],
            &["--restart", killed.to_str().unwrap()],
        ),
    );
    let err = stderr(&out);
    assert!(!out.status.success(), "{err}");
    assert!(err.contains("`bodies.block.material.E` differs"), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    assert_eq!(std::fs::read(killed.join("history.csv")).unwrap(), before);
    // output and solver settings may change; the changed solver settings are reported
    let out = run_ok(
        1,
        &args(
            &case,
            &["output.every=3", "solver.krylov_accept=0.01"],
            &["--restart", killed.to_str().unwrap()],
        ),
    );
    assert_eq!(summary(&killed)["status"], "converged", "{}", stderr(&out));
    assert!(
        stderr(&out).contains("solver settings that differ from the checkpoint's: `solver.krylov_accept` (0.001 there, 0.01 now)"),
        "{}",
        stderr(&out)
    );
    // and a directory without a checkpoint is refused
    let out = run(1, &args(&case, &[], &["--restart", dir.to_str().unwrap()]));
    assert!(!out.status.success());
    assert!(stderr(&out).contains("no checkpoint"), "{}", stderr(&out));
}

/// With checkpointing on, a SIGINT writes a checkpoint of the last converged step (whatever the
/// schedule says) and an output step of it; the restart from the checkpoint ends like an
/// uninterrupted run: the same history.csv and results.h5 (the interrupt's extra output step is
/// not in the checkpoint's copy), and summary.json counts the restart and the whole wall time.
#[test]
fn an_interrupt_writes_a_checkpoint_of_the_last_step() {
    let dir = scratch("restart/sigint");
    let case = case_file(&dir, Some(Q1E4), "");
    let (whole, stopped) = (dir.join("whole"), dir.join("stopped"));
    run_ok(1, &args(&case, &[], &["--out", whole.to_str().unwrap()]));
    let mut a = args(&case, &[], &["--out", stopped.to_str().unwrap()]);
    a.extend(["--checkpoint-every", "100000"]);
    let mut cmd = Command::new(bin());
    cmd.args(&a).stdout(Stdio::null()).stderr(Stdio::null());
    let mut child = cmd.spawn().unwrap();
    let t0 = Instant::now();
    while std::fs::read_to_string(stopped.join("history.csv"))
        .map(|t| t.lines().count() < 2)
        .unwrap_or(true)
    {
        assert!(child.try_wait().unwrap().is_none(), "ended before step 1");
        assert!(t0.elapsed() < Duration::from_secs(120), "no first step");
        std::thread::sleep(Duration::from_millis(1));
    }
    let _ = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status();
    let status = child.wait().unwrap();
    assert_eq!(status.code(), Some(130));
    let n = summary(&stopped)["converged_steps"].as_u64().unwrap();
    assert_eq!(checkpoints(&stopped), vec![format!("step-{n:06}")]);
    let (loads, _) = all_results(&stopped);
    let last_load = *history_col(&stopped, "load_factor").last().unwrap();
    assert_eq!(
        loads.iter().cloned().fold(f64::MIN, f64::max),
        last_load,
        "the interrupted run's results end with its last converged step"
    );
    let wall_stopped = summary(&stopped)["wall_time"]["total"].as_f64().unwrap();
    run_ok(
        1,
        &args(&case, &[], &["--restart", stopped.to_str().unwrap()]),
    );
    let d = compare_runs(&whole, &stopped, true);
    assert!(d <= 1e-12, "difference {d:e}");
    let s = summary(&stopped);
    assert_eq!(s["restarts"], 1);
    let before = s["wall_time"]["before_restart"].as_f64().unwrap();
    // the checkpoint's clock stops a little before the interrupted run's summary is written
    assert!(
        before > 0.0 && before <= wall_stopped,
        "before_restart {before} vs {wall_stopped}"
    );
    assert!(s["wall_time"]["total"].as_f64().unwrap() > before);
}

/// Cohesive contact between two deformable surfaces (material pairings, warm-start projections on
/// a deformable partner, and the contact sparsity pattern, which a restart must rebuild as it was
/// for the same round-off): the double cantilever beam, coarse, on 1 rank.
#[test]
fn cohesive_dcb_killed_and_restarted_equals_an_uninterrupted_run() {
    let (_, d) = kill_and_restart(
        "dcb-np1",
        None,
        "dcb_2d.toml",
        &["stages.0.steps=200"],
        1,
        1,
        "20",
        true,
    );
    assert!(d <= 1e-12, "difference {d:e}");
}

/// A mesh file that changed behind the same path is refused on restart, naming the file; the
/// unchanged file continues.
#[test]
fn a_restart_with_a_changed_mesh_file_is_refused_with_the_file() {
    let dir = scratch("restart/mesh_hash");
    std::fs::create_dir_all(dir.join("meshes")).unwrap();
    std::fs::copy(
        root().join("cases/meshes/box_4x4x4.msh"),
        dir.join("meshes/box_4x4x4.msh"),
    )
    .unwrap();
    let case = dir.join("case.toml");
    std::fs::copy(common::case("block_compression_gmsh_3d.toml"), &case).unwrap();
    let out = dir.join("run");
    let o = out.to_str().unwrap();
    run_ok(
        1,
        &args(&case, &[], &["--out", o, "--checkpoint-every", "1"]),
    );
    assert_eq!(checkpoints(&out), vec!["step-000005".to_string()]);
    run_ok(1, &args(&case, &[], &["--restart", o]));
    assert_eq!(summary(&out)["restarts"], 1);
    let msh = dir.join("meshes/box_4x4x4.msh");
    let mut text = std::fs::read_to_string(&msh).unwrap();
    text.push('\n');
    std::fs::write(&msh, text).unwrap();
    let r = run(1, &args(&case, &[], &["--restart", o]));
    assert!(!r.status.success());
    let e = stderr(&r);
    assert!(
        e.contains("`meshes/box_4x4x4.msh` (`meshes.block`) changed"),
        "{e}"
    );
}

/// Augmented Lagrangian multipliers are load-step history (checkpoint format 2): a restart that
/// lost them would start its next step from zero multipliers and take other rounds and Newton
/// iterations, which this exact comparison sees.
#[test]
fn augmented_multipliers_killed_and_restarted_equal_an_uninterrupted_run() {
    let sets = [
        "contact.0.eps_n=1e2",
        "contact.0.augmented={ tol = 1e-7, max = 50 }",
        "stages.0.steps=30",
        "output.plots=false",
    ];
    let (_, d) = kill_and_restart(
        "augmented-np1",
        None,
        "hertz_2d.toml",
        &sets,
        1,
        1,
        "5",
        true,
    );
    assert!(d <= 1e-12, "difference {d:e}");
}

/// The weighted gap's multipliers live on the control points (rows keyed by global node in the
/// checkpoint): a restart that lost them would take other rounds.
#[test]
fn weighted_gap_multipliers_killed_and_restarted_equal_an_uninterrupted_run() {
    let sets = [
        "contact.0.eps_n=1e2",
        "contact.0.gap=weighted",
        "contact.0.augmented={ tol = 1e-7, max = 50 }",
        "stages.0.steps=30",
        "output.plots=false",
    ];
    let (_, d) = kill_and_restart(
        "weighted-gap-augmented-np1",
        None,
        "hertz_2d.toml",
        &sets,
        1,
        1,
        "5",
        true,
    );
    assert!(d <= 1e-12, "difference {d:e}");
}

/// The secant predictor extrapolates from the two last converged states: a checkpoint keeps the
/// one before the last (`displacement_before`) and the predictor's counters, so that the first
/// step after a restart starts where the uninterrupted run's did (the friction path makes a
/// different start visible: a restart that lost them takes other Newton counts).
#[test]
fn secant_predictor_killed_and_restarted_equals_an_uninterrupted_run() {
    let mut sets = FRICTION.to_vec();
    sets.push("solver.predictor=\"secant\"");
    let (killed, d) = kill_and_restart(
        "predictor-np1",
        None,
        "friction_block_2d.toml",
        &sets,
        1,
        1,
        "8",
        true,
    );
    assert!(d <= 1e-12, "difference {d:e}");
    let ckpt = killed.join("checkpoints").join(&checkpoints(&killed)[0]);
    let f = h5_open(ckpt.join("state.h5")).unwrap();
    let position = f.dataset("position").unwrap().read_raw::<f64>().unwrap();
    assert_eq!(position.len(), 10, "{position:?}");
    // within the sliding stage: the last step's stage and increment are kept
    assert_eq!(position[4], 1.0, "{position:?}");
    assert!(position[5] > 0.0, "{position:?}");
    let before = f
        .dataset("displacement_before")
        .unwrap()
        .read_raw::<f64>()
        .unwrap();
    let now = f
        .dataset("displacement")
        .unwrap()
        .read_raw::<f64>()
        .unwrap();
    assert_eq!(before.len(), now.len());
    assert!(before != now);
}
