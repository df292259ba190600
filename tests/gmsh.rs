//! Meshes written by Gmsh itself (cases/meshes/*.geo -> *.msh, MSH 4.1) run like generated ones:
//! the Gmsh cube reproduces the generated cube, and the unstructured plate with a hole is in
//! equilibrium and rank-invariant. Enriched surfaces on meshes users bring: the graded,
//! unstructured half disk (a linear cell tied to the arc at a node) pressed Hertz-like, and a hex
//! block whose spherical cap is enriched by the smooth fit through its nodes.

mod common;
use common::*;

#[test]
fn gmsh_hex_cube_reproduces_the_generated_cube() {
    let (dg, dm) = (scratch("gmsh-cube-generated"), scratch("gmsh-cube-file"));
    for (c, d) in [
        ("block_compression_3d.toml", &dg),
        ("block_compression_gmsh_3d.toml", &dm),
    ] {
        run_ok(
            1,
            &[
                "run",
                case(c).to_str().unwrap(),
                "--out",
                d.to_str().unwrap(),
                "-q",
            ],
        );
    }
    let (rg, rm) = (
        history_col(&dg, "R_block_zmin_z"),
        history_col(&dm, "R_block_zmin_z"),
    );
    assert!(
        rel_diff(&rg, &rm) < 1e-10,
        "reactions differ: {rg:?} vs {rm:?}"
    );
    // Same nodes in another order: compare the displacement of each node by its position.
    let pairs = |d: &std::path::Path| {
        let f = h5_open(d.join("results.h5")).unwrap();
        let x = f
            .dataset("grids/bulk/coordinates")
            .unwrap()
            .read_raw::<f64>()
            .unwrap();
        let u = h5_last(d, "bulk", "displacement");
        let mut v: Vec<[i64; 6]> = (0..x.len() / 3)
            .map(|a| {
                let q = |t: f64| (t * 1e9).round() as i64;
                [
                    q(x[3 * a]),
                    q(x[3 * a + 1]),
                    q(x[3 * a + 2]),
                    q(u[3 * a]),
                    q(u[3 * a + 1]),
                    q(u[3 * a + 2]),
                ]
            })
            .collect();
        v.sort();
        v
    };
    assert_eq!(
        pairs(&dg),
        pairs(&dm),
        "node displacements differ beyond 1e-9"
    );
}

#[test]
fn gmsh_plate_with_hole_is_in_equilibrium_on_1_and_2_ranks() {
    let mut u = Vec::new();
    for np in [1, 2] {
        let d = scratch(&format!("gmsh-plate-np{np}"));
        run_ok(
            np,
            &[
                "run",
                case("plate_hole_2d.toml").to_str().unwrap(),
                "--out",
                d.to_str().unwrap(),
                "-q",
            ],
        );
        let (l, r) = (
            history_col(&d, "R_plate_left_x"),
            history_col(&d, "R_plate_right_x"),
        );
        let (l, r) = (l.last().unwrap(), r.last().unwrap());
        assert!(*r > 0.01, "the plate carries load: {r}");
        assert!(
            (l + r).abs() < 1e-10 * r,
            "x forces do not balance: {l} + {r}"
        );
        u.push(h5_last(&d, "bulk", "displacement"));
    }
    assert!(rel_diff(&u[0], &u[1]) < 1e-10, "1 vs 2 ranks differ");
}

#[test]
fn gmsh_graded_half_disk_with_a_tied_cell_presses_like_hertz() {
    let c = case("hertz_gmsh_2d.toml");
    let out = run_ok(1, &["check", c.to_str().unwrap()]);
    let text = String::from_utf8_lossy(&out.stdout).into_owned() + &stderr(&out);
    assert!(
        text.contains("1 linear cells touch the enriched surface `arc` only at nodes"),
        "{text}"
    );
    let d = run_case("gmsh-hertz", "hertz_gmsh_2d.toml", 1, &[]);
    let (p, r) = (last(&d, "P_flat_disk_arc_y"), last(&d, "R_disk_top_y"));
    // balanced to Newton's tolerance (absolute 1e-11 on the residual norm, relative 1e-10)
    assert!(
        p > 0.008 && (p + r).abs() < 1e-10 * p + 1e-11,
        "contact {p} vs reaction {r}"
    );
    // Hertz's peak pressure for the load the run reports, against the nominal pressure (force per
    // reference area, docs/verification/hertz.md): measured +1.65 % on these 330 quads
    let e_star = 1.0 / (1.0 - 0.3f64 * 0.3);
    let a = (4.0 * p / (std::f64::consts::PI * e_star)).sqrt();
    let p0 = 2.0 * p / (std::f64::consts::PI * a);
    let peak = h5_last(&d, "surface", "contact_pressure_nominal")
        .into_iter()
        .fold(f64::MIN, f64::max);
    let e = (peak - p0) / p0;
    assert!(e.abs() < 0.03, "nominal peak {peak} vs Hertz {p0}: {e:+.4}");
}

#[test]
fn gmsh_cap_fitted_through_its_nodes_presses_alike_on_1_and_2_ranks() {
    let mut u = Vec::new();
    for np in [1, 2] {
        let d = run_case(
            &format!("gmsh-cap-np{np}"),
            "cap_press_gmsh_3d.toml",
            np,
            &[],
        );
        let (p, r) = (last(&d, "P_plane_block_cap_z"), last(&d, "R_block_top_z"));
        assert!(
            p > 0.01 && (p + r).abs() < 1e-9 * p,
            "contact {p} vs reaction {r}"
        );
        assert!(last(&d, "active_plane_block_cap") > 10.0);
        u.push(h5_last(&d, "bulk", "displacement"));
    }
    let diff = rel_diff(&u[0], &u[1]);
    assert!(diff < 1e-10, "1 vs 2 ranks differ by {diff:e}");
}
