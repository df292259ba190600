//! Hollow hemispherical shell of Hex8 cells built from the exact NURBS outer surface (the twisting
//! hemisphere of Corbett & Sauer 2014, section 4.4, with an enrichable exact contact surface).
use super::spherical_shell::{check_shell_parameters, spherical_shell};
use super::{ExactPatch, Mesh, MeshError};
use crate::geometry::conics::hollow_hemisphere;

/// Half opening angle (degrees, from the downward axis through the centre) of the `cap` node set.
pub const CAP_HALF_ANGLE_DEG: f64 = 35.0;

/// Hollow lower hemisphere around `center` = (cx, cy, cz) with outer radius `R` and wall thickness
/// `h` (rim ring in the plane z = cz, cap pointing down), `n x n` cells over the surface (`n` even,
/// >= 2) and `m` layers through the thickness.
///
/// Construction: the exact biquadratic outer surface of `geometry::conics::hollow_hemisphere` (the
/// lower half circle in u rotated about the x axis in v, 2 x 2 Bezier elements) is k-refined to
/// `n x n` elements, and, as in the paper ("the corner points of the Q1N2 elements are used as
/// nodes for the linear mesh"), the linear mesh is built from the element corners: node (i, j, k)
/// = `center + (R - h k / m) d(u_i, v_j)`, with `d` the unit vector towards the outer surface point
/// at the knots (u_i, v_j), so every node lies exactly on its sphere (rim nodes are projected onto
/// z = cz, which round-off in the rational map would otherwise miss by 1e-16).
///
/// Degenerate cells, and why they differ from the paper's: the patch edges u = 0 and u = 1 collapse
/// to the two rim points `c -/+ (R, 0, 0)`. Their grid nodes are merged into one node per layer, so
/// the `2 n m` cells along these edges are degenerate hexes with a repeated node pair (a collapsed
/// through-thickness face); their Jacobian vanishes only on that face (tested positive at all
/// 2x2x2 Gauss points), and the collapsed points lie on the rim, where section 4.4 prescribes the
/// displacement, while the pole (the first contact point) is a regular point (S_u x S_v != 0) —
/// the principle the paper states for its own degenerate elements. (The pole lies on the knot
/// lines u = 1/2 and v = 1/2, where the exact base joins its 90 degree segments: the reference
/// surface is smooth there, but the enriched layer's continuity across these two lines is C0, as
/// at the joints of a 2D arc; every other element boundary has the continuity of Table 1.) The paper's layout (3 x 3, 7 x 7, 11 x 11 cells
/// over a square with four degenerate rim corners, see [`super::hemisphere`]) has no exact
/// biquadratic NURBS representation we know of, so we use this exact one; odd `n` is not reachable
/// with equal elements and the two exact base segments per direction.
///
/// Cells: cell (i, j, l) = (l n + j) n + i, i along u, j along v, l through the thickness from the
/// outer surface; local face 0 (zeta = -1) on the outer (contact) surface, face 1 on the inner one.
/// Nodes of layer k: the merged rim point of u = 0, then the grid rows (i = 1..n-1 fastest, j =
/// 0..n), then the merged rim point of u = 1: `(n - 1)(n + 1) + 2` nodes per layer.
///
/// Named sets:
/// - `outer` (contact surface) and `inner`: face sets (local faces 0 and 1), ordered row-major in
///   (u, v) element order (i fastest), and node sets; `outer` carries the exact surface
///   ([`Mesh::exact_surfaces`]) for the enriched layer;
/// - `rim`: node set of the top ring, all nodes through the thickness (z = cz exactly);
/// - `pole`: node set of the outer pole node (the lowest point, grid point (n/2, n/2));
/// - `cap`: node set of the outer nodes within [`CAP_HALF_ANGLE_DEG`] of the pole (seen from the
///   centre): a small loading patch around the first contact point; `inner_cap`: the inner nodes
///   in the same directions (a patch that a linear and an enriched outer layer share).
#[allow(non_snake_case)]
pub fn hemisphere_nurbs(
    center: [f64; 3],
    R: f64,
    h: f64,
    n: usize,
    m: usize,
) -> Result<Mesh, MeshError> {
    check_shell_parameters(R, h, m)?;
    if n < 2 || !n.is_multiple_of(2) {
        return Err(MeshError::InvalidParameter {
            name: "n",
            value: n.to_string(),
            reason: "must be even and >= 2 (the exact surface has 2 base elements per direction)",
        });
    }
    let geo = |e: crate::geometry::GeometryError| MeshError::Inconsistent(e.to_string());
    let (base, _) = hollow_hemisphere(center, R, h).map_err(geo)?;
    let refined = base.k_refine(2, n).map_err(geo)?;
    let params = |kv: &crate::geometry::knots::KnotVector| -> Vec<f64> {
        kv.unique_with_multiplicity().iter().map(|k| k.0).collect()
    };
    let (pu, pv) = (params(&refined.knots_u), params(&refined.knots_v));
    if pu.len() != n + 1 || pv.len() != n + 1 {
        return Err(MeshError::Inconsistent(format!(
            "refined hemisphere has {} x {} elements, expected {n} x {n}",
            pu.len() - 1,
            pv.len() - 1
        )));
    }
    let per_layer = (n - 1) * (n + 1) + 2;
    let node = |i: usize, j: usize, k: usize| -> u32 {
        let local = match i {
            0 => 0,
            i if i == n => per_layer - 1,
            i => 1 + (i - 1) + (n - 1) * j,
        };
        (k * per_layer + local) as u32
    };
    // unit directions of the grid points, in node order of one layer
    let mut dirs = vec![[0.0; 3]; per_layer];
    for j in 0..=n {
        for i in 0..=n {
            let x = refined.point(pu[i], pv[j]);
            let mut d = [x[0] - center[0], x[1] - center[1], x[2] - center[2]];
            if i == 0 || i == n || j == 0 || j == n {
                d[2] = 0.0;
            }
            let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            dirs[node(i, j, 0) as usize] = [d[0] / l, d[1] / l, d[2] / l];
        }
    }
    let layer_node = |i: usize, j: usize| node(i, j, 0) as usize;
    let mut mesh = spherical_shell(center, R, h, n, m, &dirs, &layer_node);
    let rim: Vec<u32> = (0..=m)
        .flat_map(|k| {
            (0..=n).flat_map(move |j| {
                (0..=n)
                    .filter(move |&i| i == 0 || i == n || j == 0 || j == n)
                    .map(move |i| node(i, j, k))
            })
        })
        .collect();
    mesh.insert_node_set("rim", rim);
    mesh.insert_node_set("pole", vec![node(n / 2, n / 2, 0)]);
    // d[2] = -cos(angle from the downward axis)
    let cap: Vec<u32> = (0..per_layer)
        .filter(|&a| -dirs[a][2] >= CAP_HALF_ANGLE_DEG.to_radians().cos() - 1e-12)
        .map(|a| a as u32)
        .collect();
    mesh.insert_node_set(
        "inner_cap",
        cap.iter().map(|&a| a + (m * per_layer) as u32).collect(),
    );
    mesh.insert_node_set("cap", cap);
    mesh.exact_surfaces.insert(
        "outer".into(),
        ExactPatch {
            surface: base,
            params_u: pu,
            params_v: pv,
            nodes: (0..=n)
                .flat_map(|j| (0..=n).map(move |i| node(i, j, 0)))
                .collect(),
        },
    );
    Ok(mesh)
}

