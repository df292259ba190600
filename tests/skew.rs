//! Skew conditions (`kind = "radial"`, `kind = "sliding"`): the held direction of every node's
//! displacement stays zero while the others are free, the support's reaction is normal to the
//! freedom it allows, Newton keeps converging quadratically, and 1 and 2 ranks agree.
mod common;
use common::*;
use std::path::{Path, PathBuf};

/// The cube of the twisting cases alone (2 x 2 x 2, E = 1, nu = 0.3, 4^3 Q1C1), its top pressed
/// by 0.2 and then clamped and turned by 45 degrees about z; its base fixed in z and held by
/// `base` (the conditions after `kind = ...`).
fn cube(base: &str) -> String {
    format!(
        r#"
[case]
name = "cube_twist"
dim = 3
[meshes.cube]
generator = "box"
origin = [-1.0, -1.0, -2.0]
size = [2.0, 2.0, 2.0]
divisions = [4, 4, 4]
[bodies.cube]
mesh = "cube"
element = "Q1C1"
[bodies.cube.material]
model = "neo_hookean"
E = 1.0
nu = 0.3
[bodies.cube.node_sets]
base_x0 = {{ within = "zmin", min = [-1e-9, -2.0, -3.0], max = [1e-9, 2.0, -1.0] }}
base_y0 = {{ within = "zmin", min = [-2.0, -1e-9, -3.0], max = [2.0, 1e-9, -1.0] }}
[[bcs]]
body = "cube"
set = "zmin"
kind = "fixed"
components = ["z"]
{base}
[[bcs]]
body = "cube"
set = "zmax"
kind = "rotation"
axis = [0.0, 0.0, 1.0]
center = [0.0, 0.0, 0.0]
angle_deg = [0.0, 45.0]
translation = [[0.0, 0.0, -0.2], [0.0, 0.0, -0.2]]
[[stages]]
name = "press"
steps = 2
[[stages]]
name = "twist"
steps = 3
[output]
every = 1
reactions = [{{ body = "cube", set = "zmax", moment_about = [0.0, 0.0, 0.0] }}, {{ body = "cube", set = "zmin", moment_about = [0.0, 0.0, -2.0] }}]
"#
    )
}

const RADIAL: &str = r#"[[bcs]]
body = "cube"
set = "zmin"
kind = "radial"
axis = [0.0, 0.0, 1.0]
center = [0.0, 0.0, -2.0]"#;

/// The line-support base of twisting_3d.toml: line supports on x = 0 and y = 0.
const LINES: &str = r#"[[bcs]]
body = "cube"
set = "base_x0"
kind = "fixed"
components = ["x"]
[[bcs]]
body = "cube"
set = "base_y0"
kind = "fixed"
components = ["y"]"#;

fn write_case(name: &str, text: &str) -> PathBuf {
    let dir = scratch(&format!("{name}-case"));
    let file = dir.join("case.toml");
    std::fs::write(&file, text).expect("write case");
    file
}

fn run_file(file: &Path, name: &str, np: usize) -> PathBuf {
    let d = scratch(name);
    run_ok(
        np,
        &[
            "run",
            file.to_str().unwrap(),
            "--out",
            d.to_str().unwrap(),
            "-q",
            "--overwrite",
        ],
    );
    d
}

/// Reference coordinates and last displacements of the bulk grid, [n][3] each.
fn bulk(dir: &Path) -> (Vec<f64>, Vec<f64>) {
    let f = h5_open(dir.join("results.h5")).expect("open results.h5");
    let x = f
        .dataset("grids/bulk/coordinates")
        .expect("coordinates")
        .read_raw::<f64>()
        .expect("read coordinates");
    (x, h5_last(dir, "bulk", "displacement"))
}

/// Largest |u . e_theta| and |u . e_r| over the base nodes (z = -2) off the axis.
fn base_motion(dir: &Path) -> (f64, f64) {
    let (x, u) = bulk(dir);
    let (mut circ, mut rad) = (0.0f64, 0.0f64);
    for (x, u) in x.chunks(3).zip(u.chunks(3)) {
        let r = x[0].hypot(x[1]);
        if (x[2] + 2.0).abs() > 1e-12 || r < 1e-12 {
            continue;
        }
        let (er, et) = ([x[0] / r, x[1] / r], [-x[1] / r, x[0] / r]);
        circ = circ.max((u[0] * et[0] + u[1] * et[1]).abs());
        rad = rad.max((u[0] * er[0] + u[1] * er[1]).abs());
    }
    (circ, rad)
}

