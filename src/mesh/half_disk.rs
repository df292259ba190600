//! Solid half disk (the ironing half-cylinder of Corbett & Sauer 2014, section 4.1) meshed as
//! an O-grid of Quad4 cells.
use super::{CellKind, Mesh, MeshError};
use std::f64::consts::PI;

/// Distance of the core's lower corners from the centre, as a fraction of the radius.
const CORE_FRACTION: f64 = 0.6;

/// Solid half disk of radius `r` around `center` = (cx, cy): flat side up on y = cy, curved
/// side down (polar angles 180..360 degrees).
///
/// O-grid: a rectangular core `[cx - a, cx + a] x [cy - b, cy]` of `n_bot x n_side` cells,
/// with `n_side = round(n_arc / 4)` and `n_bot = n_arc - 2 n_side`, plus an outer ring block of
/// `n_arc x n_rad` cells between the core's left, bottom and right sides (together `n_arc`
/// segments) and the arc. The arc nodes are uniform in angle; the core's lower corners sit at
/// distance 0.6 r on the rays through their arc partners (angle 180 + phi and 360 - phi
/// degrees, phi = 180 n_side / n_arc), i.e. `a = 0.6 r cos(phi)`, `b = 0.6 r sin(phi)`; ring
/// nodes interpolate linearly between core boundary and arc. No cell is degenerate; the largest
/// angle, at the core corners, is `max(180 - phi, 90 + phi)`: 135 degrees when `n_arc` is a
/// multiple of 4 (recommended), at most 150 degrees otherwise (n_arc = 6).
///
/// Ring cells have local face 0 (eta = -1) on the arc side (eta points inwards), so every arc
/// face is local face 0. Core cells use the default orientation (the top row has the flat
/// side on local face 2); the flat side of the ring cells is local face 3 (left) or 1 (right).
///
/// Named sets:
/// - `arc`: faces ordered from angle 180 to 360 degrees (left to right along the bottom),
///   all local face 0; node set: the `n_arc + 1` arc nodes;
/// - `top`: the flat side y = cy, faces ordered left to right; node set of its nodes;
/// - `top_core`: the top nodes above the core, `|x - cx| <= a` (a flat punch on the middle of
///   the top whose width `2a = 1.2 r cos(45 deg)` is the same for every `n_arc` multiple of 4);
/// - `top_center`: the top node nearest to (cx, cy) (exact when `n_bot` is even, else the
///   left one of the two nearest).
pub fn half_disk(center: [f64; 2], r: f64, n_arc: usize, n_rad: usize) -> Result<Mesh, MeshError> {
    if !(r > 0.0 && r.is_finite()) {
        return Err(MeshError::InvalidParameter {
            name: "r",
            value: r.to_string(),
            reason: "radius must be positive and finite",
        });
    }
    if n_arc < 4 {
        return Err(MeshError::InvalidParameter {
            name: "n_arc",
            value: n_arc.to_string(),
            reason: "the O-grid needs at least 4 cells along the arc",
        });
    }
    if n_rad == 0 {
        return Err(MeshError::InvalidParameter {
            name: "n_rad",
            value: n_rad.to_string(),
            reason: "need at least one cell through the ring",
        });
    }
    let [cx, cy] = center;
    let n_side = ((n_arc + 2) / 4).max(1);
    let n_bot = n_arc - 2 * n_side;
    let phi = PI * n_side as f64 / n_arc as f64;
    let a = CORE_FRACTION * r * phi.cos();
    let b = CORE_FRACTION * r * phi.sin();

    let mut mesh = Mesh::new(2);
    // core nodes (i, l), i = 0..=n_bot left to right, l = 0..=n_side bottom to top
    for l in 0..=n_side {
        for i in 0..=n_bot {
            mesh.push_node(&[
                cx - a + 2.0 * a * i as f64 / n_bot as f64,
                cy - b + b * l as f64 / n_side as f64,
            ]);
        }
    }
    let core = |i: usize, l: usize| (l * (n_bot + 1) + i) as u32;
    for l in 0..n_side {
        for i in 0..n_bot {
            mesh.push_cell(
                CellKind::Quad4,
                &[
                    core(i, l),
                    core(i + 1, l),
                    core(i + 1, l + 1),
                    core(i, l + 1),
                ],
            );
        }
    }
    // polyline node k = 0..=n_arc along the core's left (downwards), bottom, right (upwards)
    let poly = |k: usize| -> u32 {
        if k <= n_side {
            core(0, n_side - k)
        } else if k <= n_side + n_bot {
            core(k - n_side, 0)
        } else {
            core(n_bot, k - n_side - n_bot)
        }
    };
    // ring nodes (k, j): j = 0 on the arc, j = n_rad on the polyline (existing core nodes)
    let mut ring = vec![0u32; (n_arc + 1) * (n_rad + 1)];
    for k in 0..=n_arc {
        let t = PI + PI * k as f64 / n_arc as f64;
        let arc_pt = [cx + r * t.cos(), cy + r * t.sin()];
        let p = poly(k);
        let pp = [mesh.node(p)[0], mesh.node(p)[1]];
        for j in 0..n_rad {
            let s = j as f64 / n_rad as f64;
            ring[k * (n_rad + 1) + j] = mesh.push_node(&[
                arc_pt[0] + s * (pp[0] - arc_pt[0]),
                arc_pt[1] + s * (pp[1] - arc_pt[1]),
            ]);
        }
        ring[k * (n_rad + 1) + n_rad] = p;
    }
    // exact flat side: the sin(pi) / sin(2 pi) round-off must not leave y != cy on the top
    for k in [0, n_arc] {
        for j in 0..n_rad {
            let n = ring[k * (n_rad + 1) + j] as usize;
            mesh.coords[2 * n + 1] = cy;
        }
    }
    let rn = |k: usize, j: usize| ring[k * (n_rad + 1) + j];
    let first_ring_cell = mesh.n_cells();
    for k in 0..n_arc {
        for j in 0..n_rad {
            mesh.push_cell(
                CellKind::Quad4,
                &[rn(k, j), rn(k + 1, j), rn(k + 1, j + 1), rn(k, j + 1)],
            );
        }
    }
    let ring_cell = |k: usize, j: usize| (first_ring_cell + k * n_rad + j) as u32;

    mesh.face_sets.insert(
        "arc".into(),
        (0..n_arc).map(|k| (ring_cell(k, 0), 0)).collect(),
    );
    mesh.insert_node_set("arc", (0..=n_arc).map(|k| rn(k, 0)).collect());
    let mut top: Vec<(u32, u8)> = (0..n_rad).map(|j| (ring_cell(0, j), 3)).collect();
    top.extend(
        (0..n_bot)
            .map(|i| ((n_side - 1) * n_bot + i) as u32)
            .map(|c| (c, 2)),
    );
    top.extend((0..n_rad).rev().map(|j| (ring_cell(n_arc - 1, j), 1)));
    mesh.face_sets.insert("top".into(), top);
    let top_nodes = mesh.node_set_from_faces("top")?;
    mesh.insert_node_set("top", top_nodes);
    mesh.insert_node_set("top_center", vec![core(n_bot / 2, n_side)]);
    mesh.insert_node_set("top_core", (0..=n_bot).map(|i| core(i, n_side)).collect());
    Ok(mesh)
}

