//! A quarter of a ball's lowest cap, for 3D Hertz contact with two symmetry planes: the solid
//! between an exact spherical patch around the lowest point and the horizontal plane through the
//! centre, cut by the planes x = cx and y = cy, its Hex8 cells graded towards the lowest point and
//! the spherical surface ([`quarter_sphere`]); and the whole cap, that quarter mirrored across
//! both planes with one exact patch over all four quadrants ([`sphere_cap`]), the model a quarter
//! model is checked against.
use super::{CellKind, ExactPatch, Mesh, MeshError};
use crate::geometry::knots::KnotVector;
use crate::geometry::nurbs::NurbsSurface;

/// Fractions `0 = s_0 < ... < s_n = 1` of `n` cells whose sizes grow geometrically from the first
/// to the last by the factor `grading` (1: equal cells).
fn graded(n: usize, grading: f64) -> Vec<f64> {
    let r = if n > 1 {
        grading.powf(1.0 / (n - 1) as f64)
    } else {
        1.0
    };
    let mut s = vec![0.0; n + 1];
    let mut h = 1.0;
    for k in 0..n {
        s[k + 1] = s[k] + h;
        h *= r;
    }
    let total = s[n];
    s.iter_mut().for_each(|v| *v /= total);
    s[n] = 1.0;
    s
}

/// The exact spherical patch: a circular arc from the lowest point `c - (0, 0, R)` in the plane
/// y = cy up to x = cx + R sin(phi1) (u), turned about the x axis through `c` by 0..theta1 (v),
/// one rational biquadratic Bezier patch (a surface of revolution). u = 0 lies in the plane
/// x = cx, v = 0 in the plane y = cy.
#[allow(non_snake_case)]
fn cap_patch(c: [f64; 3], R: f64, phi1: f64, theta1: f64) -> Result<NurbsSurface, MeshError> {
    let geo = |e: crate::geometry::GeometryError| MeshError::Inconsistent(e.to_string());
    // the profile in the plane y = cy, relative to c: (x, -rho) with rho the distance from the axis
    let profile = [
        (0.0, R, 1.0),
        (R * (phi1 / 2.0).tan(), R, (phi1 / 2.0).cos()),
        (R * phi1.sin(), R * phi1.cos(), 1.0),
    ];
    let (tv, wv) = ((theta1 / 2.0).tan(), (theta1 / 2.0).cos());
    let mut ctrl = Vec::with_capacity(27);
    let mut weights = Vec::with_capacity(9);
    for j in 0..3 {
        for &(x, rho, w) in &profile {
            let (y, z, ww) = match j {
                0 => (0.0, -rho, 1.0),
                1 => (rho * tv, -rho, wv),
                _ => (rho * theta1.sin(), -rho * theta1.cos(), 1.0),
            };
            ctrl.extend_from_slice(&[c[0] + x, c[1] + y, c[2] + z]);
            weights.push(w * ww);
        }
    }
    let kv = || KnotVector::new(2, vec![0.0, 0.0, 0.0, 1.0, 1.0, 1.0]).map_err(geo);
    NurbsSurface::new(kv()?, kv()?, ctrl, weights).map_err(geo)
}

/// The exact spherical patch of the whole cap: the arc in the plane y = cy from x = cx - R sin(phi1)
/// through the lowest point to x = cx + R sin(phi1) (u), turned about the x axis through `c` by
/// -theta1..theta1 (v); one rational biquadratic Bezier patch, mirror-symmetric in u about 1/2
/// (the plane x = cx) and in v about 1/2 (the plane y = cy).
#[allow(non_snake_case)]
fn whole_cap_patch(c: [f64; 3], R: f64, phi1: f64, theta1: f64) -> Result<NurbsSurface, MeshError> {
    let geo = |e: crate::geometry::GeometryError| MeshError::Inconsistent(e.to_string());
    // the profile relative to c: (x, rho) with rho the distance from the x axis; the middle
    // control point is where the end tangents meet
    let profile = [
        (-R * phi1.sin(), R * phi1.cos(), 1.0),
        (0.0, R / phi1.cos(), phi1.cos()),
        (R * phi1.sin(), R * phi1.cos(), 1.0),
    ];
    // the turn about the x axis per unit rho: (y, z)
    let turn = [
        (-theta1.sin(), -theta1.cos(), 1.0),
        (0.0, -1.0 / theta1.cos(), theta1.cos()),
        (theta1.sin(), -theta1.cos(), 1.0),
    ];
    let mut ctrl = Vec::with_capacity(27);
    let mut weights = Vec::with_capacity(9);
    for &(y, z, ww) in &turn {
        for &(x, rho, w) in &profile {
            ctrl.extend_from_slice(&[c[0] + x, c[1] + rho * y, c[2] + rho * z]);
            weights.push(w * ww);
        }
    }
    let kv = || KnotVector::new(2, vec![0.0, 0.0, 0.0, 1.0, 1.0, 1.0]).map_err(geo);
    NurbsSurface::new(kv()?, kv()?, ctrl, weights).map_err(geo)
}