#[test]
fn a_radial_base_expands_without_turning_and_balances_the_twist_on_1_and_2_ranks() {
    let file = write_case("skew-radial", &cube(RADIAL));
    let dirs = [1, 2].map(|np| run_file(&file, &format!("skew-radial-np{np}"), np));
    for (np, d) in [1, 2].iter().zip(&dirs) {
        let (circ, rad) = base_motion(d);
        assert!(circ < 1e-12, "np={np}: base nodes turn by {circ:e}");
        assert!(rad > 1e-2, "np={np}: base does not expand ({rad:e})");
        // the base carries the twist: its reaction moment about the axis balances the top's
        let (top, base) = (
            history_col(d, "M_cube_zmax_z"),
            history_col(d, "M_cube_zmin_z"),
        );
        let m = top.last().unwrap();
        assert!(m.abs() > 0.1, "np={np}: no twisting moment ({m})");
        for (a, b) in top.iter().zip(&base) {
            assert!(
                (a + b).abs() < 1e-9 * a.abs().max(1.0),
                "np={np}: {a} vs {b}"
            );
        }
        // Newton stays quadratic with the constraint rows in the Jacobian
        let its = history_col(d, "newton_iterations");
        assert!(its.iter().all(|&i| i <= 6.0), "np={np}: iterations {its:?}");
    }
    let (a, b) = (bulk(&dirs[0]).1, bulk(&dirs[1]).1);
    let diff = rel_diff(&a, &b);
    assert!(diff < 1e-10, "1 and 2 ranks differ by {diff:e}");
}

#[test]
fn line_supports_let_the_base_turn_where_a_radial_base_does_not() {
    // the distinction the radial condition exists for (docs/verification/friction.md, "Frictional twisting")
    let lines = run_file(&write_case("skew-lines", &cube(LINES)), "skew-lines", 1);
    let (circ, _) = base_motion(&lines);
    assert!(circ > 1e-3, "line-supported base turns by only {circ:e}");
}

#[test]
fn a_block_sliding_on_an_inclined_support_gets_only_a_normal_reaction() {
    // a 2 x 1 block pressed down by its clamped top; its base slides on a plane with normal
    // (sin 30, cos 30): n . u = 0 at the base and the base's reaction is along n
    let (s, c) = 30f64.to_radians().sin_cos();
    let text = format!(
        r#"
[case]
name = "slide"
dim = 2
[meshes.block]
generator = "rectangle"
origin = [0.0, 0.0]
size = [2.0, 1.0]
divisions = [6, 3]
[bodies.block]
mesh = "block"
element = "Q1C1"
[bodies.block.material]
model = "neo_hookean"
E = 1.0
nu = 0.3
[[bcs]]
body = "block"
set = "bottom"
kind = "sliding"
normal = [{s}, {c}]
[[bcs]]
body = "block"
set = "top"
kind = "displacement"
value = [[0.0, -0.1]]
[[stages]]
name = "press"
steps = 2
[output]
every = 1
reactions = [{{ body = "block", set = "bottom" }}, {{ body = "block", set = "top" }}]
"#
    );
    let file = write_case("skew-slide", &text);
    let dirs = [1, 2].map(|np| run_file(&file, &format!("skew-slide-np{np}"), np));
    for (np, d) in [1, 2].iter().zip(&dirs) {
        let (x, u) = bulk(d);
        let mut slid = 0.0f64;
        for (x, u) in x.chunks(3).zip(u.chunks(3)) {
            if x[1].abs() < 1e-12 {
                let un = u[0] * s + u[1] * c;
                assert!(
                    un.abs() < 1e-12,
                    "np={np}: base node at {x:?} moves {un:e} along n"
                );
                slid = slid.max((u[0] * c - u[1] * s).abs());
            }
        }
        assert!(slid > 1e-3, "np={np}: base does not slide ({slid:e})");
        let (rx, ry) = (last(d, "R_block_bottom_x"), last(d, "R_block_bottom_y"));
        let (tx, ty) = (last(d, "R_block_top_x"), last(d, "R_block_top_y"));
        let norm = rx.hypot(ry);
        assert!(norm > 1e-2, "np={np}: no reaction");
        assert!(
            (rx * c - ry * s).abs() < 1e-9 * norm,
            "np={np}: tangential reaction {} of {norm}",
            rx * c - ry * s
        );
        // the top balances it, and carries the tangential load that keeps the block in place
        assert!((rx + tx).abs() < 1e-9 && (ry + ty).abs() < 1e-9, "np={np}");
        assert!(tx.abs() > 1e-3, "np={np}: top has no tangential reaction");
    }
    let diff = rel_diff(&bulk(&dirs[0]).1, &bulk(&dirs[1]).1);
    assert!(diff < 1e-10, "1 and 2 ranks differ by {diff:e}");
}

