//! The cylinder's sawtooth on ironing (the two-half-pass cylinder pass's P_x):
//! the defects it could have come from, checked where they would live. The block's enriched top
//! (Q1N2, Q1N3, Q1N4) is exactly flat in the reference configuration and C1 across every element
//! joint (position and unit normal agree on both sides) when deformed; the cylinder's arc is C1
//! across every joint but its one designed C^0 knot (the joint of the two exact rational quarter
//! arcs at the lowest point, `crate::model::enrich`), where it is G1 in the reference
//! configuration; and a point moving across a joint of the deformed block keeps a continuous
//! projection: partner coordinate, gap and normal change by O(the motion), no edge projection.

#![allow(non_snake_case)]

use nurbs_contact::contact::kernel::{gap_and_normal, PartnerPoint};
use nurbs_contact::contact::projection::{global_search, surface_grid, Positions};
use nurbs_contact::contact::surface::{frame, ContactSurface};
use nurbs_contact::model::Model;
use nurbs_contact::scene::parse_case;
use std::path::Path;

/// A smooth dent and shear of the size of ironing's (2/3 deep under a unit cylinder), as a
/// displacement of every node (control points included).
fn dent(x: f64, y: f64) -> [f64; 2] {
    [
        0.1 * (x * 1.3).sin() * y / 2.0,
        -0.6 * (-x * x).exp() * y / 2.0,
    ]
}

fn rest(_: f64, _: f64) -> [f64; 2] {
    [0.0, 0.0]
}

/// The ironing case at 8 block elements per unit length with the given family on both bodies.
fn ironing_model(family: &str) -> Model {
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/cases/ironing_2d.toml"
    ))
    .expect("case file");
    let sets = vec![
        "meshes.block.divisions=[80,16]".to_string(),
        "meshes.cylinder.n_arc=24".to_string(),
        "meshes.cylinder.n_radial=6".to_string(),
        format!("bodies.block.element={family}"),
        format!("bodies.cylinder.element={family}"),
    ];
    let case = parse_case(&text, Path::new("ironing_2d.toml"), &sets).expect("case parses");
    Model::build(&case).expect("model builds")
}

fn surface<'a>(model: &'a Model, name: &str) -> &'a ContactSurface {
    model
        .contact_surfaces
        .iter()
        .find(|s| s.name == name)
        .unwrap_or_else(|| panic!("no surface {name}"))
}

/// Current positions of every element of `s`, its nodes moved by `u(X)`.
fn positions(model: &Model, s: &ContactSurface, u: fn(f64, f64) -> [f64; 2]) -> Positions {
    let mut pos = Positions {
        offsets: vec![0],
        x: Vec::new(),
    };
    for el in &s.elements {
        for &n in &el.nodes {
            let (X, Y) = (
                model.coords[2 * n as usize],
                model.coords[2 * n as usize + 1],
            );
            let d = u(X, Y);
            pos.x.extend([X + d[0], Y + d[1]]);
        }
        pos.offsets.push(pos.x.len());
    }
    pos
}

/// Point and unit outward normal of element `e` at `xi`.
fn point_normal(s: &ContactSurface, pos: &Positions, e: usize, xi: f64) -> ([f64; 2], [f64; 2]) {
    let (p, _, nr) = frame(&s.elements[e], 2, pos.of(e), &[xi, 0.0]);
    let l = nr[0].hypot(nr[1]);
    let sg = s.elements[e].sign;
    ([p[0], p[1]], [sg * nr[0] / l, sg * nr[1] / l])
}

/// Per joint (element `e`, its neighbour across `xi = +1`): the jumps of position and of unit
/// normal, and the point.
fn joints(s: &ContactSurface, pos: &Positions) -> Vec<(f64, f64, [f64; 2])> {
    let mut out = Vec::new();
    for e in 0..s.elements.len() {
        let Some((f, side, _)) = s.elements[e].neighbours[1] else {
            continue;
        };
        let xi_f = if side == 0 { -1.0 } else { 1.0 };
        let (pe, ne) = point_normal(s, pos, e, 1.0);
        let (pf, nf) = point_normal(s, pos, f as usize, xi_f);
        out.push((
            (pe[0] - pf[0]).hypot(pe[1] - pf[1]),
            (ne[0] - nf[0]).hypot(ne[1] - nf[1]),
            pe,
        ));
    }
    out
}

#[test]
fn block_top_is_flat_in_the_reference_configuration() {
    for fam in ["Q1N2", "Q1N4"] {
        let model = ironing_model(fam);
        let s = surface(&model, "block.top");
        let pos = positions(&model, s, rest);
        let (mut dy, mut dn) = (0.0f64, 0.0f64);
        for e in 0..s.elements.len() {
            for i in 0..=16 {
                let (p, n) = point_normal(s, &pos, e, -1.0 + i as f64 / 8.0);
                dy = dy.max((p[1] - 2.0).abs());
                dn = dn.max(n[0].abs().max((n[1] - 1.0).abs()));
            }
        }
        assert!(
            dy < 1e-13 && dn < 1e-13,
            "{fam} block top not flat: height off by {dy:e}, normal off by {dn:e}"
        );
    }
}

