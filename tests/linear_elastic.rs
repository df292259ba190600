//! The small-strain `linear_elastic` material through the whole solver: uniaxial stretch of a
//! rectangle (plane strain) and of a box with roller supports and free lateral faces is a linear
//! problem with a homogeneous exact solution, so every load step converges in one Newton iteration
//! and the reaction is Hooke's law times the loaded area.

mod common;
use common::*;
use std::path::Path;

const E: f64 = 2.0;
const NU: f64 = 0.3;
/// Axial strain reached at the end of the stage.
const STRAIN: f64 = 0.01;

/// A `size` block (2D rectangle or 3D box) of linear elastic Q1C1 elements: rollers on the `x = 0`
/// face (x only) and on one lateral face per lateral direction, the `x = L` face pulled to `STRAIN`
/// in `steps` load steps; the other lateral faces are free.
fn case_text(size: &[f64]) -> String {
    let dim = size.len();
    let (generator, divisions, rollers, pulled) = if dim == 2 {
        (
            "rectangle",
            "[4, 3]",
            vec![("left", "x"), ("bottom", "y")],
            "right",
        )
    } else {
        (
            "box",
            "[3, 2, 2]",
            vec![("xmin", "x"), ("ymin", "y"), ("zmin", "z")],
            "xmax",
        )
    };
    let origin = vec!["0.0"; dim].join(", ");
    let size_s: Vec<String> = size.iter().map(|s| format!("{s:?}")).collect();
    let mut t = format!(
        r#"[case]
name = "linear_elastic_uniaxial"
description = "uniaxial stretch, free lateral faces"
dim = {dim}

[meshes.block]
generator = "{generator}"
origin = [{origin}]
size = [{size}]
divisions = {divisions}

[bodies.block]
mesh = "block"
element = "Q1C1"
[bodies.block.material]
model = "linear_elastic"
E = {E:?}
nu = {NU:?}
"#,
        size = size_s.join(", "),
    );
    for (set, c) in rollers {
        t += &format!(
            "\n[[bcs]]\nbody = \"block\"\nset = \"{set}\"\nkind = \"fixed\"\ncomponents = [\"{c}\"]\n"
        );
    }
    t += &format!(
        "\n[[bcs]]\nbody = \"block\"\nset = \"{pulled}\"\nkind = \"displacement\"\ncomponents = [\"x\"]\nvalue = [[{:?}]]\n",
        STRAIN * size[0]
    );
    t += &format!(
        "\n[[stages]]\nname = \"pull\"\nsteps = 2\n\n[output]\nfields = [\"displacement\", \"I1\", \"von_mises\"]\nreactions = [{{ body = \"block\", set = \"{pulled}\" }}]\n"
    );
    t
}

/// Runs the case on `np` ranks with extra `--set` overrides; returns the output directory.
fn run_case(tag: &str, size: &[f64], np: usize, sets: &[&str]) -> std::path::PathBuf {
    let d = scratch(&format!("linear-elastic-{tag}"));
    let file = d.join("case.toml");
    std::fs::write(&file, case_text(size)).unwrap();
    let out = d.join("out");
    let mut args = vec![
        "run",
        file.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "-q",
    ];
    for s in sets {
        args.extend(["--set", s]);
    }
    run_ok(np, &args);
    out
}

/// The first load step took exactly one Newton iteration, and the residual dropped to round-off;
/// the second started from the secant predictor's extrapolation, which is the solution of a
/// linear problem: no iteration, its residual at round-off from the start.
fn assert_one_iteration_per_step(d: &Path) {
    let s = summary(d);
    assert_eq!(s["status"], "converged");
    assert_eq!(s["newton"]["steps"], 2, "{s}");
    assert_eq!(s["newton"]["max_iterations_per_step"], 1, "{s}");
    assert_eq!(s["newton"]["total_iterations"], 1, "{s}");
    let steps = s["steps"].as_array().unwrap();
    let history = |st: &serde_json::Value| -> Vec<f64> {
        st["residual_history"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_f64().unwrap())
            .collect()
    };
    let (first, second) = (history(&steps[0]), history(&steps[1]));
    assert_eq!(first.len(), 2, "{first:?}");
    assert!(first[1] < 1e-12 * first[0], "residual history {first:?}");
    assert_eq!(second.len(), 1, "{second:?}");
    assert!(second[0] < 1e-12 * first[0], "predicted start {second:?}");
    for st in steps {
        assert_eq!(st["cutbacks"], 0);
    }
    assert_eq!(history_col(d, "newton_iterations"), vec![1.0, 0.0]);
}

