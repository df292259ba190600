//! Every shipped case passes `check`; runs write complete results (never a truncated results.h5).

mod common;
use common::*;

#[test]
fn every_case_in_cases_dir_passes_check() {
    let mut n = 0;
    for entry in std::fs::read_dir(root().join("cases")).expect("cases dir") {
        let p = entry.expect("entry").path();
        if p.extension().is_some_and(|e| e == "toml") {
            let out = run(1, &["check", p.to_str().unwrap()]);
            assert!(
                out.status.success(),
                "check {} failed: {}",
                p.display(),
                stderr(&out)
            );
            n += 1;
        }
    }
    assert!(n >= 2, "found only {n} cases");
}

#[test]
fn cases_readme_lists_every_case() {
    let readme = std::fs::read_to_string(root().join("cases/README.md")).expect("cases/README.md");
    for entry in std::fs::read_dir(root().join("cases")).expect("cases dir") {
        let p = entry.expect("entry").path();
        if p.extension().is_some_and(|e| e == "toml") {
            let name = p.file_name().unwrap().to_str().unwrap().to_string();
            assert!(
                readme.contains(&name),
                "cases/README.md does not mention {name}"
            );
        }
    }
}

#[test]
fn results_are_readable_and_complete() {
    let d = scratch("results-complete");
    let c = case("strip_bending_2d.toml");
    run_ok(
        1,
        &[
            "run",
            c.to_str().unwrap(),
            "--out",
            d.to_str().unwrap(),
            "-q",
        ],
    );
    assert_eq!(h5_steps(&d), 8, "one output per converged step");
    let xdmf = std::fs::read_to_string(d.join("results.xdmf")).unwrap();
    assert!(
        xdmf.contains("Quadrilateral")
            && xdmf.contains("results.h5:/steps/000007/bulk/displacement")
    );
    let i1 = h5_last(&d, "bulk", "I1");
    assert_eq!(i1.len(), 80);
    assert!(i1.iter().all(|v| v.is_finite()));
    let s = summary(&d);
    assert_eq!(s["status"], "converged");
    assert_eq!(s["elements"], 80);
    assert!(s["wall_time"]["total"].as_f64().unwrap() > 0.0);
    assert!(!d.join("results.h5.partial").exists());
    // h5dump, a reader independent of our writer, opens it.
    if let Ok(out) = std::process::Command::new("h5dump")
        .args(["-H"])
        .arg(d.join("results.h5"))
        .output()
    {
        assert!(out.status.success(), "h5dump could not read results.h5");
    }
}

#[test]
fn run_killed_while_writing_leaves_no_truncated_results() {
    let d = scratch("killed");
    let c = case("block_compression_3d.toml");
    let mut child = std::process::Command::new(bin())
        .args([
            "run",
            c.to_str().unwrap(),
            "--out",
            d.to_str().unwrap(),
            "-q",
        ])
        .args([
            "--set",
            "meshes.block.divisions=[8,8,8]",
            "--set",
            "stages.0.steps=400",
        ])
        .spawn()
        .expect("start solver");
    // Wait until the writer has started (its partial file exists), then kill it hard.
    let partial = d.join("results.h5.partial");
    let t0 = std::time::Instant::now();
    while !partial.exists() {
        assert!(t0.elapsed().as_secs() < 120, "solver never started writing");
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    std::thread::sleep(std::time::Duration::from_millis(300));
    child.kill().expect("kill");
    let status = child.wait().expect("wait");
    assert!(
        !status.success(),
        "the run finished before it was killed; make it longer"
    );
    assert!(
        !d.join("results.h5").exists(),
        "a killed run left results.h5 behind"
    );
    assert!(
        !d.join("results.xdmf").exists(),
        "a killed run left results.xdmf behind"
    );
    assert!(
        !d.join("summary.json").exists(),
        "a killed run left summary.json behind"
    );
}

/// The shipped block pushed down by 5 (500 % of its height) used to end "converged" with
/// its top face below the clamped base (det J < 0 at element corners, > 0 at every Gauss point).
/// Now the run stops at the first step whose converged states are all folded over, naming the
/// element and the corner, and the output directory holds complete results that end at the last
/// valid step (results, history, checkpoint), on 1 and 2 ranks.
#[test]
fn a_tangled_state_is_never_accepted_and_the_results_end_at_the_last_valid_step() {
    let c = case("block_compression_3d.toml");
    for np in [1, 2] {
        let d = scratch(&format!("tangled-np{np}"));
        let out = run(
            np,
            &[
                "run",
                c.to_str().unwrap(),
                "--out",
                d.to_str().unwrap(),
                "--set",
                "bcs.1.value=[[-5.0]]",
                "--checkpoint-every",
                "1",
            ],
        );
        let err = stderr(&out);
        assert_eq!(out.status.code(), Some(1), "{err}");
        assert!(
            err.contains(
                "the converged state is tangled, an element is folded over: block element"
            ) && err.contains("at corner")
                && !err.contains("results in"),
            "{err}"
        );
        // "the results end at the last valid step, N (load L)"
        let tail = err
            .split("the last valid step, ")
            .nth(1)
            .unwrap_or_else(|| panic!("no last valid step in: {err}"));
        let last_step: usize = tail.split(' ').next().unwrap().parse().unwrap();
        let last_load: f64 = tail
            .split("(load ")
            .nth(1)
            .and_then(|t| t.split(')').next())
            .unwrap()
            .parse()
            .unwrap();
        assert!(last_step >= 1, "{err}");
        // complete files only, and they end at that step
        for f in std::fs::read_dir(&d).unwrap() {
            let name = f.unwrap().file_name().to_string_lossy().into_owned();
            assert!(!name.ends_with(".partial"), "{name} left in {d:?}");
        }
        let steps = history_col(&d, "step");
        let loads = history_col(&d, "load_factor");
        assert_eq!(steps.len(), last_step, "one history row per valid step");
        assert_eq!(*steps.last().unwrap() as usize, last_step);
        assert!((loads.last().unwrap() - last_load).abs() < 1e-6);
        assert_eq!(h5_steps(&d), last_step, "one results step per valid step");
        assert!(h5_last(&d, "bulk", "displacement")
            .iter()
            .all(|v| v.is_finite()));
        let xdmf = std::fs::read_to_string(d.join("results.xdmf")).unwrap();
        assert!(xdmf.contains(&format!("/steps/{:06}/", last_step - 1)));
        assert!(!xdmf.contains(&format!("/steps/{:06}/", last_step)));
        let s = summary(&d);
        assert_eq!(s["status"], "failed", "{s}");
        assert!(s["reason"].as_str().unwrap().contains("tangled"), "{s}");
        // the checkpoint is the last valid step's, complete
        let cps: Vec<String> = std::fs::read_dir(d.join("checkpoints"))
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        assert_eq!(cps, vec![format!("step-{last_step:06}")], "{cps:?}");
    }
}
