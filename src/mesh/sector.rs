//! Annular sector of Quad4 cells.
use super::{CellKind, Mesh, MeshError};

/// Annular sector around `center` between radii `r_inner` > 0 and `r_outer` and polar angles
/// `theta0 < theta1` (radians, `theta1 - theta0 < 2 pi`), with `n_theta` cells uniform in angle
/// and `n_r` cells uniform in radius.
///
/// Every cell has local face 0 (eta = -1) on its outer arc side, eta pointing inwards, so the
/// outer arc (the natural contact surface) is local face 0 of the outer ring of cells; the inner
/// arc is local face 2.
///
/// Named node and face sets:
/// - `outer`, `inner`: faces ordered by increasing angle;
/// - `start` (theta = theta0, local face 3), `end` (theta = theta1, local face 1): faces ordered
///   from the outer to the inner radius.
pub fn sector(
    center: [f64; 2],
    r_inner: f64,
    r_outer: f64,
    theta: [f64; 2],
    n_theta: usize,
    n_r: usize,
) -> Result<Mesh, MeshError> {
    let bad = |name, value: f64, reason| MeshError::InvalidParameter {
        name,
        value: value.to_string(),
        reason,
    };
    if !(r_inner > 0.0 && r_inner.is_finite()) {
        return Err(bad("r_inner", r_inner, "must be positive and finite"));
    }
    if !(r_outer > r_inner && r_outer.is_finite()) {
        return Err(bad(
            "r_outer",
            r_outer,
            "must be finite and larger than r_inner",
        ));
    }
    let span = theta[1] - theta[0];
    if !(span > 0.0 && span < 2.0 * std::f64::consts::PI) {
        return Err(bad("theta1 - theta0", span, "must lie in (0, 2 pi)"));
    }
    if n_theta == 0 {
        return Err(bad("n_theta", 0.0, "need at least one cell"));
    }
    if n_r == 0 {
        return Err(bad("n_r", 0.0, "need at least one cell"));
    }
    let mut mesh = Mesh::new(2);
    // node (k, j): k along the angle, j from the outer (j = 0) to the inner radius
    for k in 0..=n_theta {
        let t = theta[0] + span * k as f64 / n_theta as f64;
        for j in 0..=n_r {
            let r = r_outer + (r_inner - r_outer) * j as f64 / n_r as f64;
            mesh.push_node(&[center[0] + r * t.cos(), center[1] + r * t.sin()]);
        }
    }
    let node = |k: usize, j: usize| (k * (n_r + 1) + j) as u32;
    for k in 0..n_theta {
        for j in 0..n_r {
            mesh.push_cell(
                CellKind::Quad4,
                &[
                    node(k, j),
                    node(k + 1, j),
                    node(k + 1, j + 1),
                    node(k, j + 1),
                ],
            );
        }
    }
    let cell = |k: usize, j: usize| (k * n_r + j) as u32;
    mesh.face_sets.insert(
        "outer".into(),
        (0..n_theta).map(|k| (cell(k, 0), 0)).collect(),
    );
    mesh.face_sets.insert(
        "inner".into(),
        (0..n_theta).map(|k| (cell(k, n_r - 1), 2)).collect(),
    );
    mesh.face_sets
        .insert("start".into(), (0..n_r).map(|j| (cell(0, j), 3)).collect());
    mesh.face_sets.insert(
        "end".into(),
        (0..n_r).map(|j| (cell(n_theta - 1, j), 1)).collect(),
    );
    mesh.insert_node_set("outer", (0..=n_theta).map(|k| node(k, 0)).collect());
    mesh.insert_node_set("inner", (0..=n_theta).map(|k| node(k, n_r)).collect());
    mesh.insert_node_set("start", (0..=n_r).map(|j| node(0, j)).collect());
    mesh.insert_node_set("end", (0..=n_r).map(|j| node(n_theta, j)).collect());
    Ok(mesh)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn sector_is_valid_and_area_converges() {
        let (ri, ro) = (0.5, 1.5);
        let exact = 0.5 * (ro * ro - ri * ri) * (PI / 2.0);
        let mut last_err = f64::INFINITY;
        for n in [2, 4, 8, 16] {
            let m = sector([1.0, 2.0], ri, ro, [PI / 4.0, 3.0 * PI / 4.0], n, 2).unwrap();
            m.validate().unwrap();
            let err = (m.measure() - exact).abs();
            assert!(err < last_err * 0.3, "n = {n}: error {err} vs {last_err}");
            last_err = err;
        }
    }

    #[test]
    fn sector_sets_lie_on_their_arcs_and_are_ordered() {
        let m = sector([1.0, 2.0], 0.5, 1.5, [0.0, PI], 6, 3).unwrap();
        for (set, r) in [("outer", 1.5), ("inner", 0.5)] {
            let mut last = -1.0;
            for &(c, f) in &m.face_sets[set] {
                let nodes = m.face_nodes(c as usize, f).unwrap();
                let mut ang = 0.0;
                for &n in &nodes {
                    let p = m.node(n);
                    let (dx, dy) = (p[0] - 1.0, p[1] - 2.0);
                    assert!(((dx * dx + dy * dy).sqrt() - r).abs() < 1e-12);
                    ang += dy.atan2(dx) / 2.0;
                }
                assert!(ang > last);
                last = ang;
            }
            assert_eq!(m.node_sets[set].len(), 7);
        }
        assert!(m.face_sets["outer"].iter().all(|&(_, f)| f == 0));
        assert_eq!(m.node_sets["start"].len(), 4);
        for &n in &m.node_sets["end"] {
            assert!((m.node(n)[1] - 2.0).abs() < 1e-12 && m.node(n)[0] < 1.0);
        }
    }

    #[test]
    fn sector_rejects_zero_inner_radius() {
        assert!(matches!(
            sector([0.0, 0.0], 0.0, 1.0, [0.0, 1.0], 2, 2),
            Err(MeshError::InvalidParameter {
                name: "r_inner",
                ..
            })
        ));
    }
}
