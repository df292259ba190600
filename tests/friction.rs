//! Coulomb friction end to end (`cases/friction_block_2d.toml`): a block pressed onto a rigid flat
//! without friction, then pushed sideways with `mu = 0.3`. It sticks while the tangential force is
//! below `mu` times the normal force and slides at exactly `mu` times it; Newton converges
//! quadratically within the frictional steps; 1 and 2 ranks agree.

mod common;
use common::*;
use std::path::PathBuf;

const MU: f64 = 0.3;

/// Runs `cases/friction_block_2d.toml`.
fn run_block(name: &str, np: usize, sets: &[&str]) -> PathBuf {
    run_case(name, "friction_block_2d.toml", np, sets)
}

#[test]
fn a_pushed_block_sticks_below_mu_n_then_slides_at_mu_n_with_quadratic_newton() {
    for fam in ["Q1C1", "Q1N2"] {
        let d = run_block(
            &format!("friction-block-{fam}"),
            1,
            &[&format!("bodies.block.element={fam}")],
        );
        let stage = history_col(&d, "stage");
        let px = history_col(&d, "P_fric_block_bottom_x");
        let py = history_col(&d, "P_fric_block_bottom_y");
        let pt = history_col(&d, "Pt_fric_block_bottom_x");
        let stick = history_col(&d, "stick_fric_block_bottom");
        let slip = history_col(&d, "slip_fric_block_bottom");
        let active = history_col(&d, "active_fric_block_bottom");
        assert_eq!(stage.len(), 12, "{fam}: every step converged once");
        for i in 0..stage.len() {
            assert!(py[i] > 0.01, "{fam} step {i}: pressed ({})", py[i]);
            // Coulomb's cone: never more than mu N
            assert!(
                px[i].abs() <= MU * py[i] * (1.0 + 1e-9),
                "{fam} step {i}: |P_x| {} above mu P_y {}",
                px[i].abs(),
                MU * py[i]
            );
            if stage[i] == 0.0 {
                // frictionless indentation
                assert!(
                    px[i].abs() < 1e-12 * py[i],
                    "{fam}: P_x {} in stage 0",
                    px[i]
                );
                assert_eq!(stick[i] + slip[i], 0.0);
            } else {
                // a flat rigid partner: the tangential force is the horizontal one
                assert!((pt[i] - px[i]).abs() < 1e-12 * py[i]);
            }
        }
        // first push step: mostly stuck, well below mu N, opposing the push
        let i = 2;
        assert!(
            stick[i] > slip[i],
            "{fam}: {} stick, {} slip",
            stick[i],
            slip[i]
        );
        assert!(
            px[i] < 0.0 && px[i].abs() < 0.8 * MU * py[i],
            "{fam}: first push step P_x {} vs mu P_y {}",
            px[i],
            MU * py[i]
        );
        // the end: every active point slips, the force is mu N (exact in 2D against a flat)
        let n = stage.len() - 1;
        assert_eq!(stick[n], 0.0, "{fam}: still sticking at the end");
        assert_eq!(slip[n], active[n], "{fam}: every active point slips");
        assert!(
            (px[n] + MU * py[n]).abs() < 1e-9 * py[n],
            "{fam}: sliding P_x {} vs -mu P_y {}",
            px[n],
            -MU * py[n]
        );
        // Newton within the frictional steps: converged tightly, quadratically at the end
        let s = summary(&d);
        let steps = s["steps"].as_array().unwrap();
        let mut checked = 0;
        for st in &steps[2..] {
            let h: Vec<f64> = st["residual_history"]
                .as_array()
                .unwrap()
                .iter()
                .map(|v| v.as_f64().unwrap())
                .collect();
            let last = *h.last().unwrap();
            // a step the secant predictor started at its solution (sliding at mu N is linear in
            // the unknowns) converged before any iteration, at round-off
            assert!(
                last < 1e-10 * h[0] || (h.len() == 1 && last < 1e-14),
                "{fam}: step not converged tightly: {h:?}"
            );
            // above round-off: relative to the step's start and absolutely (the residual of
            // these unit-sized forces stalls near 1e-16)
            let best = h[1..]
                .windows(3)
                .filter(|w| w[2] > 1e-13 * h[0] && w[2] > 1e-14 && w[1] < w[0])
                .map(|w| (w[2] / w[1]).ln() / (w[1] / w[0]).ln())
                .fold(f64::MIN, f64::max);
            if best > f64::MIN {
                assert!(best > 1.8, "{fam}: convergence order {best:.2} in {h:?}");
                checked += 1;
            }
        }
        // most steps converge too fast to measure a rate (the sliding ones in one iteration:
        // with every point on the cone against a flat, the residual is linear in the unknowns)
        assert!(
            checked >= 2,
            "{fam}: too few steps with a measurable rate ({checked})"
        );
        let its = history_col(&d, "newton_iterations");
        for (i, &it) in its.iter().enumerate().skip(stage.len() - 5) {
            assert!(
                it <= 2.0,
                "{fam} step {}: {it} Newton iterations while sliding",
                i + 1
            );
        }
    }
}

