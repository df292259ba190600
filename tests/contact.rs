//! Contact end to end: the contact patch test in 2D and 3D, frictionless sliding of flat blocks,
//! the default formulation's smooth sliding force, Newton's convergence while contact points cross
//! element boundaries, and the same answer on 1 and 2 ranks with contact surfaces split by METIS.

mod common;
use common::*;
use std::path::Path;

#[test]
fn contact_patch_test_pressure_is_uniform_on_both_surfaces_in_2d_and_3d() {
    for (case, dim, upper, lower) in [
        ("contact_patch_2d.toml", 2, "upper.bottom", "lower.top"),
        ("contact_patch_3d.toml", 3, "upper.zmin", "lower.zmax"),
    ] {
        for fam in ["Q1C1", "Q1N2"] {
            let d = run_case(
                &format!("patch-{dim}d-{fam}"),
                case,
                1,
                &[
                    &format!("bodies.lower.element={fam}"),
                    &format!("bodies.upper.element={fam}"),
                    "contact.0.formulation=paper",
                ],
            );
            let p = h5_last(&d, "bulk", "contact_pressure");
            let on: Vec<f64> = p.iter().copied().filter(|&v| v != 0.0).collect();
            // both surfaces' nodes (and control points) carry the projected pressure
            let (n_lower, n_upper) = if dim == 2 { (7, 5) } else { (49, 25) };
            assert!(
                on.len() >= n_lower + n_upper,
                "{case} {fam}: pressure on {} nodes only",
                on.len()
            );
            let mean = on.iter().sum::<f64>() / on.len() as f64;
            let dev = on.iter().fold(0.0f64, |m, v| m.max((v - mean).abs())) / mean;
            assert!(mean > 0.0, "{case} {fam}: compressive pressure expected");
            assert!(dev < 1e-8, "{case} {fam}: pressure varies by {dev:e}");
            // both half-passes carry the load that the top reaction measures
            let z = if dim == 2 { "y" } else { "z" };
            let r = last(
                &d,
                &format!("R_upper_{}_{z}", if dim == 2 { "top" } else { "zmax" }),
            );
            let pu = last(&d, &format!("P_patch_{}_{z}", upper.replace('.', "_")));
            let pl = last(&d, &format!("P_patch_{}_{z}", lower.replace('.', "_")));
            assert!(r < 0.0, "the top is pushed down");
            assert!(
                (pu + r).abs() < 1e-9 * r.abs(),
                "{case} {fam}: P_upper {pu} vs reaction {r}"
            );
            assert!(
                (pl - r).abs() < 1e-9 * r.abs(),
                "{case} {fam}: P_lower {pl} vs reaction {r}"
            );
            // the mean pressure (per current area, which lateral expansion enlarges by a few %) times
            // the reference area is about the load
            let area = if dim == 2 { 2.0 } else { 4.0 };
            assert!(
                (mean * area + r).abs() < 5e-2 * r.abs(),
                "{case} {fam}: pressure {mean} over the (reference) area vs load {r}"
            );
        }
    }
}

#[test]
fn frictionless_sliding_of_a_flat_block_has_no_horizontal_contact_force() {
    // the paper's formulation (both half-passes) and, between Q1N2 surfaces, the default
    // (one-pass: the slave's force)
    for (fam, form, passes) in [
        ("Q1C1", "paper", &["upper_bottom", "lower_top"][..]),
        ("Q1N2", "paper", &["upper_bottom", "lower_top"][..]),
        ("Q1N2", "default", &["upper_bottom"][..]),
    ] {
        let mut sets = vec![
            format!("bodies.lower.element={fam}"),
            format!("bodies.upper.element={fam}"),
        ];
        if form == "paper" {
            sets.push("contact.0.formulation=paper".into());
        }
        let sets: Vec<&str> = sets.iter().map(String::as_str).collect();
        let d = run_case(
            &format!("slide-flat-{fam}-{form}"),
            "sliding_flat_2d.toml",
            1,
            &sets,
        );
        let load = history_col(&d, "load_factor");
        assert!((load.last().unwrap() - 2.0).abs() < 1e-12, "all stages ran");
        for pass in passes {
            let px = history_col(&d, &format!("P_slide_{pass}_x"));
            let py = history_col(&d, &format!("P_slide_{pass}_y"));
            let scale = py.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            assert!(
                scale > 1e-3,
                "{fam} {form} {pass}: the blocks are pressed together"
            );
            for (x, y) in px.iter().zip(&py) {
                assert!(
                    x.abs() < 1e-12 * scale,
                    "{fam} {form} {pass}: P_x = {x} with P_y = {y}"
                );
            }
        }
        // the upper block is in homogeneous compression: its reaction does not change while sliding
        let r = history_col(&d, "R_upper_top_y");
        let slide: Vec<f64> = r[r.len() - 10..].to_vec();
        assert!(
            rel_diff(&slide, &vec![slide[0]; slide.len()]) < 1e-9,
            "{slide:?}"
        );
    }
}

