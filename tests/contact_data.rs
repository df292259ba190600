//! summary.json `contact_data`: what each rank holds for contact and receives per evaluation (the
//! measure of distributed contact surfaces), consistent between 1, 2 and 4 ranks; the
//! ghost layer (each rank gathers only its own surface elements and the partner elements within
//! reach) changes no result and is refreshed as surfaces slide.

mod common;
use common::*;
use std::path::Path;

/// The largest relative difference between two runs of the last displacement and contact
/// pressure, and of the history columns `cols` over every step.
fn largest_difference(a: &Path, b: &Path, cols: &[&str]) -> f64 {
    let mut e: f64 = 0.0;
    for field in ["displacement", "contact_pressure"] {
        e = e.max(rel_diff(
            &h5_last(a, "bulk", field),
            &h5_last(b, "bulk", field),
        ));
    }
    for col in cols {
        e = e.max(rel_diff(&history_col(a, col), &history_col(b, col)));
    }
    e
}

fn column(s: &serde_json::Value, key: &str) -> Vec<u64> {
    summary_list(s, "contact_data", key)
}

#[test]
fn contact_data_counts_what_each_rank_holds_and_receives() {
    let sets = [
        "meshes.block.divisions=[4,4,4]",
        "meshes.shell.n_surface=4",
        "stages.0.steps=2",
        "output.plots=false",
        // on this small case the search distance reaches across most of the block top (256
        // facing cell pairs for 16 + 16 surface cells), so on the default partition every rank
        // gathers every surface node; the cells-only split shows partial gathers
        "solver.partition=cells",
        // two half-passes: both surfaces' points are integrated and counted
        "contact.0.formulation=paper",
    ];
    let d1 = run_case("contact-data-np1", "hemisphere_block_3d.toml", 1, &sets);
    let d2 = run_case("contact-data-np2", "hemisphere_block_3d.toml", 2, &sets);
    let d4 = run_case("contact-data-np4", "hemisphere_block_3d.toml", 4, &sets);
    let (s1, s2, s4) = (summary(&d1), summary(&d2), summary(&d4));
    // the ghost layer changes no result
    let cols = ["P_press_shell_outer_z", "P_press_block_zmax_z"];
    assert!(last(&d1, cols[1]) < -0.1, "the shell presses the block");
    for (d, np) in [(&d2, 2), (&d4, 4)] {
        let e = largest_difference(&d1, d, &cols);
        assert!(e < 1e-10, "1 vs {np} ranks differ by {e:e}");
    }
    for (s, np) in [(&s1, 1), (&s2, 2), (&s4, 4)] {
        for key in [
            "table_nodes",
            "surface_bytes",
            "point_bytes",
            "received_bytes_per_evaluation",
            "ghost_elements",
            "refreshes",
        ] {
            assert_eq!(
                column(s, key).len(),
                np,
                "{key} on {np} ranks: one entry per rank"
            );
        }
        let table = column(s, "table_nodes");
        let recv = column(s, "received_bytes_per_evaluation");
        for r in 0..np {
            assert!(column(s, "surface_bytes")[r] > 0 && column(s, "point_bytes")[r] > 0);
            // at most every table node's three components, 8 bytes each
            assert!(
                recv[r] <= 24 * table[r],
                "rank {r}: {} > 24 x {}",
                recv[r],
                table[r]
            );
        }
    }
    // one rank owns everything it gathers and holds every element: no ghosts, no refreshes
    assert_eq!(column(&s1, "received_bytes_per_evaluation"), vec![0]);
    assert_eq!(column(&s1, "ghost_elements"), vec![0]);
    assert_eq!(column(&s1, "refreshes"), vec![0]);
    // on several ranks some gather only part of the surfaces' nodes (on this small case the rank
    // that owns the shell has the whole block top within reach), some of them other ranks'
    let all = column(&s1, "table_nodes")[0];
    for s in [&s2, &s4] {
        let t = column(s, "table_nodes");
        assert!(
            t.iter().all(|&n| n <= all) && t.iter().any(|&n| n < all),
            "table nodes {t:?} vs every surface node {all}"
        );
        assert!(column(s, "ghost_elements").iter().any(|&g| g > 0));
    }
    assert!(column(&s2, "received_bytes_per_evaluation")
        .iter()
        .all(|&b| b > 0));
    // the points are split between the ranks
    let (p1, p2) = (column(&s1, "point_bytes")[0], column(&s2, "point_bytes"));
    assert!(
        p2.iter().all(|&p| p < p1),
        "points {p2:?} vs one rank's {p1}"
    );
    // the gather runs once per evaluation, the same number on any rank count (same Newton path)
    let ev = |s: &serde_json::Value| s["contact_data"]["evaluations"].as_u64().unwrap();
    assert!(ev(&s1) > 0);
    assert_eq!(ev(&s1), ev(&s2));
    // each rank's own timers: the contact work (update, evaluation) is part of its contact time;
    // the slowest rank's is `wall_time`'s
    for (s, np) in [(&s1, 1), (&s2, 2), (&s4, 4)] {
        let t = |key: &str| -> Vec<f64> {
            s["rank_times"][key]
                .as_array()
                .unwrap_or_else(|| panic!("rank_times.{key} on {np} ranks"))
                .iter()
                .map(|v| v.as_f64().unwrap())
                .collect()
        };
        let (update, evaluate, contact) =
            (t("contact_update"), t("contact_evaluate"), t("contact"));
        assert_eq!(
            contact.len(),
            np,
            "rank_times on {np} ranks: one entry per rank"
        );
        for r in 0..np {
            assert!(update[r] > 0.0 && evaluate[r] > 0.0, "rank {r} of {np}");
            let refresh = t("contact_refresh")[r];
            assert!(
                update[r] + evaluate[r] + refresh <= contact[r],
                "rank {r} of {np}"
            );
            // one rank holds every element: it never refreshes a ghost layer
            assert!(np > 1 || refresh == 0.0);
        }
        let slowest = contact.iter().copied().fold(0.0, f64::max);
        assert_eq!(
            s["wall_time"]["contact"].as_f64(),
            Some(slowest),
            "{np} ranks"
        );
    }
}

