//! The closest-point projection against analytic closest points, onto faceted corners and beyond a
//! surface's end; the cohesive pairing's debonded box; a projection that fails everywhere.

use super::*;

/// Current (here: reference) positions of every element of a surface.
fn positions(h: &Harness, s: usize) -> crate::contact::projection::Positions {
    let surf = &h.model.contact_surfaces[s];
    let mut pos = crate::contact::projection::Positions::default();
    pos.offsets.push(0);
    for e in &surf.elements {
        pos.x.extend(crate::contact::surface::reference_positions(
            &h.model.coords,
            h.model.dim,
            &e.nodes,
        ));
        pos.offsets.push(pos.x.len());
    }
    pos
}

fn grid_of(
    s: &crate::contact::surface::ContactSurface,
    pos: &crate::contact::projection::Positions,
    dist: f64,
) -> crate::contact::search::BinGrid {
    crate::contact::projection::surface_grid(s, pos, dist)
}

#[test]
fn projection_onto_the_nurbs_circle_and_sphere_matches_the_analytic_closest_point() {
    use crate::contact::projection::{global_search, walk};
    // the exact arc of the half disk (Q1N2 and Q1N2.1) and the exact hemisphere (Q1N2)
    let cases = [
        (
            case_2d("Q1C1", "Q1N2", "law = \"penalty\"\neps_n = 1.0"),
            0usize,
            [0.0, 1.0, 0.0],
        ),
        (
            case_2d("Q1C1", "Q1N2.1", "law = \"penalty\"\neps_n = 1.0"),
            0,
            [0.0, 1.0, 0.0],
        ),
        (
            case_3d_hemisphere("Q1C1", "Q1N2", "law = \"penalty\"\neps_n = 1.0"),
            0,
            [0.0, 0.0, 1.0],
        ),
    ];
    for (text, s, c) in cases {
        let h = Harness::new(&text);
        let surf = &h.model.contact_surfaces[s];
        assert!(
            surf.name.ends_with("arc") || surf.name.ends_with("outer"),
            "{}",
            surf.name
        );
        let dim = surf.dim;
        let pos = positions(&h, s);
        let grid = grid_of(surf, &pos, 0.5);
        let mut seed = 99u64;
        let mut scratch = Vec::new();
        let mut checked = 0;
        for _ in 0..400 {
            // a random point near the lower half of the circle / sphere (radius 0.7 .. 1.3)
            let mut d = [rnd(&mut seed), -1.0 - rnd(&mut seed).abs(), rnd(&mut seed)];
            if dim == 2 {
                d[2] = 0.0;
            } else {
                d.swap(1, 2);
            }
            let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            let r = 1.0 + 0.3 * rnd(&mut seed);
            let x = [0, 1, 2].map(|k| c[k] + r * d[k] / l);
            let exact = [0, 1, 2].map(|k| c[k] + d[k] / l);
            let Ok(Some(p)) = global_search(surf, &pos, &grid, &x, &mut scratch) else {
                continue; // beyond the rim or farther than the search distance
            };
            let el = &surf.elements[p.elem as usize];
            let xp = crate::contact::surface::frame(el, dim, pos.of(p.elem as usize), &p.xi).0;
            let err = (0..dim)
                .map(|k| (xp[k] - exact[k]).powi(2))
                .sum::<f64>()
                .sqrt();
            assert!(
                err < 1e-12,
                "{}: closest point off by {err:e} for x = {x:?}",
                surf.name
            );
            assert!(((r - 1.0).abs() - p.dist).abs() < 1e-12, "distance");
            // a warm start on a far element walks across neighbours to the same point
            let far = if p.elem as usize >= surf.elements.len() / 2 {
                0
            } else {
                surf.elements.len() - 1
            };
            if let Ok(Some(w)) = walk(surf, &pos, &x, (far as u32, [0.0; 2])) {
                let xw = crate::contact::surface::frame(
                    &surf.elements[w.elem as usize],
                    dim,
                    pos.of(w.elem as usize),
                    &w.xi,
                )
                .0;
                let ew = (0..dim)
                    .map(|k| (xw[k] - exact[k]).powi(2))
                    .sum::<f64>()
                    .sqrt();
                assert!(
                    ew < 1e-12,
                    "{}: walk from element {far} off by {ew:e}",
                    surf.name
                );
            }
            checked += 1;
        }
        assert!(
            checked > 100,
            "{}: too few points projected ({checked})",
            surf.name
        );
    }
}

