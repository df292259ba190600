//! Convergence is the run's judgement, not a PETSc option's side effect: after every solve SNES
//! calls converged, the load stepping evaluates the residual at the solution itself and accepts the
//! step only when it is small against the step's force scale. `-snes_atol 1e10` (every start
//! "converges" in 0 iterations) and `-snes_max_it 0` end the run with an error naming the option;
//! `-snes_type ksponly` (one linear solve per step), on the command line or through an options
//! file, is accepted only where the linear solve reached the run's tolerance, so its reactions are
//! Newton's, and the residual it reports is the one evaluated at the solution.

mod common;
use common::*;

/// Runs a shipped case with extra arguments on `np` ranks into a fresh directory.
fn run_case(
    np: usize,
    name: &str,
    shipped: &str,
    extra: &[&str],
) -> (std::process::Output, std::path::PathBuf) {
    let dir = scratch(&format!("convergence_judgement/{name}"));
    let out = dir.join("out");
    let case = case(shipped);
    let mut a = vec![
        "run",
        case.to_str().unwrap(),
        "-q",
        "--out",
        out.to_str().unwrap(),
        "--set",
        "output.plots=false",
    ];
    a.extend_from_slice(extra);
    (run(np, &a), out)
}

fn refused_naming(np: usize, name: &str, option: &str) {
    let (o, _) = run_case(
        np,
        name,
        "hertz_2d.toml",
        &option.split(' ').collect::<Vec<_>>(),
    );
    let err = stderr(&o);
    assert!(
        !o.status.success(),
        "{option} produced a converged run:\n{err}"
    );
    assert!(!err.contains("panicked"), "{err}");
    assert!(
        err.contains(&format!("`{option}` (set on the command line)")),
        "the error does not name {option}:\n{err}"
    );
}

#[test]
fn an_absurd_snes_atol_cannot_converge_and_is_named_on_1_and_2_ranks() {
    refused_naming(1, "atol1", "-snes_atol 1e10");
    refused_naming(2, "atol2", "-snes_atol 1e10");
    let (o, _) = run_case(1, "atol_msg", "hertz_2d.toml", &["-snes_atol", "1e10"]);
    let err = stderr(&o);
    assert!(
        err.contains(
            "SNES reported CONVERGED_FNORM_ABS after 0 Newton iterations, but the residual norm"
        ),
        "{err}"
    );
}

#[test]
fn snes_max_it_0_fails_naming_the_option() {
    refused_naming(1, "max_it", "-snes_max_it 0");
}

#[test]
fn ksponly_steps_are_accepted_only_at_newtons_answer() {
    let (o, newton) = run_case(1, "newton", "contact_patch_3d.toml", &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let r_newton = *history_col(&newton, "R_upper_zmax_z").last().unwrap();
    let dir = scratch("convergence_judgement/options_file");
    let file = dir.join("ksponly.opts");
    std::fs::write(&file, "-snes_type ksponly\n").unwrap();
    let via_file = ["-options_file", file.to_str().unwrap()];
    for (name, extra) in [
        ("ksponly", &["-snes_type", "ksponly"][..]),
        ("ksponly_file", &via_file[..]),
    ] {
        let (o, out) = run_case(1, name, "contact_patch_3d.toml", extra);
        let err = stderr(&o);
        assert!(!err.contains("panicked"), "{err}");
        if !o.status.success() {
            // refused altogether: the error names the option
            assert!(err.contains("-snes_type ksponly"), "{err}");
            continue;
        }
        let r = history_col(&out, "R_upper_zmax_z");
        let res = history_col(&out, "residual");
        let last = *r.last().unwrap();
        assert!(
            (last - r_newton).abs() <= 1e-5 * r_newton.abs(),
            "{name}: reaction {last} where Newton gives {r_newton}"
        );
        // every step's reaction is that of its own state (not 0 from a residual never evaluated
        // there) and its residual the one evaluated at the solution
        assert!(r.iter().all(|&v| v < 0.0), "{name}: {r:?}");
        assert!(res.iter().all(|&v| v > 0.0), "{name}: residuals {res:?}");
    }
}

/// Tolerances tightened below what round-off allows (`-snes_atol`, `-snes_rtol` and
/// `-snes_stol` at 1e-30) leave every solve iterating at the residual's floor until the
/// stagnation test or the iteration limit stops it; the state it stops at meets the default
/// tolerances and is accepted as converged: no step is cut back and the answer is the default
/// run's. Without that, each such solve would be a failed attempt and the run would end in
/// cutbacks.
#[test]
fn a_solve_stopped_at_the_round_off_floor_is_converged_on_1_and_2_ranks() {
    let (o, default) = run_case(1, "floor_default", "hertz_2d.toml", &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let tight = [
        "-snes_atol",
        "1e-30",
        "-snes_rtol",
        "1e-30",
        "-snes_stol",
        "1e-30",
    ];
    let p_default = history_col(&default, "R_disk_top_y");
    let steps_default = summary(&default)["newton"]["steps"].as_u64().unwrap();
    for np in [1, 2] {
        let (o, out) = run_case(np, &format!("floor_tight_np{np}"), "hertz_2d.toml", &tight);
        let err = stderr(&o);
        assert!(o.status.success(), "np {np}:\n{err}");
        let s = summary(&out);
        assert_eq!(
            s["newton"]["steps"].as_u64().unwrap(),
            steps_default,
            "np {np}"
        );
        assert_eq!(
            s["newton"]["failed_iterations"].as_u64().unwrap(),
            0,
            "np {np}"
        );
        assert!(
            history_col(&out, "cutbacks").iter().all(|&c| c == 0.0),
            "np {np}"
        );
        let p = history_col(&out, "R_disk_top_y");
        assert_eq!(p.len(), p_default.len());
        for (a, b) in p.iter().zip(&p_default) {
            assert!(
                (a - b).abs() <= 1e-9 * b.abs().max(1e-300),
                "np {np}: {a} against {b}"
            );
        }
    }
}
