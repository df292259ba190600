//! The same case on 1 and 2 MPI ranks gives the same answer: displacement to 1e-10 relative, and the
//! same load history. The meshes are sized so that METIS splits them irregularly (not along a plane),
//! which the tests check from the owning-rank field.

mod common;
use common::*;

/// Runs `case` on 1 and 2 ranks with `sets` and returns the two output directories.
fn run_both(name: &str, case: &str, sets: &[&str]) -> (std::path::PathBuf, std::path::PathBuf) {
    let d1 = scratch(&format!("{name}-np1"));
    let d2 = scratch(&format!("{name}-np2"));
    let c = common::case(case);
    for (np, d) in [(1, &d1), (2, &d2)] {
        let mut args = vec![
            "run",
            c.to_str().unwrap(),
            "--out",
            d.to_str().unwrap(),
            "-q",
        ];
        for s in sets {
            args.extend(["--set", s]);
        }
        run_ok(np, &args);
    }
    (d1, d2)
}

/// The partition is not a cut by one coordinate plane: some rank-0 cell lies beyond some rank-1 cell
/// along every axis direction.
fn assert_irregular_partition(dir: &std::path::Path, dim: usize) {
    let ranks = h5_last(dir, "bulk", "rank");
    assert!(
        ranks.contains(&0.0) && ranks.contains(&1.0),
        "both ranks own cells"
    );
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
    let centre = |c: usize, k: usize| -> f64 {
        conn[c * npc..(c + 1) * npc]
            .iter()
            .map(|&n| coords[n as usize * 3 + k])
            .sum::<f64>()
            / npc as f64
    };
    let n_cells = ranks.len();
    let mut planar_cut = false;
    for k in 0..dim {
        let max0 = (0..n_cells)
            .filter(|&c| ranks[c] == 0.0)
            .map(|c| centre(c, k))
            .fold(f64::MIN, f64::max);
        let min0 = (0..n_cells)
            .filter(|&c| ranks[c] == 0.0)
            .map(|c| centre(c, k))
            .fold(f64::MAX, f64::min);
        let max1 = (0..n_cells)
            .filter(|&c| ranks[c] == 1.0)
            .map(|c| centre(c, k))
            .fold(f64::MIN, f64::max);
        let min1 = (0..n_cells)
            .filter(|&c| ranks[c] == 1.0)
            .map(|c| centre(c, k))
            .fold(f64::MAX, f64::min);
        if max0 < min1 || max1 < min0 {
            planar_cut = true;
        }
    }
    assert!(
        !planar_cut,
        "the 2-rank partition is a single axis-aligned cut; pick a mesh METIS splits irregularly"
    );
}

#[test]
fn block_compression_3d_same_displacement_on_1_and_2_ranks() {
    let (d1, d2) = run_both(
        "block3d",
        "block_compression_3d.toml",
        &["meshes.block.divisions=[7,5,3]"],
    );
    let u1 = h5_last(&d1, "bulk", "displacement");
    let u2 = h5_last(&d2, "bulk", "displacement");
    let e = rel_diff(&u1, &u2);
    assert!(e < 1e-10, "1 vs 2 ranks differ by {e:e}");
    assert!(
        u1.iter().any(|&u| u.abs() > 0.1),
        "the block was compressed"
    );
    assert_irregular_partition(&d2, 3);
    let (r1, r2) = (
        history_col(&d1, "R_block_zmin_z"),
        history_col(&d2, "R_block_zmin_z"),
    );
    assert!(
        rel_diff(&r1, &r2) < 1e-9,
        "reaction histories differ: {r1:?} vs {r2:?}"
    );
}

#[test]
fn strip_bending_2d_same_displacement_on_1_and_2_ranks() {
    let (d1, d2) = run_both(
        "strip2d",
        "strip_bending_2d.toml",
        &["meshes.strip.divisions=[23,3]"],
    );
    let u1 = h5_last(&d1, "bulk", "displacement");
    let u2 = h5_last(&d2, "bulk", "displacement");
    let e = rel_diff(&u1, &u2);
    assert!(e < 1e-10, "1 vs 2 ranks differ by {e:e}");
    assert!(u1.iter().any(|&u| u.abs() > 0.3), "the strip was bent");
    assert_irregular_partition(&d2, 2);
    let (l1, l2) = (
        history_col(&d1, "load_factor"),
        history_col(&d2, "load_factor"),
    );
    assert_eq!(l1, l2, "both runs take the same load steps");
}