#[test]
fn block_top_is_c1_across_every_joint_when_deformed() {
    for fam in ["Q1N2", "Q1N3", "Q1N4"] {
        let model = ironing_model(fam);
        let s = surface(&model, "block.top");
        let pos = positions(&model, s, dent);
        let j = joints(s, &pos);
        assert!(j.len() >= 79, "{fam}: {} joints", j.len());
        for (dp, dn, at) in j {
            assert!(
                dp < 1e-12 && dn < 1e-12,
                "{fam} block top at {at:?}: position jump {dp:e}, normal jump {dn:e}"
            );
        }
    }
}

#[test]
fn cylinder_arc_is_c1_but_at_its_c0_knot_at_the_lowest_point() {
    for fam in ["Q1N2", "Q1N4"] {
        let model = ironing_model(fam);
        let s = surface(&model, "cylinder.arc");
        let (jr, jd) = (
            joints(s, &positions(&model, s, rest)),
            joints(s, &positions(&model, s, dent)),
        );
        assert_eq!(jr.len(), 23, "{fam}: 24 arc elements");
        let mut kinks = 0;
        for ((dpr, dnr, at), (dpd, dnd, _)) in jr.into_iter().zip(jd) {
            assert!(
                dpr < 1e-12 && dpd < 1e-12 && dnr < 1e-12,
                "{fam} cylinder arc at {at:?}: position jumps {dpr:e} / {dpd:e}, reference normal jump {dnr:e}"
            );
            if dnd > 1e-12 {
                // the C^0 knot: only at the lowest point (0, 2), and a real kink once deformed
                assert!(
                    at[0].abs() < 1e-12 && (at[1] - 2.0).abs() < 1e-12 && dnd > 1e-3,
                    "{fam} cylinder arc at {at:?}: normal jump {dnd:e} when deformed"
                );
                kinks += 1;
            }
        }
        assert_eq!(kinks, 1, "{fam}: one C^0 knot");
    }
}

#[test]
fn projection_across_a_joint_of_the_deformed_block_is_continuous() {
    let model = ironing_model("Q1N2");
    let s = surface(&model, "block.top");
    let pos = positions(&model, s, dent);
    let grid = surface_grid(s, &pos, 1.0);
    let mut scratch = Vec::new();
    // points 1e-3 below the deformed surface (inside the block, as a penetrating point) at the
    // joint nearest to x = 0.5, moved along its tangent across it in steps of 1e-6
    let e = (0..s.elements.len())
        .min_by(|&a, &b| {
            let xa = point_normal(s, &pos, a, 1.0).0[0] - 0.5;
            let xb = point_normal(s, &pos, b, 1.0).0[0] - 0.5;
            xa.abs().total_cmp(&xb.abs())
        })
        .expect("elements");
    let (pj, nj) = point_normal(s, &pos, e, 1.0);
    let at = |t: f64| {
        [
            pj[0] - 1e-3 * nj[0] + t * nj[1],
            pj[1] - 1e-3 * nj[1] - t * nj[0],
            0.0,
        ]
    };
    let mut prev: Option<(u32, f64, f64, [f64; 3])> = None;
    let mut crossed = false;
    let step = 1e-6;
    for i in -50..=50 {
        let x = at(i as f64 * step);
        let p = global_search(s, &pos, &grid, &x, &mut scratch)
            .expect("projection")
            .expect("a partner");
        assert!(p.free[0], "edge projection at {x:?} on a C1 surface: {p:?}");
        let el = &s.elements[p.elem as usize];
        let pp = PartnerPoint::Projected {
            el,
            y: pos.of(p.elem as usize),
            xi: p.xi,
            free: p.free,
            basis: None,
            beyond: false,
        };
        let pg = gap_and_normal(2, &x, &pp).expect("gap");
        let g_n = pg.g[0] * pg.n[0] + pg.g[1] * pg.n[1];
        if let Some((e0, xi0, g0, n0)) = prev {
            if e0 != p.elem {
                crossed = true;
                assert!(
                    (1.0 - xi0.abs()) < 1e-3 && (1.0 - p.xi[0].abs()) < 1e-3,
                    "partner switch away from the joint: xi {xi0} -> {}",
                    p.xi[0]
                );
            }
            let dn = (pg.n[0] - n0[0]).hypot(pg.n[1] - n0[1]);
            assert!(
                (g_n - g0).abs() < 10.0 * step && dn < 10.0 * step,
                "jump at {x:?}: gap {g0:e} -> {g_n:e}, normal by {dn:e}"
            );
        }
        prev = Some((p.elem, p.xi[0], g_n, pg.n));
    }
    assert!(crossed, "the points did not cross a joint");
}
