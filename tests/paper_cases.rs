//! The paper's section 4 cases at their coarsest settings, a few steps each, on 1 and 2 ranks: the
//! same answer (1e-10), and the balances that make their reported forces and moments trustworthy.
//! Also the building blocks they need: a rigid end with a prescribed rotation and a free
//! translation (pure end moment), Q1E4 bulk below an enriched layer, a contact region.
//! The full runs are benchmarks (docs/verification/paper.md), not tests.

mod common;
use common::*;
use std::path::Path;

/// Histories and last displacements equal on 1 and 2 ranks. The active-point counts are left out
/// where a law's activity switches at a gap of zero, which a bonded cohesive interface sits on:
/// round-off decides those points, and they carry no force.
fn assert_ranks_agree(d1: &Path, d2: &Path, what: &str) {
    let (h1, h2) = (history_values(d1), history_values(d2));
    let dh = rel_diff(&h1, &h2);
    let u1 = h5_last(d1, "bulk", "displacement");
    let u2 = h5_last(d2, "bulk", "displacement");
    let du = rel_diff(&u1, &u2);
    assert!(
        dh < 1e-10 && du < 1e-10,
        "{what}: 1 and 2 ranks differ: history {dh:e}, displacement {du:e}"
    );
}

#[test]
fn a_rigid_end_with_free_translation_bends_the_strip_by_a_pure_moment() {
    // strip 20 x 1, clamped left, right end rotated to 90 degrees with its translation free:
    // a pure end moment, so no reaction force at the end, equal and opposite moments at both
    // ends, and M = EI theta / L (linear beam theory; the strain stays below 4 %)
    let sets = ["bcs.1.free_translation=true"];
    let d1 = run_case("rigid-end-1", "strip_bending_2d.toml", 1, &sets);
    let d2 = run_case("rigid-end-2", "strip_bending_2d.toml", 2, &sets);
    assert_ranks_agree(&d1, &d2, "strip_bending_2d with a free end");
    let m_right = history_col(&d1, "M_strip_right");
    let m_left = history_col(&d1, "M_strip_left");
    let load = history_col(&d1, "load_factor");
    let ei = 1.0 / 12.0 / (1.0 - 0.3f64 * 0.3);
    for i in 0..load.len() {
        let theta = (load[i] * 45.0).to_radians();
        let beam = ei * theta / 20.0;
        let err = (m_right[i] - beam).abs() / beam;
        assert!(
            err < 5e-3,
            "step {i}: end moment {} vs EI theta / L = {beam} ({err:e})",
            m_right[i]
        );
        assert!(
            (m_right[i] + m_left[i]).abs() < 1e-9 * m_right[i].abs(),
            "step {i}: end moments {} and {} do not balance",
            m_right[i],
            m_left[i]
        );
    }
    for c in ["R_strip_right_x", "R_strip_right_y"] {
        let r = last(&d1, c);
        assert!(
            r.abs() < 1e-10,
            "{c} = {r:e}: a free translation carries no force"
        );
    }
}

#[test]
fn a_rigid_end_with_free_translation_rejects_a_prescribed_translation_and_overlaps() {
    let c = case("strip_bending_2d.toml");
    let out = run(
        1,
        &[
            "check",
            c.to_str().unwrap(),
            "--set",
            "bcs.1.free_translation=true",
            "--set",
            "bcs.1.translation=[[0.0, 1.0], [0.0, 1.0]]",
        ],
    );
    assert!(!out.status.success());
    assert!(
        stderr(&out).contains("bcs.1.free_translation"),
        "{}",
        stderr(&out)
    );
    // the rigid end may not also be clamped: its nodes share one translation
    let out = run(
        1,
        &[
            "check",
            c.to_str().unwrap(),
            "--set",
            "bcs.1.free_translation=true",
            "--set",
            "bcs.0.set=right",
        ],
    );
    assert!(!out.status.success());
    let msg = stderr(&out);
    assert!(
        msg.contains("free-translation rotation") && msg.contains("bcs.0"),
        "{msg}"
    );
}