#[test]
fn friction_is_rank_invariant() {
    let sets = [
        "bodies.block.element=Q1N2",
        "meshes.block.divisions=[12, 4]",
        "stages.1.steps=5",
    ];
    let d1 = run_block("friction-np1", 1, &sets);
    let d2 = run_block("friction-np2", 2, &sets);
    let e = rel_diff(
        &h5_last(&d1, "bulk", "displacement"),
        &h5_last(&d2, "bulk", "displacement"),
    );
    assert!(e < 1e-10, "1 vs 2 ranks differ by {e:e}");
    // the resultants are penalty forces, eps times a gap (a difference of positions ~1e3 times
    // smaller than them): they amplify the displacement's round-off; measured up to 1.3e-10
    for col in ["P_fric_block_bottom_x", "Pt_fric_block_bottom_x"] {
        let (a, b) = (history_col(&d1, col), history_col(&d2, col));
        let e = rel_diff(&a, &b);
        assert!(e < 1e-8, "{col}: 1 vs 2 ranks differ by {e:e}");
    }
    for col in ["stick_fric_block_bottom", "slip_fric_block_bottom"] {
        assert_eq!(
            history_col(&d1, col),
            history_col(&d2, col),
            "{col}: 1 vs 2 ranks"
        );
    }
    // the contact points in results.h5: the same order and state on any number of ranks
    assert_eq!(
        h5_last(&d1, "contact_points", "friction_state"),
        h5_last(&d2, "contact_points", "friction_state")
    );
    let e = rel_diff(
        &h5_last(&d1, "contact_points", "displacement"),
        &h5_last(&d2, "contact_points", "displacement"),
    );
    assert!(e < 1e-10, "contact points: 1 vs 2 ranks differ by {e:e}");
    // the friction fields on the sampled surface (sums over the ranks' points): tractions are
    // penalty values like the resultants above, the fractions are not
    for (f, tol) in [
        ("tangential_traction", 1e-8),
        ("stick_fraction", 1e-12),
        ("slip_fraction", 1e-12),
    ] {
        let e = rel_diff(&h5_last(&d1, "surface", f), &h5_last(&d2, "surface", f));
        assert!(e < tol, "surface {f}: 1 vs 2 ranks differ by {e:e}");
    }
    // some frictional steps mix stick and slip
    let stick = history_col(&d2, "stick_fric_block_bottom");
    assert!(stick.iter().any(|&v| v > 0.0));
}

