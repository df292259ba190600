//! Augmented Lagrangian enforcement of penalty contact (`augmented = { tol, max }`): on
//! the Hertz case (a half disk pressed onto a rigid flat) the contact force no longer depends on
//! the penalty, the penetration ends below `tol`, the rounds are counted in history.csv and
//! summary.json, 2 ranks give the 1-rank answer, a pair that runs out of rounds is cut back and
//! then named, and bad settings are named by key.

mod common;
use common::*;

const AL: &str = "contact.0.augmented={ tol = 1e-7, max = 50 }";

fn hertz(name: &str, np: usize, eps_n: &str, augmented: bool) -> std::path::PathBuf {
    let eps = format!("contact.0.eps_n={eps_n}");
    let mut sets = vec![eps.as_str(), "output.plots=false"];
    if augmented {
        sets.push(AL);
    }
    run_case(&format!("augmented/{name}"), "hertz_2d.toml", np, &sets)
}

#[test]
fn hertz_force_does_not_depend_on_the_penalty_and_rounds_are_counted() {
    let soft = hertz("soft", 1, "1e2", true);
    let stiff = hertz("stiff", 1, "1e4", true);
    let plain = hertz("plain", 1, "1e2", false);
    let (p_soft, p_stiff, p_plain) = (
        last(&soft, "P_flat_disk_arc_y"),
        last(&stiff, "P_flat_disk_arc_y"),
        last(&plain, "P_flat_disk_arc_y"),
    );
    eprintln!("P_y: augmented eps 1e2 {p_soft:.9e}, 1e4 {p_stiff:.9e}; penalty 1e2 {p_plain:.9e}");
    // measured: 8.70706e-3 and 8.70709e-3 (3e-6 apart); the plain penalty at 1e2: 8.400e-3
    assert!(
        (p_soft - p_stiff).abs() <= 1e-4 * p_stiff,
        "{p_soft} vs {p_stiff}"
    );
    assert!(
        (p_plain - p_stiff).abs() >= 1e-2 * p_stiff,
        "the plain penalty at 1e2 should be visibly softer: {p_plain} vs {p_stiff}"
    );
    for d in [&soft, &stiff] {
        for pen in history_col(d, "penetration_flat_disk_arc") {
            assert!(
                pen <= 1e-7,
                "penetration {pen} above tol in {}",
                d.display()
            );
        }
    }
    assert!(last(&plain, "penetration_flat_disk_arc") > 1e-5);
    // the soft penalty needs several rounds per step; the history and the summary agree
    let rounds = history_col(&soft, "augmentation_rounds");
    assert!(rounds.iter().all(|&r| r >= 2.0), "{rounds:?}");
    let s = summary(&soft);
    let logged: Vec<f64> = s["steps"]
        .as_array()
        .unwrap()
        .iter()
        .map(|st| st["augmentation_rounds"].as_f64().unwrap_or(0.0))
        .collect();
    assert_eq!(logged, rounds);
    // a run without augmentation has no such column
    assert!(!history(&plain)
        .iter()
        .any(|(n, _)| n == "augmentation_rounds"));
}

#[test]
fn two_ranks_give_the_one_rank_answer() {
    let one = hertz("np1", 1, "1e2", true);
    let two = hertz("np2", 2, "1e2", true);
    for col in [
        "P_flat_disk_arc_y",
        "R_disk_top_y",
        "augmentation_rounds",
        "penetration_flat_disk_arc",
    ] {
        let (a, b) = (history_col(&one, col), history_col(&two, col));
        let d = rel_diff(&a, &b);
        assert!(d <= 1e-8, "{col}: 1 rank {a:?}, 2 ranks {b:?}");
    }
}

#[test]
fn a_pair_out_of_rounds_is_cut_back_then_named() {
    let (_, out) = run_case_output(
        "augmented/exhausted",
        "hertz_2d.toml",
        1,
        &[
            "contact.0.eps_n=1e2",
            "contact.0.augmented={ tol = 1e-13, max = 1 }",
            "steps.max_cutbacks=1",
            "steps.pseudo_steps=0",
            "output.plots=false",
        ],
    );
    let err = stderr(&out);
    assert!(!out.status.success(), "{err}");
    assert!(
        err.contains("contact `flat`") && err.contains("augmented Lagrangian left a violation"),
        "{err}"
    );
    assert!(err.contains("cutback"), "{err}");
}