#[test]
fn newton_converges_fast_while_contact_points_cross_element_boundaries() {
    // ironing: 40 slide steps of 1/10 block element, so every point crosses element boundaries
    let d = run_case("ironing-newton", "ironing_2d.toml", 1, &[]);
    let s = summary(&d);
    assert_eq!(s["status"], "converged");
    let steps = s["steps"].as_array().unwrap();
    let mut checked = 0;
    for st in &steps[20..] {
        let h: Vec<f64> = st["residual_history"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_f64().unwrap())
            .collect();
        let last = *h.last().unwrap();
        assert!(
            last < 1e-10 * h[0] || last < 1e-11,
            "step converged tightly: {h:?}"
        );
        // the best rate over consecutive triples above round-off: about 2 once the active set has
        // settled (a wrong tangent converges linearly, order ~1, everywhere). Round-off: below the
        // solver's relative tolerance (1e-10 h[0]) the residual stalls near 1e-13 here, which a
        // quadratic step reaches from 4e-8 (order 1.35 measured against the floor, not the rate).
        // A solve stopped for a new contact sparsity pattern and resumed reports the resumed
        // solve's history only: not counted here.
        let its = st["iterations"].as_u64().unwrap() as usize;
        assert!(its <= 16, "{its} Newton iterations in one step: {h:?}");
        if its + 1 != h.len() {
            continue;
        }
        let best = h[1..]
            .windows(3)
            .filter(|w| w[2] > 1e-10 * h[0] && w[1] < w[0])
            .map(|w| (w[2] / w[1]).ln() / (w[1] / w[0]).ln())
            .fold(f64::MIN, f64::max);
        if best > f64::MIN {
            assert!(best > 1.8, "convergence order {best:.2} in history {h:?}");
            checked += 1;
        }
    }
    assert!(
        checked >= 20,
        "too few sliding steps with a measurable rate ({checked})"
    );
    // the case names no formulation: it runs the default, the one-pass weighted gap, and says so
    let resolved = std::fs::read_to_string(d.join("case.toml")).unwrap();
    assert!(
        resolved.contains("formulation = \"weighted_gap\""),
        "{resolved}"
    );
    // the slave's force balances the cylinder's reaction, and over the slide it stays within 1 %
    // of its mean (the paper's two-half-pass formulation: 17 % on this mesh; measured here 0.27 %)
    let r = last(&d, "R_cylinder_top_y");
    let p1 = last(&d, "P_ironing_cylinder_arc_y");
    assert!(r < -0.1, "the cylinder is pressed into the block: R = {r}");
    assert!((p1 + r).abs() < 1e-8 * r.abs(), "P_1 {p1} vs reaction {r}");
    let load = history_col(&d, "load_factor");
    let py: Vec<f64> = history_col(&d, "P_ironing_cylinder_arc_y")
        .into_iter()
        .zip(&load)
        .filter(|&(_, &l)| l >= 1.25)
        .map(|(p, _)| p)
        .collect();
    assert!(py.len() >= 30, "{} sliding steps", py.len());
    let mean = py.iter().sum::<f64>() / py.len() as f64;
    let range =
        py.iter().fold(f64::MIN, |m, &p| m.max(p)) - py.iter().fold(f64::MAX, |m, &p| m.min(p));
    assert!(range < 0.01 * mean, "P_y ranges over {range} about {mean}");
}

