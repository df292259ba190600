//! Rigid contact partners: a plane (a line in 2D), a circle/sphere and a cylinder (3D), each moved
//! rigidly per load stage. A rigid partner answers the same question as a deformable surface: for a
//! point `x`, the gap `g = x - x_p` to its closest point, the partner's outward unit normal `n` there,
//! and their derivatives with respect to `x` (the partner itself has no unknowns).

use crate::assembly::dirichlet::{rotate, stage_lerp};

/// A rigid shape in its reference position. Normals point out of the rigid body, towards the
/// deformable one.
#[derive(Debug, Clone, PartialEq)]
pub enum RigidShape {
    /// Plane through `point` with unit `normal` [3] (2D: a line, third components zero).
    Plane { point: [f64; 3], normal: [f64; 3] },
    /// Circle (2D) or sphere (3D) of `radius` around `center`. `inside`: the deformable body is inside
    /// the cavity (normal towards the centre); otherwise outside the ball (normal away from it).
    Sphere {
        center: [f64; 3],
        radius: f64,
        inside: bool,
    },
    /// Cylinder (3D) of `radius` about the line through `center` along unit `axis`.
    Cylinder {
        center: [f64; 3],
        axis: [f64; 3],
        radius: f64,
        inside: bool,
    },
}

/// A rigid motion per load stage: at the end of stage `s` the shape is rotated by `angles[s]` (radians)
/// about `axis` through `center` (its reference position), then translated by `translations[s]`;
/// linear in each stage, as prescribed displacements are.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct RigidMotion {
    /// [n_stages][3] (empty: no translation).
    pub translations: Vec<[f64; 3]>,
    /// [n_stages] (empty: no rotation).
    pub angles: Vec<f64>,
    /// Unit rotation axis ([0,0,1] in 2D).
    pub axis: [f64; 3],
    /// Centre of rotation in the reference configuration.
    pub center: [f64; 3],
}

/// Closest point data of a point against a rigid partner.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RigidProjection {
    /// Gap `g = x - x_p` [3].
    pub g: [f64; 3],
    /// Outward unit normal of the partner at `x_p` [3].
    pub n: [f64; 3],
    /// `d g_i / d x_j` [3][3] row-major.
    pub dg_dx: [f64; 9],
    /// `d n_i / d x_j` [3][3] row-major.
    pub dn_dx: [f64; 9],
}

