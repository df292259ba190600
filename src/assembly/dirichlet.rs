//! Dirichlet conditions: fixed components, prescribed displacements per load stage, and prescribed
//! rigid rotations of a node set about an axis. Values are functions of the load parameter
//! `lambda` in `[0, n_stages]`: stage `s` runs from `lambda = s` to `s + 1`, linear inside a stage.

use super::dofmap::{DofMap, GlobalDof};
use std::collections::HashMap;

/// What a condition prescribes.
#[derive(Debug, Clone)]
pub enum Prescription {
    /// Zero displacement of the listed components.
    Fixed,
    /// Displacement of the listed components at the end of each stage. [n_stages][n_components]
    Displacement(Vec<Vec<f64>>),
    /// Rigid rotation of the set about `axis` (unit, 3D; ignored in 2D) through `center`, by the
    /// angle (radians) reached at the end of each stage. All components are prescribed.
    Rotation {
        /// Unit axis (3D).
        axis: [f64; 3],
        /// A point on the axis.
        center: [f64; 3],
        /// Angle at each stage end. [n_stages]
        angles: Vec<f64>,
        /// Translation at each stage end, `x = center + t + R (X - center)`. [n_stages][3];
        /// empty: none.
        translations: Vec<[f64; 3]>,
    },
}

/// One Dirichlet condition on a node set.
#[derive(Debug, Clone)]
pub struct DirichletBc {
    /// Where it comes from, for messages, e.g. `bcs[2] (block/zmin)`.
    pub label: String,
    /// Global node ids.
    pub nodes: Vec<u32>,
    /// Prescribed components (all of them for rotations).
    pub components: Vec<usize>,
    /// What is prescribed.
    pub kind: Prescription,
}

/// Two conditions prescribe different values to the same unknown.
#[derive(Debug, Clone, thiserror::Error)]
#[error("{}", self.describe(&|n| format!("node {n}")))]
pub struct ConflictError {
    /// Global node id.
    pub node: u32,
    /// Component.
    pub component: usize,
    /// First condition and its value.
    pub label_a: String,
    /// First value.
    pub a: f64,
    /// Second condition.
    pub label_b: String,
    /// Second value.
    pub b: f64,
    /// Load parameter where they differ.
    pub lambda: f64,
}

impl ConflictError {
    /// The message, with the node named by `name` (e.g. the model's node label, which knows its
    /// mesh tag).
    pub fn describe(&self, name: &dyn Fn(u32) -> String) -> String {
        format!(
            "inconsistent boundary conditions: {}, component {}, is prescribed {} by {} and {} by {} at load {}",
            name(self.node),
            self.component,
            self.a,
            self.label_a,
            self.b,
            self.label_b,
            self.lambda
        )
    }
}

/// Linear interpolation of per-stage end values at `lambda`; the value before stage 0 is `zero`.
pub(crate) fn stage_lerp<T: Copy>(
    ends: &[T],
    lambda: f64,
    zero: T,
    lerp: impl Fn(T, T, f64) -> T,
) -> T {
    if ends.is_empty() {
        return zero;
    }
    let n = ends.len();
    let s = (lambda.floor().max(0.0) as usize).min(n - 1);
    let f = (lambda - s as f64).clamp(0.0, 1.0);
    let start = if s == 0 { zero } else { ends[s - 1] };
    lerp(start, ends[s], f)
}

/// Rotation of `v` by `theta` about unit `axis` (Rodrigues).
pub(crate) fn rotate(v: [f64; 3], axis: [f64; 3], theta: f64) -> [f64; 3] {
    let (s, c) = theta.sin_cos();
    let k = axis;
    let kxv = [
        k[1] * v[2] - k[2] * v[1],
        k[2] * v[0] - k[0] * v[2],
        k[0] * v[1] - k[1] * v[0],
    ];
    let kv = k[0] * v[0] + k[1] * v[1] + k[2] * v[2];
    [0, 1, 2].map(|i| v[i] * c + kxv[i] * s + k[i] * kv * (1.0 - c))
}

impl DirichletBc {
    /// The prescribed displacement of component `comp` of a node at reference position `x` [dim].
    pub fn value(&self, comp_index: usize, x: &[f64], lambda: f64) -> f64 {
        match &self.kind {
            Prescription::Fixed => 0.0,
            Prescription::Displacement(ends) => {
                let vals: Vec<f64> = ends.iter().map(|v| v[comp_index]).collect();
                stage_lerp(&vals, lambda, 0.0, |a, b, f| a + (b - a) * f)
            }
            Prescription::Rotation {
                axis,
                center,
                angles,
                translations,
            } => {
                let theta = stage_lerp(angles, lambda, 0.0, |a, b, f| a + (b - a) * f);
                let dim = x.len();
                let mut r = [0.0; 3];
                for i in 0..dim {
                    r[i] = x[i] - center[i];
                }
                // In 2D the rotation is in-plane, about z.
                let ax = if dim == 2 { [0.0, 0.0, 1.0] } else { *axis };
                let rr = rotate(r, ax, theta);
                let comp = self.components[comp_index];
                let t = stage_lerp(translations, lambda, [0.0; 3], |a, b, f| {
                    [0, 1, 2].map(|i| a[i] + (b[i] - a[i]) * f)
                });
                rr[comp] - r[comp] + t[comp]
            }
        }
    }
}