#[test]
fn a_skew_condition_on_a_prescribed_component_is_refused_with_the_node_and_condition() {
    let both = format!("{RADIAL}\n{LINES}");
    let file = write_case("skew-conflict", &cube(&both));
    let d = scratch("skew-conflict");
    let out = run(
        1,
        &[
            "run",
            file.to_str().unwrap(),
            "--out",
            d.to_str().unwrap(),
            "-q",
            "--overwrite",
        ],
    );
    assert!(!out.status.success());
    let err = stderr(&out);
    assert!(
        err.contains("case.toml") && err.contains("bcs.1 (cube/zmin)") && err.contains("node"),
        "{err}"
    );
    // `check` finds the same conflict without running
    let out = run(1, &["check", file.to_str().unwrap()]);
    assert!(!out.status.success(), "check accepted the conflict");
    assert_eq!(stderr(&out), err);
    // a 2D radial condition with an axis, a zero sliding normal: named keys
    for (bad, key) in [
        (
            "kind = \"radial\"\naxis = [0.0, 0.0, 0.0]\ncenter = [0.0, 0.0, 0.0]",
            "bcs.1.axis",
        ),
        (
            "kind = \"radial\"\naxis = [0.0, 0.0, 1.0]\ncenter = [0.0, 0.0]",
            "bcs.1.center",
        ),
        (
            "kind = \"sliding\"\nnormal = [0.0, 0.0, 0.0]",
            "bcs.1.normal",
        ),
    ] {
        let text = cube(&format!("[[bcs]]\nbody = \"cube\"\nset = \"zmin\"\n{bad}"));
        let file = write_case("skew-bad", &text);
        let out = run(1, &["check", file.to_str().unwrap()]);
        assert!(!out.status.success(), "{bad} accepted");
        let err = stderr(&out);
        assert!(err.contains(key), "{bad}: {err}");
    }
}

/// `cases/hertz_3d.toml` (a quarter sphere on a rigid flat, Q1C1, coarse) with its two symmetry
/// planes' rollers replaced by `rollers` (the `[[bcs]]` tables after the top's), written to a
/// scratch case beside a copy of nothing else (the case needs no files).
fn quarter_case(name: &str, rollers: &str) -> PathBuf {
    let text = std::fs::read_to_string(case("hertz_3d.toml")).expect("read hertz_3d.toml");
    let start = text
        .find("[[bcs]]\nbody = \"ball\"\nset = \"xmin\"")
        .expect("xmin rollers");
    let end = text.find("[[contact]]").expect("contact table");
    let text = format!("{}{rollers}\n\n{}", &text[..start], &text[end..]);
    write_case(name, &text)
}

fn roller(set: &str, kind: &str) -> String {
    let c = if set == "xmin" { "x" } else { "y" };
    let normal = if set == "xmin" {
        "[1.0, 0.0, 0.0]"
    } else {
        "[0.0, 1.0, 0.0]"
    };
    match kind {
        "sliding" => format!(
            "[[bcs]]\nbody = \"ball\"\nset = \"{set}\"\nkind = \"sliding\"\nnormal = {normal}\n"
        ),
        _ => format!(
            "[[bcs]]\nbody = \"ball\"\nset = \"{set}\"\nkind = \"fixed\"\ncomponents = [\"{c}\"]\n"
        ),
    }
}