/// Cell centres of the bulk grid [n_cells][3] and the owning rank of each cell.
fn cells_and_ranks(dir: &Path, dim: usize) -> (Vec<[f64; 3]>, Vec<f64>) {
    let f = h5_open(dir.join("results.h5")).unwrap();
    let coords = f
        .dataset("grids/bulk/coordinates")
        .unwrap()
        .read_raw::<f64>()
        .unwrap();
    let conn = f
        .dataset("grids/bulk/connectivity")
        .unwrap()
        .read_raw::<i64>()
        .unwrap();
    let npc = if dim == 2 { 4 } else { 8 };
    let centres = conn
        .chunks_exact(npc)
        .map(|c| {
            let mut x = [0.0; 3];
            for &n in c {
                for k in 0..3 {
                    x[k] += coords[n as usize * 3 + k] / npc as f64;
                }
            }
            x
        })
        .collect();
    (centres, h5_last(dir, "bulk", "rank"))
}

#[test]
fn contact_is_rank_invariant_in_2d_and_3d_with_split_contact_surfaces() {
    // 2D: ironing, depression and a short slide
    let sets = [
        "output.fields=[\"displacement\", \"rank\"]",
        "contact.0.formulation=paper",
        "stages.1.steps=5",
        "bcs.1.value=[[0.0, -0.6666666666666666], [0.125, -0.6666666666666666]]",
    ];
    let d1 = run_case("ironing-np1", "ironing_2d.toml", 1, &sets);
    let d2 = run_case("ironing-np2", "ironing_2d.toml", 2, &sets);
    let e = rel_diff(
        &h5_last(&d1, "bulk", "displacement"),
        &h5_last(&d2, "bulk", "displacement"),
    );
    assert!(e < 1e-10, "ironing: 1 vs 2 ranks differ by {e:e}");
    // forces against the contact force of the run (the sliding force P_x is 400x smaller than
    // P_y: against its own largest value, Newton's tolerance alone showed as 1.1e-10 once under
    // the reference BLAS), the moment against its own
    let force_scale = history_col(&d1, "P_ironing_cylinder_arc_y")
        .iter()
        .fold(0.0f64, |m, x| m.max(x.abs()));
    for (col, own_scale) in [
        ("P_ironing_cylinder_arc_y", false),
        ("P_ironing_block_top_x", false),
        ("M_ironing_block_top", true),
    ] {
        let (a, b) = (history_col(&d1, col), history_col(&d2, col));
        let e = if own_scale {
            rel_diff(&a, &b)
        } else {
            a.iter()
                .zip(&b)
                .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()))
                / force_scale
        };
        assert!(e < 1e-10, "ironing {col}: 1 vs 2 ranks differ by {e:e}");
    }
    // both contact surfaces are split: cells along the block's top and the cylinder's arc on both ranks
    let (c, r) = cells_and_ranks(&d2, 2);
    let top: Vec<f64> = (0..c.len())
        .filter(|&i| c[i][1] > 1.75 && c[i][1] < 2.0)
        .map(|i| r[i])
        .collect();
    let arc: Vec<f64> = (0..c.len())
        .filter(|&i| ((c[i][0]).powi(2) + (c[i][1] - 3.0).powi(2)).sqrt() > 0.75 && c[i][1] < 3.0)
        .map(|i| r[i])
        .collect();
    for (name, v) in [("block top", &top), ("cylinder arc", &arc)] {
        assert!(
            v.contains(&0.0) && v.contains(&1.0),
            "METIS did not split the {name}: {v:?}"
        );
    }

    // 2D one-pass (master/slave): the master's rows travel through the contact table's scatter
    let one = [
        sets[0],
        sets[2],
        sets[3],
        "contact.0.algorithm=\"one_pass\"",
    ];
    let o1 = run_case("ironing-one-pass-np1", "ironing_2d.toml", 1, &one);
    let o2 = run_case("ironing-one-pass-np2", "ironing_2d.toml", 2, &one);
    let e = rel_diff(
        &h5_last(&o1, "bulk", "displacement"),
        &h5_last(&o2, "bulk", "displacement"),
    );
    assert!(e < 1e-10, "one-pass ironing: 1 vs 2 ranks differ by {e:e}");
    // one pass balances momentum: the cylinder's reaction carries the block's load
    let (r_cyl, r_blk) = (
        last(&o1, "R_cylinder_top_y"),
        last(&o1, "P_ironing_cylinder_arc_y"),
    );
    assert!(
        (r_cyl + r_blk).abs() < 1e-8 * r_blk.abs(),
        "{r_cyl} vs {r_blk}"
    );

    // 3D: the Q1N2 patch test
    let sets = [
        "bodies.lower.element=Q1N2",
        "bodies.upper.element=Q1N2",
        "meshes.lower.divisions=[6,6,3]",
        "output.fields=[\"displacement\", \"rank\"]",
        "contact.0.formulation=paper",
    ];
    let d1 = run_case("patch3d-np1", "contact_patch_3d.toml", 1, &sets);
    let d2 = run_case("patch3d-np2", "contact_patch_3d.toml", 2, &sets);
    let e = rel_diff(
        &h5_last(&d1, "bulk", "displacement"),
        &h5_last(&d2, "bulk", "displacement"),
    );
    assert!(e < 1e-10, "3D patch: 1 vs 2 ranks differ by {e:e}");
    let e = rel_diff(
        &h5_last(&d1, "bulk", "contact_pressure"),
        &h5_last(&d2, "bulk", "contact_pressure"),
    );
    assert!(e < 1e-10, "3D patch pressure: 1 vs 2 ranks differ by {e:e}");
    let (c, r) = cells_and_ranks(&d2, 3);
    let lower_top: Vec<f64> = (0..c.len())
        .filter(|&i| c[i][2] > 0.6 && c[i][2] < 1.0)
        .map(|i| r[i])
        .collect();
    let upper: Vec<f64> = (0..c.len())
        .filter(|&i| c[i][2] > 1.0)
        .map(|i| r[i])
        .collect();
    // 3D curved: the Q1N2 hemisphere pressed onto a Q1N2 block (coarse)
    let sets = [
        "meshes.block.divisions=[6,6,3]",
        "meshes.shell.n_surface=4",
        "meshes.shell.n_thickness=1",
        "stages.0.steps=3",
        "output.fields=[\"displacement\", \"rank\"]",
        "contact.0.formulation=paper",
    ];
    let h1 = run_case("hemisphere-np1", "hemisphere_block_3d.toml", 1, &sets);
    let h2 = run_case("hemisphere-np2", "hemisphere_block_3d.toml", 2, &sets);
    let e = rel_diff(
        &h5_last(&h1, "bulk", "displacement"),
        &h5_last(&h2, "bulk", "displacement"),
    );
    assert!(e < 1e-10, "3D hemisphere: 1 vs 2 ranks differ by {e:e}");
    for col in ["P_press_shell_outer_z", "P_press_block_zmax_z"] {
        let e = rel_diff(&history_col(&h1, col), &history_col(&h2, col));
        assert!(
            e < 1e-10,
            "3D hemisphere {col}: 1 vs 2 ranks differ by {e:e}"
        );
    }
    assert!(
        last(&h1, "P_press_block_zmax_z") < -0.1,
        "the shell presses the block"
    );
    let (c, r) = cells_and_ranks(&h2, 3);
    let top: Vec<f64> = (0..c.len())
        .filter(|&i| c[i][2] > -1.0 / 3.0 && c[i][2] < 0.0)
        .map(|i| r[i])
        .collect();
    assert!(
        top.contains(&0.0) && top.contains(&1.0),
        "METIS did not split the block's contact layer: {top:?}"
    );

    // METIS keeps the smaller body whole here; the lower contact layer is split, so contact pairs
    // points and partner elements owned by different ranks
    assert!(
        lower_top.contains(&0.0) && lower_top.contains(&1.0),
        "METIS did not split the lower contact layer: {lower_top:?}"
    );
    let up = upper[0];
    assert!(
        lower_top.iter().any(|&r| r != up),
        "some lower contact cells live on the other rank than the upper block"
    );
}

