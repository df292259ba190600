//! Checkpoints are checked on read: a `state.h5` whose position, step size or fields no run of the
//! case can have written (a load outside its stage, a stage beyond the case's, a negative
//! increment, a non-finite or rescaled displacement, a contact pattern naming an element the
//! surface does not have), or that is missing, stops the restart with an
//! error naming the file and the dataset as a bad checkpoint; nothing is continued from it, and
//! the run directory is left as it was. The checkpoints are corrupted here with the crate's own
//! HDF5 binding.

mod common;
use common::*;
use std::path::{Path, PathBuf};

/// Runs the frictional block of cases/ (2 stages, 12 steps) with a checkpoint at step 8 into
/// `dir/run` and returns the run directory and its checkpoint's state.h5.
fn checkpointed_run(name: &str) -> (PathBuf, PathBuf) {
    let dir = scratch(&format!("bad_checkpoints/{name}"));
    let out = dir.join("run");
    run_ok(
        1,
        &[
            "run",
            case("friction_block_2d.toml").to_str().unwrap(),
            "-q",
            "--out",
            out.to_str().unwrap(),
            "--checkpoint-every",
            "8",
            "--set",
            "output.plots=false",
        ],
    );
    let state = out.join("checkpoints/step-000008/state.h5");
    assert!(state.is_file(), "no checkpoint at step 8");
    (out, state)
}

/// Rewrites the dataset `name` of `state` (same length) through `change`.
fn corrupt(state: &Path, name: &str, change: impl FnOnce(&mut Vec<f64>)) {
    let f = h5_open_rw(state).unwrap();
    let d = f.dataset(name).unwrap();
    let mut v: Vec<f64> = d.read_raw().unwrap();
    change(&mut v);
    d.write_raw(&v).unwrap();
}

/// Restarts from `out` on `np` ranks; asserts the restart fails without a panic, naming the
/// checkpoint's file and `dataset` as a bad checkpoint, and leaves the run's files as they were.
/// Returns the message.
fn refused(np: usize, out: &Path, dataset: &str) -> String {
    let before = std::fs::read(out.join("history.csv")).unwrap();
    let summary_before = std::fs::read(out.join("summary.json")).unwrap();
    let o = run(
        np,
        &[
            "run",
            case("friction_block_2d.toml").to_str().unwrap(),
            "-q",
            "--restart",
            out.to_str().unwrap(),
            "--set",
            "output.plots=false",
        ],
    );
    let err = stderr(&o);
    assert!(
        !o.status.success(),
        "a bad checkpoint was continued:\n{err}"
    );
    assert!(!err.contains("panicked"), "{err}");
    assert!(err.contains("a bad checkpoint"), "{err}");
    assert!(
        err.contains("step-000008/state.h5"),
        "no file named:\n{err}"
    );
    assert!(err.contains(&format!("`{dataset}`")), "no dataset:\n{err}");
    assert!(
        !err.contains("writing"),
        "a read error called writing:\n{err}"
    );
    assert_eq!(std::fs::read(out.join("history.csv")).unwrap(), before);
    assert_eq!(
        std::fs::read(out.join("summary.json")).unwrap(),
        summary_before
    );
    err
}

#[test]
fn a_position_out_of_every_range_is_a_bad_checkpoint() {
    let (out, state) = checkpointed_run("position");
    corrupt(&state, "position", |p| {
        p[..4].copy_from_slice(&[1e20, 99.0, f64::NAN, f64::NAN])
    });
    let err = refused(1, &out, "position");
    assert!(err.contains("NaN"), "{err}");
}

#[test]
fn a_stage_beyond_the_case_is_a_bad_checkpoint() {
    let (out, state) = checkpointed_run("stage");
    corrupt(&state, "position", |p| p[1] = 7.0);
    let err = refused(1, &out, "position");
    assert!(
        err.contains("the stage 7 is beyond the case's 2 stages"),
        "{err}"
    );
}

#[test]
fn a_negative_step_size_is_a_bad_checkpoint_on_2_ranks() {
    let (out, state) = checkpointed_run("step_size");
    corrupt(&state, "position", |p| p[3] = -0.1);
    let err = refused(2, &out, "position");
    assert!(err.contains("load increment -0.1"), "{err}");
}

#[test]
fn a_nan_displacement_is_a_bad_checkpoint() {
    let (out, state) = checkpointed_run("nan");
    corrupt(&state, "displacement", |u| u[17] = f64::NAN);
    let err = refused(1, &out, "displacement");
    assert!(err.contains("value 17 is NaN"), "{err}");
}

#[test]
fn a_scaled_displacement_is_a_bad_checkpoint_on_1_and_2_ranks() {
    let (out, state) = checkpointed_run("scaled");
    corrupt(&state, "displacement", |u| {
        u.iter_mut().for_each(|v| *v *= 3.0)
    });
    for np in [1, 2] {
        let err = refused(np, &out, "displacement");
        assert!(err.contains("the boundary conditions prescribe"), "{err}");
    }
}

#[test]
fn a_missing_state_is_a_bad_checkpoint_read_not_written() {
    let (out, state) = checkpointed_run("missing");
    std::fs::remove_file(&state).unwrap();
    let before = std::fs::read(out.join("history.csv")).unwrap();
    let o = run(
        1,
        &[
            "run",
            case("friction_block_2d.toml").to_str().unwrap(),
            "-q",
            "--restart",
            out.to_str().unwrap(),
        ],
    );
    let err = stderr(&o);
    assert!(!o.status.success(), "{err}");
    assert!(err.contains("a bad checkpoint"), "{err}");
    assert!(err.contains("has no state.h5"), "{err}");
    assert!(!err.contains("writing"), "{err}");
    assert_eq!(std::fs::read(out.join("history.csv")).unwrap(), before);
}

#[test]
fn a_contact_pattern_naming_an_element_beyond_the_surface_is_a_bad_checkpoint() {
    let (out, state) = checkpointed_run("pattern");
    // the first coupling's columns: an element of its own surface (the key's bit 31) that the
    // surface does not have
    corrupt(&state, "contact_pattern", |p| {
        p[2] = f64::from((1u32 << 31) + 9999)
    });
    let err = refused(1, &out, "contact_pattern");
    assert!(err.contains("element 9999"), "{err}");
}
