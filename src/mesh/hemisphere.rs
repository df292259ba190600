//! Hollow hemispherical shell of Hex8 cells (the twisting hemisphere of Corbett & Sauer 2014,
//! section 4.4).
use super::spherical_shell::{check_shell_parameters, spherical_shell};
use super::{Mesh, MeshError};
use std::f64::consts::{FRAC_PI_2, FRAC_PI_4, PI};

/// Hollow hemisphere around `center` = (cx, cy, cz) with outer radius `R` and wall thickness
/// `h`, cap pointing down (-z), rim ring in the plane z = cz.
///
/// The curved surface is parametrised by a square (u, v) in [-1, 1]^2 with `n x n` cells
/// (the paper uses n = 3, 7, 11) whose boundary is the rim: each side of the square maps
/// uniformly in angle onto a quarter of the rim circle (square corners at polar angles 45,
/// 135, 225, 315 degrees), the interior onto the unit disk by the Coons (transfinite)
/// interpolation of these four arcs, and the disk onto the sphere by the equidistant
/// azimuthal map (disk radius rho -> angle rho pi/2 from the -z axis). Layers through the
/// thickness are uniform in radius, `m` cells.
///
/// Degenerate cells: the paper (section 4.4) says "four elements on the hemisphere are
/// degenerated to triangles" and that their degenerate edges have prescribed displacements;
/// these are the four cells at the corners of the square, whose two rim edges become almost
/// collinear (angle 180 - 360/(4n) degrees between the chords). (The issue text speaks of
/// degenerate elements at the pole; we follow the paper: the pole is a regular interior point
/// of the Coons map.) In a trilinear Hex8 the two rim edges and the through-thickness edge of
/// such a corner node all lie in the plane z = cz, so det J = 0 exactly at the (outer and
/// inner) rim-corner nodes; it is positive at the cell centre and at all 2x2x2 Gauss points
/// (tested). [`Mesh::validate`] accepts such zero corner Jacobians.
///
/// Cells: cell (i, j, l) = (l n + j) n + i with i along u, j along v, l through the thickness
/// from the outer surface; local face 0 (zeta = -1) is on the outer (contact) surface, face 1
/// on the inner surface.
///
/// Named sets:
/// - `outer` (contact surface) and `inner`: face sets (local faces 0 and 1), ordered row-major
///   over the square (i fastest, then j), and node sets;
/// - `rim`: node set of the top ring, all nodes through the thickness (z = cz exactly), and the
///   face set of the rim faces ordered counter-clockwise around the square (seen from +z with
///   the cap below: v = -1 side left to right, u = 1 bottom to top, v = 1 right to left,
///   u = -1 top to bottom), layers innermost-loop.
#[allow(non_snake_case)]
pub fn hemisphere(center: [f64; 3], R: f64, h: f64, n: usize, m: usize) -> Result<Mesh, MeshError> {
    check_shell_parameters(R, h, m)?;
    if n < 2 {
        return Err(MeshError::InvalidParameter {
            name: "n",
            value: n.to_string(),
            reason:
                "need at least 2 cells per side of the square so that no cell has three rim edges",
        });
    }
    let n1 = n + 1;
    let mut dirs = Vec::with_capacity(n1 * n1);
    for j in 0..=n {
        for i in 0..=n {
            let s = -1.0 + 2.0 * i as f64 / n as f64;
            let t = -1.0 + 2.0 * j as f64 / n as f64;
            let on_rim = i == 0 || j == 0 || i == n || j == n;
            dirs.push(unit_sphere_point(s, t, on_rim));
        }
    }
    let mut mesh = spherical_shell(center, R, h, n, m, &dirs, &|i, j| j * n1 + i);
    let cell = |i: usize, j: usize, l: usize| ((l * n + j) * n + i) as u32;
    // rim faces, counter-clockwise: v = -1 (face 2), u = 1 (face 3), v = 1 (face 4), u = -1 (face 5)
    let mut rim_faces = Vec::with_capacity(4 * n * m);
    let side_cell = |side: usize, p: usize| -> (u8, usize, usize) {
        match side {
            0 => (2, p, 0),
            1 => (3, n - 1, p),
            2 => (4, n - 1 - p, n - 1),
            _ => (5, 0, n - 1 - p),
        }
    };
    for side in 0..4 {
        for p in 0..n {
            let (face, i, j) = side_cell(side, p);
            for l in 0..m {
                rim_faces.push((cell(i, j, l), face));
            }
        }
    }
    mesh.face_sets.insert("rim".into(), rim_faces);
    let rim = mesh.node_set_from_faces("rim")?;
    mesh.insert_node_set("rim", rim);
    Ok(mesh)
}

