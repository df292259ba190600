//! Rigid couplings: a node set that moves rigidly with a prescribed rotation and a *free*
//! translation, the kinematic coupling of a rigid end loaded by a pure moment (the peeling strip's
//! rotated end, which must be free to lift off as the strip peels).
//!
//! The set's nodes are tied to one representative, so they share its unknowns (the translation),
//! and each node's displacement is the representative's plus the offset of the prescribed rotation:
//!
//! `u_n = u_r + (R(theta) - I) (X_n - X_r)`.
//!
//! The offsets depend on the load only, never on the unknowns, so the residual of the group is the
//! sum of its nodes' residuals (virtual displacements are the translation's) and the tangent is
//! the tied one. The reaction moment at the set needs each node's own force, which the tie sums
//! away; the assembler keeps them per coupled node ([`NodeOffsets::slot`]).

use super::dirichlet::{rotate, stage_lerp};

/// A node set moving rigidly: rotation prescribed per stage, translation free.
#[derive(Debug, Clone)]
pub struct RigidCoupling {
    /// Where it comes from, for messages, e.g. `bcs[0] (strip/right)`.
    pub label: String,
    /// Global node ids (at least one).
    pub nodes: Vec<u32>,
    /// Unit rotation axis (3D; 2D rotates in the plane).
    pub axis: [f64; 3],
    /// Rotation angle (radians) at the end of each stage. [n_stages]
    pub angles: Vec<f64>,
}

/// The load-dependent displacement offsets of every coupled node relative to its representative.
#[derive(Debug, Clone, Default)]
pub struct NodeOffsets {
    dim: usize,
    /// Slot of each node, `u32::MAX` for uncoupled nodes. [n_nodes]
    slot_of: Vec<u32>,
    /// Per slot: global node, its coupling, and `X_n - X_r` [3].
    rel: Vec<(u32, usize, [f64; 3])>,
    /// Per coupling: axis and stage-end angles.
    rotations: Vec<([f64; 3], Vec<f64>)>,
    /// Per slot: the offset at the current load. [n_slots][dim]
    value: Vec<f64>,
}

impl NodeOffsets {
    /// Offsets of the couplings' nodes relative to their tie representatives `rep` [n_nodes];
    /// `coords` are the reference positions [n_nodes][dim]. Offsets start at load 0 (zero).
    pub fn new(couplings: &[RigidCoupling], rep: &[u32], coords: &[f64], dim: usize) -> Self {
        let mut out = NodeOffsets {
            dim,
            slot_of: vec![u32::MAX; if couplings.is_empty() { 0 } else { rep.len() }],
            ..Default::default()
        };
        for (ci, c) in couplings.iter().enumerate() {
            out.rotations.push((c.axis, c.angles.clone()));
            for &n in &c.nodes {
                if out.slot_of[n as usize] != u32::MAX {
                    continue;
                }
                let r = rep[n as usize] as usize;
                let mut d = [0.0; 3];
                for (k, dk) in d.iter_mut().enumerate().take(dim) {
                    *dk = coords[n as usize * dim + k] - coords[r * dim + k];
                }
                out.slot_of[n as usize] = out.rel.len() as u32;
                out.rel.push((n, ci, d));
            }
        }
        out.value = vec![0.0; out.rel.len() * dim];
        out
    }

    /// Unknowns per node.
    pub fn dim(&self) -> usize {
        self.dim
    }

    /// True when no node is coupled.
    pub fn is_empty(&self) -> bool {
        self.rel.is_empty()
    }

    /// Number of coupled nodes.
    pub fn len(&self) -> usize {
        self.rel.len()
    }

    /// The slot of `node` (an index into the per-slot arrays), if it is coupled.
    pub fn slot(&self, node: u32) -> Option<usize> {
        match self.slot_of.get(node as usize) {
            Some(&s) if s != u32::MAX => Some(s as usize),
            _ => None,
        }
    }

    /// Global node of a slot.
    pub fn node(&self, slot: usize) -> u32 {
        self.rel[slot].0
    }

    /// Offset of component `c` of slot `slot` at the current load.
    pub fn value(&self, slot: usize, c: usize) -> f64 {
        self.value[slot * self.dim + c]
    }

    /// Offset of component `c` of `node` at the current load (zero for uncoupled nodes).
    pub fn of(&self, node: u32, c: usize) -> f64 {
        self.slot(node).map_or(0.0, |s| self.value(s, c))
    }

    /// Evaluates the offsets at load `lambda` (see [`super::dirichlet`] for the stage convention).
    pub fn set_load(&mut self, lambda: f64) {
        let dim = self.dim;
        let thetas: Vec<f64> = self
            .rotations
            .iter()
            .map(|(_, a)| stage_lerp(a, lambda, 0.0, |a, b, f| a + (b - a) * f))
            .collect();
        for (s, &(_, ci, d)) in self.rel.iter().enumerate() {
            let axis = if dim == 2 {
                [0.0, 0.0, 1.0]
            } else {
                self.rotations[ci].0
            };
            let rd = rotate(d, axis, thetas[ci]);
            for c in 0..dim {
                self.value[s * dim + c] = rd[c] - d[c];
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn offsets_rotate_each_node_about_its_representative() {
        // three nodes on a vertical end x = 2, y = 0, 1, 2; representative node 0
        let coords = [2.0, 0.0, 2.0, 1.0, 2.0, 2.0, 5.0, 5.0];
        let rep = [0, 0, 0, 3];
        let c = RigidCoupling {
            label: "t".into(),
            nodes: vec![0, 1, 2],
            axis: [0.0, 0.0, 1.0],
            angles: vec![std::f64::consts::FRAC_PI_2],
        };
        let mut off = NodeOffsets::new(&[c], &rep, &coords, 2);
        assert_eq!(off.len(), 3);
        assert_eq!(off.slot(3), None);
        off.set_load(1.0);
        // a quarter turn maps (0, 2) relative to the representative to (-2, 0)
        assert!((off.of(2, 0) + 2.0).abs() < 1e-14);
        assert!((off.of(2, 1) + 2.0).abs() < 1e-14);
        assert!((off.of(1, 0) + 1.0).abs() < 1e-14);
        assert!((off.of(1, 1) + 1.0).abs() < 1e-14);
        assert_eq!(off.of(0, 0), 0.0);
        assert_eq!(off.of(3, 1), 0.0);
        // half-way through the stage: 45 degrees
        off.set_load(0.5);
        let s = std::f64::consts::FRAC_1_SQRT_2;
        assert!((off.of(1, 0) + s).abs() < 1e-14);
        assert!((off.of(1, 1) - (s - 1.0)).abs() < 1e-14);
    }
}
