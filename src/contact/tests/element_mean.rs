//! The element-mean gap: its tangent against central differences, one pressure per element, and
//! with friction.

use super::friction::{friction_fd_2d, friction_fd_hemisphere};
use super::*;

#[test]
fn element_mean_gap_tangent_matches_central_differences() {
    // `gap = "element_mean"`: every point's traction depends on the gaps of all points of its
    // element and so on all their partners; deformable partners (smooth and faceted, whose edge
    // projections take the normal along the gap), 2D and 3D, and rigid partners
    let law = "law = \"penalty\"\neps_n = 100.0\ngap = \"element_mean\"";
    for (block, disk) in [
        ("Q1C1", "Q1C1"),
        ("Q1N2", "Q1N2"),
        ("Q1C1", "Q1N2"),
        ("Q1N2.1", "Q1CH"),
    ] {
        let mut h = Harness::new(&case_2d(block, disk, law));
        let u = pressed(&h, 0.08, 0.13, 2e-3, 11);
        let (err, kmax) = tangent_error(&mut h, &u);
        assert!(kmax > 1.0, "{block}/{disk}: no contact stiffness ({kmax})");
        assert!(err < 1e-6, "{block}/{disk}: tangent error {err:e}");
    }
    for (lower, upper) in [("Q1N2", "Q1N2"), ("Q1C1", "Q1N2")] {
        let mut h = Harness::new(&case_3d_blocks(lower, upper, law));
        let u = pressed_3d(&h, 0.04, [0.11, -0.07], 2e-3, 17);
        let (err, kmax) = tangent_error(&mut h, &u);
        assert!(kmax > 1.0, "{lower}/{upper}: no contact stiffness ({kmax})");
        assert!(err < 1e-6, "{lower}/{upper}: tangent error {err:e}");
    }
    let mut h = Harness::new(&case_3d_hemisphere("Q1N2", "Q1N2", law));
    let u = pressed_3d(&h, 0.06, [0.05, 0.08], 2e-3, 23);
    let (err, kmax) = tangent_error(&mut h, &u);
    assert!(kmax > 1.0 && err < 1e-6, "hemisphere: {err:e} ({kmax})");
    for (dim, fam, r) in [
        (
            2,
            "Q1N2",
            "{ shape = \"circle\", center = [0.3, -2.0], radius = 2.0 }",
        ),
        (
            2,
            "Q1C1",
            "{ shape = \"plane\", point = [0.0, 0.0], normal = [0.2, 1.0] }",
        ),
        (
            3,
            "Q1N2",
            "{ shape = \"sphere\", center = [0.2, 0.1, -3.0], radius = 3.0 }",
        ),
    ] {
        let mut h = Harness::new(&case_rigid_law(dim, fam, r, law));
        let shift = if dim == 2 {
            vec![0.05, -0.06]
        } else {
            vec![0.02, 0.01, -0.05]
        };
        let u = h.shifted_noisy(&shift, 3);
        let (err, kmax) = tangent_error(&mut h, &u);
        assert!(kmax > 1.0, "{fam} {r}: no contact stiffness ({kmax})");
        assert!(err < 1e-6, "{fam} {r}: tangent error {err:e}");
    }
}

#[test]
fn element_mean_gap_gives_every_point_of_an_element_the_same_pressure() {
    // the residual side: the points of one element carry the mean over the element (weights
    // w J0) of the pointwise penalty pressures eps_n <-g_N>
    let mut h = Harness::new(&case_2d(
        "Q1N2",
        "Q1N2",
        "law = \"penalty\"\neps_n = 100.0\ngap = \"element_mean\"",
    ));
    let u = pressed(&h, 0.08, 0.13, 0.0, 1);
    h.eval(&u, false);
    let (mut active, mut spread) = (0, 0.0f64);
    for pass in 0..2 {
        for points in h.sys.points_per_element(0, pass) {
            let w: f64 = points.iter().map(|p| p.2).sum();
            let paired: Vec<(f64, f64, f64)> =
                points.into_iter().filter(|p| !p.1.is_nan()).collect();
            if paired.is_empty() {
                continue;
            }
            // the mean of the pointwise penalty pressures over the element's area
            let expected = 100.0 * paired.iter().map(|p| (-p.1).max(0.0) * p.2).sum::<f64>() / w;
            for &(p, _, _) in &paired {
                assert!(
                    (p - expected).abs() < 1e-12 * (1.0 + expected),
                    "{p} vs {expected}"
                );
            }
            if expected > 0.0 {
                active += 1;
                let (lo, hi) = paired
                    .iter()
                    .fold((f64::MAX, f64::MIN), |(a, b), p| (a.min(p.1), b.max(p.1)));
                spread = spread.max(hi - lo);
            }
        }
    }
    // elements in contact whose points have different gaps: the pressure is not the pointwise one
    assert!(
        active > 2 && spread > 1e-4,
        "{active} elements, gap spread {spread:e}"
    );
}

#[test]
fn element_mean_gap_friction_tangent_matches_central_differences_in_stick_and_slip() {
    // the slip traction mu p s depends on the element's pressure: its rows take the mean's
    // variation along n + mu s
    let law = "law = \"penalty\"\neps_n = 100.0\nmu = 0.3\neps_t = 80.0\ngap = \"element_mean\"";
    for (block, disk) in [("Q1N2", "Q1N2"), ("Q1C1", "Q1C1")] {
        friction_fd_2d(block, disk, law);
    }
    let law3 = "law = \"penalty\"\neps_n = 100.0\nmu = 0.3\ngap = \"element_mean\"";
    friction_fd_hemisphere("Q1N2", "Q1N2", law3);
}