/// Runs a case file on 1 rank (coarse Q1C1 quarter sphere) and returns the directory and stderr.
fn run_quarter(file: &Path, name: &str) -> (PathBuf, String) {
    run_quarter_as(file, name, "Q1C1")
}

/// [`run_quarter`] with the ball's element family `element`.
fn run_quarter_as(file: &Path, name: &str, element: &str) -> (PathBuf, String) {
    let element = format!("bodies.ball.element={element}");
    let d = scratch(name);
    let out = run_ok(
        1,
        &[
            "run",
            file.to_str().unwrap(),
            "--out",
            d.to_str().unwrap(),
            "-q",
            "--overwrite",
            "--set",
            &element,
            "--set",
            "meshes.ball.divisions=[4,4,3]",
        ],
    );
    (d, stderr(&out))
}

#[test]
fn symmetry_rollers_meeting_at_an_edge_as_sliding_equal_fixed_components_without_warnings() {
    let cases = [
        ("sliding", "sliding"), // both planes sliding: nodes on x = y = 0 lie on both
        ("sliding", "fixed"),   // one plane sliding: no free translation left to warn about
        ("fixed", "fixed"),
    ];
    let mut runs = Vec::new();
    for (kx, ky) in cases {
        let name = format!("quarter-rollers-{kx}-{ky}");
        let file = quarter_case(
            &name,
            &format!("{}\n{}", roller("xmin", kx), roller("ymin", ky)),
        );
        let (d, err) = run_quarter(&file, &name);
        assert!(!err.contains("warning"), "{kx}/{ky}: {err}");
        runs.push(d);
    }
    let fixed = &runs[2];
    let load = last(fixed, "P_flat_ball_sphere_z");
    assert!(load > 3e-4, "the quarter's load {load}");
    for d in &runs[..2] {
        // the history (forces, reactions) and the displacement agree to round-off
        for col in [
            "P_flat_ball_sphere_z",
            "R_ball_top_z",
            "R_ball_top_x",
            "R_ball_top_y",
        ] {
            let (a, b) = (history_col(d, col), history_col(fixed, col));
            let diff = rel_diff(&b, &a);
            assert!(diff < 1e-10, "{}: {col} differs by {diff:e}", d.display());
        }
        let diff = rel_diff(&bulk(fixed).1, &bulk(d).1);
        assert!(
            diff < 1e-10,
            "{}: displacement differs by {diff:e}",
            d.display()
        );
    }
}

/// The enriched (Q1N2) quarter sphere with its rollers written as `fixed` components projects the
/// contact pressure as with `sliding` rollers: both are symmetry planes, across which the
/// projection is the mirrored whole surface's (without that, the `fixed` run's projection slopes
/// at the planes and differs by percents).
#[test]
fn fixed_component_rollers_are_symmetry_planes_of_the_enriched_surface_as_sliding_ones_are() {
    let runs: Vec<PathBuf> = ["sliding", "fixed"]
        .iter()
        .map(|k| {
            let name = format!("quarter-q1n2-rollers-{k}");
            let file = quarter_case(
                &name,
                &format!("{}\n{}", roller("xmin", k), roller("ymin", k)),
            );
            run_quarter_as(&file, &name, "Q1N2").0
        })
        .collect();
    let (a, b) = (
        h5_last(&runs[0], "surface", "contact_pressure_nominal"),
        h5_last(&runs[1], "surface", "contact_pressure_nominal"),
    );
    assert!(a.iter().fold(0.0f64, |m, &v| m.max(v)) > 0.0, "no pressure");
    let diff = rel_diff(&a, &b);
    assert!(diff < 1e-8, "nominal pressure differs by {diff:e}");
}

