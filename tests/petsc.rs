//! The PETSc boundary seen from outside: options pass through with the right precedence, and the
//! matrix is exactly preallocated (PETSc reports 0 mallocs) on both assembly paths.

mod common;
use common::*;

#[test]
fn preallocation_is_exact_with_coo_and_with_matsetvalues_on_2_ranks() {
    for extra in [None, Some("--matsetvalues")] {
        let d = scratch(&format!("mallocs-{}", extra.is_some()));
        let c = case("block_compression_3d.toml");
        let mut args = vec![
            "run",
            c.to_str().unwrap(),
            "--out",
            d.to_str().unwrap(),
            "-q",
            "-info",
            ":mat",
        ];
        args.extend(extra);
        let out = run_ok(2, &args);
        let text = String::from_utf8_lossy(&out.stdout).into_owned() + &stderr(&out);
        let counts: Vec<u64> = text
            .lines()
            .filter_map(|l| {
                l.split("Number of mallocs during MatSetValues() is ")
                    .nth(1)
            })
            .map(|n| n.trim().parse().expect("malloc count"))
            .collect();
        assert!(
            !counts.is_empty(),
            "PETSc printed no malloc report ({extra:?})"
        );
        assert!(
            counts.iter().all(|&n| n == 0),
            "mallocs during assembly {counts:?} ({extra:?})"
        );
    }
}

#[test]
fn command_line_petsc_options_reach_petsc_and_override_the_case() {
    let d = scratch("options");
    // The case caps Newton at one iteration, which cannot converge this nonlinear problem ...
    let text = std::fs::read_to_string(case("block_compression_3d.toml"))
        .unwrap()
        .replace(
            "[output]",
            "[solver]\npetsc_options = \"-snes_max_it 1\"\n\n[steps]\nmax_cutbacks = 2\n\n[output]",
        );
    let p = d.join("case.toml");
    std::fs::write(&p, text).unwrap();
    let out = run(
        1,
        &[
            "run",
            p.to_str().unwrap(),
            "--out",
            d.join("a").to_str().unwrap(),
            "-q",
        ],
    );
    assert!(
        !out.status.success(),
        "one Newton iteration per step should not converge"
    );
    // the rescue (on by default) was tried too, and the message says so
    assert!(
        stderr(&out).contains("minimum increment")
            && stderr(&out).contains("rescue found no equilibrium"),
        "{}",
        stderr(&out)
    );
    // ... and the command line wins over the case file; -snes_monitor prints through PETSc.
    let out = run_ok(
        1,
        &[
            "run",
            p.to_str().unwrap(),
            "--out",
            d.join("b").to_str().unwrap(),
            "-q",
            "-snes_max_it",
            "30",
            "-snes_monitor",
        ],
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.contains("SNES Function norm"),
        "-snes_monitor did not reach PETSc: {stdout}"
    );
}
