//! Exact conic geometry and flat segments as NURBS (Piegl & Tiller A7.1), the hollow hemisphere of
//! section 4.4 of Corbett & Sauer 2014, and a builder for refined curves of an element family (p, t).
//!
//! Hemisphere parametrisation (our design, the paper gives none): the lower half circle in the
//! x-z plane, `(r cos th, 0, r sin th)` for `th` in [pi, 2 pi] (parameter u, two 90 degree Bezier
//! segments), is rotated about the x axis by `phi` in [-pi/2, pi/2] (parameter v, two segments):
//! `S(u,v) = c + (x(u), -z(u) sin phi(v), z(u) cos phi(v))`. This is exact (the rotation is linear
//! in the homogeneous control points). The rim ring (z = c_z) is the whole patch boundary: the edges
//! v = 0, 1 are the two rim half circles and the edges u = 0, 1 collapse to the rim points
//! `c -/+ (r,0,0)`, so the elements along u = 0 and u = 1 are triangles whose degenerate edge lies
//! on the Dirichlet ring (2 n_el such elements, not the paper's four). The lowest point `c - (0,0,r)`
//! is at (u,v) = (1/2,1/2), a knot line in both directions. `S_u x S_v` points towards the centre,
//! i.e. into the shell for the outer surface, so a Q1Np element with xi = u, eta = v and zeta running
//! from the outer into the inner surface has a positive Jacobian. Element counts per direction must
//! be even (2 base segments); the paper's 3, 7, 11 are not reachable with equal elements and an
//! exact quadratic base (see `circular_arc_segments` for other base segment counts).
#![allow(clippy::needless_range_loop)] // index loops mirror the equations
use crate::geometry::knots::KnotVector;
use crate::geometry::nurbs::{NurbsCurve, NurbsSurface};
use crate::geometry::GeometryError;
use std::f64::consts::PI;

/// Exact circular arc of radius `r` about `center` from angle `th_s` to `th_e` (radians,
/// counter-clockwise, `0 < th_e - th_s <= 2 pi`) in 2D, with `n_seg` quadratic rational Bezier
/// segments (each below 180 degrees), parameter domain [0,1], interior knots doubled.
pub fn circular_arc_segments(
    center: [f64; 2],
    r: f64,
    th_s: f64,
    th_e: f64,
    n_seg: usize,
) -> Result<NurbsCurve, GeometryError> {
    if !(r.is_finite() && r > 0.0) {
        return Err(GeometryError::BadParameter {
            name: "radius",
            value: r,
            reason: "must be positive and finite",
        });
    }
    let sweep = th_e - th_s;
    if !(sweep > 0.0 && sweep <= 2.0 * PI * (1.0 + 1e-15)) {
        return Err(GeometryError::BadParameter {
            name: "sweep angle",
            value: sweep,
            reason: "must be in (0, 2 pi]",
        });
    }
    if n_seg == 0 || sweep / n_seg as f64 >= PI * (1.0 - 1e-9) {
        return Err(GeometryError::BadParameter {
            name: "n_seg",
            value: n_seg as f64,
            reason: "each segment must span less than 180 degrees",
        });
    }
    let dth = sweep / n_seg as f64;
    let w1 = (0.5 * dth).cos();
    let mut ctrl = Vec::with_capacity(2 * (2 * n_seg + 1));
    let mut weights = Vec::with_capacity(2 * n_seg + 1);
    let on_circle = |th: f64, rr: f64| [center[0] + rr * th.cos(), center[1] + rr * th.sin()];
    ctrl.extend(on_circle(th_s, r));
    weights.push(1.0);
    let mut knots = vec![0.0; 3];
    for i in 0..n_seg {
        let a = th_s + dth * i as f64;
        // middle control point: intersection of the end tangents, at distance r / cos(dth/2)
        ctrl.extend(on_circle(a + 0.5 * dth, r / w1));
        weights.push(w1);
        ctrl.extend(on_circle(a + dth, r));
        weights.push(1.0);
        if i + 1 < n_seg {
            let u = (i + 1) as f64 / n_seg as f64;
            knots.extend([u, u]);
        }
    }
    knots.extend([1.0; 3]);
    NurbsCurve::new(KnotVector::new(2, knots)?, 2, ctrl, weights)
}

/// Exact circular arc with the fewest segments of at most 90 degrees (P&T A7.1).
pub fn circular_arc(
    center: [f64; 2],
    r: f64,
    th_s: f64,
    th_e: f64,
) -> Result<NurbsCurve, GeometryError> {
    let n_seg = ((th_e - th_s) / (0.5 * PI) - 1e-12).ceil().max(1.0) as usize;
    circular_arc_segments(center, r, th_s, th_e, n_seg)
}

/// Lower half circle of radius `r` about `center`, from `(c_x - r, c_y)` through the lowest point
/// to `(c_x + r, c_y)` (two 90 degree segments), e.g. the ironing half cylinder.
pub fn lower_half_circle(center: [f64; 2], r: f64) -> Result<NurbsCurve, GeometryError> {
    circular_arc(center, r, PI, 2.0 * PI)
}