#[test]
fn cattaneo_mindlin_stick_zone_of_the_hertz_half_disk() {
    // Q1N2 at the middle mesh (n_arc = 128): pressed, then shifted to Q/(mu P) of about 0.5
    let d = scratch("cattaneo-mindlin-q1n2-128");
    let c = case("cattaneo_mindlin_2d.toml");
    run_ok(
        1,
        &[
            "run",
            c.to_str().unwrap(),
            "--out",
            d.to_str().unwrap(),
            "-q",
            "--overwrite",
        ],
    );
    let q = history_col(&d, "P_cm_disk_arc_x");
    let p = history_col(&d, "P_cm_disk_arc_y");
    let stick = history_col(&d, "stick_cm_disk_arc");
    let slip = history_col(&d, "slip_cm_disk_arc");
    let active = history_col(&d, "active_cm_disk_arc");
    let n = q.len() - 1;
    let ratio = -q[n] / (MU * p[n]);
    assert!(
        ratio > 0.3 && ratio < 0.9,
        "partial slip expected: Q/(mu P) = {ratio}"
    );
    assert!(
        stick[n] > 0.0 && slip[n] > 0.0,
        "a stick zone and slip zones"
    );
    assert_eq!(
        stick[n] + slip[n],
        active[n],
        "every active point sticks or slips"
    );
    // c/a from the points' positions (results.h5, grid contact_points, last step): on each side
    // a midway between the last active and the first inactive point, c midway between the last
    // sticking and the first slipping point; both sides averaged
    let f = h5_open(d.join("results.h5")).expect("open results.h5");
    let x0 = f
        .dataset("grids/contact_points/coordinates")
        .unwrap()
        .read_raw::<f64>()
        .unwrap();
    let u = h5_last(&d, "contact_points", "displacement");
    let p_pt = h5_last(&d, "contact_points", "contact_pressure");
    let state = h5_last(&d, "contact_points", "friction_state");
    let mut pts: Vec<(f64, f64, f64)> = (0..state.len())
        .map(|i| (x0[3 * i] + u[3 * i], p_pt[i], state[i]))
        .collect();
    pts.sort_by(|a, b| a.0.partial_cmp(&b.0).unwrap());
    // (the half-width through the last points in, through the first points out)
    let bracket = |inside: &dyn Fn(&(f64, f64, f64)) -> bool| {
        let lo = pts.iter().position(inside).expect("a point inside");
        let hi = pts.len() - 1 - pts.iter().rev().position(inside).unwrap();
        assert!(
            lo > 0 && hi + 1 < pts.len(),
            "the zone reaches the end of the points"
        );
        (
            0.5 * (pts[hi].0 - pts[lo].0),
            0.5 * (pts[hi + 1].0 - pts[lo - 1].0),
        )
    };
    let (a_in, a_out) = bracket(&|q| q.1 > 0.0);
    let (c_in, c_out) = bracket(&|q| q.2 == 1.0);
    let (a, c) = (0.5 * (a_in + a_out), 0.5 * (c_in + c_out));
    assert_eq!(
        pts.iter().filter(|q| q.2 == 1.0).count() as f64,
        stick[n],
        "points vs history"
    );
    let c_a = c / a;
    let cm = (1.0 - ratio).sqrt();
    let err = c_a / cm - 1.0;
    // measured -9.7 % (docs/verification/friction.md; the counts stick/active give -8.7 %): half a point spacing
    // is 5 % of a here, and with eps_t = eps_n / 10 the same mesh gives +5.4 %: the 5 % is
    // not met at this mesh and penalty
    assert!(
        err.abs() < 0.12,
        "c/a = {c_a:.4} against Cattaneo-Mindlin {cm:.4} ({:+.1} %)",
        100.0 * err
    );
    // to the resolution of the points: Cattaneo-Mindlin's c for some a the points allow lies
    // where the points allow c (measured: c in 0.0507..0.0600, C-M 0.0587..0.0639; Q1C1 at
    // n_arc = 64 fails this, 0.0379..0.0583 against 0.0598..0.0741)
    assert!(
        cm * a_in <= c_out && c_in <= cm * a_out,
        "c in {c_in:.4}..{c_out:.4}, Cattaneo-Mindlin's c in {:.4}..{:.4}",
        cm * a_in,
        cm * a_out
    );
}