/// Peaks of the post-processed pressure per current area and per reference area (nominal), and the
/// load, of a `hertz_2d` run.
fn hertz_peaks(family: &str, n_arc: usize) -> (f64, f64, f64) {
    hertz_peaks_with(family, n_arc, 1, &[])
}

#[test]
fn hertz_2d_nominal_peak_pressure_converges_to_hertz() {
    // Hertz's theory is geometrically linear: its pressure is the force per reference area. The
    // pressure per current area is larger by the inverse surface stretch (about 2.3 % at the
    // centre, where the surface is compressed). docs/verification/hertz.md, "Hertz contact".
    let (peak_c, peak_n, p) = hertz_peaks("Q1C1", 128);
    let (e_c, e_n) = (hertz_error(peak_c, p), hertz_error(peak_n, p));
    assert!(
        e_n.abs() < 0.01,
        "Q1C1 n_arc 128: nominal peak {peak_n} is {e_n:+.4} from Hertz"
    );
    let stretch = peak_n / peak_c;
    assert!(
        (0.965..0.985).contains(&stretch),
        "Q1C1: nominal / current peak {stretch} (current {e_c:+.4})"
    );
    // Q1N2: 8 elements across the contact width (n_arc 128) +1.95 %, 16 (n_arc 256) +0.93 %
    let (_, n128, p128) = hertz_peaks("Q1N2", 128);
    let (_, n256, p256) = hertz_peaks("Q1N2", 256);
    let (e128, e256) = (hertz_error(n128, p128), hertz_error(n256, p256));
    assert!(
        e128.abs() < 0.025 && e256.abs() < 0.01 && e256.abs() < 0.6 * e128.abs(),
        "Q1N2 nominal peak errors {e128:+.4} (n_arc 128), {e256:+.4} (n_arc 256)"
    );
}

