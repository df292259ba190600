//! summary.json `contact_data`: what each rank holds for contact and receives per evaluation (the
//! measure of issue 21's distributed contact surfaces), consistent between 1 and 2 ranks.

mod common;
use common::*;

fn column(s: &serde_json::Value, key: &str) -> Vec<u64> {
    s["contact_data"][key]
        .as_array()
        .unwrap_or_else(|| panic!("contact_data.{key} missing: {s}"))
        .iter()
        .map(|v| v.as_u64().unwrap())
        .collect()
}

#[test]
fn contact_data_counts_what_each_rank_holds_and_receives() {
    let sets = [
        "meshes.block.divisions=[4,4,4]",
        "meshes.shell.n_surface=4",
        "stages.0.steps=2",
        "output.plots=false",
    ];
    let d1 = run_case("contact-data-np1", "hemisphere_block_3d.toml", 1, &sets);
    let d2 = run_case("contact-data-np2", "hemisphere_block_3d.toml", 2, &sets);
    let (s1, s2) = (summary(&d1), summary(&d2));
    for (s, np) in [(&s1, 1), (&s2, 2)] {
        for key in [
            "table_nodes",
            "surface_bytes",
            "point_bytes",
            "received_bytes_per_evaluation",
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
    // one rank owns everything it gathers; two ranks receive part of the surfaces
    assert_eq!(column(&s1, "received_bytes_per_evaluation"), vec![0]);
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
}