#[test]
fn one_pass_frictional_sliding_slips_at_mu_n_alike_on_1_and_2_ranks() {
    // cases/sliding_flat_2d.toml with mu = 0.3 from the start and `algorithm = "one_pass"` (the
    // upper block's surface the slave, the lower one taking the opposite force): every slave point
    // slips on the cone while sliding, the pass's tangential force is -mu times its normal one,
    // and 2 ranks (the master's rows on the other rank) give the 1-rank displacement
    for gap in ["pointwise", "weighted"] {
        let sets = [
            "contact.0.mu=0.3",
            "contact.0.algorithm=one_pass",
            &format!("contact.0.gap={gap}"),
            "bodies.upper.element=Q1N2",
            "bodies.lower.element=Q1N2",
            "output.plots=false",
        ];
        let mut dirs = Vec::new();
        for np in [1, 2] {
            let d = run_case(
                &format!("friction-one-pass-{gap}-np{np}"),
                "sliding_flat_2d.toml",
                np,
                &sets,
            );
            let stage = history_col(&d, "stage");
            let pt = history_col(&d, "Pt_slide_upper_bottom_x");
            let py = history_col(&d, "P_slide_upper_bottom_y");
            let slip = history_col(&d, "slip_slide_upper_bottom");
            let active = history_col(&d, "active_slide_upper_bottom");
            assert_eq!(summary(&d)["status"], "converged");
            for i in 3..stage.len() {
                assert!(
                    active[i] > 0.0 && slip[i] == active[i],
                    "{gap} step {}",
                    i + 1
                );
                assert!(
                    (pt[i] + 0.3 * py[i]).abs() < 1e-9 * py[i],
                    "{gap} step {}: P_t {} vs -mu P_n {}",
                    i + 1,
                    pt[i],
                    -0.3 * py[i]
                );
            }
            dirs.push(d);
        }
        let e = rel_diff(
            &h5_last(&dirs[0], "bulk", "displacement"),
            &h5_last(&dirs[1], "bulk", "displacement"),
        );
        assert!(e < 1e-10, "{gap}: 1 vs 2 ranks differ by {e:e}");
    }
}

#[test]
fn bad_friction_keys_are_named() {
    let c = case("friction_block_2d.toml");
    for (set, want) in [
        ("contact.0.mu=-0.1", "contact.0.mu"),
        ("contact.0.eps_t=0.0", "contact.0.eps_t"),
        (
            "contact.0.friction_stages=[true]",
            "contact.0.friction_stages",
        ),
    ] {
        let d = scratch(&format!("friction-bad-{}", want.replace('.', "-")));
        let out = run(
            1,
            &[
                "run",
                c.to_str().unwrap(),
                "--out",
                d.to_str().unwrap(),
                "-q",
                "--overwrite",
                "--set",
                set,
            ],
        );
        let err = stderr(&out);
        assert!(!out.status.success(), "{set}: accepted");
        assert!(!err.contains("panicked"), "{set}: panic:\n{err}");
        assert!(
            err.contains(want) && err.contains("friction_block_2d.toml"),
            "{set}: message does not name the key and file:\n{err}"
        );
    }
}

/// One dataset of output step `k` (0-based) of `results.h5`, flattened.
fn h5_step(dir: &std::path::Path, k: usize, grid: &str, field: &str) -> Vec<f64> {
    let f = h5_open(dir.join("results.h5")).expect("open results.h5");
    let ds = f
        .dataset(&format!("steps/{k:06}/{grid}/{field}"))
        .unwrap_or_else(|e| panic!("dataset {k:06}/{grid}/{field}: {e}"));
    ds.read_raw::<f64>().expect("read dataset")
}