#[test]
fn hertz_2d_element_mean_gap_meets_one_percent_at_eight_elements_across_the_contact() {
    // `gap = "element_mean"` (one pressure per surface element) removes the point-to-point
    // pressure oscillation of Q1N2 that the pointwise law shows at this mesh (+1.95 %, asserted
    // above) and with it the dependence on the penalty (docs/verification/hertz.md)
    for (eps, np) in [("1e4", 1), ("1e4", 2), ("1e5", 1)] {
        let eps_set = format!("contact.0.eps_n={eps}");
        let (_, peak, p) =
            hertz_peaks_with("Q1N2", 128, np, &["contact.0.gap=element_mean", &eps_set]);
        let e = hertz_error(peak, p);
        assert!(
            e.abs() < 0.01,
            "Q1N2 n_arc 128 element_mean eps_n {eps}, {np} rank(s): nominal peak {e:+.4} from Hertz"
        );
    }
}

#[test]
fn a_failed_projection_cuts_the_load_step_back_on_1_and_2_ranks() {
    // The first two projections of the run fail (fault injection, src/contact/fault.rs): the first
    // attempt of step 1 must be cut back and retried, and the run must end where an undisturbed run
    // ends (frictionless elastic contact: the end state does not depend on the load path).
    let clean = run_case("projection-fault-clean", "contact_patch_2d.toml", 1, &[]);
    let u_clean = h5_last(&clean, "bulk", "displacement");
    for np in [1, 2] {
        let d = scratch(&format!("projection-fault-{np}"));
        let c = case("contact_patch_2d.toml");
        let args = [
            "run",
            c.to_str().unwrap(),
            "--out",
            d.to_str().unwrap(),
            "-q",
            "--overwrite",
        ];
        let out = run_with_env(
            np,
            &args,
            None,
            std::time::Duration::from_secs(300),
            &[("NURBS_CONTACT_FAIL_PROJECTION_AT", "1-2")],
        )
        .expect("the run finished");
        assert!(out.status.success(), "{np} ranks: {}", stderr(&out));
        let s = summary(&d);
        assert_eq!(s["status"], "converged", "{np} ranks");
        let first = &s["steps"][0];
        assert_eq!(first["cutbacks"], 1, "{np} ranks: {first}");
        let reason = first["failed_attempts"][0][1].as_str().unwrap_or_default();
        assert!(
            reason.contains("projection"),
            "{np} ranks: the failed attempt names the projection: {reason}"
        );
        let u = h5_last(&d, "bulk", "displacement");
        let diff = rel_diff(&u_clean, &u);
        assert!(diff < 1e-10, "{np} ranks: end state differs by {diff:e}");
    }
}

#[test]
fn element_mean_gap_outside_its_scope_is_refused_with_the_key() {
    for (file, sets, want) in [
        (
            "peeling_2d.toml",
            vec!["contact.0.gap=element_mean"],
            "penalty",
        ),
        ("hertz_2d.toml", vec!["contact.0.gap=mean"], "element_mean"),
    ] {
        let c = case(file);
        let mut args = vec!["check", c.to_str().unwrap()];
        for s in &sets {
            args.extend(["--set", s]);
        }
        let out = run(1, &args);
        let err = stderr(&out);
        assert!(!out.status.success(), "{sets:?}: accepted");
        assert!(!err.contains("panicked"), "{sets:?}: panic:\n{err}");
        assert!(
            err.contains("contact.0.gap") && err.contains(want) && err.contains(file),
            "{sets:?}: message does not name the key, the reason and the file:\n{err}"
        );
    }
}

