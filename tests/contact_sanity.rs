//! Contact that is silently not there, or that a step cannot follow, is reported:
//! - hertz_2d with a coarse Q1C1 disk (8 cells along the arc) presses its lowest node 0.015
//!   through the rigid flat while its smooth contact surface, which lies inside its control
//!   points, never reaches it (force 0, no active point). A warning names the pair, the surface
//!   and the node as the model names it (its body, mesh node or Gmsh tag, or enriched-layer node),
//!   on 1 and 2 ranks; the shipped mesh, whose contact points are active, gets none;
//! - the same against a deformable partner: ironing_2d one-pass with a coarse linear cylinder
//!   pressed 0.005 into the block, whose lowest node goes in between the cylinder's points;
//! - surfaces that start inside their partner at load 0 (a rigid flat raised by 0.01 into the
//!   Hertz disk, the ironing cylinder lowered by 0.05 into the block);
//! - a frictional step whose points slide farther than an element (friction_block pushed 0.5 in
//!   two steps), named with the step and its stage.

mod common;
use common::*;

fn hertz(np: usize, name: &str, sets: &[&str]) -> String {
    run_case(np, name, "hertz_2d.toml", sets)
}

fn run_case(np: usize, name: &str, file: &str, sets: &[&str]) -> String {
    let dir = scratch(&format!("contact_sanity/{name}"));
    let case = case(file);
    let out = dir.join("out");
    let mut a = vec![
        "run",
        case.to_str().unwrap(),
        "-q",
        "--out",
        out.to_str().unwrap(),
        "--set",
        "output.plots=false",
    ];
    for s in sets {
        a.extend(["--set", s]);
    }
    let o = run(np, &a);
    let err = stderr(&o);
    assert!(!err.contains("panicked"), "{err}");
    err
}

const COARSE: &[&str] = &[
    "bodies.disk.element=Q1C1",
    "meshes.disk.n_arc=8",
    "meshes.disk.n_radial=2",
];

#[test]
fn a_node_through_a_rigid_flat_without_active_contact_is_warned_of_on_1_and_2_ranks() {
    for np in [1, 2] {
        let err = hertz(np, &format!("coarse{np}"), COARSE);
        assert!(
            err.contains(
                "warning: step 1 (load 0.333333): contact `flat`: surface `disk.arc`: mesh \
                 node 23 of body `disk` at ("
            ),
            "{np} ranks:\n{err}"
        );
        assert!(err.contains("inside the rigid partner"), "{err}");
        assert!(
            err.contains("no contact point of the pair is active"),
            "{err}"
        );
        // once per pair, not at every step
        assert_eq!(err.matches("inside the rigid partner").count(), 1, "{err}");
    }
}

#[test]
fn active_contact_gets_no_such_warning() {
    let err = hertz(1, "shipped", &["bodies.disk.element=Q1C1"]);
    assert!(!err.contains("inside the rigid partner"), "{err}");
}

/// ironing_2d, one-pass, both bodies linear (Q1C1), a cylinder of 8 cells along its arc pressed by
/// `depth` in one step (the sliding stage: one step without motion).
fn ironing_pressed(depth: &str) -> Vec<String> {
    [
        "bodies.block.element=Q1C1",
        "bodies.cylinder.element=Q1C1",
        "meshes.cylinder.n_arc=8",
        "meshes.cylinder.n_radial=2",
        "contact.0.algorithm=one_pass",
        "stages.0.steps=1",
        "stages.1.steps=1",
    ]
    .iter()
    .map(|s| s.to_string())
    .chain([format!("bcs.1.value=[[0.0, -{depth}], [0.0, -{depth}]]")])
    .collect()
}

#[test]
fn a_node_inside_a_deformable_partner_without_active_contact_is_warned_of_on_1_and_2_ranks() {
    let sets = ironing_pressed("0.005");
    let sets: Vec<&str> = sets.iter().map(|s| s.as_str()).collect();
    for np in [1, 2] {
        let err = run_case(np, &format!("deformable{np}"), "ironing_2d.toml", &sets);
        assert!(
            err.contains(
                "warning: step 1 (load 1.000000): contact `ironing`: surface `cylinder.arc`: \
                 mesh node 23 of body `cylinder` at ("
            ),
            "{np} ranks:\n{err}"
        );
        assert!(
            err.contains("lies 5.000e-3 inside the partner surface `block.top` (in its body)"),
            "{np} ranks:\n{err}"
        );
        assert_eq!(
            err.matches("inside the partner surface").count(),
            1,
            "{err}"
        );
    }
}

