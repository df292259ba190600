//! Contact that is silently not there is reported: hertz_2d with a coarse Q1C1 disk (8 cells along
//! the arc) presses its lowest node 0.015 through the rigid flat while its smooth contact surface,
//! which lies inside its control points, never reaches it (force 0, no active point). A warning
//! names the pair, the surface and the node as the model names it (its body, mesh node or Gmsh
//! tag, or enriched-layer node), on 1 and 2 ranks; the shipped mesh, whose contact
//! points are active, gets none.

mod common;
use common::*;

fn hertz(np: usize, name: &str, sets: &[&str]) -> String {
    let dir = scratch(&format!("contact_sanity/{name}"));
    let case = case("hertz_2d.toml");
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
