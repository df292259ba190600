//! Consistent tangents of surfaces against rigid partners (plane, circle, sphere, cylinder),
//! against central differences.

use super::*;

#[test]
fn penalty_tangent_against_rigid_partners_matches_central_differences() {
    let rigid_2d = [
        "{ shape = \"plane\", point = [0.0, 0.0], normal = [0.2, 1.0] }",
        "{ shape = \"circle\", center = [0.3, -2.0], radius = 2.0 }",
        "{ shape = \"circle\", center = [0.0, 1.0], radius = 1.01, inside = true }",
    ];
    for fam in FAMILIES_2D {
        for r in rigid_2d {
            let mut h = Harness::new(&case_rigid(2, fam, r));
            let u = h.shifted_noisy(&[0.05, -0.06], 1);
            let (err, kmax) = tangent_error(&mut h, &u);
            assert!(kmax > 1.0, "{fam} {r}: no contact stiffness ({kmax})");
            assert!(err < 1e-6, "{fam} {r}: tangent error {err:e}");
        }
    }
    let rigid_3d = [
        "{ shape = \"plane\", point = [0.0, 0.0, 0.0], normal = [0.1, -0.2, 1.0] }",
        "{ shape = \"sphere\", center = [0.2, 0.1, -3.0], radius = 3.0 }",
        "{ shape = \"cylinder\", center = [0.0, 0.0, -2.0], axis = [1.0, 0.3, 0.0], radius = 2.0 }",
    ];
    for fam in ["Q1C1", "Q1N2"] {
        for r in rigid_3d {
            let mut h = Harness::new(&case_rigid(3, fam, r));
            let u = h.shifted_noisy(&[0.02, 0.01, -0.05], 7);
            let (err, kmax) = tangent_error(&mut h, &u);
            assert!(kmax > 1.0, "{fam} {r}: no contact stiffness ({kmax})");
            assert!(err < 1e-6, "{fam} {r}: tangent error {err:e}");
        }
    }
}

#[test]
fn van_der_waals_tangent_against_rigid_partners_matches_central_differences() {
    // the surface held a little above each rigid partner, within the adhesion range: every
    // family in 2D, both 3D families
    let law = "law = \"van_der_waals\"\na_h = 1.0\nr0 = 0.3\nsearch_distance = 1.0";
    let rigid_2d = [
        "{ shape = \"plane\", point = [0.0, 0.0], normal = [0.2, 1.0] }",
        "{ shape = \"circle\", center = [0.3, -2.0], radius = 2.0 }",
    ];
    for fam in FAMILIES_2D {
        for r in rigid_2d {
            let mut h = Harness::new(&case_rigid_law(2, fam, r, law));
            let u = h.shifted_noisy(&[0.05, 0.12], 3);
            let (err, kmax) = tangent_error(&mut h, &u);
            assert!(kmax > 1e-3, "{fam} {r}: no adhesion stiffness ({kmax})");
            assert!(err < 1e-6, "{fam} {r}: tangent error {err:e}");
        }
    }
    let rigid_3d = [
        "{ shape = \"plane\", point = [0.0, 0.0, 0.0], normal = [0.1, -0.2, 1.0] }",
        "{ shape = \"sphere\", center = [0.2, 0.1, -3.0], radius = 3.0 }",
    ];
    for fam in ["Q1C1", "Q1N2"] {
        for r in rigid_3d {
            let mut h = Harness::new(&case_rigid_law(3, fam, r, law));
            let u = h.shifted_noisy(&[0.02, 0.01, 0.15], 5);
            let (err, kmax) = tangent_error(&mut h, &u);
            assert!(kmax > 1e-3, "{fam} {r}: no adhesion stiffness ({kmax})");
            assert!(err < 1e-6, "{fam} {r}: tangent error {err:e}");
        }
    }
}
