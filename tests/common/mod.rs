//! Shared helpers of the integration tests: run the solver binary (optionally under mpirun), read
//! its results back with real readers (HDF5, CSV, JSON).
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The solver binary cargo built for these tests.
pub fn bin() -> &'static str {
    env!("CARGO_BIN_EXE_nurbs-contact")
}

/// The repository root.
pub fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// A case file shipped in `cases/`.
pub fn case(name: &str) -> PathBuf {
    root().join("cases").join(name)
}

/// A fresh scratch directory for one test.
pub fn scratch(name: &str) -> PathBuf {
    let d = root().join("target").join("test-scratch").join(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("create scratch dir");
    d
}

/// The environment Open MPI needs here (root, yield, shared-memory transport).
pub fn mpi_env(cmd: &mut Command) {
    cmd.env("OMPI_ALLOW_RUN_AS_ROOT", "1")
        .env("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1")
        .env("OMPI_MCA_mpi_yield_when_idle", "1")
        .env("OMPI_MCA_btl", "self,vader")
        .env("OMPI_MCA_rmaps_base_oversubscribe", "1");
}

/// Longest a single solver run may take in the tests: a run that exceeds it is treated as a hang
/// (e.g. a rank waiting in a collective call another rank never makes) and fails the test.
const RUN_TIMEOUT: std::time::Duration = std::time::Duration::from_secs(300);

/// Runs `nurbs-contact args...` on `np` ranks (np = 1 runs it directly, without mpirun); kills it
/// and fails the test if it runs past [`RUN_TIMEOUT`].
pub fn run(np: usize, args: &[&str]) -> Output {
    run_with(np, args, None, RUN_TIMEOUT).unwrap_or_else(|| {
        panic!("nurbs-contact {args:?} on {np} ranks did not finish in {RUN_TIMEOUT:?}: a hang?")
    })
}

/// [`run`] in the working directory `cwd` (default: the test's), with its own time limit; `None`
/// if it had to be killed at the limit.
pub fn run_with(
    np: usize,
    args: &[&str],
    cwd: Option<&Path>,
    timeout: std::time::Duration,
) -> Option<Output> {
    run_with_env(np, args, cwd, timeout, &[])
}

/// [`run_with`] with extra environment variables (inherited by every rank).
pub fn run_with_env(
    np: usize,
    args: &[&str],
    cwd: Option<&Path>,
    timeout: std::time::Duration,
    env: &[(&str, &str)],
) -> Option<Output> {
    use std::io::Read;
    let mut cmd = if np == 1 {
        Command::new(bin())
    } else {
        let mut c = Command::new("mpirun");
        c.args(["--oversubscribe", "-np", &np.to_string(), bin()]);
        c
    };
    cmd.args(args)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped());
    mpi_env(&mut cmd);
    cmd.envs(env.iter().copied());
    if let Some(dir) = cwd {
        cmd.current_dir(dir);
    }
    let mut child = cmd.spawn().expect("failed to start nurbs-contact");
    // Drain both pipes on threads so a chatty run cannot block on a full pipe.
    let mut out_pipe = child.stdout.take().expect("stdout pipe");
    let mut err_pipe = child.stderr.take().expect("stderr pipe");
    let out_t = std::thread::spawn(move || {
        let mut b = Vec::new();
        let _ = out_pipe.read_to_end(&mut b);
        b
    });
    let err_t = std::thread::spawn(move || {
        let mut b = Vec::new();
        let _ = err_pipe.read_to_end(&mut b);
        b
    });
    let t0 = std::time::Instant::now();
    let status = loop {
        if let Some(st) = child.try_wait().expect("wait for nurbs-contact") {
            break st;
        }
        if t0.elapsed() > timeout {
            let _ = child.kill();
            let _ = child.wait();
            return None;
        }
        std::thread::sleep(std::time::Duration::from_millis(10));
    };
    Some(Output {
        status,
        stdout: out_t.join().unwrap_or_default(),
        stderr: err_t.join().unwrap_or_default(),
    })
}

