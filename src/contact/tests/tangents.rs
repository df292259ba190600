//! Consistent tangents between two deformable surfaces against central differences: every law,
//! every 2D family pair, 3D blocks and the hemisphere, and the one-pass algorithm.

use super::*;

#[test]
fn penalty_tangent_matches_central_differences_for_every_2d_family_pair() {
    for block in FAMILIES_2D {
        for disk in FAMILIES_2D {
            let mut h = Harness::new(&case_2d(
                block,
                disk,
                "law = \"penalty\"\neps_n = 100.0\nformulation = \"paper\"",
            ));
            // a shift of a fraction of an element makes points project across element boundaries
            let u = pressed(&h, 0.08, 0.13, 2e-3, 11);
            let (err, kmax) = tangent_error(&mut h, &u);
            assert!(kmax > 1.0, "{block}/{disk}: no contact stiffness ({kmax})");
            assert!(err < 1e-6, "{block}/{disk}: tangent error {err:e}");
        }
    }
}

#[test]
fn van_der_waals_tangent_matches_central_differences_with_corner_projections() {
    // Q1C1 on both sides: points of the faceted arc outside the block, and block points outside the
    // disk, project onto convex corners; adhesion is active there, so the corner linearisation counts.
    for (block, disk) in [
        ("Q1C1", "Q1C1"),
        ("Q1N2", "Q1C1"),
        ("Q1C1", "Q1N2"),
        ("Q1N2.1", "Q1CH"),
    ] {
        let mut h = Harness::new(&case_2d(
            block,
            disk,
            "law = \"van_der_waals\"\na_h = 1.0\nr0 = 0.3\nsearch_distance = 1.0",
        ));
        let u = pressed(&h, -0.05, 0.07, 2e-3, 5);
        let (err, kmax) = tangent_error(&mut h, &u);
        assert!(
            kmax > 1e-3,
            "{block}/{disk}: no adhesion stiffness ({kmax})"
        );
        assert!(err < 1e-6, "{block}/{disk}: tangent error {err:e}");
    }
    // The faceted half disk with 4 arc elements has a vertex at its lowest point (0, 0); the
    // block's middle Q1N2 quadrature point lies right below it and projects onto that corner.
    for block in ["Q1N2", "Q1N2.1"] {
        let mut h = Harness::new(&case_2d_arc(
            block,
            "Q1C1",
            "law = \"van_der_waals\"\na_h = 1.0\nr0 = 0.3\nsearch_distance = 1.0",
            4,
        ));
        let u = pressed(&h, -0.05, 0.003, 1e-4, 9);
        let (err, _) = tangent_error(&mut h, &u);
        let corners: usize = h.sys.results()[0].1.iter().map(|r| r.n_edge).sum();
        assert!(corners >= 1, "{block}: no point projected onto a corner");
        assert!(err < 1e-6, "{block}/Q1C1 corner: tangent error {err:e}");
    }
}

#[test]
fn cohesive_tangent_matches_central_differences() {
    for (block, disk) in [("Q1C1", "Q1C1"), ("Q1N2", "Q1N2"), ("Q1N2.1", "Q1C2")] {
        // the flat top of the disk glued to the block's bottom... simpler: glue the arc where it
        // touches (within the search distance) and pull the disk up and sideways
        let mut h = Harness::new(&case_2d(
            block,
            disk,
            "law = \"cohesive\"\nt0 = 0.2\ng0 = 0.05\neps_n = 50.0\nsearch_distance = 0.3",
        ));
        let u = pressed(&h, -0.03, 0.02, 2e-3, 3);
        let (err, kmax) = tangent_error(&mut h, &u);
        assert!(
            kmax > 1e-3,
            "{block}/{disk}: no cohesive stiffness ({kmax})"
        );
        assert!(err < 1e-6, "{block}/{disk}: tangent error {err:e}");
    }
}

#[test]
fn penalty_tangent_matches_central_differences_in_3d() {
    for (lower, upper) in [
        ("Q1C1", "Q1C1"),
        ("Q1N2", "Q1C1"),
        ("Q1C1", "Q1N2"),
        ("Q1N2", "Q1N2"),
    ] {
        let mut h = Harness::new(&case_3d_blocks(
            lower,
            upper,
            "law = \"penalty\"\neps_n = 100.0\nformulation = \"paper\"",
        ));
        // the upper block's points sit over several lower elements and cross their edges
        let u = pressed_3d(&h, 0.04, [0.11, -0.07], 2e-3, 17);
        let (err, kmax) = tangent_error(&mut h, &u);
        assert!(kmax > 1.0, "{lower}/{upper}: no contact stiffness ({kmax})");
        assert!(err < 1e-6, "{lower}/{upper}: tangent error {err:e}");
    }
    for (lower, shell) in [("Q1C1", "Q1N2"), ("Q1N2", "Q1N2"), ("Q1N2", "Q1C1")] {
        let mut h = Harness::new(&case_3d_hemisphere(
            lower,
            shell,
            "law = \"penalty\"\neps_n = 100.0\nformulation = \"paper\"",
        ));
        let u = pressed_3d(&h, 0.06, [0.05, 0.08], 2e-3, 23);
        let (err, kmax) = tangent_error(&mut h, &u);
        assert!(kmax > 1.0, "{lower}/{shell}: no contact stiffness ({kmax})");
        assert!(err < 1e-6, "{lower}/{shell}: tangent error {err:e}");
    }
}