/// The node tags of a Gmsh 4.1 file with their coordinates.
fn gmsh_nodes(text: &str) -> Vec<(i64, [f64; 3])> {
    let body = &text[text.find("$Nodes").unwrap() + 6..text.find("$EndNodes").unwrap()];
    let mut lines = body.lines().filter(|l| !l.trim().is_empty());
    let n_blocks: usize = lines
        .next()
        .unwrap()
        .split_whitespace()
        .next()
        .unwrap()
        .parse()
        .unwrap();
    let mut out = Vec::new();
    for _ in 0..n_blocks {
        let head: Vec<usize> = lines
            .next()
            .unwrap()
            .split_whitespace()
            .map(|v| v.parse().unwrap())
            .collect();
        let n = head[3];
        let tags: Vec<i64> = (0..n)
            .map(|_| lines.next().unwrap().trim().parse().unwrap())
            .collect();
        for t in tags {
            let x: Vec<f64> = lines
                .next()
                .unwrap()
                .split_whitespace()
                .map(|v| v.parse().unwrap())
                .collect();
            out.push((t, [x[0], x[1], x[2]]));
        }
    }
    out
}

#[test]
fn a_refused_skew_condition_names_the_gmsh_node_by_its_tag() {
    let text = std::fs::read_to_string(case("block_compression_gmsh_3d.toml")).unwrap();
    let mesh = case("meshes/box_4x4x4.msh");
    let text = text.replace("meshes/box_4x4x4.msh", mesh.to_str().unwrap())
        + "\n[[bcs]]\nbody = \"block\"\nset = \"zmin\"\nkind = \"sliding\"\nnormal = [0.0, 0.0, 1.0]\n";
    let file = write_case("skew-gmsh-tag", &text);
    let out = run(1, &["check", file.to_str().unwrap()]);
    assert!(
        !out.status.success(),
        "check accepted a sliding z on a fixed base"
    );
    let err = stderr(&out);
    // "Gmsh node <tag> of body `block` at (x, y, z) of bcs.2 (block/zmin) is also prescribed..."
    assert_names_a_gmsh_node(&err, &mesh);
    assert!(
        err.contains("of body `block`") && err.contains("bcs.2 (block/zmin)"),
        "{err}"
    );
}

/// `err` names a node as `Gmsh node <tag> ... at (x, y, z)` with the tag and position of one node
/// of the Gmsh file `mesh`, a tag that is not the node's index in the file.
fn assert_names_a_gmsh_node(err: &str, mesh: &Path) {
    let rest = &err[err
        .find("Gmsh node ")
        .unwrap_or_else(|| panic!("no Gmsh tag: {err}"))
        + 10..];
    let tag: i64 = rest
        .split_whitespace()
        .next()
        .unwrap()
        .trim_end_matches(',')
        .parse()
        .unwrap();
    let at = &rest[rest.find(" at (").expect("a position") + 5..];
    let x: Vec<f64> = at[..at.find(')').unwrap()]
        .split(", ")
        .map(|v| v.parse().unwrap())
        .collect();
    let nodes = gmsh_nodes(&std::fs::read_to_string(mesh).unwrap());
    let (_, y) = nodes
        .iter()
        .find(|(t, _)| *t == tag)
        .expect("the tag is in the file");
    assert!(
        (0..3).all(|i| (x[i] - y[i]).abs() <= 1e-9 * (1.0 + y[i].abs())),
        "tag {tag} is at {y:?}, the message says {x:?}"
    );
    // the tag is not the solver's index of the node
    let index = nodes.iter().position(|(t, _)| *t == tag).unwrap();
    assert_ne!(tag, index as i64, "{err}");
}

#[test]
fn contradicting_conditions_name_the_gmsh_node_by_its_tag() {
    let text = std::fs::read_to_string(case("block_compression_gmsh_3d.toml")).unwrap();
    let mesh = case("meshes/box_4x4x4.msh");
    let text = text.replace("meshes/box_4x4x4.msh", mesh.to_str().unwrap())
        + "\n[[bcs]]\nbody = \"block\"\nset = \"zmin\"\nkind = \"displacement\"\ncomponents = [\"z\"]\nvalue = [[0.1]]\n";
    let file = write_case("conflict-gmsh-tag", &text);
    let out = run(1, &["check", file.to_str().unwrap()]);
    assert!(
        !out.status.success(),
        "check accepted a base both fixed and moved in z"
    );
    let err = stderr(&out);
    assert!(err.contains("inconsistent boundary conditions"), "{err}");
    assert_names_a_gmsh_node(&err, &mesh);
    assert!(
        err.contains("of body `block`") && err.contains("bcs.2 (block/zmin)"),
        "{err}"
    );
}