/// The parameter in [1/2, 1] at which the increasing function `angle` of a symmetric arc's
/// parameter (0 at 1/2) reaches `a` >= 0 (bisection to round-off).
fn parameter_of(angle: impl Fn(f64) -> f64, a: f64) -> f64 {
    if a == 0.0 {
        return 0.5;
    }
    let (mut lo, mut hi) = (0.5, 1.0);
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if angle(mid) < a {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// Checks [`quarter_sphere`]'s parameters, naming the first bad one.
#[allow(non_snake_case)]
fn check_parameters(
    R: f64,
    extent: f64,
    divisions: [usize; 3],
    grading: [f64; 3],
) -> Result<(), MeshError> {
    if !(R > 0.0 && R.is_finite()) {
        return Err(MeshError::InvalidParameter {
            name: "radius",
            value: R.to_string(),
            reason: "must be positive and finite",
        });
    }
    if !(extent > 0.0 && extent < R) {
        return Err(MeshError::InvalidParameter {
            name: "extent",
            value: extent.to_string(),
            reason: "must lie in (0, radius)",
        });
    }
    for (name, n) in [
        ("n_u", divisions[0]),
        ("n_v", divisions[1]),
        ("n_z", divisions[2]),
    ] {
        if n == 0 {
            return Err(MeshError::InvalidParameter {
                name,
                value: n.to_string(),
                reason: "need at least one cell",
            });
        }
    }
    for (name, g) in [
        ("g_u", grading[0]),
        ("g_v", grading[1]),
        ("g_z", grading[2]),
    ] {
        if !(g > 0.0 && g.is_finite()) {
            return Err(MeshError::InvalidParameter {
                name,
                value: g.to_string(),
                reason: "a grading must be positive and finite",
            });
        }
    }
    Ok(())
}

/// Node (i, j, k) of a cap's grid of `[n_u, n_v]` cells per layer: `(k (n_v + 1) + j) (n_u + 1) + i`.
fn grid_node([nu, nv]: [usize; 2], i: usize, j: usize, k: usize) -> u32 {
    ((k * (nv + 1) + j) * (nu + 1) + i) as u32
}

/// The nodes of layer `k`, i fastest.
fn layer_nodes(n: [usize; 2], k: usize) -> Vec<u32> {
    (0..=n[1])
        .flat_map(|j| (0..=n[0]).map(move |i| grid_node(n, i, j, k)))
        .collect()
}

/// The nodes of every layer with i = `fixed_i` and / or j = `fixed_j`.
fn side_nodes(
    n: [usize; 2],
    nz: usize,
    fixed_i: Option<usize>,
    fixed_j: Option<usize>,
) -> Vec<u32> {
    (0..=nz)
        .flat_map(|k| (0..=n[1]).flat_map(move |j| (0..=n[0]).map(move |i| (i, j, k))))
        .filter(|&(i, j, _)| fixed_i.is_none_or(|f| f == i) && fixed_j.is_none_or(|f| f == j))
        .map(|(i, j, k)| grid_node(n, i, j, k))
        .collect()
}

/// The solid below a cap's surface grid `base` ([(n_v + 1)][(n_u + 1)] points, i fastest): each
/// point's vertical line from the surface up to the plane z = cz at the fractions `pz`; Hex8
/// cells `(k n_v + j) n_u + i`; the face and node sets `sphere` (local faces 0 of layer 0) and
/// `top` (local faces 1 of the last layer), and the node sets `xmin`, `xmax`, `ymin`, `ymax` of
/// the grid's four sides.
fn solid(center: [f64; 3], base: &[[f64; 3]], n: [usize; 2], pz: &[f64]) -> Mesh {
    let ([nu, nv], nz) = (n, pz.len() - 1);
    let mut mesh = Mesh::new(3);
    for &s in pz {
        for x in base {
            let z = if s == 1.0 {
                center[2]
            } else {
                x[2] + (center[2] - x[2]) * s
            };
            mesh.push_node(&[x[0], x[1], z]);
        }
    }
    let node = |i: usize, j: usize, k: usize| grid_node(n, i, j, k);
    for k in 0..nz {
        for j in 0..nv {
            for i in 0..nu {
                mesh.push_cell(
                    CellKind::Hex8,
                    &[
                        node(i, j, k),
                        node(i + 1, j, k),
                        node(i + 1, j + 1, k),
                        node(i, j + 1, k),
                        node(i, j, k + 1),
                        node(i + 1, j, k + 1),
                        node(i + 1, j + 1, k + 1),
                        node(i, j + 1, k + 1),
                    ],
                );
            }
        }
    }
    let cell = |i: usize, j: usize, k: usize| ((k * nv + j) * nu + i) as u32;
    let faces = |k: usize, f: u8| -> Vec<(u32, u8)> {
        (0..nv)
            .flat_map(|j| (0..nu).map(move |i| (cell(i, j, k), f)))
            .collect()
    };
    mesh.face_sets.insert("sphere".into(), faces(0, 0));
    mesh.face_sets.insert("top".into(), faces(nz - 1, 1));
    mesh.insert_node_set("sphere", layer_nodes(n, 0));
    mesh.insert_node_set("top", layer_nodes(n, nz));
    mesh.insert_node_set("xmin", side_nodes(n, nz, Some(0), None));
    mesh.insert_node_set("xmax", side_nodes(n, nz, Some(nu), None));
    mesh.insert_node_set("ymin", side_nodes(n, nz, None, Some(0)));
    mesh.insert_node_set("ymax", side_nodes(n, nz, None, Some(nv)));
    mesh
}

/// The quarter cap of the ball of radius `R` around `center` = c: the solid between the exact
/// spherical patch around the lowest point `c - (0, 0, R)` and the plane z = cz, on the side
/// x >= cx, y >= cy. The patch reaches `extent` from the symmetry planes: x - cx = extent on the
/// plane y = cy, y - cy = extent on the plane x = cx (so `extent` < R); it is a surface of
/// revolution about the x axis through c (an arc of the great circle in y = cy, turned), so its
/// far edges are the small circle x - cx = extent and the great circle through the x axis at the
/// angle asin(extent / R).
///
/// Cells: `divisions = [n_u, n_v, n_z]`: n_u along the arc, n_v around the axis, n_z from the
/// sphere up to the plane along vertical lines; `grading = [g_u, g_v, g_z]`: the last cell of each
/// direction is `g` times the first (geometric; > 1 refines towards the lowest point and the
/// sphere), in the patch's parameters (u, v: within 10 % of the angle at this opening) and in the
/// height of each vertical line (z).
///
/// Nodes (i, j, k) are numbered `(k (n_v + 1) + j) (n_u + 1) + i`, cells likewise
/// `(k n_v + j) n_u + i`; local face 0 (zeta = -1) of the cells with k = 0 lies on the sphere.
///
/// Named sets:
/// - `sphere`: face set (local faces 0, ordered i fastest, then j) and node set of the spherical
///   surface; it carries the exact surface ([`Mesh::exact_surfaces`]) for an enriched layer;
/// - `top`: face set (local faces 1) and node set on the plane z = cz;
/// - `xmin` (on the plane x = cx), `ymin` (on the plane y = cy): node sets of the symmetry planes;
///   `xmax`, `ymax`: node sets of the far sides (i = n_u, j = n_v);
/// - `pole`: the lowest point.
#[allow(non_snake_case)]
pub fn quarter_sphere(
    center: [f64; 3],
    R: f64,
    extent: f64,
    divisions: [usize; 3],
    grading: [f64; 3],
) -> Result<Mesh, MeshError> {
    check_parameters(R, extent, divisions, grading)?;
    let [nu, nv, nz] = divisions;
    let angle = (extent / R).asin();
    let surface = cap_patch(center, R, angle, angle)?;
    let (pu, pv, pz) = (
        graded(nu, grading[0]),
        graded(nv, grading[1]),
        graded(nz, grading[2]),
    );
    let mut base = Vec::with_capacity((nu + 1) * (nv + 1));
    for &v in &pv {
        for &u in &pu {
            let mut x = surface.point(u, v);
            // the symmetry planes exactly (the rational map misses them by round-off)
            if u == 0.0 {
                x[0] = center[0];
            }
            if v == 0.0 {
                x[1] = center[1];
            }
            base.push(x);
        }
    }
    let mut mesh = solid(center, &base, [nu, nv], &pz);
    mesh.insert_node_set("pole", vec![grid_node([nu, nv], 0, 0, 0)]);
    mesh.exact_surfaces.insert(
        "sphere".into(),
        ExactPatch {
            surface,
            params_u: pu,
            params_v: pv,
            nodes: layer_nodes([nu, nv], 0),
        },
    );
    Ok(mesh)
}

/// The whole cap: [`quarter_sphere`]'s quarter with the same parameters, mirrored across the
/// planes x = cx and y = cy, so that each quadrant holds the quarter's cells and nodes (its
/// `divisions` and `grading` count from the lowest point outwards, the whole cap has
/// `[2 n_u, 2 n_v, n_z]` cells) and the patch `sphere` is one exact patch over all four quadrants,
/// C^1 across the two planes. A quarter model and this one are the same discretisation but for
/// the patch's edges on the planes.
///
/// Nodes (i, j, k), i in 0..=2 n_u, j in 0..=2 n_v, are numbered as the quarter's; local face 0 of
/// the cells with k = 0 lies on the sphere.
///
/// Named sets: `sphere`, `top` as the quarter's; `xmin`, `xmax`, `ymin`, `ymax`: node sets of the
/// four far sides (x - cx = -extent ... on y = cy, and so on); `xmid` (on the plane x = cx),
/// `ymid` (on y = cy): node sets of the two mirror planes, which the patch crosses (rollers on
/// them hold the cap against rigid motion without acting as symmetry planes); `axis`: the
/// vertical line x = cx, y = cy; `pole`: the lowest point.
#[allow(non_snake_case)]
pub fn sphere_cap(
    center: [f64; 3],
    R: f64,
    extent: f64,
    divisions: [usize; 3],
    grading: [f64; 3],
) -> Result<Mesh, MeshError> {
    check_parameters(R, extent, divisions, grading)?;
    let [nu, nv, nz] = divisions;
    let angle = (extent / R).asin();
    let quarter = cap_patch(center, R, angle, angle)?;
    let surface = whole_cap_patch(center, R, angle, angle)?;
    // the quarter's grid angles: along the arc (in y = cy) and about the x axis (in x = cx)
    let arc = |p: [f64; 3]| ((p[0] - center[0]) / R).clamp(-1.0, 1.0).asin();
    let turn = |p: [f64; 3]| (p[1] - center[1]).atan2(center[2] - p[2]);
    let (pu, pv, pz) = (
        graded(nu, grading[0]),
        graded(nv, grading[1]),
        graded(nz, grading[2]),
    );
    // the same angles on the whole patch, mirrored about its middle parameter 1/2
    let mirrored = |half: Vec<f64>| -> Vec<f64> {
        let n = half.len() - 1;
        (0..=2 * n)
            .map(|k| {
                if k >= n {
                    half[k - n]
                } else {
                    1.0 - half[n - k]
                }
            })
            .collect()
    };
    let params_u = mirrored(
        pu.iter()
            .map(|&u| parameter_of(|t| arc(surface.point(t, 0.5)), arc(quarter.point(u, 0.0))))
            .collect(),
    );
    let params_v = mirrored(
        pv.iter()
            .map(|&v| parameter_of(|t| turn(surface.point(0.5, t)), turn(quarter.point(0.0, v))))
            .collect(),
    );
    let (mu, mv) = (2 * nu, 2 * nv);
    // the positive quadrant from the patch, the others its exact mirror images
    let mut base = vec![[0.0; 3]; (mu + 1) * (mv + 1)];
    for (j, &v) in params_v.iter().enumerate().skip(nv) {
        for (i, &u) in params_u.iter().enumerate().skip(nu) {
            let mut x = surface.point(u, v);
            if i == nu {
                x[0] = center[0];
            }
            if j == nv {
                x[1] = center[1];
            }
            if i == nu && j == nv {
                x[2] = center[2] - R;
            }
            for (jj, sy) in [(j, 1.0), (mv - j, -1.0)] {
                for (ii, sx) in [(i, 1.0), (mu - i, -1.0)] {
                    base[jj * (mu + 1) + ii] = [
                        center[0] + sx * (x[0] - center[0]),
                        center[1] + sy * (x[1] - center[1]),
                        x[2],
                    ];
                }
            }
        }
    }
    let mut mesh = solid(center, &base, [mu, mv], &pz);
    let side = |i: Option<usize>, j: Option<usize>| side_nodes([mu, mv], nz, i, j);
    mesh.insert_node_set("xmid", side(Some(nu), None));
    mesh.insert_node_set("ymid", side(None, Some(nv)));
    mesh.insert_node_set("axis", side(Some(nu), Some(nv)));
    mesh.insert_node_set("pole", vec![grid_node([mu, mv], nu, nv, 0)]);
    mesh.exact_surfaces.insert(
        "sphere".into(),
        ExactPatch {
            surface,
            params_u,
            params_v,
            nodes: layer_nodes([mu, mv], 0),
        },
    );
    Ok(mesh)
}

#[cfg(test)]
mod tests {
    use super::*;

    const C: [f64; 3] = [0.0, 0.0, 1.0];

    fn dist(x: &[f64], c: [f64; 3]) -> f64 {
        ((x[0] - c[0]).powi(2) + (x[1] - c[1]).powi(2) + (x[2] - c[2]).powi(2)).sqrt()
    }

    #[test]
    fn the_patch_is_on_the_sphere_and_meets_the_symmetry_planes() {
        let m = quarter_sphere(C, 1.0, 0.6, [6, 5, 4], [4.0, 3.0, 2.0]).unwrap();
        m.validate().unwrap();
        let patch = &m.exact_surfaces["sphere"];
        for k in 0..=40 {
            for l in 0..=40 {
                let (u, v) = (k as f64 / 40.0, l as f64 / 40.0);
                let x = patch.surface.point(u, v);
                assert!((dist(&x, C) - 1.0).abs() < 1e-14, "({u}, {v}): {x:?}");
                // normal slope zero across the planes: the normal lies in them
                if k == 0 || l == 0 {
                    let n = patch.surface.normal(u, v).unwrap();
                    let c = if k == 0 { 0 } else { 1 };
                    assert!(n[c].abs() < 1e-14, "({u}, {v}): normal {n:?}");
                }
            }
        }
        for &a in &m.node_sets["sphere"] {
            assert!((dist(m.node(a), C) - 1.0).abs() < 1e-14);
        }
        for &a in &m.node_sets["xmin"] {
            assert_eq!(m.node(a)[0], 0.0);
        }
        for &a in &m.node_sets["ymin"] {
            assert_eq!(m.node(a)[1], 0.0);
        }
        for &a in &m.node_sets["top"] {
            assert_eq!(m.node(a)[2], 1.0);
        }
        assert_eq!(m.node(m.node_sets["pole"][0]), &[0.0, 0.0, 0.0]);
        // the far corner of the xmax side on y = 0, and of the ymax side on x = 0
        let far_x = m.node(6);
        assert!(
            (far_x[0] - 0.6).abs() < 1e-14 && far_x[1] == 0.0,
            "{far_x:?}"
        );
        let far_y = m.node(7 * 5);
        assert!(
            far_y[0] == 0.0 && (far_y[1] - 0.6).abs() < 1e-14,
            "{far_y:?}"
        );
        // graded: the first cell along u is a quarter of the last
        let (h0, h1) = (m.node(1)[0], far_x[0] - m.node(5)[0]);
        assert!(h0 < 0.3 * h1, "first {h0}, last {h1}");
        for c in 0..m.n_cells() {
            let x: Vec<f64> = m.cell(c).iter().flat_map(|&a| m.node(a).to_vec()).collect();
            for xi in CellKind::Hex8.gauss2_points().chunks(3) {
                assert!(CellKind::Hex8.jacobian_det(&x, xi) > 0.0, "cell {c}");
            }
        }
        assert_eq!(m.face_sets["sphere"].len(), 30);
    }

    #[test]
    fn the_whole_cap_is_the_quarter_mirrored_on_one_patch() {
        let (div, grading) = ([6, 5, 4], [4.0, 3.0, 2.0]);
        let q = quarter_sphere(C, 1.0, 0.6, div, grading).unwrap();
        let m = sphere_cap(C, 1.0, 0.6, div, grading).unwrap();
        m.validate().unwrap();
        assert_eq!(m.n_cells(), 4 * q.n_cells());
        assert_eq!(m.face_sets["sphere"].len(), 4 * q.face_sets["sphere"].len());
        let (mu, mv) = (12, 10);
        let node = |i: usize, j: usize, k: usize| ((k * (mv + 1) + j) * (mu + 1) + i) as u32;
        let qnode = |i: usize, j: usize, k: usize| ((k * 6 + j) * 7 + i) as u32;
        // every quadrant holds the quarter's nodes, mirrored
        for k in 0..=4 {
            for j in 0..=5 {
                for i in 0..=6 {
                    let x = q.node(qnode(i, j, k));
                    for (ii, sx) in [(6 + i, 1.0), (6 - i, -1.0)] {
                        for (jj, sy) in [(5 + j, 1.0), (5 - j, -1.0)] {
                            let y = m.node(node(ii, jj, k));
                            let want = [sx * x[0], sy * x[1], x[2]];
                            for c in 0..3 {
                                assert!((y[c] - want[c]).abs() < 1e-14, "{y:?} {want:?}");
                            }
                        }
                    }
                }
            }
        }
        // one exact patch through the grid's nodes, on the sphere, with its normal in the mirror
        // planes where it crosses them (C^1 across them)
        let patch = &m.exact_surfaces["sphere"];
        assert_eq!(patch.n_faces(), (mu, mv));
        for (l, &v) in patch.params_v.iter().enumerate() {
            for (k, &u) in patch.params_u.iter().enumerate() {
                let x = patch.surface.point(u, v);
                let y = m.node(patch.nodes[l * (mu + 1) + k]);
                for c in 0..3 {
                    assert!((x[c] - y[c]).abs() < 1e-13, "({k}, {l}): {x:?} {y:?}");
                }
            }
        }
        for k in 0..=40 {
            let t = k as f64 / 40.0;
            assert!((dist(&patch.surface.point(t, 0.3), C) - 1.0).abs() < 1e-14);
            assert!(patch.surface.normal(0.5, t).unwrap()[0].abs() < 1e-14);
            assert!(patch.surface.normal(t, 0.5).unwrap()[1].abs() < 1e-14);
        }
        assert_eq!(m.node(m.node_sets["pole"][0]), &[0.0, 0.0, 0.0]);
        for &a in &m.node_sets["xmid"] {
            assert_eq!(m.node(a)[0], 0.0);
        }
        for &a in &m.node_sets["ymid"] {
            assert_eq!(m.node(a)[1], 0.0);
        }
        for c in 0..m.n_cells() {
            let x: Vec<f64> = m.cell(c).iter().flat_map(|&a| m.node(a).to_vec()).collect();
            for xi in CellKind::Hex8.gauss2_points().chunks(3) {
                assert!(CellKind::Hex8.jacobian_det(&x, xi) > 0.0, "cell {c}");
            }
        }
        let e = sphere_cap(C, 1.0, 1.2, div, grading).unwrap_err();
        assert!(e.to_string().contains("extent"), "{e}");
    }

    #[test]
    fn bad_parameters_are_named() {
        let e = quarter_sphere(C, 1.0, 1.2, [2, 2, 2], [1.0; 3]).unwrap_err();
        assert!(e.to_string().contains("extent"), "{e}");
        let e = quarter_sphere(C, 1.0, 0.5, [2, 0, 2], [1.0; 3]).unwrap_err();
        assert!(e.to_string().contains("n_v"), "{e}");
        let e = quarter_sphere(C, 1.0, 0.5, [2, 2, 2], [1.0, -1.0, 1.0]).unwrap_err();
        assert!(e.to_string().contains("g_v"), "{e}");
    }
}