#[test]
fn contact_points_in_results_carry_the_stick_slip_state_and_the_tangential_traction() {
    // the pushed block, Q1N2: stick, mixed and slip steps; every step is written
    let d = run_block(
        "friction-points-q1n2",
        1,
        &["bodies.block.element=Q1N2", "contact.0.eps_t=50.0"],
    );
    let (eps_t, mu) = (50.0, MU);
    let stick = history_col(&d, "stick_fric_block_bottom");
    let slip = history_col(&d, "slip_fric_block_bottom");
    let active = history_col(&d, "active_fric_block_bottom");
    let pt = history_col(&d, "Pt_fric_block_bottom_x");
    assert_eq!(h5_steps(&d), stick.len(), "one output step per load step");
    let xdmf = std::fs::read_to_string(d.join("results.xdmf")).unwrap();
    assert!(xdmf.contains("Grid Name=\"contact_points\"") && xdmf.contains("friction_state"));
    let mut mixed = 0;
    for k in 0..stick.len() {
        let state = h5_step(&d, k, "contact_points", "friction_state");
        let p = h5_step(&d, k, "contact_points", "contact_pressure");
        let tt = h5_step(&d, k, "contact_points", "tangential_traction");
        let gt = h5_step(&d, k, "contact_points", "tangential_gap");
        let n = state.len();
        assert!(n >= active[k] as usize && tt.len() == 3 * n && gt.len() == 3 * n);
        let count = |s: f64| state.iter().filter(|&&v| v == s).count() as f64;
        assert_eq!(
            count(1.0),
            stick[k],
            "step {k}: sticking points vs history.csv"
        );
        assert_eq!(
            count(2.0),
            slip[k],
            "step {k}: slipping points vs history.csv"
        );
        mixed += (stick[k] > 0.0 && slip[k] > 0.0) as usize;
        let mut sum_sign = 0.0;
        for i in 0..n {
            let t = &tt[3 * i..3 * i + 3];
            let g = &gt[3 * i..3 * i + 3];
            let tl = (t[0] * t[0] + t[1] * t[1] + t[2] * t[2]).sqrt();
            match state[i] as i32 {
                0 => assert_eq!(tl, 0.0, "step {k} point {i}: traction without friction"),
                1 => {
                    // stick: t_T = -eps_t g_T, inside the cone
                    for c in 0..3 {
                        assert!((t[c] + eps_t * g[c]).abs() <= 1e-12 * (1.0 + tl));
                    }
                    assert!(
                        tl <= mu * p[i] * (1.0 + 1e-9),
                        "step {k} point {i}: outside the cone"
                    );
                }
                2 => {
                    // slip: on the cone, against the tangential gap
                    assert!(
                        (tl - mu * p[i]).abs() <= 1e-9 * mu * p[i],
                        "step {k} point {i}"
                    );
                    let gl = (g[0] * g[0] + g[1] * g[1] + g[2] * g[2]).sqrt();
                    assert!(eps_t * gl >= mu * p[i] * (1.0 - 1e-8));
                    assert!(t[0] * g[0] + t[1] * g[1] + t[2] * g[2] < 0.0);
                }
                s => panic!("step {k} point {i}: state {s}"),
            }
            sum_sign += t[0];
        }
        // the pointwise traction opposes the push as the resultant does
        if pt[k] != 0.0 {
            assert!(
                sum_sign * pt[k] > 0.0,
                "step {k}: {sum_sign} vs P_t {}",
                pt[k]
            );
        }
    }
    assert!(mixed >= 1, "no step with both stick and slip");
}

#[test]
fn friction_on_the_sampled_surface_is_the_l2_projection_of_the_points() {
    // the pushed block, Q1N2: its enriched bottom is sampled (grid `surface`)
    let d = run_block("friction-surface-q1n2", 1, &["bodies.block.element=Q1N2"]);
    let n_steps = h5_steps(&d);
    let xdmf = std::fs::read_to_string(d.join("results.xdmf")).unwrap();
    for f in ["tangential_traction", "stick_fraction", "slip_fraction"] {
        assert!(xdmf.contains(f), "{f} not in results.xdmf");
    }
    let x0 = {
        let f = h5_open(d.join("results.h5")).expect("open results.h5");
        f.dataset("grids/surface/coordinates")
            .unwrap()
            .read_raw::<f64>()
            .unwrap()
    };
    // the end of the frictionless press: no friction anywhere
    for f in ["tangential_traction", "stick_fraction", "slip_fraction"] {
        let v = h5_step(&d, 1, "surface", f);
        assert!(v.iter().all(|&x| x == 0.0), "press: {f} not zero");
    }
    // the last step slides: every point slips, t_T = -mu p at each point, and the projections
    // (linear in the pointwise values, the same mass matrix) keep that relation at the nodes
    // (up to the tangential traction's tiny component along the deformed surface's own normal,
    // which the pressure includes)
    let k = n_steps - 1;
    let p = h5_step(&d, k, "surface", "contact_pressure");
    let tt = h5_step(&d, k, "surface", "tangential_traction");
    let stick = h5_step(&d, k, "surface", "stick_fraction");
    let slip = h5_step(&d, k, "surface", "slip_fraction");
    let n = p.len();
    assert_eq!(tt.len(), 3 * n, "vectors are written with three components");
    let p_max = p.iter().cloned().fold(0.0, f64::max);
    assert!(p_max > 0.01, "pressed: {p_max}");
    let mut interior = 0;
    for i in 0..n {
        assert!(
            (tt[3 * i] + MU * p[i]).abs() <= 2e-3 * p_max
                && tt[3 * i + 1].abs() <= 1e-12
                && tt[3 * i + 2] == 0.0,
            "node {i}: t_T {:?} against -mu p = {}",
            &tt[3 * i..3 * i + 3],
            -MU * p[i]
        );
        // away from the ends (where the projection of an indicator ripples): all slip
        if x0[3 * i].abs() < 0.3 {
            interior += 1;
            assert!(
                (slip[i] - 1.0).abs() < 0.1 && stick[i].abs() < 0.05,
                "node {i} at x {}: slip {} stick {}",
                x0[3 * i],
                slip[i],
                stick[i]
            );
        }
    }
    assert!(interior >= 10, "{interior} interior nodes");
}

