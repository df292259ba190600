//! Newton converges quadratically on a well-posed problem: read from the residual history that the
//! solver records per load step in summary.json.

mod common;
use common::*;

#[test]
fn newton_converges_quadratically_on_block_compression() {
    let d = scratch("newton-quadratic");
    let c = case("block_compression_3d.toml");
    // Two large steps (10 % compression each) so each solve has several iterations in the
    // asymptotic regime.
    run_ok(
        1,
        &[
            "run",
            c.to_str().unwrap(),
            "--out",
            d.to_str().unwrap(),
            "-q",
            "--set",
            "stages.0.steps=2",
        ],
    );
    let s = summary(&d);
    assert_eq!(s["status"], "converged");
    let steps = s["steps"].as_array().expect("steps in summary");
    assert_eq!(steps.len(), 2);
    let mut checked = 0;
    for st in steps {
        let h: Vec<f64> = st["residual_history"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_f64().unwrap())
            .collect();
        // Rates over consecutive triples above round-off: log(r2/r1) / log(r1/r0) -> 2. The first
        // iteration is skipped: it removes the (linear) boundary-value rows exactly and is not in the
        // asymptotic regime.
        for w in h[1..].windows(3) {
            let (r0, r1, r2) = (w[0], w[1], w[2]);
            if r2 < 1e-13 * h[0].max(1.0) || r1 >= r0 {
                continue;
            }
            let order = (r2 / r1).ln() / (r1 / r0).ln();
            assert!(order > 1.8, "convergence order {order:.2} in history {h:?}");
            checked += 1;
        }
        assert!(
            *h.last().unwrap() < 1e-10 * h[0],
            "step converged to a tight tolerance: {h:?}"
        );
    }
    assert!(
        checked >= 2,
        "saw too few Newton iterations above round-off to measure the order ({checked})"
    );
}
