//! Meshes written by Gmsh itself (cases/meshes/*.geo -> *.msh, MSH 4.1) run like generated ones:
//! the Gmsh cube reproduces the generated cube, and the unstructured plate with a hole is in
//! equilibrium and rank-invariant.

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
        let f = hdf5::File::open(d.join("results.h5")).unwrap();
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