/// Each attempt of a load step has its own budget of sparsity-pattern rebuilds (4). Ironing with
/// no reserved band (`contact_pattern_ring = 0`: every partner change needs a rebuild) and the
/// slide in 4 nominal steps: attempts use up their rebuilds and steps are cut back. When the budget
/// was per step, an attempt after a cutback started with it used up and failed at its first
/// outdated pattern after 1-2 Newton iterations (10 cutbacks in this run instead of 4; the
/// 1e5-unknown scale scene's first step needed 7 cutbacks for that reason). An attempt that fails on the budget says so, and has had
/// at least 5 solves.
#[test]
fn every_attempt_of_a_step_has_its_own_pattern_rebuild_budget() {
    let d = run_case(
        "pattern-budget",
        "ironing_2d.toml",
        1,
        &["stages.1.steps=4", "solver.contact_pattern_ring=0"],
    );
    let s = summary(&d);
    assert_eq!(s["status"], "converged");
    let rebuilds = s["contact_pattern"]["rebuilds"].as_u64().unwrap();
    assert!(
        rebuilds >= 20,
        "too few pattern rebuilds to test: {rebuilds}"
    );
    // the pattern's sizes are reported (a contact run has both)
    let coo = s["contact_pattern"]["coo_entries"].as_u64().unwrap();
    let regions = s["contact_pattern"]["region_entries"].as_u64().unwrap();
    assert!(regions > 0 && coo > 0, "{}", s["contact_pattern"]);
    // the contact rows' column patterns: at most one column per contact COO entry
    let run_columns = s["contact_pattern"]["run_columns"].as_u64().unwrap();
    assert!(
        run_columns > 0 && run_columns < coo,
        "{}",
        s["contact_pattern"]
    );
    let mut on_budget = 0;
    for st in s["steps"].as_array().unwrap() {
        let fails = st["failed_attempts"].as_array().unwrap();
        let n = fails
            .iter()
            .filter(|a| {
                let why = a[1].as_str().unwrap();
                assert!(
                    why != "DIVERGED_JACOBIAN_DOMAIN",
                    "a failure on the pattern that does not say so: {st}"
                );
                why.contains("outside the sparsity pattern after 4 rebuilds")
            })
            .count() as u64;
        // each such attempt ran 5 solves of at least one Newton iteration
        let failed_its = st["failed_iterations"].as_u64().unwrap_or(0);
        assert!(
            failed_its >= 5 * n,
            "{n} attempts failed on the budget in {failed_its} iterations: {st}"
        );
        on_budget += n;
    }
    assert!(
        on_budget >= 1,
        "no attempt used up its budget: nothing tested"
    );
}

/// `[solver] max_penetration`: a state deeper than the bound is outside the domain. On Hertz
/// (`eps_n = 1e4`, the first step presses 0.005, 700x the solution's penetration of 7e-6) the
/// first Newton iterate would lift the whole increment into the block; with a bound of 5e-4 the
/// line search shortens it (more Newton iterations) and the answer is the unbounded one. A bound
/// below the solution's penetration leaves no admissible equilibrium: the run fails naming the key.
#[test]
fn a_penetration_bound_shortens_newton_steps_and_keeps_the_answer() {
    let free = run_case("maxpen-free", "hertz_2d.toml", 1, &[]);
    let bound = run_case(
        "maxpen-bound",
        "hertz_2d.toml",
        1,
        &["solver.max_penetration=5e-4"],
    );
    for col in ["R_disk_top_y", "penetration_flat_disk_arc"] {
        let (a, b) = (history_col(&free, col), history_col(&bound, col));
        let d = rel_diff(&a, &b);
        assert!(d < 1e-8, "{col}: {a:?} vs {b:?} ({d:e})");
    }
    let its = |d: &Path| summary(d)["newton"]["total_iterations"].as_u64().unwrap();
    assert!(
        its(&bound) > its(&free),
        "the bound did not act: {} vs {} Newton iterations",
        its(&bound),
        its(&free)
    );
    let (_, out) = run_case_output(
        "maxpen-below",
        "hertz_2d.toml",
        1,
        &[
            "output.plots=false",
            "solver.max_penetration=5e-6",
            "steps.pseudo_steps=0",
        ],
    );
    let err = stderr(&out);
    assert!(!out.status.success(), "{err}");
    assert!(
        err.contains("more than `solver.max_penetration` = 5e-6"),
        "{err}"
    );
}