/// Interior angles (radians) of every Quad4 cell, [n_cells][4].
#[cfg(test)]
pub(crate) fn quad_angles(m: &Mesh) -> Vec<f64> {
    let mut out = Vec::new();
    for c in 0..m.n_cells() {
        let n = m.cell(c);
        for a in 0..4 {
            let p = m.node(n[a]);
            let q = m.node(n[(a + 1) % 4]);
            let s = m.node(n[(a + 3) % 4]);
            let (u, v) = ([q[0] - p[0], q[1] - p[1]], [s[0] - p[0], s[1] - p[1]]);
            let cross = u[0] * v[1] - u[1] * v[0];
            let dot = u[0] * v[0] + u[1] * v[1];
            out.push(cross.atan2(dot));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn half_disk_cells_are_valid_with_min_angle_above_35_degrees() {
        for (n_arc, n_rad) in [
            (4, 1),
            (5, 1),
            (6, 1),
            (7, 1),
            (8, 2),
            (10, 2),
            (12, 2),
            (16, 3),
            (32, 5),
            (64, 10),
        ] {
            let m = half_disk([0.5, 3.0], 1.0, n_arc, n_rad).unwrap();
            m.validate().unwrap();
            let angles = quad_angles(&m);
            let min = angles
                .iter()
                .cloned()
                .fold(f64::INFINITY, f64::min)
                .to_degrees();
            let max = angles.iter().cloned().fold(0.0, f64::max).to_degrees();
            assert!(min > 35.0, "n_arc {n_arc}: min angle {min}");
            let max_allowed = if n_arc % 4 == 0 {
                135.0 + 1e-9
            } else {
                150.0 + 1e-9
            };
            assert!(max < max_allowed, "n_arc {n_arc}: max angle {max}");
        }
    }

    #[test]
    fn half_disk_area_converges_to_half_circle() {
        let exact = PI * 2.0f64.powi(2) / 2.0;
        let mut last = f64::INFINITY;
        for (n_arc, n_rad) in [(4, 1), (8, 2), (16, 3), (32, 6), (64, 12)] {
            let m = half_disk([0.0, 0.0], 2.0, n_arc, n_rad).unwrap();
            let err = exact - m.measure();
            // inscribed polygon: always smaller, error ~ 1/n_arc^2
            assert!(
                err > 0.0 && err < 0.3 * last,
                "n_arc {n_arc}: {err} vs {last}"
            );
            last = err;
        }
        assert!(last < 1e-2);
    }

    #[test]
    fn half_disk_arc_and_top_sets() {
        let (cx, cy, r) = (0.5, 3.0, 1.25);
        let m = half_disk([cx, cy], r, 12, 2).unwrap();
        let arc = &m.face_sets["arc"];
        assert_eq!(arc.len(), 12);
        let mut last_angle = PI - 1e-12;
        for &(c, f) in arc {
            assert_eq!(f, 0);
            let nodes = m.face_nodes(c as usize, f).unwrap();
            for &n in &nodes {
                let p = m.node(n);
                assert!((((p[0] - cx).powi(2) + (p[1] - cy).powi(2)).sqrt() - r).abs() < 1e-12);
            }
            // consecutive faces continue where the previous one ended, at increasing angle
            let p0 = m.node(nodes[0]);
            let p1 = m.node(nodes[1]);
            let t0 = (p0[1] - cy).atan2(p0[0] - cx).rem_euclid(2.0 * PI);
            let t1 = (p1[1] - cy).atan2(p1[0] - cx).rem_euclid(2.0 * PI);
            let t0 = if t0 < PI / 2.0 { t0 + 2.0 * PI } else { t0 };
            let t1 = if t1 < PI / 2.0 { t1 + 2.0 * PI } else { t1 };
            assert!((t0 - last_angle).abs() < 1e-9 || last_angle == PI - 1e-12);
            assert!(t1 > t0);
            last_angle = t1;
        }
        assert!((last_angle - 2.0 * PI).abs() < 1e-9);
        assert_eq!(m.node_sets["arc"].len(), 13);

        let top = &m.face_sets["top"];
        // n_side = 3, n_bot = 6: 2 + 6 + 2 faces, tiling [cx - r, cx + r] left to right
        assert_eq!(top.len(), 10);
        let mut x = cx - r;
        for &(c, f) in top {
            let nodes = m.face_nodes(c as usize, f).unwrap();
            let xs: Vec<f64> = nodes.iter().map(|&n| m.node(n)[0]).collect();
            assert!((xs[0].min(xs[1]) - x).abs() < 1e-12);
            x = xs[0].max(xs[1]);
            for &n in &nodes {
                assert_eq!(m.node(n)[1], cy);
            }
        }
        assert!((x - (cx + r)).abs() < 1e-12);
        assert_eq!(m.node_sets["top"].len(), 11);
        assert_eq!(m.node(m.node_sets["top_center"][0]), &[cx, cy]);
        // top_core: the core's top row, centred, strictly inside the top
        let core = &m.node_sets["top_core"];
        let xs: Vec<f64> = core.iter().map(|&n| m.node(n)[0] - cx).collect();
        assert!(core.iter().all(|&n| m.node(n)[1] == cy));
        let half = xs.iter().fold(0.0_f64, |a, x| a.max(x.abs()));
        assert!(half < r && half > 0.3 * r);
        assert!((xs.iter().sum::<f64>()).abs() < 1e-12);
    }
}