/// Point of the unit rim circle (polar angle `phi`) as (x, y).
fn circle(phi: f64) -> [f64; 2] {
    [phi.cos(), phi.sin()]
}

/// Coons map of the square (s, t) in [-1, 1]^2 onto the unit disk whose four sides map
/// uniformly in angle onto the quarter arcs of the unit circle.
fn coons_disk(s: f64, t: f64) -> [f64; 2] {
    let bottom = circle(-FRAC_PI_2 + FRAC_PI_4 * s);
    let top = circle(FRAC_PI_2 - FRAC_PI_4 * s);
    let left = circle(PI - FRAC_PI_4 * t);
    let right = circle(FRAC_PI_4 * t);
    let corners = [
        circle(-3.0 * FRAC_PI_4), // (-1, -1)
        circle(-FRAC_PI_4),       // (1, -1)
        circle(FRAC_PI_4),        // (1, 1)
        circle(3.0 * FRAC_PI_4),  // (-1, 1)
    ];
    let (sm, sp, tm, tp) = (
        (1.0 - s) / 2.0,
        (1.0 + s) / 2.0,
        (1.0 - t) / 2.0,
        (1.0 + t) / 2.0,
    );
    let mut p = [0.0; 2];
    for k in 0..2 {
        p[k] = sm * left[k] + sp * right[k] + tm * bottom[k] + tp * top[k]
            - (sm * tm * corners[0][k]
                + sp * tm * corners[1][k]
                + sp * tp * corners[2][k]
                + sm * tp * corners[3][k]);
    }
    p
}

