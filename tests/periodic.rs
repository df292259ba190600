//! Periodic ties: homogeneous simple shear of a periodic block is an exact solution of the discrete
//! problem, so it must be reproduced to round-off on 1 and 2 ranks.

mod common;
use common::*;

#[test]
fn periodic_block_in_simple_shear_is_homogeneous_on_1_and_2_ranks() {
    for np in [1, 2] {
        let d = scratch(&format!("periodic-np{np}"));
        let c = case("periodic_shear_2d.toml");
        run_ok(
            np,
            &[
                "run",
                c.to_str().unwrap(),
                "--out",
                d.to_str().unwrap(),
                "-q",
            ],
        );
        let f = h5_open(d.join("results.h5")).unwrap();
        let x = f
            .dataset("grids/bulk/coordinates")
            .unwrap()
            .read_raw::<f64>()
            .unwrap();
        let u = h5_last(&d, "bulk", "displacement");
        let n = x.len() / 3;
        let mut err = 0.0f64;
        for a in 0..n {
            let y = x[3 * a + 1];
            err = err.max((u[3 * a] - 0.5 * y).abs()).max(u[3 * a + 1].abs());
        }
        assert!(
            err < 1e-10,
            "{np} ranks: deviation from homogeneous simple shear {err:e}"
        );
        // Shear stress of the homogeneous state: sigma_12 = mu * gamma = 0.5/(2*1.3) * 0.5 per unit
        // length of the top (4 long): the reaction on the top is 4 * mu * gamma in x.
        let rx = history_col(&d, "R_block_top_x");
        let mu = 1.0 / (2.0 * 1.3);
        assert!(
            (rx.last().unwrap() - 4.0 * mu * 0.5).abs() < 1e-9,
            "reaction {rx:?}"
        );
    }
}
