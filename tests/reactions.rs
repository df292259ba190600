//! Reaction moments on node sets: the strip bent by rotating one end about its midpoint while the
//! other is clamped carries no other load, so the moments of the two ends' reactions about any
//! point cancel, and each is the bending moment the rotation needs.

mod common;
use common::*;

#[test]
fn reaction_moments_of_the_two_ends_of_a_bent_strip_balance() {
    let d = scratch("reaction-moments");
    let c = case("strip_bending_2d.toml");
    run_ok(
        1,
        &[
            "run",
            c.to_str().unwrap(),
            "--out",
            d.to_str().unwrap(),
            "-q",
        ],
    );
    let ml = history_col(&d, "M_strip_left");
    let mr = history_col(&d, "M_strip_right");
    let (rlx, rrx) = (
        history_col(&d, "R_strip_left_x"),
        history_col(&d, "R_strip_right_x"),
    );
    assert!(!ml.is_empty() && ml.len() == mr.len());
    let scale = mr.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    assert!(scale > 1e-3, "the rotated end carries a moment: {mr:?}");
    for (i, (a, b)) in ml.iter().zip(&mr).enumerate() {
        assert!(
            (a + b).abs() < 1e-8 * scale,
            "step {i}: moments {a} + {b} do not balance"
        );
        assert!(
            (rlx[i] + rrx[i]).abs() < 1e-8 * scale,
            "step {i}: forces do not balance"
        );
    }
    // the moment grows with the rotation (first stage: 0 -> 45 degrees)
    assert!(mr[1].abs() > mr[0].abs(), "{mr:?}");
}
