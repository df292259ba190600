//! Newton converges quadratically on a well-posed problem: read from the residual history that the
//! solver records per load step in summary.json.

mod common;
use common::*;

#[test]
fn newton_converges_quadratically_on_block_compression() {
    let d = scratch("newton-quadratic");
    let c = case("block_compression_3d.toml");
    // Two large steps (10 % compression each) so each solve has several iterations in the
    // asymptotic regime.
    run_ok(
        1,
        &[
            "run",
            c.to_str().unwrap(),
            "--out",
            d.to_str().unwrap(),
            "-q",
            "--set",
            "stages.0.steps=2",
            // from the converged state: the secant predictor would start the second step
            // near its solution, leaving too few iterations above round-off to read a rate
            "--set",
            "solver.predictor=none",
        ],
    );
    let s = summary(&d);
    assert_eq!(s["status"], "converged");
    let steps = s["steps"].as_array().expect("steps in summary");
    assert_eq!(steps.len(), 2);
    let mut checked = 0;
    for st in steps {
        let h: Vec<f64> = st["residual_history"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_f64().unwrap())
            .collect();
        // Rates over consecutive triples above round-off: log(r2/r1) / log(r1/r0) -> 2. The first
        // iteration is skipped: it removes the (linear) boundary-value rows exactly and is not in the
        // asymptotic regime.
        for w in h[1..].windows(3) {
            let (r0, r1, r2) = (w[0], w[1], w[2]);
            if r2 < 1e-13 * h[0].max(1.0) || r1 >= r0 {
                continue;
            }
            let order = (r2 / r1).ln() / (r1 / r0).ln();
            assert!(order > 1.8, "convergence order {order:.2} in history {h:?}");
            checked += 1;
        }
        assert!(
            *h.last().unwrap() < 1e-10 * h[0],
            "step converged to a tight tolerance: {h:?}"
        );
    }
    assert!(
        checked >= 2,
        "saw too few Newton iterations above round-off to measure the order ({checked})"
    );
}

/// `[solver] predictor = "secant"` on steady sliding (ironing at mesh 8, one-pass mortar, two
/// block elements of sliding in 20 steps): every load both runs reach gives the same state to
/// Newton's tolerance, and the predicted starts save iterations (measured: 180 against 209 in all,
/// 3 against 5 per sliding step); a bad value is named by key.
#[test]
fn the_secant_predictor_reaches_the_same_states_in_fewer_iterations() {
    let mut runs = Vec::new();
    for p in ["none", "secant"] {
        let d = run_case(
            &format!("newton/predictor-{p}"),
            "ironing_2d.toml",
            1,
            &[
                "meshes.block.divisions=[80,16]",
                "meshes.cylinder.n_arc=24",
                "meshes.cylinder.n_radial=6",
                "bcs.1.value=[[0.0,-0.6666666666666666],[0.25,-0.6666666666666666]]",
                "stages.1.steps=20",
                "contact.0.algorithm=one_pass",
                "contact.0.gap=weighted",
                &format!("solver.predictor={p}"),
                "output.plots=false",
            ],
        );
        assert_eq!(summary(&d)["status"], "converged");
        let its = summary(&d)["newton"]["total_iterations"].as_f64().unwrap();
        let load = history_col(&d, "load_factor");
        let cols: Vec<Vec<f64>> = ["P_ironing_cylinder_arc_x", "P_ironing_cylinder_arc_y"]
            .iter()
            .map(|c| history_col(&d, c))
            .collect();
        runs.push((its, load, cols));
    }
    let (none, secant) = (&runs[0], &runs[1]);
    assert!(
        secant.0 < 0.95 * none.0,
        "Newton iterations: secant {} against none {}",
        secant.0,
        none.0
    );
    let mut compared = 0;
    for (i, l) in none.1.iter().enumerate() {
        let Some(j) = secant.1.iter().position(|m| (m - l).abs() < 1e-12) else {
            continue;
        };
        for (a, b) in none.2.iter().zip(&secant.2) {
            assert!(
                (a[i] - b[j]).abs() < 1e-8 * (1.0 + a[i].abs()),
                "load {l}: {} against {}",
                a[i],
                b[j]
            );
        }
        compared += 1;
    }
    assert!(compared >= 20, "{compared} loads in common");
    let c = case("ironing_2d.toml");
    let out = run(
        1,
        &[
            "check",
            c.to_str().unwrap(),
            "--set",
            "solver.predictor=linear",
        ],
    );
    let err = stderr(&out);
    assert!(
        !out.status.success() && err.contains("solver.predictor") && err.contains("secant"),
        "{err}"
    );
}