#[test]
fn peeling_coarse_agrees_on_one_and_two_ranks_and_balances_its_moment() {
    // the paper's 40 x 2 illustration mesh (Figure 11), the end rotated by 10 degrees in 4 steps
    let sets = [
        "meshes.strip.divisions=[40,2]",
        "bcs.1.angle_deg=[10.0]",
        "stages.0.steps=4",
        "output.every=4",
    ];
    let d1 = run_case("peel-1", "peeling_2d.toml", 1, &sets);
    let d2 = run_case("peel-2", "peeling_2d.toml", 2, &sets);
    assert_ranks_agree(&d1, &d2, "peeling_2d");
    // the end moment is carried by the adhesion alone (the left end holds x only, and nothing
    // holds the strip vertically): the contact moment balances it and the resultants vanish
    let m = last(&d1, "M_strip_right");
    let mc = last(&d1, "M_adhesion_strip_bottom");
    assert!(m > 0.0, "the end moment {m} should open the strip");
    assert!((m + mc).abs() < 1e-8 * m, "end moment {m} vs contact {mc}");
    let py = last(&d1, "P_adhesion_strip_bottom_y");
    assert!(py.abs() < 1e-8 * m, "vertical adhesion resultant {py}");
}

#[test]
fn dcb_coarse_agrees_on_one_and_two_ranks_and_the_pin_force_balances_the_cohesion() {
    // 5 steps to an opening of 0.5 (bonded, elastic range)
    let sets = [
        "bcs.0.value=[[0.0, 0.5]]",
        "stages.0.steps=5",
        "output.every=5",
    ];
    let d1 = run_case("dcb-1", "dcb_2d.toml", 1, &sets);
    let d2 = run_case("dcb-2", "dcb_2d.toml", 2, &sets);
    assert_ranks_agree(&d1, &d2, "dcb_2d");
    let col = |name: &str| last(&d1, name);
    let r_upper = col("R_upper_pin_y");
    let r_lower = col("R_lower_pin_y");
    let p_upper = col("P_bond_upper_bottom_y");
    let p_lower = col("P_bond_lower_top_y");
    assert!(
        r_upper > 0.0,
        "pulling the upper strip up needs a force: {r_upper}"
    );
    // each strip: pin reaction + cohesive force = 0 (the two half-passes' resultants differ
    // on this coarse non-matching interface, so the pins need not balance each other exactly)
    for (r, p, what) in [(r_upper, p_upper, "upper"), (r_lower, p_lower, "lower")] {
        assert!(
            (r + p).abs() < 1e-8 * r_upper,
            "{what}: pin reaction {r} vs cohesive resultant {p}"
        );
    }
}

#[test]
fn twisting_coarse_agrees_on_one_and_two_ranks_and_the_rim_balances_the_contact() {
    // mesh 2, pressed by 0.2 in 2 steps, then twisted by 6 degrees in 2 steps
    let sets = [
        "bcs.3.translation=[[0.0, 0.0, -0.2], [0.0, 0.0, -0.2]]",
        "bcs.3.angle_deg=[0.0, 6.0]",
        "stages.0.steps=2",
        "stages.1.steps=2",
        "output.every=4",
    ];
    let d1 = run_case("twist-1", "twisting_3d.toml", 1, &sets);
    let d2 = run_case("twist-2", "twisting_3d.toml", 2, &sets);
    assert_ranks_agree(&d1, &d2, "twisting_3d");
    // the shell is held by its rim only: rim reaction + the shell's contact force = 0, and the
    // same for the moment about the vertical axis
    let col = |name: &str| last(&d1, name);
    let rz = col("R_shell_rim_z");
    let pz = col("P_twist_shell_outer_z");
    // reactions are the forces the conditions exert: the rim is pulled down against the cube
    assert!(
        rz < 0.0,
        "the rim is held down against the cube's push: {rz}"
    );
    assert!(
        (rz + pz).abs() < 1e-8 * rz.abs(),
        "rim {rz} vs contact {pz}"
    );
    let mz = col("M_shell_rim_z");
    let mcz = col("M_twist_shell_outer_z");
    assert!(mz.abs() > 0.0, "twisting should need a moment");
    assert!(
        (mz + mcz).abs() < 1e-6 * rz.abs(),
        "rim moment {mz} vs contact moment {mcz}"
    );
}

