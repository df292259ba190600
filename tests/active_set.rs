//! Newton at the kink of the penalty law (REPRODUCTION.md 4.1): a faceted (Q1C1) block pressed by
//! a smooth (Q1N2) cylinder with two-half-pass penalty contact has block points that sit at
//! `g_n = 0` during the depression; plain Newton cycles there (active, inactive, active, ...) until
//! its iteration limit at every increment, and the active-set stabilisation
//! (`solver.contact_freeze_after`) converges the same steps on the law's own active set.
mod common;
use common::*;

/// The ironing scene (mesh 4, Q1C1 block, Q1N2 cylinder) pressed to 0.4 of its depth in 8 steps
/// (the first 8 depression steps of the case), then one step without motion: that step's initial
/// residual is the plain law's residual at the state the last depression step converged to.
fn kink_sets(freeze_after: usize) -> Vec<String> {
    vec![
        "bodies.block.element=Q1C1".into(),
        "bodies.cylinder.element=Q1N2".into(),
        "steps.pseudo_steps=0".into(),
        "bcs.1.value=[[0.0, -0.26666666666666666], [0.0, -0.26666666666666666]]".into(),
        "stages.0.steps=8".into(),
        "stages.1.steps=1".into(),
        // the cycling is that of Newton started from the converged state (the secant predictor
        // starts the kink's step elsewhere, and plain Newton gets through it)
        "solver.predictor=none".into(),
        format!("solver.contact_freeze_after={freeze_after}"),
    ]
}

fn args<'a>(dir: &'a str, case: &'a str, sets: &'a [String]) -> Vec<&'a str> {
    let mut a = vec!["run", case, "--out", dir, "-q", "--overwrite"];
    for s in sets {
        a.extend(["--set", s.as_str()]);
    }
    a
}

#[test]
fn newton_cycling_at_the_penalty_kink_is_cured_by_freezing_the_active_set_on_1_and_2_ranks() {
    let case = case("ironing_2d.toml");
    let case = case.to_str().unwrap();
    let limit = std::time::Duration::from_secs(300);
    // plain Newton: the step to 0.38 of the depth cycles at every increment down to the minimum,
    // each attempt until the stagnation stop (`solver.stagnation_window`, default 10) or, with
    // that off, until the iteration limit
    for (window, reason) in [(10, "DIVERGED_STAGNATION"), (0, "DIVERGED_MAX_IT")] {
        let plain = scratch(&format!("kink-plain-{window}"));
        let mut sets = kink_sets(0);
        sets.push(format!("solver.stagnation_window={window}"));
        let out = run(1, &args(plain.to_str().unwrap(), case, &sets));
        assert!(!out.status.success(), "plain Newton got through the kink");
        assert!(stderr(&out).contains(reason), "{}", stderr(&out));
    }
    // stabilised: every step converges without a cutback
    let sets = kink_sets(4);
    let mut histories = Vec::new();
    for np in [1, 2] {
        let d = scratch(&format!("kink-frozen-{np}"));
        let out = run_with_env(
            np,
            &args(d.to_str().unwrap(), case, &sets),
            None,
            limit,
            &[("NURBS_CONTACT_DEBUG_ACTIVE_SET", "1")],
        )
        .expect("no hang");
        let err = stderr(&out);
        assert!(out.status.success(), "{err}");
        assert!(err.contains("freezes"), "no point was frozen:\n{err}");
        let s = summary(&d);
        assert_eq!(s["status"], "converged");
        let steps = s["steps"].as_array().unwrap();
        assert_eq!(steps.len(), 9);
        for st in steps {
            assert_eq!(st["cutbacks"], 0, "{st}");
        }
        // the converged state satisfies eq. (5): the plain law's residual there (the initial
        // residual of the step without motion, nothing frozen) is below the solver's absolute
        // tolerance (1e-11)
        let r0 = steps[8]["residual_history"][0].as_f64().unwrap();
        assert!(r0 < 1e-11, "law's residual at the converged state {r0:e}");
        assert_eq!(steps[8]["iterations"], 0);
        histories.push(d);
    }
    for col in [
        "P_ironing_block_top_y",
        "P_ironing_cylinder_arc_y",
        "R_cylinder_top_y",
    ] {
        let (a, b) = (
            history_col(&histories[0], col),
            history_col(&histories[1], col),
        );
        assert!(rel_diff(&a, &b) < 1e-8, "{col}: 1 vs 2 ranks {a:?} {b:?}");
    }
}
