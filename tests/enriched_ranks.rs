//! The half-cylinder case (cases/half_cylinder_press_2d.toml) with every enriched family: the same
//! displacement on 1 and 2 ranks, and refinement converging towards a fine Q1C1 solution; the 3D
//! block case with a Q1N2-enriched top on 1 and 2 ranks.

mod common;
use common::*;
use std::path::PathBuf;

/// Runs `case_file` on `ranks` ranks with `--set` overrides; returns the output directory.
fn run_case(case_file: &str, tag: &str, ranks: usize, sets: &[String]) -> PathBuf {
    let out = scratch(&format!("enriched_ranks_{tag}_np{ranks}"));
    let c = case(case_file);
    let mut args = vec![
        "run",
        c.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "-q",
    ];
    for s in sets {
        args.extend(["--set", s.as_str()]);
    }
    run_ok(ranks, &args);
    out
}

fn run(tag: &str, ranks: usize, sets: &[String]) -> PathBuf {
    run_case("half_cylinder_press_2d.toml", tag, ranks, sets)
}

fn element(family: &str) -> String {
    format!("bodies.disk.element={family}")
}

#[test]
fn every_enriched_family_gives_the_same_displacement_on_1_and_2_ranks() {
    for family in ["Q1C1", "Q1N2", "Q1N2.1", "Q1C2", "Q1CH"] {
        let sets = [element(family)];
        let u1 = h5_last(&run(family, 1, &sets), "bulk", "displacement");
        let u2 = h5_last(&run(family, 2, &sets), "bulk", "displacement");
        let scale = u1.iter().fold(0.0_f64, |a, x| a.max(x.abs()));
        assert!(scale > 0.09, "{family}: the top must move by 0.1");
        let d = rel_diff(&u1, &u2);
        assert!(d <= 1e-10, "{family}: 1 vs 2 ranks differ by {d:e}");
    }
}

#[test]
fn enriched_3d_block_gives_the_same_displacement_on_1_and_2_ranks() {
    let sets = [
        "bodies.block.element=Q1N2".to_string(),
        "bodies.block.enriched_surface=zmax".to_string(),
    ];
    let u1 = h5_last(
        &run_case("block_compression_3d.toml", "block_q1n2", 1, &sets),
        "bulk",
        "displacement",
    );
    let u2 = h5_last(
        &run_case("block_compression_3d.toml", "block_q1n2", 2, &sets),
        "bulk",
        "displacement",
    );
    assert!(u1.iter().any(|u| u.abs() > 0.1), "the block was compressed");
    let d = rel_diff(&u1, &u2);
    assert!(d <= 1e-10, "3D Q1N2: 1 vs 2 ranks differ by {d:e}");
}

#[test]
fn refined_enriched_meshes_converge_to_the_fine_q1c1_reaction() {
    let reaction = |tag: &str, family: &str, n_arc: usize, n_rad: usize| {
        let sets = [
            format!("meshes.disk.n_arc={n_arc}"),
            format!("meshes.disk.n_radial={n_rad}"),
            element(family),
        ];
        *history_col(&run(tag, 1, &sets), "R_disk_top_core_y")
            .last()
            .unwrap()
    };
    let fine = reaction("fine_q1c1", "Q1C1", 128, 32);
    for family in ["Q1N2", "Q1N2.1"] {
        let errors: Vec<f64> = [(8, 2), (16, 4), (32, 8)]
            .iter()
            .map(|&(a, r)| (reaction(&format!("{family}_{a}"), family, a, r) - fine).abs())
            .collect();
        assert!(
            errors.windows(2).all(|w| w[1] < 0.7 * w[0]),
            "{family}: reaction errors {errors:?} must decrease with refinement"
        );
    }
}