/// Straight segment from `a` to `b` (2D or 3D) as a linear NURBS curve with unit weights.
pub fn line_segment(a: &[f64], b: &[f64]) -> Result<NurbsCurve, GeometryError> {
    if a.len() != b.len() {
        return Err(GeometryError::LengthMismatch {
            what: "segment end point",
            expected: a.len(),
            found: b.len(),
        });
    }
    let ctrl = a.iter().chain(b).copied().collect();
    NurbsCurve::new(
        KnotVector::new(1, vec![0., 0., 1., 1.])?,
        a.len(),
        ctrl,
        vec![1.0, 1.0],
    )
}

/// Flat parallelogram `origin + u e1 + v e2`, (u,v) in [0,1]^2, as a bilinear NURBS surface.
pub fn plane_patch(
    origin: [f64; 3],
    e1: [f64; 3],
    e2: [f64; 3],
) -> Result<NurbsSurface, GeometryError> {
    let kv = KnotVector::new(1, vec![0., 0., 1., 1.])?;
    let mut ctrl = Vec::with_capacity(12);
    for j in 0..2 {
        for i in 0..2 {
            for c in 0..3 {
                ctrl.push(origin[c] + i as f64 * e1[c] + j as f64 * e2[c]);
            }
        }
    }
    NurbsSurface::new(kv.clone(), kv, ctrl, vec![1.0; 4])
}

/// Lower hemisphere of radius `r` about `center` as one biquadratic patch of 2x2 Bezier elements
/// (parametrisation in the module docs).
pub fn hemisphere_surface(center: [f64; 3], r: f64) -> Result<NurbsSurface, GeometryError> {
    let profile = lower_half_circle([0.0, 0.0], r)?; // (x, z) in u
    let rot = circular_arc([0.0, 0.0], 1.0, -0.5 * PI, 0.5 * PI)?; // (cos phi, sin phi) in v
    let (nu, nv) = (profile.n_ctrl(), rot.n_ctrl());
    let mut ctrl = Vec::with_capacity(3 * nu * nv);
    let mut weights = Vec::with_capacity(nu * nv);
    for j in 0..nv {
        let (c, s) = (rot.ctrl[2 * j], rot.ctrl[2 * j + 1]);
        for i in 0..nu {
            let (x, z) = (profile.ctrl[2 * i], profile.ctrl[2 * i + 1]);
            ctrl.extend([center[0] + x, center[1] - z * s, center[2] + z * c]);
            weights.push(rot.weights[j] * profile.weights[i]);
        }
    }
    NurbsSurface::new(profile.knots.clone(), rot.knots.clone(), ctrl, weights)
}

/// Outer (radius `r_outer`) and inner (radius `r_outer - thickness`) surfaces of the hollow
/// hemisphere of section 4.4, sharing one parametrisation so a shell mesh can join them radially.
pub fn hollow_hemisphere(
    center: [f64; 3],
    r_outer: f64,
    thickness: f64,
) -> Result<(NurbsSurface, NurbsSurface), GeometryError> {
    if !(thickness > 0.0 && thickness < r_outer) {
        return Err(GeometryError::BadParameter {
            name: "thickness",
            value: thickness,
            reason: "must lie in (0, r_outer)",
        });
    }
    Ok((
        hemisphere_surface(center, r_outer)?,
        hemisphere_surface(center, r_outer - thickness)?,
    ))
}

/// Refined curve of family Q1Np.t with `n_el` elements: k-refine the exact base geometry (p=2 for
/// arcs, p=1 for lines) to order `p`, then elevate `t` times (section 3.3). `n_el` must be a multiple
/// of the base's element count (2 for a half circle, 1 for a line).
pub fn refined_curve(
    base: &NurbsCurve,
    p: usize,
    t: usize,
    n_el: usize,
) -> Result<NurbsCurve, GeometryError> {
    base.refine_q1np_t(p, t, n_el)
}

#[cfg(test)]
#[allow(non_snake_case)]
mod tests {
    use super::*;
    use crate::fem::quadrature::gauss_legendre;

    fn max_radius_error(c: &NurbsCurve, center: [f64; 2], r: f64, n: usize) -> f64 {
        (0..n)
            .map(|s| {
                let x = c.point(s as f64 / (n - 1) as f64);
                ((x[0] - center[0]).hypot(x[1] - center[1]) - r).abs()
            })
            .fold(0.0, f64::max)
    }

    #[test]
    fn circle_is_exact() {
        let (c0, r) = ([0.3, -1.2], 2.5);
        for (a, b) in [
            (0.0, 2.0 * PI),
            (0.1, 0.1 + 0.5),
            (PI, 2.0 * PI),
            (-1.0, 3.5),
        ] {
            let c = circular_arc(c0, r, a, b).unwrap();
            assert!(max_radius_error(&c, c0, r, 1000) < 1e-13 * r);
            let end = c.point(1.0);
            assert!((end[0] - (c0[0] + r * b.cos())).abs() < 1e-14 * r);
        }
        for n_seg in [3, 7, 11] {
            let c = circular_arc_segments(c0, r, PI, 2.0 * PI, n_seg).unwrap();
            assert!(max_radius_error(&c, c0, r, 1000) < 1e-13 * r);
        }
    }