#[test]
fn bad_settings_are_named_by_key() {
    let c = case("hertz_2d.toml");
    // the Hertz pair with van der Waals adhesion instead of the penalty law
    let text = std::fs::read_to_string(&c).unwrap();
    assert!(text.contains("law = \"penalty\"\neps_n = 1e4"));
    let vdw = scratch("augmented/vdw").join("hertz_vdw.toml");
    std::fs::write(
        &vdw,
        text.replace(
            "law = \"penalty\"\neps_n = 1e4",
            "law = \"van_der_waals\"\na_h = 1e-3\nr0 = 0.1",
        ),
    )
    .unwrap();
    let out = run(1, &["check", vdw.to_str().unwrap()]);
    assert!(out.status.success(), "{}", stderr(&out));
    let out = run(1, &["check", vdw.to_str().unwrap(), "--set", AL]);
    let err = stderr(&out);
    assert!(
        !out.status.success() && err.contains("contact.0.augmented"),
        "{err}"
    );
    assert!(err.contains("`penalty` law only"), "{err}");
    for (sets, key) in [
        (
            vec!["contact.0.augmented={ tol = 0.0, max = 5 }"],
            "contact.0.augmented.tol",
        ),
        (
            vec!["contact.0.augmented={ tol = 1e-6, max = 0 }"],
            "contact.0.augmented.max",
        ),
        (
            vec![AL, "contact.0.gap=\"element_mean\""],
            "contact.0.augmented",
        ),
        (
            vec![AL, "contact.0.gap=\"weighted_mean\""],
            "contact.0.augmented",
        ),
        (
            vec!["contact.0.augmented={ tol = 1e-6, max = 5, rounds = 3 }"],
            "rounds",
        ),
    ] {
        let mut args = vec!["check", c.to_str().unwrap()];
        for s in &sets {
            args.extend(["--set", s]);
        }
        let out = run(1, &args);
        let err = stderr(&out);
        assert!(!out.status.success(), "{sets:?} passed the check");
        assert!(err.contains(key), "{sets:?}: {err}");
        assert!(!err.contains("panicked"), "{err}");
    }
}

/// Two deformable Q1C1 bodies in 2D with Coulomb friction (their default formulation is the paper's
/// two half-passes): the augmented pair converges, each half-pass's
/// penetration ends below `tol`, and rounds are made (measured: one round in 21 of 46 steps).
#[test]
fn two_deformable_bodies_with_friction_meet_the_tolerance() {
    let d = run_case(
        "augmented/slide",
        "sliding_flat_2d.toml",
        1,
        &[
            "contact.0.mu=0.3",
            "contact.0.friction_stages=[false, true]",
            "contact.0.augmented={ tol = 1e-6, max = 30 }",
            "output.plots=false",
        ],
    );
    assert_eq!(summary(&d)["status"], "converged");
    for col in [
        "penetration_slide_upper_bottom",
        "penetration_slide_lower_top",
    ] {
        let pen = history_col(&d, col);
        assert!(pen.iter().all(|&p| p <= 1e-6), "{col}: {pen:?}");
    }
    let rounds = history_col(&d, "augmentation_rounds");
    assert!(rounds.iter().any(|&r| r >= 1.0), "{rounds:?}");
}

/// One-pass (the slave's points, or with the mortar gap its control points, carry the
/// multipliers; the master takes the opposite traction): on the non-matching contact patch at two
/// penalties 10x apart, every step makes rounds, ends with the slave's penetration (pointwise)
/// within `tol`, and the reaction no longer depends on the penalty (measured: the plain penalty
/// at 1e3 and 1e4 gives reactions 5.3e-4 apart (pointwise and mortar), the augmented pair 3e-11
/// (pointwise) and 1.6e-9 (mortar: its control points' weighted gaps are within `tol`, its points'
/// gaps still vary by 8e-6 about them on the non-matching master)).
#[test]
fn one_pass_meets_the_tolerance_and_drops_the_penalty() {
    for gap in ["pointwise", "weighted"] {
        let mut r = Vec::new();
        for eps in ["1e3", "1e4"] {
            let d = run_case(
                &format!("augmented/one-pass-{gap}-{eps}"),
                "contact_patch_2d.toml",
                1,
                &[
                    "contact.0.algorithm=one_pass",
                    &format!("contact.0.gap={gap}"),
                    &format!("contact.0.eps_n={eps}"),
                    "contact.0.augmented={ tol = 1e-9, max = 50 }",
                    // the case's `-snes_atol 1e-13` lies below this solve's round-off floor
                    // (residual norms 4e-13 to 3e-12 at the converged iterates, `-snes_monitor`),
                    // where only the step test ends a solve, by chance within the stagnation
                    // window or not: an absolute tolerance above the floor
                    "solver.petsc_options=\"-snes_rtol 1e-14 -snes_atol 1e-11\"",
                    "output.plots=false",
                ],
            );
            assert_eq!(summary(&d)["status"], "converged");
            if gap == "pointwise" {
                let pen = history_col(&d, "penetration_patch_upper_bottom");
                assert!(pen.iter().all(|&p| p <= 1e-9), "{gap} {eps}: {pen:?}");
            }
            let rounds = history_col(&d, "augmentation_rounds");
            assert!(rounds.iter().all(|&n| n >= 1.0), "{gap} {eps}: {rounds:?}");
            r.push(last(&d, "R_upper_top_y"));
        }
        let rel = (r[0] - r[1]).abs() / r[1].abs();
        assert!(rel < 1e-7, "{gap}: reactions {r:?} differ by {rel:e}");
    }
}