#[test]
fn frictional_sliding_of_two_deformable_blocks_converges_without_cutbacks_at_mu_n() {
    // cases/sliding_flat_2d.toml with mu = 0.3 from the start: the upper block slides 0.75 over
    // the lower one in 15 steps, every point of its surface slipping
    for fam in ["Q1C1", "Q1N2"] {
        let d = run_case(
            &format!("friction-sliding-{fam}"),
            "sliding_flat_2d.toml",
            1,
            &[
                "contact.0.mu=0.3",
                &format!("bodies.upper.element={fam}"),
                &format!("bodies.lower.element={fam}"),
            ],
        );
        let stage = history_col(&d, "stage");
        let its = history_col(&d, "newton_iterations");
        let cut = history_col(&d, "cutbacks");
        let pt = history_col(&d, "Pt_slide_upper_bottom_x");
        let py = history_col(&d, "P_slide_upper_bottom_y");
        let slip = history_col(&d, "slip_slide_upper_bottom");
        let active = history_col(&d, "active_slide_upper_bottom");
        assert_eq!(stage.len(), 17, "{fam}: 2 + 15 steps, none cut back");
        assert!(cut.iter().all(|&c| c == 0.0), "{fam}: cutbacks {cut:?}");
        let s = summary(&d);
        for st in s["steps"].as_array().unwrap() {
            assert_eq!(st["cutbacks"].as_u64(), Some(0), "{fam}: {st}");
        }
        // the first slide step turns the stuck contact into sliding; then a few iterations a
        // step (measured 3 to 5 once a Jacobian domain error stops SNES: before, up to 33)
        for (i, &it) in its.iter().enumerate().skip(3) {
            assert!(it <= 6.0, "{fam} step {}: {it} Newton iterations", i + 1);
        }
        for i in 3..stage.len() {
            assert_eq!(
                slip[i],
                active[i],
                "{fam} step {}: every point slips",
                i + 1
            );
            assert!(
                (pt[i] + 0.3 * py[i]).abs() < 1e-9 * py[i],
                "{fam} step {}: P_t {} vs -mu P_n {}",
                i + 1,
                pt[i],
                -0.3 * py[i]
            );
        }
    }
}