    #[test]
    fn refined_half_circle_is_exact() {
        let (c0, r) = ([1.0, 4.0], 1.5);
        let half = lower_half_circle(c0, r).unwrap();
        for (p, t) in [
            (2, 0),
            (3, 0),
            (4, 0),
            (2, 1),
            (2, 2),
            (2, 3),
            (3, 1),
            (3, 2),
            (3, 3),
        ] {
            let c = refined_curve(&half, p, t, 8).unwrap();
            assert_eq!(c.degree(), p + t);
            assert!(max_radius_error(&c, c0, r, 1000) < 1e-13, "p={p} t={t}");
            assert!(c.point(0.5)[1] - (c0[1] - r) < 1e-13);
        }
    }

    /// Perimeter and area (Green's theorem, closing along the diameter) by Gauss quadrature per element.
    fn perimeter_and_area(c: &NurbsCurve, n_gp: usize) -> (f64, f64) {
        let (x, w) = gauss_legendre(n_gp).unwrap();
        let (mut len, mut area) = (0.0, 0.0);
        let U = c.knots.unique_with_multiplicity();
        for e in U.windows(2) {
            let (a, b) = (e[0].0, e[1].0);
            for (xi, wi) in x.iter().zip(&w) {
                let u = 0.5 * (a + b) + 0.5 * (b - a) * xi;
                let (pt, d) = c.eval(u);
                let jac = 0.5 * (b - a);
                len += wi * jac * d[0].hypot(d[1]);
                area += wi * jac * 0.5 * (pt[0] * d[1] - pt[1] * d[0]);
            }
        }
        // the closing diameter runs from the end back to the start: straight line, add its term
        let (s, e) = (c.point(0.0), c.point(1.0));
        area += 0.5 * (e[0] * s[1] - e[1] * s[0]);
        (len, area)
    }

    #[test]
    fn half_disk_perimeter_and_area_match_pi_r() {
        let (c0, r) = ([0.7, -0.2], 1.3);
        for (p, t, n_el) in [(2, 0, 2), (2, 0, 8), (3, 1, 6), (2, 3, 4)] {
            let c = refined_curve(&lower_half_circle(c0, r).unwrap(), p, t, n_el).unwrap();
            // arc length integrand is not polynomial: converge with many points
            let (len, area) = perimeter_and_area(&c, 30);
            assert!(
                (len - PI * r).abs() < 1e-11,
                "p={p} t={t} len err {}",
                len - PI * r
            );
            // counter-clockwise lower half + diameter back: positive area
            assert!(
                (area - 0.5 * PI * r * r).abs() < 1e-12,
                "area err {}",
                area - 0.5 * PI * r * r
            );
        }
    }

    #[test]
    fn hemisphere_is_exact_with_inward_normal_and_rim_boundary() {
        let (c, r) = ([0.1, -0.4, 2.0], 1.0);
        let (outer, inner) = hollow_hemisphere(c, r, 1.0 / 3.0).unwrap();
        for (s, rr) in [(&outer, r), (&inner, r - 1.0 / 3.0)] {
            for a in 0..=30 {
                for b in 0..=30 {
                    let (u, v) = (a as f64 / 30.0, b as f64 / 30.0);
                    let x = s.point(u, v);
                    let d = [x[0] - c[0], x[1] - c[1], x[2] - c[2]];
                    let rad = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                    assert!((rad - rr).abs() < 1e-13);
                    assert!(d[2] <= 1e-14);
                    if let Some(n) = s.normal(u, v) {
                        let dot = (n[0] * d[0] + n[1] * d[1] + n[2] * d[2]) / rr;
                        assert!(dot < -1.0 + 1e-10, "u={u} v={v} dot={dot}");
                    }
                    if a == 0 || a == 30 || b == 0 || b == 30 {
                        assert!(d[2].abs() < 1e-14, "boundary point not on rim");
                    }
                }
            }
            let low = s.point(0.5, 0.5);
            assert!((low[2] - (c[2] - rr)).abs() < 1e-14);
        }
        let refined = outer.refine_q1np_t(2, 1, 4).unwrap();
        for a in 0..=20 {
            let (u, v) = (a as f64 / 20.0, (a as f64 * 0.37).fract());
            let (x, y) = (outer.point(u, v), refined.point(u, v));
            assert!((0..3).all(|k| (x[k] - y[k]).abs() < 1e-12));
        }
        assert!(matches!(
            hollow_hemisphere(c, r, 2.0),
            Err(GeometryError::BadParameter {
                name: "thickness",
                ..
            })
        ));
    }
}