#[test]
fn a_contact_region_integrates_only_the_points_inside_it() {
    // hertz_2d: the half disk's arc pressed onto a rigid flat at y = 0 near x = 0
    let full = run_case("region-full", "hertz_2d.toml", 1, &[]);
    let far = run_case(
        "region-far",
        "hertz_2d.toml",
        1,
        &["contact.0.region={ min = [5.0, -1.0], max = [6.0, 1.0] }"],
    );
    let half = run_case(
        "region-half",
        "hertz_2d.toml",
        1,
        &["contact.0.region={ min = [0.0, -1.0], max = [2.0, 3.0] }"],
    );
    let h = history(&full);
    let active = h
        .iter()
        .find(|(n, _)| n.starts_with("active_"))
        .map(|(n, _)| n.clone())
        .expect("an active-points column");
    let force = h
        .iter()
        .find(|(n, _)| n.starts_with("P_") && n.ends_with("_y"))
        .map(|(n, _)| n.clone())
        .expect("a contact force column");
    let (n_full, n_far, n_half) = (
        last(&full, &active),
        last(&far, &active),
        last(&half, &active),
    );
    assert!(n_full > 0.0);
    assert_eq!(n_far, 0.0, "no point lies in a region away from the disk");
    assert_eq!(last(&far, &force), 0.0);
    // the symmetric contact zone: the right half keeps about half of the active points
    assert!(
        n_half < n_full && n_half >= (n_full / 2.0).floor(),
        "active points: full {n_full}, right half {n_half}"
    );
}

#[test]
fn q1e4_bulk_below_an_enriched_layer_removes_most_of_the_bending_locking() {
    // pure bending of the 40 x 2 strip (rigid end, free translation) to 90 degrees, measured
    // against M = EI theta / L: the Q1N2-enriched strip with a Q1C1 bulk locks (measured +11.7 %),
    // with the Q1E4 bulk only its enriched layer does (+3.8 %; all-Q1E4: +0.1 %)
    let beam = 1.0 / 12.0 / (1.0 - 0.3f64 * 0.3) * std::f64::consts::FRAC_PI_2 / 20.0;
    let moment = |name: &str, bulk: Option<&str>| -> f64 {
        let mut sets = vec![
            "bcs.1.free_translation=true".to_string(),
            "bodies.strip.element=Q1N2".to_string(),
            "bodies.strip.enriched_surface=bottom".to_string(),
        ];
        if let Some(b) = bulk {
            sets.push(format!("bodies.strip.bulk={b}"));
        }
        let refs: Vec<&str> = sets.iter().map(String::as_str).collect();
        let d = run_case(name, "strip_bending_2d.toml", 1, &refs);
        last(&d, "M_strip_right")
    };
    let err_c1 = moment("locking-c1", None) / beam - 1.0;
    let err_e4 = moment("locking-e4", Some("Q1E4")) / beam - 1.0;
    assert!(
        err_c1 > 0.08,
        "a Q1C1 bulk should lock in bending: {err_c1}"
    );
    assert!(
        err_e4 > 0.0 && err_e4 < 0.05 && err_e4 < 0.5 * err_c1,
        "Q1E4 bulk: moment error {err_e4} (Q1C1 bulk: {err_c1})"
    );
}