#[test]
fn van_der_waals_and_cohesive_tangents_match_central_differences_in_3d() {
    for (lower, upper) in [("Q1C1", "Q1C1"), ("Q1N2", "Q1N2")] {
        let mut h = Harness::new(&case_3d_blocks(
            lower,
            upper,
            "law = \"van_der_waals\"\na_h = 1.0\nr0 = 0.3\nsearch_distance = 1.0",
        ));
        let u = pressed_3d(&h, -0.05, [0.09, 0.05], 2e-3, 31);
        let (err, kmax) = tangent_error(&mut h, &u);
        assert!(kmax > 1e-3, "vdW {lower}/{upper}: no stiffness ({kmax})");
        assert!(err < 1e-6, "vdW {lower}/{upper}: tangent error {err:e}");
        let mut h = Harness::new(&case_3d_blocks(
            lower,
            upper,
            "law = \"cohesive\"\nt0 = 0.2\ng0 = 0.05\neps_n = 50.0\nsearch_distance = 0.3",
        ));
        let u = pressed_3d(&h, -0.02, [0.03, 0.01], 2e-3, 37);
        let (err, kmax) = tangent_error(&mut h, &u);
        assert!(
            kmax > 1e-3,
            "cohesive {lower}/{upper}: no stiffness ({kmax})"
        );
        assert!(
            err < 1e-6,
            "cohesive {lower}/{upper}: tangent error {err:e}"
        );
    }
}

#[test]
fn one_pass_tangent_matches_central_differences_and_balances_momentum() {
    for (block, disk) in [
        ("Q1C1", "Q1C1"),
        ("Q1N2", "Q1N2"),
        ("Q1N2.1", "Q1CH"),
        ("Q1C2", "Q1N3"),
    ] {
        let law = "law = \"penalty\"\neps_n = 100.0\nalgorithm = \"one_pass\"";
        let mut h = Harness::new(&case_2d(block, disk, law));
        let u = pressed(&h, 0.08, 0.13, 2e-3, 41);
        let (err, kmax) = tangent_error(&mut h, &u);
        assert!(kmax > 1.0, "{block}/{disk}: no contact stiffness ({kmax})");
        assert!(err < 1e-6, "one-pass {block}/{disk}: tangent error {err:e}");
        // the slave's force and the master's are equal and opposite: the summed residual vanishes
        let (f, _) = h.eval(&u, false);
        let (sum, scale) = net_force(&h, &f);
        for c in 0..2 {
            assert!(
                scale[c] > 1e-3 && sum[c].abs() < 1e-12 * scale[c],
                "{block}/{disk}: net force {} (scale {})",
                sum[c],
                scale[c]
            );
        }
    }
}

#[test]
fn adhesive_and_cohesive_tangents_match_central_differences_for_every_2d_family_on_either_side() {
    // each family once as the block and once as the disk, against a Q1N2 partner, with points
    // projecting across element boundaries (the sideways shift)
    let laws = [
        (
            "van_der_waals",
            "law = \"van_der_waals\"\na_h = 1.0\nr0 = 0.3\nsearch_distance = 1.0",
            -0.05,
        ),
        (
            "cohesive",
            "law = \"cohesive\"\nt0 = 0.2\ng0 = 0.05\neps_n = 50.0\nsearch_distance = 0.3",
            -0.03,
        ),
    ];
    for (name, law, depth) in laws {
        for fam in FAMILIES_2D {
            for (block, disk) in [(fam, "Q1N2"), ("Q1N2", fam)] {
                let mut h = Harness::new(&case_2d(block, disk, law));
                let u = pressed(&h, depth, 0.09, 2e-3, 13);
                let (err, kmax) = tangent_error(&mut h, &u);
                assert!(kmax > 1e-3, "{name} {block}/{disk}: no stiffness ({kmax})");
                assert!(err < 1e-6, "{name} {block}/{disk}: tangent error {err:e}");
            }
        }
    }
}