/// All prescribed (unknown, value) pairs at `lambda`, checked for conflicts. `coords` is the reference
/// position of every global node, [n_nodes][dim].
pub fn prescribed_values(
    bcs: &[DirichletBc],
    dofs: &DofMap,
    coords: &[f64],
    lambda: f64,
) -> Result<Vec<(GlobalDof, f64)>, ConflictError> {
    let dim = dofs.dim;
    let mut by_dof: HashMap<GlobalDof, (f64, usize, u32)> = HashMap::new();
    let mut out = Vec::new();
    for (bi, bc) in bcs.iter().enumerate() {
        for &n in &bc.nodes {
            let x = &coords[n as usize * dim..(n as usize + 1) * dim];
            for (ci, &c) in bc.components.iter().enumerate() {
                let Some(g) = dofs.global(n, c) else { continue };
                let v = bc.value(ci, x, lambda);
                match by_dof.get(&g) {
                    None => {
                        by_dof.insert(g, (v, bi, n));
                        out.push((g, v));
                    }
                    Some(&(v0, b0, _)) => {
                        let scale = 1.0 + v.abs().max(v0.abs());
                        if (v - v0).abs() > 1e-12 * scale {
                            return Err(ConflictError {
                                node: n,
                                component: c,
                                label_a: bcs[b0].label.clone(),
                                a: v0,
                                label_b: bc.label.clone(),
                                b: v,
                                lambda,
                            });
                        }
                    }
                }
            }
        }
    }
    Ok(out)
}

/// Flags of every constrained unknown. [n_global]
pub fn constrained_flags(bcs: &[DirichletBc], dofs: &DofMap) -> Vec<bool> {
    let mut flags = vec![false; dofs.n_global()];
    for bc in bcs {
        for &n in &bc.nodes {
            for &c in &bc.components {
                if let Some(g) = dofs.global(n, c) {
                    flags[g.0 as usize] = true;
                }
            }
        }
    }
    flags
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn displacement_is_linear_within_each_stage() {
        let bc = DirichletBc {
            label: "t".into(),
            nodes: vec![0],
            components: vec![1],
            kind: Prescription::Displacement(vec![vec![-1.0], vec![-1.0], vec![2.0]]),
        };
        let x = [0.0, 0.0];
        assert!((bc.value(0, &x, 0.5) + 0.5).abs() < 1e-15);
        assert!((bc.value(0, &x, 1.7) + 1.0).abs() < 1e-15);
        assert!((bc.value(0, &x, 2.5) - 0.5).abs() < 1e-15);
        assert!((bc.value(0, &x, 3.0) - 2.0).abs() < 1e-15);
    }

    #[test]
    fn quarter_turn_rotation_moves_point_onto_axis_image() {
        let bc = DirichletBc {
            label: "r".into(),
            nodes: vec![0],
            components: vec![0, 1, 2],
            kind: Prescription::Rotation {
                axis: [0.0, 0.0, 1.0],
                center: [1.0, 0.0, 0.0],
                angles: vec![std::f64::consts::FRAC_PI_2],
                translations: vec![],
            },
        };
        // (2,0,5) about the z axis through (1,0,0) by 90 degrees -> (1,1,5).
        let x = [2.0, 0.0, 5.0];
        let u: Vec<f64> = (0..3).map(|c| bc.value(c, &x, 1.0)).collect();
        assert!((u[0] + 1.0).abs() < 1e-14 && (u[1] - 1.0).abs() < 1e-14 && u[2].abs() < 1e-14);
    }

    #[test]
    fn rotation_with_translation_presses_then_twists() {
        // stage 1: down by 1 without turning; stage 2: a quarter turn about the moved axis
        let bc = DirichletBc {
            label: "r".into(),
            nodes: vec![0],
            components: vec![0, 1, 2],
            kind: Prescription::Rotation {
                axis: [0.0, 0.0, 1.0],
                center: [0.0, 0.0, 0.0],
                angles: vec![0.0, std::f64::consts::FRAC_PI_2],
                translations: vec![[0.0, 0.0, -1.0], [0.0, 0.0, -1.0]],
            },
        };
        let x = [1.0, 0.0, 2.0];
        let u = |l: f64| -> Vec<f64> { (0..3).map(|c| bc.value(c, &x, l)).collect() };
        let half = u(0.5);
        assert!(half[0].abs() < 1e-15 && half[1].abs() < 1e-15 && (half[2] + 0.5).abs() < 1e-15);
        // (1,0,2) -> (0,1,1) at the end
        let end = u(2.0);
        assert!((end[0] + 1.0).abs() < 1e-14 && (end[1] - 1.0).abs() < 1e-14);
        assert!((end[2] + 1.0).abs() < 1e-14, "{end:?}");
    }

    #[test]
    fn conflicting_conditions_are_reported_with_both_labels() {
        let dofs = DofMap::new(2, 4, &[0, 4], &[0, 1, 2, 3], &[0], &[], 1, 0).unwrap();
        let a = DirichletBc {
            label: "bcs[0]".into(),
            nodes: vec![0, 1],
            components: vec![0],
            kind: Prescription::Fixed,
        };
        let b = DirichletBc {
            label: "bcs[1]".into(),
            nodes: vec![1, 2],
            components: vec![0],
            kind: Prescription::Displacement(vec![vec![0.1]]),
        };
        let coords = vec![0.0; 8];
        let err = prescribed_values(&[a, b], &dofs, &coords, 1.0).unwrap_err();
        let msg = err.to_string();
        assert!(
            msg.contains("bcs[0]") && msg.contains("bcs[1]") && msg.contains("node 1"),
            "{msg}"
        );
    }
}