#[test]
fn the_ghost_layer_follows_a_sliding_block_and_changes_no_result() {
    // an upper block slid by 3 of its widths' quarters over a lower one with friction: the ghost
    // layer (a quarter of the search distance, 2 h, thick beyond it) must be refreshed
    // (the default formulation: one-pass, the slave `upper.bottom` reports the forces)
    let sets = [
        "bodies.lower.element=Q1N2",
        "bodies.upper.element=Q1N2",
        "contact.0.mu=0.3",
        "output.plots=false",
    ];
    let d1 = run_case("ghost-slide-np1", "sliding_flat_2d.toml", 1, &sets);
    let d2 = run_case("ghost-slide-np2", "sliding_flat_2d.toml", 2, &sets);
    let cols = ["P_slide_upper_bottom_y", "Pt_slide_upper_bottom_x"];
    assert!(
        last(&d1, cols[0]).abs() > 1e-3,
        "the blocks are pressed together"
    );
    assert!(last(&d1, cols[1]).abs() > 1e-4, "friction acts");
    let e = largest_difference(&d1, &d2, &cols);
    assert!(e < 1e-10, "1 vs 2 ranks differ by {e:e}");
    for col in ["stick_slide_upper_bottom", "slip_slide_upper_bottom"] {
        assert_eq!(history_col(&d1, col), history_col(&d2, col), "{col}");
    }
    let (s1, s2) = (summary(&d1), summary(&d2));
    assert_eq!(column(&s1, "refreshes"), vec![0]);
    let r = column(&s2, "refreshes");
    assert!(r[0] > 0 && r[0] == r[1], "refreshes {r:?}");
    assert!(column(&s2, "ghost_elements").iter().any(|&g| g > 0));
}