#[test]
fn projection_onto_a_faceted_corner_and_beyond_the_surface_end() {
    use crate::contact::projection::global_search;
    // the faceted half disk with 4 arc elements: vertices at angles 180, 225, 270, 315, 360 degrees
    let h = Harness::new(&case_2d_arc(
        "Q1C1",
        "Q1C1",
        "law = \"penalty\"\neps_n = 1.0",
        4,
    ));
    let surf = &h.model.contact_surfaces[0];
    let pos = positions(&h, 0);
    let grid = grid_of(surf, &pos, 1.0);
    let mut scratch = Vec::new();
    // straight below the lowest vertex (0, 0): its closest point is the vertex, no orthogonal one
    let p = global_search(surf, &pos, &grid, &[0.01, -0.3, 0.0], &mut scratch)
        .unwrap()
        .unwrap();
    assert!(
        !p.free[0],
        "a corner projection holds the coordinate on the boundary"
    );
    assert!(
        (p.dist - (0.01f64.powi(2) + 0.09).sqrt()).abs() < 1e-12,
        "distance to the vertex {}",
        p.dist
    );
    // beside the arc's end (the vertex at (1, 1)), outwards: beyond the surface, no partner
    let q = global_search(surf, &pos, &grid, &[1.3, 1.2, 0.0], &mut scratch).unwrap();
    assert!(
        q.is_none(),
        "a point beyond the end of the surface has no partner: {q:?}"
    );
}

#[test]
fn cohesive_debonded_box_leaves_its_points_unpaired() {
    let glued = "law = \"cohesive\"\nt0 = 0.2\ng0 = 0.05\neps_n = 50.0\nsearch_distance = 0.3";
    let mut h = Harness::new(&case_2d("Q1C1", "Q1C1", glued));
    let u = pressed(&h, -0.03, 0.0, 0.0, 1);
    h.eval(&u, false);
    let bonded: f64 = h.sys.results()[0].1.iter().map(|r| r.force[1].abs()).sum();
    assert!(
        bonded > 1e-4,
        "the pulled disk feels the cohesive traction ({bonded})"
    );
    let free = format!("{glued}\ndebonded = {{ min = [-2.0, -2.0], max = [2.0, 3.0] }}");
    let mut h = Harness::new(&case_2d("Q1C1", "Q1C1", &free));
    h.eval(&u, false);
    let none: f64 = h.sys.results()[0].1.iter().map(|r| r.force[1].abs()).sum();
    assert_eq!(none, 0.0, "every point lies in the debonded box");
}

#[test]
fn a_projection_that_fails_on_every_candidate_is_an_error_for_the_step() {
    // a non-finite partner geometry (what a diverged Newton iterate gives) makes every candidate's
    // projection fail: `update` reports it (the assembler turns it into a domain error, and the
    // load step is cut back as for an inverted element)
    let mut h = Harness::new(&case_2d("Q1C1", "Q1N2", "law = \"penalty\"\neps_n = 100.0"));
    let u = pressed(&h, 0.05, 0.0, 0.0, 1);
    h.eval(&u, false);
    let mut bad = u.clone();
    // every other node of the block's top (the partner of the disk's points) becomes NaN: each
    // element's box stays finite (so it is a candidate) but its geometry is not
    let block = &h.model.bodies[0];
    assert_eq!(block.name, "block");
    for g in h
        .model
        .set_nodes("block", "top")
        .unwrap()
        .into_iter()
        .step_by(2)
    {
        for c in 0..2 {
            bad[h.dofs.global(g, c).unwrap().0 as usize] = f64::NAN;
        }
    }
    let ut: Vec<f64> = h.table.iter().map(|&g| bad[g as usize]).collect();
    let e = h.sys.update(&ut).expect_err("the projection must fail");
    assert!(e.contains("projection") && e.contains("block.top"), "{e}");
    // and a finite state projects again
    let ut: Vec<f64> = h.table.iter().map(|&g| u[g as usize]).collect();
    h.sys.update(&ut).expect("finite state");
}