fn sub(a: &[f64; 3], b: &[f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn dot(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

impl RigidMotion {
    fn at(&self, lambda: f64) -> (f64, [f64; 3]) {
        let theta = stage_lerp(&self.angles, lambda, 0.0, |a, b, f| a + (b - a) * f);
        let shift = stage_lerp(&self.translations, lambda, [0.0; 3], |a, b, f| {
            [0, 1, 2].map(|i| a[i] + (b[i] - a[i]) * f)
        });
        (theta, shift)
    }

    /// Current position at load `lambda` of the rigid body's material point `p` (reference
    /// position).
    pub fn apply(&self, p: &[f64; 3], lambda: f64) -> [f64; 3] {
        let (theta, shift) = self.at(lambda);
        let r = rotate(sub(p, &self.center), self.axis, theta);
        [0, 1, 2].map(|i| self.center[i] + r[i] + shift[i])
    }

    /// Reference position of the rigid body's material point that is at `x` at load `lambda`
    /// (the inverse of [`RigidMotion::apply`]).
    pub fn inverse(&self, x: &[f64; 3], lambda: f64) -> [f64; 3] {
        let (theta, shift) = self.at(lambda);
        let d = [0, 1, 2].map(|i| x[i] - shift[i] - self.center[i]);
        let r = rotate(d, self.axis, -theta);
        [0, 1, 2].map(|i| self.center[i] + r[i])
    }
}

impl RigidShape {
    /// The shape moved by `motion` at load `lambda`.
    pub fn at(&self, motion: &RigidMotion, lambda: f64) -> RigidShape {
        let theta = stage_lerp(&motion.angles, lambda, 0.0, |a, b, f| a + (b - a) * f);
        let shift = stage_lerp(&motion.translations, lambda, [0.0; 3], |a, b, f| {
            [0, 1, 2].map(|i| a[i] + (b[i] - a[i]) * f)
        });
        let point = |p: &[f64; 3]| {
            let r = rotate(sub(p, &motion.center), motion.axis, theta);
            [0, 1, 2].map(|i| motion.center[i] + r[i] + shift[i])
        };
        let dir = |d: &[f64; 3]| rotate(*d, motion.axis, theta);
        match self {
            RigidShape::Plane { point: p, normal } => RigidShape::Plane {
                point: point(p),
                normal: dir(normal),
            },
            RigidShape::Sphere {
                center,
                radius,
                inside,
            } => RigidShape::Sphere {
                center: point(center),
                radius: *radius,
                inside: *inside,
            },
            RigidShape::Cylinder {
                center,
                axis,
                radius,
                inside,
            } => RigidShape::Cylinder {
                center: point(center),
                axis: dir(axis),
                radius: *radius,
                inside: *inside,
            },
        }
    }

    /// Closest point of `x` [3] on the shape, with derivatives. `None` where the closest point is
    /// not unique (a point on the axis of a sphere or cylinder).
    pub fn project(&self, x: &[f64; 3]) -> Option<RigidProjection> {
        match self {
            RigidShape::Plane { point, normal: n } => {
                let g_n = dot(&sub(x, point), n);
                let mut p = RigidProjection {
                    g: n.map(|c| g_n * c),
                    n: *n,
                    dg_dx: [0.0; 9],
                    dn_dx: [0.0; 9],
                };
                for i in 0..3 {
                    for j in 0..3 {
                        p.dg_dx[3 * i + j] = n[i] * n[j];
                    }
                }
                Some(p)
            }
            RigidShape::Sphere {
                center,
                radius,
                inside,
            } => Some(radial(sub(x, center), &[0.0; 9], *radius, *inside)?),
            RigidShape::Cylinder {
                center,
                axis: e,
                radius,
                inside,
            } => {
                let d = sub(x, center);
                let de = dot(&d, e);
                let r = [0, 1, 2].map(|i| d[i] - de * e[i]);
                let mut ee = [0.0; 9];
                for i in 0..3 {
                    for j in 0..3 {
                        ee[3 * i + j] = e[i] * e[j];
                    }
                }
                radial(r, &ee, *radius, *inside)
            }
        }
    }
}

/// Sphere/cylinder: `r` is the radial vector from the centre (axis), `ee` the projector on the axis
/// that `r` does not depend on (`dr/dx = I - ee`).
fn radial(r: [f64; 3], ee: &[f64; 9], radius: f64, inside: bool) -> Option<RigidProjection> {
    let rho = dot(&r, &r).sqrt();
    if rho <= 1e-14 * radius.max(1.0) {
        return None;
    }
    let rh = r.map(|c| c / rho);
    let s = if inside { -1.0 } else { 1.0 };
    // g = (rho - R) rh ; n = s rh
    let mut p = RigidProjection {
        g: rh.map(|c| (rho - radius) * c),
        n: rh.map(|c| s * c),
        dg_dx: [0.0; 9],
        dn_dx: [0.0; 9],
    };
    for i in 0..3 {
        for j in 0..3 {
            let id = if i == j { 1.0 } else { 0.0 };
            // d rh / dx = (I - rh rh - ee) / rho
            let drh = (id - rh[i] * rh[j] - ee[3 * i + j]) / rho;
            p.dg_dx[3 * i + j] = rh[i] * rh[j] + (rho - radius) * drh;
            p.dn_dx[3 * i + j] = s * drh;
        }
    }
    Some(p)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fd_check(shape: &RigidShape, x: [f64; 3], dim: usize) {
        let p = shape.project(&x).unwrap();
        let h = 1e-6;
        for j in 0..dim {
            let (mut xp, mut xm) = (x, x);
            xp[j] += h;
            xm[j] -= h;
            let (a, b) = (shape.project(&xp).unwrap(), shape.project(&xm).unwrap());
            for i in 0..dim {
                let fg = (a.g[i] - b.g[i]) / (2.0 * h);
                let fnn = (a.n[i] - b.n[i]) / (2.0 * h);
                assert!((fg - p.dg_dx[3 * i + j]).abs() < 1e-7, "dg {i}{j}");
                assert!((fnn - p.dn_dx[3 * i + j]).abs() < 1e-7, "dn {i}{j}");
            }
        }
    }

    #[test]
    fn rigid_motion_inverse_returns_the_material_point() {
        let m = RigidMotion {
            translations: vec![[0.1, -0.2, 0.3], [0.4, 0.0, -0.1]],
            angles: vec![0.3, 1.2],
            axis: [0.0, 0.6, 0.8],
            center: [0.5, -0.5, 1.0],
        };
        let p = [0.3, 0.7, -0.2];
        for lambda in [0.0, 0.4, 1.0, 1.7] {
            let x = m.apply(&p, lambda);
            let back = m.inverse(&x, lambda);
            assert!((0..3).all(|i| (back[i] - p[i]).abs() < 1e-14), "{back:?}");
        }
        // the moved shape carries its material points along
        let plane = RigidShape::Plane {
            point: p,
            normal: [0.0, 0.0, 1.0],
        };
        let RigidShape::Plane { point, .. } = plane.at(&m, 1.7) else {
            unreachable!()
        };
        let x = m.apply(&p, 1.7);
        assert!((0..3).all(|i| (x[i] - point[i]).abs() < 1e-14));
    }

    #[test]
    fn rigid_shape_derivatives_match_central_differences() {
        let s = 1.0 / 3f64.sqrt();
        let shapes = [
            RigidShape::Plane {
                point: [0.1, 0.2, 0.3],
                normal: [s, s, s],
            },
            RigidShape::Sphere {
                center: [0.0, 1.0, 0.5],
                radius: 0.7,
                inside: false,
            },
            RigidShape::Sphere {
                center: [0.0, 1.0, 0.5],
                radius: 2.0,
                inside: true,
            },
            RigidShape::Cylinder {
                center: [0.0, 0.0, 0.0],
                axis: [0.0, s * 3f64.sqrt() * 0.6, 0.8],
                radius: 0.5,
                inside: false,
            },
        ];
        for sh in &shapes {
            fd_check(sh, [0.3, -0.4, 0.2], 3);
        }
        // 2D circle
        fd_check(
            &RigidShape::Sphere {
                center: [0.0, 0.0, 0.0],
                radius: 1.0,
                inside: false,
            },
            [0.4, 1.1, 0.0],
            2,
        );
    }

    #[test]
    fn sphere_gap_is_distance_to_surface_with_sign() {
        let out = RigidShape::Sphere {
            center: [0.0; 3],
            radius: 1.0,
            inside: false,
        };
        let p = out.project(&[0.0, 0.0, 0.9]).unwrap();
        assert!(
            (dot(&p.g, &p.n) + 0.1).abs() < 1e-14,
            "penetrating: g_n = -0.1"
        );
        let cav = RigidShape::Sphere {
            center: [0.0; 3],
            radius: 1.0,
            inside: true,
        };
        let p = cav.project(&[0.0, 0.0, 0.9]).unwrap();
        assert!(
            (dot(&p.g, &p.n) - 0.1).abs() < 1e-14,
            "inside the cavity: g_n = +0.1"
        );
        assert!(out.project(&[0.0; 3]).is_none());
    }

    #[test]
    fn rigid_motion_moves_and_turns_the_shape() {
        let plane = RigidShape::Plane {
            point: [1.0, 0.0, 0.0],
            normal: [0.0, 1.0, 0.0],
        };
        let m = RigidMotion {
            translations: vec![[0.0, -0.5, 0.0], [1.0, -0.5, 0.0]],
            angles: vec![0.0, std::f64::consts::FRAC_PI_2],
            axis: [0.0, 0.0, 1.0],
            center: [0.0; 3],
        };
        match plane.at(&m, 0.5) {
            RigidShape::Plane { point, normal } => {
                assert!((point[1] + 0.25).abs() < 1e-14 && (normal[1] - 1.0).abs() < 1e-14)
            }
            _ => unreachable!(),
        }
        match plane.at(&m, 2.0) {
            RigidShape::Plane { point, normal } => {
                // rotated 90 degrees about z through the origin, then shifted by (1, -0.5)
                assert!((point[0] - 1.0).abs() < 1e-12 && (point[1] - 0.5).abs() < 1e-12);
                assert!((normal[0] + 1.0).abs() < 1e-12);
            }
            _ => unreachable!(),
        }
    }
}