#[cfg(test)]
#[allow(non_snake_case)]
mod tests {
    use super::*;
    use crate::mesh::CellKind;
    use std::f64::consts::PI;

    const C: [f64; 3] = [0.2, -0.1, 1.5];

    fn radius(m: &Mesh, a: u32) -> f64 {
        let x = m.node(a);
        ((x[0] - C[0]).powi(2) + (x[1] - C[1]).powi(2) + (x[2] - C[2]).powi(2)).sqrt()
    }

    #[test]
    fn hemisphere_nurbs_has_positive_jacobian_at_all_gauss_points() {
        for (n, m) in [(2, 1), (4, 2), (6, 3), (8, 2)] {
            let mesh = hemisphere_nurbs(C, 1.0, 1.0 / 3.0, n, m).unwrap();
            mesh.validate().unwrap();
            let mut min_rel = f64::INFINITY;
            for c in 0..mesh.n_cells() {
                let x: Vec<f64> = mesh
                    .cell(c)
                    .iter()
                    .flat_map(|&a| mesh.node(a).to_vec())
                    .collect();
                let h3 = mesh.cell_diameter(c).powi(3);
                for xi in CellKind::Hex8.gauss2_points().chunks(3) {
                    let det = CellKind::Hex8.jacobian_det(&x, xi);
                    min_rel = min_rel.min(det / h3);
                }
            }
            assert!(min_rel > 1e-3, "n={n} m={m}: min det J / h^3 = {min_rel}");
        }
    }