#[test]
fn a_stored_basis_gives_the_same_projections_and_gaps_bit_for_bit() {
    use crate::contact::kernel::{gap_and_normal, PartnerPoint};
    use crate::contact::projection::{
        basis_values, global_search, global_search_from, walk, walk_from, BasisAt,
    };
    // the exact hemisphere (Q1N2, rational) and the faceted Q1C1 blocks, 3D; the arc in 2D
    let cases = [
        (
            case_3d_hemisphere("Q1C1", "Q1N2", "law = \"penalty\"\neps_n = 1.0"),
            [0.0, 0.0, 1.0],
        ),
        (
            case_2d("Q1C1", "Q1N2", "law = \"penalty\"\neps_n = 1.0"),
            [0.0, 1.0, 0.0],
        ),
    ];
    let mut compared = 0;
    for (text, c) in cases {
        let h = Harness::new(&text);
        for (s, surf) in h.model.contact_surfaces.iter().enumerate() {
            let dim = surf.dim;
            let pos = positions(&h, s);
            let grid = grid_of(surf, &pos, 0.5);
            let centres: Vec<Vec<f64>> = surf
                .elements
                .iter()
                .map(|el| {
                    let mut b = Vec::new();
                    basis_values(&el.basis, &[0.0; 2], &mut b);
                    b
                })
                .collect();
            let (mut seed, mut scratch) = (7u64, Vec::new());
            for _ in 0..200 {
                let mut d = [rnd(&mut seed), -1.0 - rnd(&mut seed).abs(), rnd(&mut seed)];
                if dim == 2 {
                    d[2] = 0.0;
                } else {
                    d.swap(1, 2);
                }
                let x = [0, 1, 2].map(|k| c[k] + 1.2 * d[k]);
                let slow = global_search(surf, &pos, &grid, &x, &mut scratch);
                let fast = global_search_from(surf, &pos, &grid, &x, &mut scratch, Some(&centres));
                assert_eq!(slow, fast, "{}: global search at {x:?}", surf.name);
                let Ok(Some(p)) = slow else { continue };
                // a warm start from a shifted point of the found element, basis given or not
                let start = (p.elem, p.xi.map(|v| 0.5 * v + 0.1 * rnd(&mut seed)));
                let mut at = BasisAt::default();
                at.set(surf, start.0, &start.1);
                let known = at.get(start.0, &start.1);
                assert!(
                    known.is_some() && at.get(start.0, &[start.1[0] + 1e-16, start.1[1]]).is_none()
                );
                let w_slow = walk(surf, &pos, &x, start);
                let w_fast = walk_from(surf, &pos, &x, start, known);
                assert_eq!(w_slow, w_fast, "{}: walk at {x:?}", surf.name);
                // the kernel's gap and normal with the basis at the projection given
                at.set(surf, p.elem, &p.xi);
                let el = &surf.elements[p.elem as usize];
                let y = pos.of(p.elem as usize);
                let pp = |basis| PartnerPoint::Projected {
                    el,
                    y,
                    xi: p.xi,
                    free: p.free,
                    basis,
                    beyond: false,
                };
                let g_slow = gap_and_normal(dim, &x, &pp(None)).expect("a projected partner");
                let g_fast = gap_and_normal(dim, &x, &pp(at.get(p.elem, &p.xi)))
                    .expect("a projected partner");
                let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                assert_eq!(bits(&g_slow.g), bits(&g_fast.g));
                assert_eq!(bits(&g_slow.n), bits(&g_fast.n));
                assert_eq!(bits(&g_slow.basis), bits(&g_fast.basis));
                compared += 1;
            }
        }
    }
    assert!(compared > 100, "{compared} points compared");
}

#[test]
fn the_hull_bound_never_exceeds_the_distance_to_a_point_of_the_element() {
    use crate::contact::projection::hull_distance_bound;
    let text = case_3d_hemisphere("Q1C1", "Q1N2", "law = \"penalty\"\neps_n = 1.0");
    let h = Harness::new(&text);
    let (mut seed, mut positive) = (3u64, 0);
    for (s, surf) in h.model.contact_surfaces.iter().enumerate() {
        let pos = positions(&h, s);
        for e in 0..surf.elements.len() {
            for _ in 0..20 {
                let x = [0, 1, 2].map(|_| 1.5 * rnd(&mut seed));
                let lb = hull_distance_bound(surf, &pos, e, &x);
                positive += (lb > 0.0) as usize;
                for i in 0..=8 {
                    for j in 0..=8 {
                        let xi = [-1.0 + 0.25 * i as f64, -1.0 + 0.25 * j as f64];
                        let el = &surf.elements[e];
                        let p = crate::contact::surface::frame(el, 3, pos.of(e), &xi).0;
                        let d = (0..3).map(|k| (p[k] - x[k]).powi(2)).sum::<f64>().sqrt();
                        assert!(lb <= d * (1.0 + 1e-12), "{}: {lb} > {d}", surf.name);
                    }
                }
            }
        }
    }
    assert!(positive > 100, "{positive}");
}