/// Runs and asserts success, printing the output otherwise.
pub fn run_ok(np: usize, args: &[&str]) -> Output {
    let out = run(np, args);
    assert!(
        out.status.success(),
        "nurbs-contact {args:?} on {np} ranks failed:\nstdout:\n{}\nstderr:\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

/// The stderr of a run as text.
pub fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// The ratios `||J - Jfd||_F / ||J||_F` that PETSc's `-snes_test_jacobian` printed on a run's
/// standard output, one per Newton iterate, in order.
pub fn jacobian_check_ratios(out: &Output) -> Vec<f64> {
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .filter_map(|l| l.split("||J - Jfd||_F/||J||_F = ").nth(1))
        .map(|r| {
            r.split(',')
                .next()
                .unwrap()
                .trim()
                .parse()
                .expect("a ratio")
        })
        .collect()
}

/// Opens an HDF5 file read-only without HDF5's file lock. A run spawned by another test while the
/// file is open inherits its descriptor (HDF5 does not open with close-on-exec), and a lock held
/// through that descriptor outlives the test's own close: a later run's open of the file would
/// then fail ("unable to lock file").
pub fn h5_open(path: impl AsRef<Path>) -> hdf5::Result<hdf5::File> {
    hdf5::File::with_options()
        .with_fapl(|p| p.file_locking(false))
        .open(path)
}

/// [`h5_open`] for reading and writing.
pub fn h5_open_rw(path: impl AsRef<Path>) -> hdf5::Result<hdf5::File> {
    hdf5::File::with_options()
        .with_fapl(|p| p.file_locking(false))
        .open_rw(path)
}

/// Number of output steps in a results.h5.
pub fn h5_steps(dir: &Path) -> usize {
    let f = h5_open(dir.join("results.h5")).expect("open results.h5");
    f.group("steps")
        .expect("steps group")
        .member_names()
        .expect("members")
        .len()
}

/// A dataset of the last output step of grid `grid`, flattened.
pub fn h5_last(dir: &Path, grid: &str, field: &str) -> Vec<f64> {
    let f = h5_open(dir.join("results.h5")).expect("open results.h5");
    let steps = f.group("steps").expect("steps group");
    let mut names = steps.member_names().expect("members");
    names.sort_by_key(|n| n.parse::<usize>().unwrap_or(0));
    let last = names.last().expect("at least one step");
    let ds = steps
        .dataset(&format!("{last}/{grid}/{field}"))
        .unwrap_or_else(|e| panic!("dataset {last}/{grid}/{field}: {e}"));
    ds.read_raw::<f64>().expect("read dataset")
}

/// The columns of history.csv by header name.
pub fn history(dir: &Path) -> Vec<(String, Vec<f64>)> {
    let text = std::fs::read_to_string(dir.join("history.csv")).expect("read history.csv");
    let mut lines = text.lines();
    let header: Vec<String> = lines
        .next()
        .expect("header")
        .split(',')
        .map(str::to_string)
        .collect();
    let mut cols: Vec<Vec<f64>> = vec![Vec::new(); header.len()];
    for l in lines {
        for (c, v) in l.split(',').enumerate() {
            cols[c].push(v.parse().expect("number in history.csv"));
        }
    }
    header.into_iter().zip(cols).collect()
}

/// Every history column except the wall time and the active-point counts, flattened, for rank
/// comparisons.
pub fn history_values(dir: &Path) -> Vec<f64> {
    history(dir)
        .into_iter()
        .filter(|(h, _)| h != "wall_time" && !h.starts_with("active_"))
        .flat_map(|(_, v)| v)
        .collect()
}

/// One column of history.csv.
pub fn history_col(dir: &Path, name: &str) -> Vec<f64> {
    history(dir)
        .into_iter()
        .find(|(h, _)| h == name)
        .unwrap_or_else(|| panic!("no column {name} in history.csv"))
        .1
}

/// summary.json as a JSON value.
pub fn summary(dir: &Path) -> serde_json::Value {
    let text = std::fs::read_to_string(dir.join("summary.json")).expect("read summary.json");
    serde_json::from_str(&text).expect("parse summary.json")
}

/// A per-rank list of summary.json's `section` (e.g. `contact_data`, `partition`) as integers.
pub fn summary_list(s: &serde_json::Value, section: &str, key: &str) -> Vec<u64> {
    s[section][key]
        .as_array()
        .unwrap_or_else(|| panic!("{section}.{key} missing: {s}"))
        .iter()
        .map(|v| v.as_u64().unwrap())
        .collect()
}

/// max |a - b| / max |a|.
pub fn rel_diff(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len(), "compared fields differ in length");
    let scale = a.iter().fold(0.0f64, |m, x| m.max(x.abs())).max(1e-300);
    a.iter()
        .zip(b)
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()))
        / scale
}

/// Runs `cases/<case>` on `np` ranks into a fresh scratch directory `name` with `--set` overrides
/// (quiet, overwriting), asserts success, and returns the output directory.
pub fn run_case(name: &str, case_file: &str, np: usize, sets: &[&str]) -> PathBuf {
    run_case_with(name, case_file, np, sets, &[])
}

/// [`run_case`] with further command-line arguments after the `--set`s (e.g. PETSc options).
pub fn run_case_with(
    name: &str,
    case_file: &str,
    np: usize,
    sets: &[&str],
    extra: &[&str],
) -> PathBuf {
    let (d, c) = (scratch(name), case(case_file));
    run_ok(np, &case_args(&c, &d, sets, extra));
    d
}