#[test]
fn the_contact_partition_keeps_facing_pieces_together_on_a_long_contact_interface() {
    // two flat blocks 16 long pressed together over their whole length: with the ghost layer a
    // rank gathers its own surface piece and the partner elements across from it, so the table
    // falls with the rank count; the default partition keeps the facing pieces of the two blocks
    // on one rank (edges between facing contact cells), so a rank receives only the few values
    // across its pieces' ends, where the cells-only split (two blocks, no face between them)
    // separates the facing pieces and a rank receives most of the partner surface under its own
    let sets = [
        "bodies.lower.element=Q1N2",
        "bodies.upper.element=Q1N2",
        "meshes.lower.origin=[-8.0,-1.0]",
        "meshes.lower.size=[16.0,1.0]",
        "meshes.lower.divisions=[96,4]",
        "meshes.upper.origin=[-8.0,0.0]",
        "meshes.upper.size=[16.0,0.5]",
        "meshes.upper.divisions=[72,3]",
        "bcs.3.value=[[0.0],[0.0]]",
        "stages.1.steps=1",
        "output.plots=false",
        // two half-passes: both blocks' points face a partner and are balanced
        "contact.0.formulation=paper",
    ];
    let runs: Vec<_> = [1, 2, 4]
        .iter()
        .map(|&np| {
            run_case(
                &format!("ghost-long-np{np}"),
                "sliding_flat_2d.toml",
                np,
                &sets,
            )
        })
        .collect();
    let mut cells_sets = sets.to_vec();
    cells_sets.push("solver.partition=cells");
    let cells = run_case(
        "ghost-long-cells-np2",
        "sliding_flat_2d.toml",
        2,
        &cells_sets,
    );
    let cols = ["P_slide_upper_bottom_y", "P_slide_lower_top_y"];
    assert!(
        last(&runs[0], cols[0]).abs() > 1e-3,
        "the blocks are pressed together"
    );
    for (d, np) in runs[1..].iter().chain([&cells]).zip([2, 4, 2]) {
        let e = largest_difference(&runs[0], d, &cols);
        assert!(e < 1e-10, "1 vs {np} ranks differ by {e:e}");
    }
    let s: Vec<_> = runs.iter().map(|d| summary(d)).collect();
    let mean = |v: Vec<u64>| v.iter().sum::<u64>() as f64 / v.len() as f64;
    let recv: Vec<f64> = s
        .iter()
        .map(|s| mean(column(s, "received_bytes_per_evaluation")))
        .collect();
    let table: Vec<f64> = s.iter().map(|s| mean(column(s, "table_nodes"))).collect();
    assert_eq!(recv[0], 0.0);
    assert!(
        table[2] < table[1] && table[1] < table[0],
        "mean table nodes per rank on 1, 2, 4 ranks: {table:?}"
    );
    // every surface node a rank does not hold is a value it no longer receives
    let all = column(&s[0], "table_nodes")[0];
    assert!(column(&s[2], "table_nodes").iter().all(|&t| t < all));
    // the partition keeps the facing pieces together: a fraction of the cells-only traffic
    let sc = summary(&cells);
    let recv_cells = mean(column(&sc, "received_bytes_per_evaluation"));
    assert!(
        recv[1] > 0.0 && 2.0 * recv[1] < recv_cells,
        "mean received bytes per rank on 2 ranks: {} (contact partition) vs {recv_cells} (cells)",
        recv[1]
    );
    // the default partition balances the points that face a partner, on 2 and 4 ranks
    for s in &s[1..] {
        let facing: Vec<u64> = s["partition"]["facing_points"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_u64().unwrap())
            .collect();
        let (lo, hi) = (facing.iter().min().unwrap(), facing.iter().max().unwrap());
        assert!(
            *lo > 0 && 10 * (hi - lo) <= hi + lo,
            "facing points per rank {facing:?}"
        );
    }
    let cut = |s: &serde_json::Value| s["partition"]["cut_facing_pairs"].as_u64().unwrap();
    let kind = |s: &serde_json::Value| s["partition"]["kind"].as_str().unwrap().to_string();
    assert_eq!((kind(&s[1]), kind(&sc)), ("contact".into(), "cells".into()));
    assert!(
        4 * cut(&s[1]) < cut(&sc),
        "facing pairs cut: {} vs {}",
        cut(&s[1]),
        cut(&sc)
    );
}