/// The reaction on the pulled face after each step is `stiffness * strain * area`, to 1e-8 relative.
fn assert_reactions(d: &Path, column: &str, stiffness: f64, area: f64) {
    let r = history_col(d, column);
    assert_eq!(r.len(), 2);
    for (step, &got) in r.iter().enumerate() {
        let exact = stiffness * STRAIN * (step + 1) as f64 / 2.0 * area;
        assert!(
            (got - exact).abs() <= 1e-8 * exact,
            "step {}: reaction {got} vs exact {exact} (rel. error {:e})",
            step + 1,
            (got - exact).abs() / exact
        );
    }
}

#[test]
fn plane_strain_uniaxial_stretch_is_linear_and_exact_q1c1_and_q1e4() {
    // plane strain, sigma_yy = 0: sigma_xx = E/(1 - nu^2) eps_xx, eps_yy = -nu/(1 - nu) eps_xx and
    // sigma_zz = nu sigma_xx, so I1 = (1 + nu) sigma_xx and von Mises = sigma_xx sqrt(1 - nu + nu^2)
    let size = [2.0, 1.5];
    let e_eff = E / (1.0 - NU * NU);
    let sxx = e_eff * STRAIN;
    for family in ["Q1C1", "Q1E4"] {
        let d = run_case(
            &format!("2d-{family}"),
            &size,
            1,
            &[&format!("bodies.block.element={family}")],
        );
        assert_one_iteration_per_step(&d);
        assert_reactions(&d, "R_block_right_x", e_eff, size[1]);
        let i1 = h5_last(&d, "bulk", "I1");
        let vm = h5_last(&d, "bulk", "von_mises");
        assert_eq!(i1.len(), 12);
        for (a, b) in i1.iter().zip(&vm) {
            assert!(
                (a - (1.0 + NU) * sxx).abs() < 1e-10 * sxx,
                "{family}: I1 {a}"
            );
            let vm_exact = sxx * (1.0 - NU + NU * NU).sqrt();
            assert!(
                (b - vm_exact).abs() < 1e-10 * sxx,
                "{family}: von Mises {b}"
            );
        }
        // the homogeneous displacement: u_x = eps x, u_y = -nu/(1 - nu) eps y
        let f = h5_open(d.join("results.h5")).unwrap();
        let x = f
            .dataset("grids/bulk/coordinates")
            .unwrap()
            .read_raw::<f64>()
            .unwrap();
        let u = h5_last(&d, "bulk", "displacement");
        for (xa, ua) in x.chunks_exact(3).zip(u.chunks_exact(3)) {
            assert!((ua[0] - STRAIN * xa[0]).abs() < 1e-12);
            assert!((ua[1] + NU / (1.0 - NU) * STRAIN * xa[1]).abs() < 1e-12);
        }
    }
}

#[test]
fn box_uniaxial_stretch_is_linear_and_exact_on_2_ranks() {
    // 3D uniaxial stress: sigma_xx = E eps_xx on the whole x = L face
    let size = [2.0, 1.0, 0.5];
    let d = run_case("3d", &size, 2, &[]);
    assert_one_iteration_per_step(&d);
    assert_reactions(&d, "R_block_xmax_x", E, size[1] * size[2]);
    for (a, b) in h5_last(&d, "bulk", "I1")
        .iter()
        .zip(&h5_last(&d, "bulk", "von_mises"))
    {
        assert!((a - E * STRAIN).abs() < 1e-10 * E * STRAIN, "I1 {a}");
        assert!((b - E * STRAIN).abs() < 1e-10 * E * STRAIN, "von Mises {b}");
    }
}

/// The uniaxial states above have a symmetric displacement gradient, on which a tangent that is wrong only
/// in its skew part acts correctly; a non-homogeneous load (left end clamped, right end moved sideways)
/// converges in one iteration per step only with the exact constant tangent, and its reaction is
/// linear in the load.
#[test]
fn plane_strain_transverse_load_converges_in_one_iteration() {
    let d = run_case(
        "2d-transverse",
        &[2.0, 1.5],
        1,
        &[
            // the y roller moves from the bottom to the left end, which is then clamped
            "bcs.1.set=left",
            "bcs.2.components=[\"y\"]",
            "bcs.2.value=[[0.05]]",
        ],
    );
    assert_one_iteration_per_step(&d);
    let ry = history_col(&d, "R_block_right_y");
    assert!(ry[1] > 0.0, "{ry:?}");
    assert!((ry[1] - 2.0 * ry[0]).abs() < 1e-12 * ry[1], "{ry:?}");
}