/// A run of `case_file` into a fresh scratch directory `name` that may fail: the directory and
/// the process's output (for tests of refused or failing runs).
pub fn run_case_output(name: &str, case_file: &str, np: usize, sets: &[&str]) -> (PathBuf, Output) {
    run_case_output_with(name, case_file, np, sets, &[])
}

/// [`run_case_output`] with further command-line arguments after the `--set`s (e.g. PETSc
/// options whose report the test reads from the output).
pub fn run_case_output_with(
    name: &str,
    case_file: &str,
    np: usize,
    sets: &[&str],
    extra: &[&str],
) -> (PathBuf, Output) {
    let (d, c) = (scratch(name), case(case_file));
    let out = run(np, &case_args(&c, &d, sets, extra));
    (d, out)
}

/// `run CASE --out DIR -q --overwrite --set S ... EXTRA...`
pub fn case_args<'a>(
    c: &'a Path,
    d: &'a Path,
    sets: &[&'a str],
    extra: &[&'a str],
) -> Vec<&'a str> {
    let mut args = vec![
        "run",
        c.to_str().unwrap(),
        "--out",
        d.to_str().unwrap(),
        "-q",
        "--overwrite",
    ];
    for s in sets {
        args.extend(["--set", *s]);
    }
    args.extend_from_slice(extra);
    args
}

/// The last value of a history.csv column (the last converged step).
pub fn last(dir: &Path, col: &str) -> f64 {
    *history_col(dir, col).last().expect("a converged step")
}

/// Parses a CSV with quoted cells (the reasons hold commas) into header and rows.
pub fn read_csv(path: &Path) -> (Vec<String>, Vec<Vec<String>>) {
    let text = std::fs::read_to_string(path).expect("read csv");
    let mut rows = Vec::new();
    for line in text.lines() {
        let mut cells = Vec::new();
        let mut cur = String::new();
        let mut quoted = false;
        let mut chars = line.chars().peekable();
        while let Some(c) = chars.next() {
            match c {
                '"' if quoted && chars.peek() == Some(&'"') => {
                    cur.push('"');
                    chars.next();
                }
                '"' => quoted = !quoted,
                ',' if !quoted => cells.push(std::mem::take(&mut cur)),
                _ => cur.push(c),
            }
        }
        cells.push(cur);
        rows.push(cells);
    }
    let header = rows.remove(0);
    (header, rows)
}

/// study.csv rows by run name, each a map column -> cell.
pub fn study_rows(
    out: &Path,
) -> std::collections::HashMap<String, std::collections::HashMap<String, String>> {
    let (header, rows) = read_csv(&out.join("study.csv"));
    rows.into_iter()
        .map(|r| {
            assert_eq!(r.len(), header.len(), "row {r:?}");
            let m: std::collections::HashMap<String, String> =
                header.iter().cloned().zip(r).collect();
            (m["run"].clone(), m)
        })
        .collect()
}

/// Hertz, 2D (`hertz_2d.toml`): the disk's family and mesh `n_arc` (radial `n_arc / 4`) on `np`
/// ranks with further `--set` overrides. Returns the peaks of the current and nominal L2-projected
/// pressures and the load (checked against the disk's reaction).
pub fn hertz_peaks_with(family: &str, n_arc: usize, np: usize, extra: &[&str]) -> (f64, f64, f64) {
    let mut sets = vec![
        format!("bodies.disk.element={family}"),
        format!("meshes.disk.n_arc={n_arc}"),
        format!("meshes.disk.n_radial={}", n_arc / 4),
    ];
    sets.extend(extra.iter().map(|s| s.to_string()));
    let sets: Vec<&str> = sets.iter().map(String::as_str).collect();
    let tag = extra.join("-").replace(['=', '.'], "_");
    let d = run_case(
        &format!("hertz-{family}-{n_arc}-np{np}-{tag}"),
        "hertz_2d.toml",
        np,
        &sets,
    );
    let grid = if family == "Q1C1" { "bulk" } else { "surface" };
    let max = |v: Vec<f64>| v.iter().fold(f64::MIN, |m, &x| m.max(x));
    let peak = max(h5_last(&d, grid, "contact_pressure"));
    let peak_nominal = max(h5_last(&d, grid, "contact_pressure_nominal"));
    let load = last(&d, "P_flat_disk_arc_y");
    let r = last(&d, "R_disk_top_y");
    assert!(
        (load + r).abs() < 1e-8 * load,
        "contact force {load} vs reaction {r}"
    );
    (peak, peak_nominal, load)
}

/// Relative error of a peak pressure against Hertz's p0 for load `p` (R = 1, E = 1, nu = 0.3).
pub fn hertz_error(peak: f64, p: f64) -> f64 {
    let e_star = 1.0 / (1.0 - 0.3f64 * 0.3);
    let a = (4.0 * p / (std::f64::consts::PI * e_star)).sqrt();
    let p0 = 2.0 * p / (std::f64::consts::PI * a);
    (peak - p0) / p0
}