/// Point of the lower unit hemisphere for square coordinates (s, t); `on_rim` forces the exact
/// rim plane z = 0 and radius 1 that round-off would otherwise spoil.
fn unit_sphere_point(s: f64, t: f64, on_rim: bool) -> [f64; 3] {
    let p = coons_disk(s, t);
    let rho = (p[0] * p[0] + p[1] * p[1]).sqrt();
    if on_rim {
        return [p[0] / rho, p[1] / rho, 0.0];
    }
    if rho < 1e-300 {
        return [0.0, 0.0, -1.0];
    }
    // equidistant azimuthal map: rho = 1 is the rim (angle pi/2 from the -z axis)
    let alpha = FRAC_PI_2 * rho;
    [
        alpha.sin() * p[0] / rho,
        alpha.sin() * p[1] / rho,
        -alpha.cos(),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::CellKind;

    const PAPER_MESHES: [(usize, usize); 3] = [(3, 1), (7, 2), (11, 3)];

    #[test]
    fn hemisphere_has_positive_jacobian_at_all_gauss_points() {
        for (n, m) in PAPER_MESHES.into_iter().chain([(2, 1), (4, 2), (16, 2)]) {
            let mesh = hemisphere([0.0, 0.0, 2.0], 1.0, 1.0 / 3.0, n, m).unwrap();
            mesh.validate().unwrap();
            let g = CellKind::Hex8.gauss2_points();
            for c in 0..mesh.n_cells() {
                let x: Vec<f64> = mesh
                    .cell(c)
                    .iter()
                    .flat_map(|&a| mesh.node(a).to_vec())
                    .collect();
                let centre = CellKind::Hex8.jacobian_det(&x, &[0.0; 3]);
                for xi in g.chunks(3) {
                    let det = CellKind::Hex8.jacobian_det(&x, xi);
                    // also well away from zero: the degenerate corner cells stay above 1/3
                    assert!(
                        det > 0.25 * centre,
                        "n {n}, cell {c}: det {det} at {xi:?}, centre {centre}"
                    );
                }
            }
        }
    }

    #[test]
    fn hemisphere_corner_cells_are_degenerate_at_the_rim_corner_only() {
        let n = 3;
        let mesh = hemisphere([0.0, 0.0, 0.0], 1.0, 1.0 / 3.0, n, 1).unwrap();
        let x: Vec<f64> = mesh
            .cell(0)
            .iter()
            .flat_map(|&a| mesh.node(a).to_vec())
            .collect();
        let at_corner = CellKind::Hex8.jacobian_det(&x, &[-1.0, -1.0, -1.0]);
        let at_centre = CellKind::Hex8.jacobian_det(&x, &[0.0, 0.0, 0.0]);
        assert!(
            at_corner.abs() < 1e-12 * at_centre,
            "corner det {at_corner}"
        );
        // the angle between the two rim chords at the corner node is 180 - 360/(4n) degrees
        let c = mesh.node(mesh.cell(0)[0]);
        let a = mesh.node(mesh.cell(0)[1]);
        let b = mesh.node(mesh.cell(0)[3]);
        let u: Vec<f64> = (0..3).map(|k| a[k] - c[k]).collect();
        let v: Vec<f64> = (0..3).map(|k| b[k] - c[k]).collect();
        let dot: f64 = u.iter().zip(&v).map(|(p, q)| p * q).sum();
        let nu = u.iter().map(|p| p * p).sum::<f64>().sqrt();
        let nv = v.iter().map(|p| p * p).sum::<f64>().sqrt();
        let angle = (dot / (nu * nv)).acos().to_degrees();
        assert!(
            (angle - (180.0 - 360.0 / (4.0 * n as f64))).abs() < 1e-9,
            "angle {angle}"
        );
    }

    #[test]
    #[allow(non_snake_case)]
    fn hemisphere_shell_volume_converges() {
        let (R, h) = (1.0_f64, 1.0 / 3.0);
        let exact = 2.0 / 3.0 * PI * (R.powi(3) - (R - h).powi(3));
        let mut last = f64::INFINITY;
        for (n, m) in PAPER_MESHES.into_iter().chain([(21, 3), (41, 4)]) {
            let vol = hemisphere([0.0, 0.0, 0.0], R, h, n, m).unwrap().measure();
            let err = ((vol - exact) / exact).abs();
            assert!(err < 0.6 * last, "n {n}: relative error {err} vs {last}");
            last = err;
        }
        assert!(last < 5e-3, "finest relative error {last}");
    }

    #[test]
    #[allow(non_snake_case)]
    fn hemisphere_sets_lie_on_their_surfaces() {
        let (c, R, h, n, m) = ([0.5, -0.5, 2.0], 1.0, 1.0 / 3.0, 7, 2);
        let mesh = hemisphere(c, R, h, n, m).unwrap();
        let dist = |p: &[f64]| {
            ((p[0] - c[0]).powi(2) + (p[1] - c[1]).powi(2) + (p[2] - c[2]).powi(2)).sqrt()
        };
        assert_eq!(mesh.face_sets["outer"].len(), n * n);
        assert_eq!(mesh.face_sets["inner"].len(), n * n);
        for (set, r) in [("outer", R), ("inner", R - h)] {
            for n in mesh.node_set_from_faces(set).unwrap() {
                assert!((dist(mesh.node(n)) - r).abs() < 1e-12, "{set}");
                assert!(mesh.node(n)[2] <= c[2]);
            }
        }
        assert!(mesh.face_sets["outer"].iter().all(|&(_, f)| f == 0));
        // rim: 4n nodes around, m + 1 layers, all at z = cz
        assert_eq!(mesh.node_sets["rim"].len(), 4 * n * (m + 1));
        assert!(mesh.node_sets["rim"]
            .iter()
            .all(|&a| mesh.node(a)[2] == c[2]));
        let not_rim =
            (0..mesh.n_nodes() as u32).filter(|a| mesh.node_sets["rim"].binary_search(a).is_err());
        assert!(not_rim.into_iter().all(|a| mesh.node(a)[2] < c[2] - 1e-3));
        // outer faces ordered row-major: cell numbers increase along the set
        let cells: Vec<u32> = mesh.face_sets["outer"].iter().map(|f| f.0).collect();
        assert!(cells.windows(2).all(|w| w[1] == w[0] + 1));
        // rim faces run around the rim: polar angle of face centres increases (mod 2 pi)
        let angles: Vec<f64> = mesh.face_sets["rim"]
            .iter()
            .step_by(m)
            .map(|&(cell, f)| {
                let ns = mesh.face_nodes(cell as usize, f).unwrap();
                let x = ns.iter().map(|&a| mesh.node(a)[0] - c[0]).sum::<f64>();
                let y = ns.iter().map(|&a| mesh.node(a)[1] - c[1]).sum::<f64>();
                (y.atan2(x) + 0.75 * PI).rem_euclid(2.0 * PI)
            })
            .collect();
        assert_eq!(angles.len(), 4 * n);
        assert!(angles.windows(2).all(|w| w[1] > w[0]), "{angles:?}");
    }
}
