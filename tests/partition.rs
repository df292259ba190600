//! summary.json `partition`: with contact, METIS balances the contact quadrature points between
//! the ranks as well as the cells (a second constraint), so that the ranks owning a contact
//! surface do not carry all of its points; and results do not depend on the split.

mod common;
use common::*;

fn list(s: &serde_json::Value, key: &str) -> Vec<u64> {
    summary_list(s, "partition", key)
}

/// max / mean of the entries.
fn imbalance(v: &[u64]) -> f64 {
    let mean = v.iter().sum::<u64>() as f64 / v.len() as f64;
    *v.iter().max().unwrap() as f64 / mean
}

#[test]
fn contact_points_and_cells_are_balanced_on_two_ranks() {
    // The hemisphere pressed onto the block: with the cells balanced alone, one rank held 1.5x
    // the mean of the contact points at this size (docs/performance/contact.md, "Contact data per rank").
    let sets = [
        "meshes.block.divisions=[8,8,8]",
        "meshes.shell.n_surface=8",
        "stages.0.steps=1",
        "bcs.1.value=[[0.0,0.0,-0.05]]",
        "output.plots=false",
        "output.fields=[\"displacement\"]",
    ];
    let d1 = run_case("partition-np1", "hemisphere_block_3d.toml", 1, &sets);
    let d2 = run_case("partition-np2", "hemisphere_block_3d.toml", 2, &sets);
    let (s1, s2) = (summary(&d1), summary(&d2));
    assert!(s1.get("partition").is_none(), "one rank has no partition");
    let (cells, points) = (list(&s2, "cells"), list(&s2, "contact_points"));
    assert_eq!(cells.iter().sum::<u64>(), s2["elements"].as_u64().unwrap());
    assert!(points.iter().sum::<u64>() > 0);
    assert!(imbalance(&cells) < 1.05, "cells {cells:?}");
    assert!(imbalance(&points) < 1.05, "contact points {points:?}");
    assert!(s2["partition"]["cut_faces"].as_u64().unwrap() > 0);
    // The same answer on both splits.
    assert_eq!(s1["status"], "converged");
    let (h1, h2) = (history_values(&d1), history_values(&d2));
    assert!(
        h1.iter().any(|v| v.abs() > 1e-3),
        "no contact force: {h1:?}"
    );
    let dh = rel_diff(&h1, &h2);
    assert!(dh < 1e-10, "1 and 2 ranks differ: history {dh:e}");
}