#[test]
fn a_snapping_peel_front_is_carried_through_by_the_pseudo_transient_rescue() {
    // Q1C1 on the coarse 40 x 2 strip: the faceted front snaps from element to element; without
    // the rescue a step fails at the smallest increment (measured: at about 94 degrees), with it
    // every step ends in an undamped equilibrium, the same on 1 and 2 ranks
    let base = [
        "bodies.strip.element=Q1C1",
        "meshes.strip.divisions=[40,2]",
        "bcs.1.angle_deg=[104.0]",
        "stages.0.steps=104",
        "output.every=104",
        // Newton from the converged state: the secant predictor crosses this snap without the
        // rescue (docs/user-guide/solvers.md, "Newton with contact")
        "solver.predictor=none",
    ];
    let d = scratch("rescue-off");
    let c = case("peeling_2d.toml");
    let mut args = vec![
        "run",
        c.to_str().unwrap(),
        "--out",
        d.to_str().unwrap(),
        "-q",
        "--overwrite",
        "--set",
        "steps.pseudo_steps=0",
    ];
    for s in base {
        args.extend(["--set", s]);
    }
    let out = run(1, &args);
    assert!(!out.status.success(), "the plain load stepping should fail");
    assert!(
        stderr(&out).contains("minimum increment") && !stderr(&out).contains("rescue"),
        "{}",
        stderr(&out)
    );

    let d1 = run_case("rescue-1", "peeling_2d.toml", 1, &base);
    let d2 = run_case("rescue-2", "peeling_2d.toml", 2, &base);
    let s = summary(&d1);
    let steps = s["steps"].as_array().expect("steps");
    let rescued = steps
        .iter()
        .filter(|st| st["pseudo_steps"].as_u64().unwrap_or(0) > 0)
        .count();
    assert!(rescued > 0, "no step needed the rescue");
    // accepted states are equilibria: each step's last residual met the Newton tolerance
    for st in steps {
        let h = st["residual_history"].as_array().unwrap();
        let last = h.last().unwrap().as_f64().unwrap();
        assert!(last < 1e-9, "step {}: residual {last:e}", st["step"]);
    }
    let load = history_col(&d1, "load_factor");
    assert!((load.last().unwrap() - 1.0).abs() < 1e-12);
    // 1 and 2 ranks agree up to the first rescued step. Beyond it the snapping front may settle in
    // a different equilibrium: round-off differences between 2-rank runs under CPU load (likely
    // MUMPS's dynamic scheduling across processes; not established) are amplified by the snap
    // (measured once in the full suite: 11 % apart in the moment after it; run alone, equal to
    // 1e-9 on 3 of 3 tries)
    let first_rescue = steps
        .iter()
        .position(|st| st["pseudo_steps"].as_u64().unwrap_or(0) > 0)
        .expect("a rescued step");
    let (m1, m2) = (
        history_col(&d1, "M_strip_right"),
        history_col(&d2, "M_strip_right"),
    );
    assert!(first_rescue > 10 && m2.len() > first_rescue);
    let dm = rel_diff(&m1[..first_rescue], &m2[..first_rescue]);
    assert!(dm < 1e-9, "1 and 2 ranks differ by {dm:e} before the snap");
    let load2 = history_col(&d2, "load_factor");
    assert!(
        (load2.last().unwrap() - 1.0).abs() < 1e-12,
        "2 ranks finish"
    );
}

#[test]
fn frictional_twisting_coarse_agrees_on_one_and_two_ranks_and_the_rim_carries_the_friction_moment()
{
    // mesh 2, pressed by 0.2 without friction, then twisted by 6 degrees with mu = 0.5
    let sets = [
        "bcs.2.translation=[[0.0, 0.0, -0.2], [0.0, 0.0, -0.2]]",
        "bcs.2.angle_deg=[0.0, 6.0]",
        "stages.0.steps=2",
        "stages.1.steps=3",
        "output.every=5",
    ];
    let d1 = run_case("twist-friction-1", "twisting_friction_3d.toml", 1, &sets);
    let d2 = run_case("twist-friction-2", "twisting_friction_3d.toml", 2, &sets);
    assert_ranks_agree(&d1, &d2, "twisting_friction_3d");
    let mz = last(&d1, "M_shell_rim_z");
    let mc = last(&d1, "M_twist_shell_outer_z");
    let rz = last(&d1, "R_shell_rim_z");
    // the frictional torque is what the rim must hold; it balances the shell's contact moment
    assert!(
        mz.abs() > 1e-3 * rz.abs(),
        "friction should resist the twist: rim moment {mz}, rim force {rz}"
    );
    assert!(
        (mz + mc).abs() < 1e-8 * mz.abs(),
        "rim {mz} vs contact {mc}"
    );
    let frictional = last(&d1, "slip_twist_shell_outer") + last(&d1, "stick_twist_shell_outer");
    assert!(frictional > 0.0, "no frictional point on the shell");
}