#[test]
fn a_deformable_partner_held_by_active_points_gets_no_such_warning() {
    // pressed 0.05: the cylinder's points reach the block
    let sets = ironing_pressed("0.05");
    let sets: Vec<&str> = sets.iter().map(|s| s.as_str()).collect();
    let err = run_case(1, "deformable_active", "ironing_2d.toml", &sets);
    assert!(!err.contains("inside the partner surface"), "{err}");
}

#[test]
fn a_surface_starting_inside_a_rigid_partner_is_warned_of_on_1_and_2_ranks() {
    for np in [1, 2] {
        let err = hertz(
            np,
            &format!("initial_rigid{np}"),
            &["contact.0.rigid.point=[0.0, 0.01]"],
        );
        assert!(
            err.contains(
                "warning: load 0: contact `flat`: surface `disk.arc` starts 9.941e-3 inside the \
                 rigid partner (10.1 % of the surface's element size), deepest at ("
            ),
            "{np} ranks:\n{err}"
        );
        assert!(err.contains("of body `disk` at ("), "{err}");
        assert_eq!(err.matches("warning: load 0:").count(), 1, "{err}");
    }
}

#[test]
fn a_surface_starting_inside_a_deformable_partner_is_warned_of() {
    // the default formulation (one-pass) checks its slave's points; the paper's two half-passes
    // check both surfaces
    for paper in [false, true] {
        let mut sets = vec![
            "meshes.cylinder.center=[0.0, 2.95]",
            "stages.0.steps=1",
            "stages.1.steps=1",
            "bcs.1.value=[[0.0, 0.0], [0.0, 0.0]]",
        ];
        if paper {
            sets.push("contact.0.formulation=paper");
        }
        let err = run_case(
            1,
            &format!("initial_deformable_{paper}"),
            "ironing_2d.toml",
            &sets,
        );
        assert!(
            err.contains(
                "warning: load 0: contact `ironing`: surface `cylinder.arc` starts 4.960e-2 inside \
                 the partner surface `block.top` (in its body)"
            ),
            "{err}"
        );
        assert_eq!(
            err.contains("warning: load 0: contact `ironing`: surface `block.top` starts"),
            paper,
            "{err}"
        );
    }
}

#[test]
fn touching_surfaces_at_load_0_get_no_such_warning() {
    let err = hertz(1, "initial_touching", &[]);
    assert!(!err.contains("warning: load 0"), "{err}");
    let err = run_case(
        1,
        "initial_touching_ironing",
        "ironing_2d.toml",
        &["stages.0.steps=1", "stages.1.steps=1"],
    );
    assert!(!err.contains("warning: load 0"), "{err}");
}

#[test]
fn a_frictional_step_sliding_farther_than_an_element_is_warned_of_on_1_and_2_ranks() {
    for np in [1, 2] {
        let err = run_case(
            np,
            &format!("slip{np}"),
            "friction_block_2d.toml",
            &[
                "bcs.0.value=[[0.0, -0.01], [0.5, -0.01]]",
                "stages.1.steps=2",
            ],
        );
        assert!(
            err.contains(
                "warning: step 3 (load 1.500000): contact `fric`: surface `block.bottom`: a \
                 frictional point, now at ("
            ),
            "{np} ranks:\n{err}"
        );
        assert!(
            err.contains("give stage `push` more steps (`stages.1.steps` = 2)"),
            "{err}"
        );
        assert_eq!(err.matches("a frictional point").count(), 1, "{err}");
    }
    // the shipped push, 0.005 per step
    let err = run_case(1, "slip_shipped", "friction_block_2d.toml", &[]);
    assert!(!err.contains("a frictional point"), "{err}");
}