    #[test]
    fn hemisphere_nurbs_nodes_lie_on_their_spheres_and_the_rim_plane() {
        let (R, h, n, m) = (1.3, 0.4, 6, 3);
        let mesh = hemisphere_nurbs(C, R, h, n, m).unwrap();
        for k in 0..=m {
            let r = R - h * k as f64 / m as f64;
            let per_layer = (n - 1) * (n + 1) + 2;
            for a in k * per_layer..(k + 1) * per_layer {
                assert!((radius(&mesh, a as u32) - r).abs() < 1e-12, "node {a}");
                assert!(
                    mesh.node(a as u32)[2] <= C[2] + 1e-15,
                    "node {a} above the rim"
                );
            }
        }
        for &a in &mesh.node_sets["outer"] {
            assert!((radius(&mesh, a) - R).abs() < 1e-12);
        }
        for &a in &mesh.node_sets["inner"] {
            assert!((radius(&mesh, a) - (R - h)).abs() < 1e-12);
        }
        let rim = &mesh.node_sets["rim"];
        // 4 n ring points minus the 2 merged pairs... the ring of an n x n grid has 4 n points; the
        // u = 0 and u = 1 sides (n + 1 points each) are one node each: 2 (n - 1) + 2 per layer
        assert_eq!(rim.len(), (2 * (n - 1) + 2) * (m + 1));
        for &a in rim {
            assert_eq!(mesh.node(a)[2], C[2], "rim node {a} off the plane z = cz");
        }
        for &a in &mesh.node_sets["cap"] {
            let z = mesh.node(a)[2] - C[2];
            assert!((radius(&mesh, a) - R).abs() < 1e-12);
            assert!(
                -z / R >= 35f64.to_radians().cos() - 1e-12,
                "cap node {a} too far out"
            );
        }
        // n = 6: the pole and its 4 grid neighbours (29.3 degrees out; the diagonal ones are at 40.4)
        assert_eq!(mesh.node_sets["cap"].len(), 5);
        let n8 = hemisphere_nurbs(C, R, h, 8, 1).unwrap();
        // n = 8: the pole and its first ring (21.6 degrees along the grid lines, 30.2 diagonally)
        assert_eq!(n8.node_sets["cap"].len(), 9);
        for (&a, &b) in mesh.node_sets["cap"]
            .iter()
            .zip(&mesh.node_sets["inner_cap"])
        {
            assert!((radius(&mesh, b) - (R - h)).abs() < 1e-12);
            let (xa, xb) = (mesh.node(a), mesh.node(b));
            let d: Vec<f64> = (0..3)
                .map(|k| (xa[k] - C[k]) / R - (xb[k] - C[k]) / (R - h))
                .collect();
            assert!(
                d.iter().all(|x| x.abs() < 1e-12),
                "inner cap node {b} not below {a}"
            );
        }
        let pole = mesh.node_sets["pole"][0];
        let x = mesh.node(pole);
        assert!((x[0] - C[0]).abs() < 1e-14 && (x[1] - C[1]).abs() < 1e-14);
        assert!((x[2] - (C[2] - R)).abs() < 1e-14);
    }

    #[test]
    fn hemisphere_nurbs_merges_the_collapsed_rim_points() {
        for (n, m) in [(2, 1), (4, 2), (8, 2)] {
            let mesh = hemisphere_nurbs(C, 1.0, 0.25, n, m).unwrap();
            assert_eq!(mesh.n_nodes(), (m + 1) * ((n - 1) * (n + 1) + 2));
            assert_eq!(mesh.n_cells(), n * n * m);
            // no two distinct nodes at the same point
            for a in 0..mesh.n_nodes() as u32 {
                for b in a + 1..mesh.n_nodes() as u32 {
                    let d: f64 = (0..3)
                        .map(|k| (mesh.node(a)[k] - mesh.node(b)[k]).powi(2))
                        .sum();
                    assert!(d.sqrt() > 1e-8, "nodes {a} and {b} coincide");
                }
            }
            // exactly the 2 n m cells along u = 0 and u = 1 have a repeated node
            let degenerate = (0..mesh.n_cells())
                .filter(|&c| {
                    let mut v = mesh.cell(c).to_vec();
                    v.sort_unstable();
                    v.dedup();
                    v.len() < 8
                })
                .count();
            assert_eq!(degenerate, 2 * n * m);
            let p = &mesh.exact_surfaces["outer"];
            assert_eq!(p.n_faces(), (n, n));
            assert_eq!(mesh.face_sets["outer"].len(), n * n);
            for (e, &(c, f)) in mesh.face_sets["outer"].iter().enumerate() {
                let (i, j) = (e % n, e / n);
                let g = |i: usize, j: usize| p.nodes[i + (n + 1) * j];
                assert_eq!(f, 0);
                assert_eq!(
                    mesh.cell(c as usize)[..4],
                    [g(i, j), g(i + 1, j), g(i + 1, j + 1), g(i, j + 1)]
                );
            }
        }
    }

    #[test]
    fn hemisphere_nurbs_volume_converges() {
        let (R, h): (f64, f64) = (1.0, 1.0 / 3.0);
        let exact = 2.0 / 3.0 * PI * (R.powi(3) - (R - h).powi(3));
        let errors: Vec<f64> = [2, 4, 8, 16]
            .iter()
            .map(|&n| (hemisphere_nurbs(C, R, h, n, 2).unwrap().measure() - exact).abs() / exact)
            .collect();
        assert!(errors[3] < 2e-2, "errors {errors:?}");
        assert!(
            errors.windows(2).all(|w| w[1] < 0.35 * w[0]),
            "errors {errors:?} must fall ~4x per halving (second order)"
        );
    }

    #[test]
    fn hemisphere_nurbs_rejects_odd_or_small_n() {
        for n in [0, 1, 3, 7] {
            assert!(matches!(
                hemisphere_nurbs(C, 1.0, 0.3, n, 1),
                Err(MeshError::InvalidParameter { name: "n", .. })
            ));
        }
        assert!(hemisphere_nurbs(C, 1.0, 1.0, 2, 1).is_err());
        assert!(hemisphere_nurbs(C, 1.0, 0.3, 2, 0).is_err());
    }
}