#[test]
fn a_rescued_frictional_step_is_one_increment_from_the_last_equilibrium() {
    // The damped pseudo-steps of the rescue are not on the load path: committing the friction
    // anchors at each of them made the friction follow the pseudo-time path (on twisting mesh 8 a
    // rescued step invalidated everything after it). With SNES limited to `max_it` iterations and
    // no cutbacks, steps that plain Newton needs more iterations for are rescued; their result
    // must be the plain solve's (the same anchors, the same load), to the solver's tolerance.
    // cases/sliding_flat_2d.toml with the paper's two half-passes, friction from the start, a thin
    // upper block slid by `slide`: points stick at the end (slide 0.01: some slip). Measured before the fix: with max_it = 2 (slide 0.002) the press
    // steps are rescued, and points touching during the pseudo-steps got anchors there: the first
    // step carried friction a plain step does not (8 sticking, 4 slipping points instead of none);
    // with max_it = 3 (slide 0.01) the last slide step is rescued: 9 sticking points instead of 8,
    // the forces off by 12 %. With the rescue's intermediate commits (77b8629): the same to 1e-11.
    for (slide, max_it) in [("0.002", 2), ("0.01", 3)] {
        let value = format!("bcs.3.value=[[0.0], [{slide}]]");
        let base = [
            "contact.0.mu=0.3",
            &value,
            "stages.1.steps=2",
            "meshes.upper.divisions=[6, 1]",
            "steps.max_cutbacks=0",
            "contact.0.formulation=paper",
        ];
        let plain = run_case(
            &format!("friction-rescue-plain-{max_it}"),
            "sliding_flat_2d.toml",
            1,
            &base,
        );
        let cols: Vec<String> = history(&plain)
            .into_iter()
            .map(|(h, _)| h)
            .filter(|h| h.starts_with("P_") || h.starts_with("Pt_") || h.starts_with("M_"))
            .collect();
        let stick = history_col(&plain, "stick_slide_upper_bottom");
        // the friction history decides the end state: points stick there
        assert!(
            *stick.last().unwrap() > 0.0,
            "slide {slide}: the plain run ends with sticking points: {stick:?}"
        );
        let mut sets = base.to_vec();
        let opt = format!("solver.petsc_options=\"-snes_max_it {max_it}\"");
        sets.push(&opt);
        let d = run_case(
            &format!("friction-rescue-{max_it}"),
            "sliding_flat_2d.toml",
            1,
            &sets,
        );
        let s = summary(&d);
        let steps = s["steps"].as_array().unwrap();
        let rescued: Vec<u64> = steps
            .iter()
            .filter(|st| st["pseudo_steps"].as_u64().unwrap_or(0) > 0)
            .map(|st| st["step"].as_u64().unwrap())
            .collect();
        assert!(!rescued.is_empty(), "max_it {max_it}: no step was rescued");
        assert_eq!(steps.len(), 4, "max_it {max_it}: 2 + 2 steps");
        for name in ["stick", "slip"] {
            for side in ["upper_bottom", "lower_top"] {
                let c = format!("{name}_slide_{side}");
                assert_eq!(
                    history_col(&plain, &c),
                    history_col(&d, &c),
                    "max_it {max_it} (rescued steps {rescued:?}): {c}"
                );
            }
        }
        for c in &cols {
            let diff = rel_diff(&history_col(&plain, c), &history_col(&d, c));
            assert!(
                diff < 1e-8,
                "max_it {max_it} (rescued steps {rescued:?}): {c} differs by {diff:e}"
            );
        }
    }
}

#[test]
fn friction_onset_after_a_frictionless_press_converges_without_rescue_with_one_pressure_per_element(
) {
    // cases/sliding_flat_2d.toml pressed without friction, then slid with mu = 0.3: with the
    // pointwise law the first frictional steps need the damped rescue (docs/verification/friction.md,
    // "Frictional sliding of two deformable blocks"); with `gap = "element_mean"` every step converges by plain
    // Newton without a cutback, on 1 and 2 ranks alike, and the block slides at mu
    for fam in ["Q1C1", "Q1N2"] {
        let element = [
            format!("bodies.upper.element={fam}"),
            format!("bodies.lower.element={fam}"),
        ];
        let mut dirs = Vec::new();
        for np in [1, 2] {
            let d = run_case(
                &format!("friction-onset-{fam}-np{np}"),
                "sliding_flat_2d.toml",
                np,
                &[
                    "contact.0.mu=0.3",
                    "contact.0.friction_stages=[false, true]",
                    "contact.0.gap=element_mean",
                    "steps.pseudo_steps=0",
                    "steps.max_cutbacks=0",
                    &element[0],
                    &element[1],
                ],
            );
            let s = summary(&d);
            assert_eq!(s["status"], "converged", "{fam} np={np}");
            let (pt, p) = (
                last(&d, "Pt_slide_upper_bottom_x"),
                last(&d, "P_slide_upper_bottom_y"),
            );
            assert!(
                (pt.abs() - MU * p.abs()).abs() < 1e-9 * p.abs(),
                "{fam} np={np}: tangential {pt} against mu times normal {p}"
            );
            dirs.push(d);
        }
        let (a, b) = (
            history_col(&dirs[0], "Pt_slide_upper_bottom_x"),
            history_col(&dirs[1], "Pt_slide_upper_bottom_x"),
        );
        let diff = rel_diff(&a, &b);
        assert!(diff < 1e-10, "{fam}: 1 and 2 ranks differ by {diff:e}");
    }
}