/// Two-half-pass pointwise ironing at mesh 8 (Table 2's Q1N2 run, three block elements of
/// sliding): once per block element a predicted start makes Newton's first iteration raise the
/// residual norm, and from there Newton took 14 iterations where the converged start takes 5-6
/// (docs/user-guide/solvers.md, "Newton with contact"). Such a start is given up after that
/// iteration (`DIVERGED_PREDICTED_START`) and the step starts again from the converged state, so
/// the predictor costs no more sliding iterations than the converged start, failed ones included
/// (measured here: 154 + 3 against 165; over the whole 4-unit slide 1639 + 31 against 1760,
/// without the rule 1914).
#[test]
fn a_predicted_start_that_raises_the_residual_is_given_up_at_once() {
    let mut runs = Vec::new();
    for p in ["none", "secant"] {
        let d = scratch(&format!("newton/rising-{p}"));
        let c = case("ironing_2d.toml");
        let mut args = vec![
            "run".to_string(),
            c.to_str().unwrap().to_string(),
            "--out".into(),
            d.to_str().unwrap().into(),
            "-q".into(),
            "--overwrite".into(),
        ];
        for s in [
            "bodies.block.element=Q1N2",
            "bodies.cylinder.element=Q1N2",
            "meshes.block.divisions=[80,16]",
            "meshes.cylinder.n_arc=24",
            "meshes.cylinder.n_radial=6",
            "bcs.1.value=[[0.0,-0.6666666666666666],[0.375,-0.6666666666666666]]",
            "stages.1.steps=30",
            "contact.0.formulation=paper",
            &format!("solver.predictor={p}"),
            "output.plots=false",
        ] {
            args.extend(["--set".to_string(), s.to_string()]);
        }
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let out = run_with_env(
            1,
            &args,
            None,
            std::time::Duration::from_secs(120),
            &[("NURBS_CONTACT_DEBUG_PREDICTOR", "1")],
        )
        .expect("no hang");
        assert!(out.status.success(), "{}", stderr(&out));
        // the slide's iterations, failed ones included (the press, where the contact zone
        // grows, takes more with the predictor: 126 against 105, no start rising)
        let s = summary(&d);
        let stage = history_col(&d, "stage");
        let its: u64 = s["steps"]
            .as_array()
            .unwrap()
            .iter()
            .zip(&stage)
            .filter(|(_, &st)| st == 1.0)
            .map(|(st, _)| {
                st["iterations"].as_u64().unwrap()
                    + st.get("failed_iterations")
                        .and_then(|v| v.as_u64())
                        .unwrap_or(0)
            })
            .sum();
        runs.push((
            its,
            stderr(&out),
            history_col(&d, "P_ironing_cylinder_arc_y"),
        ));
    }
    let (none, secant) = (&runs[0], &runs[1]);
    let given_up = secant.1.matches("DIVERGED_PREDICTED_START").count();
    assert!(given_up >= 2, "no rising start was given up:\n{}", secant.1);
    assert!(
        secant.0 <= none.0,
        "sliding Newton iterations with failed ones: secant {} against none {}",
        secant.0,
        none.0
    );
    assert_eq!(none.2.len(), secant.2.len(), "same steps");
    let last = none.2.len() - 1;
    assert!(
        (none.2[last] - secant.2[last]).abs() < 1e-8 * none.2[last].abs(),
        "final P_y {} against {}",
        none.2[last],
        secant.2[last]
    );
}

/// Newton at the kink of the penalty law (docs/verification/paper.md, "4.1 Ironing"): a faceted (Q1C1) block pressed by
/// a smooth (Q1N2) cylinder with two-half-pass penalty contact has block points that sit at
/// `g_n = 0` during the depression (the ironing scene, mesh 4, pressed to 0.4 of its depth in 8
/// steps, Newton started from the converged state). Newton cycles there (active, inactive,
/// active, ...) at every increment down to the minimum; each attempt ends at the stagnation stop
/// (`solver.stagnation_window`, default 10) or, with that off, at the iteration limit, and the run
/// fails with that reason.
#[test]
fn newton_cycling_at_the_penalty_kink_ends_at_the_stagnation_stop_or_the_iteration_limit() {
    let case = case("ironing_2d.toml");
    let case = case.to_str().unwrap();
    for (window, reason) in [(10, "DIVERGED_STAGNATION"), (0, "DIVERGED_MAX_IT")] {
        let d = scratch(&format!("kink-plain-{window}"));
        let sets = [
            "bodies.block.element=Q1C1".to_string(),
            "bodies.cylinder.element=Q1N2".into(),
            "contact.0.formulation=paper".into(),
            "steps.pseudo_steps=0".into(),
            "bcs.1.value=[[0.0, -0.26666666666666666], [0.0, -0.26666666666666666]]".into(),
            "stages.0.steps=8".into(),
            "stages.1.steps=1".into(),
            // the cycling is that of Newton started from the converged state (the secant
            // predictor starts the kink's step elsewhere, and plain Newton gets through it)
            "solver.predictor=none".into(),
            format!("solver.stagnation_window={window}"),
        ];
        let mut args = vec![
            "run",
            case,
            "--out",
            d.to_str().unwrap(),
            "-q",
            "--overwrite",
        ];
        for s in &sets {
            args.extend(["--set", s.as_str()]);
        }
        let out = run(1, &args);
        assert!(!out.status.success(), "plain Newton got through the kink");
        assert!(stderr(&out).contains(reason), "{}", stderr(&out));
    }
}