#[test]
fn the_hull_bound_reaches_the_distance_to_a_long_element_from_beyond_its_corner() {
    use crate::contact::basis::FaceBasis;
    use crate::contact::projection::{hull_distance_bound, Positions};
    use crate::contact::surface::{ContactSurface, SurfaceElement};
    // a flat 10 x 1 quad: from (11, -1, 0) its closest point is the corner (10, 0, 0), at sqrt(2);
    // the nodes' extent along the direction to their centroid alone gives 7.5 / 38.25^0.5 = 1.21
    let surf = ContactSurface {
        name: "long".into(),
        body: 0,
        dim: 3,
        h: 1.0,
        elements: vec![SurfaceElement {
            basis: FaceBasis::Quad4,
            nodes: vec![0, 1, 2, 3],
            cell: 0,
            sign: 1.0,
            corners: vec![0, 1, 2, 3],
            neighbours: vec![None; 4],
        }],
    };
    let pos = Positions {
        offsets: vec![0, 12],
        x: vec![0.0, 0.0, 0.0, 10.0, 0.0, 0.0, 10.0, 1.0, 0.0, 0.0, 1.0, 0.0],
    };
    for (x, d) in [
        ([11.0, -1.0, 0.0], 2f64.sqrt()),
        ([11.0, -1.0, 2.0], 6f64.sqrt()),
        ([-3.0, 2.0, -1.0], 11f64.sqrt()),
        ([5.0, 3.0, 0.0], 2.0),
        ([5.0, 0.5, 0.5], 0.5),
    ] {
        let lb = hull_distance_bound(&surf, &pos, 0, &x);
        assert!(
            lb <= d * (1.0 + 1e-12) && lb >= 0.99 * d,
            "{x:?}: bound {lb} against the distance {d}"
        );
    }
}

/// A point beyond a surface's end: its closest point, held on the boundary, is stationary along
/// it. The projection onto an element steps from the element's centre, damped to half the box per
/// step, and such steps can land at `-1 + ulp` rather than on `-1`. The coordinate then counted as
/// free, the next Newton step pushed it out and was clamped into a direction that did not descend,
/// the line search found no decrease, and the projection stopped there, not stationary along the
/// boundary (on the twisting case: distances off by 4.5e-5, changing with 1e-7 perturbations, so
/// the mortar gaps that weigh such points jumped and PETSc's Jacobian check differed by up to 2.2).
#[test]
fn a_point_beyond_the_rim_projects_to_its_closest_point_on_the_rim() {
    use crate::contact::projection::{global_closest_from, off_the_edge, project_on_element};
    // the exact NURBS hemisphere, centre (0, 0, 1), radius 1, rim the circle in the plane z = 1:
    // the closest point of a point above that plane is the rim point at its azimuth
    let h = Harness::new(&case_3d_hemisphere(
        "Q1C1",
        "Q1N2",
        "law = \"penalty\"\neps_n = 1.0",
    ));
    let s = 0;
    let surf = &h.model.contact_surfaces[s];
    assert!(surf.name.ends_with("outer"), "{}", surf.name);
    let pos = positions(&h, s);
    let grid = grid_of(surf, &pos, 2.0);
    let mut seed = 7u64;
    let mut scratch = Vec::new();
    let mut worst = 0.0f64;
    for _ in 0..2000 {
        let phi = std::f64::consts::PI * rnd(&mut seed);
        let rho = 1.0 + 0.7 * rnd(&mut seed);
        let z = 1.0 + 0.3 * (1.0 + rnd(&mut seed));
        let x = [rho * phi.cos(), rho * phi.sin(), z];
        let exact = ((rho - 1.0).powi(2) + (z - 1.0).powi(2)).sqrt();
        let p = global_closest_from(surf, &pos, &grid, &x, &mut scratch, None, None)
            .expect("a projection")
            .expect("a point within the search distance");
        assert!(
            off_the_edge(surf, &p),
            "x = {x:?}: not beyond the rim: {p:?}"
        );
        worst = worst.max((p.dist - exact).abs());
        assert!(
            (p.dist - exact).abs() < 1e-12,
            "x = {x:?}: distance {} against {exact} ({p:?})",
            p.dist
        );
        // from a start just inside the rim side (not within round-off of it) and off along it
        for gap in [1e-9, 1e-7, 1e-4] {
            let mut xi0 = p.xi;
            for i in 0..2 {
                if !p.free[i] {
                    xi0[i] = p.xi[i] * (1.0 - gap);
                } else {
                    xi0[i] = (p.xi[i] + 0.05).clamp(-1.0, 1.0) * (1.0 - 1e-3);
                }
            }
            let q = project_on_element(surf, &pos, p.elem as usize, &x, xi0)
                .expect("an element projection");
            worst = worst.max((q.dist - exact).abs());
            assert!(
                (q.dist - exact).abs() < 1e-12,
                "x = {x:?} from {xi0:?}: distance {} against {exact} ({q:?})",
                q.dist
            );
        }
    }
    eprintln!("largest distance error {worst:e}");
}
