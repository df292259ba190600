//! Element sets: the elements of one body and family owned by this rank, with their precomputed
//! reference data, exposed to assembly through [`ElementSet`].

use super::kernel::TlElement;
use super::q1e4::Q1e4Element;
use super::untangle::MapCheck;
use crate::assembly::{ElementFailure, ElementSet};
use crate::material::Material;

/// Elements that all use the generic total-Lagrangian kernel (Q1C1 quads and hexes, and every family
/// that only differs in its reference basis).
pub struct TlSet {
    body: usize,
    body_name: String,
    family: String,
    material: Material,
    /// Global node ids, `n_nodes` per element. [n_el][n_nodes]
    nodes: Vec<u32>,
    /// Start of each element's nodes. [n_el + 1]
    offsets: Vec<usize>,
    /// Body-local cell id of each element. [n_el]
    cells: Vec<usize>,
    elements: Vec<TlElement>,
    /// The tangle check of each element. [n_el]
    checks: Vec<MapCheck>,
}

impl TlSet {
    /// An empty set for `family` elements of body `body`.
    pub fn new(body: usize, body_name: &str, family: &str, material: Material) -> Self {
        TlSet {
            body,
            body_name: body_name.into(),
            family: family.into(),
            material,
            nodes: Vec::new(),
            offsets: vec![0],
            cells: Vec::new(),
            elements: Vec::new(),
            checks: Vec::new(),
        }
    }

    /// Adds an element: body-local `cell`, its global `nodes`, its precomputed kernel data and
    /// its tangle check.
    pub fn push(&mut self, cell: usize, nodes: &[u32], element: TlElement, check: MapCheck) {
        self.nodes.extend_from_slice(nodes);
        self.offsets.push(self.nodes.len());
        self.cells.push(cell);
        self.elements.push(element);
        self.checks.push(check);
    }

    /// The tangle check of element `e` at `u_e`; a small-strain material accepts any map.
    fn untangled(&self, e: usize, u_e: &[f64]) -> Result<(), ElementFailure> {
        if !self.material.finite_strain() {
            return Ok(());
        }
        self.checks[e].check(u_e).map_err(|t| self.failure(e, t))
    }

    fn failure(&self, e: usize, reason: impl ToString) -> ElementFailure {
        ElementFailure {
            body: self.body_name.clone(),
            cell: self.cells[e],
            family: self.family.clone(),
            reason: reason.to_string(),
        }
    }
}

impl ElementSet for TlSet {
    fn len(&self) -> usize {
        self.elements.len()
    }

    fn nodes(&self, e: usize) -> &[u32] {
        &self.nodes[self.offsets[e]..self.offsets[e + 1]]
    }

    fn evaluate(
        &mut self,
        e: usize,
        u_e: &[f64],
        r_e: &mut [f64],
        k_e: Option<&mut [f64]>,
    ) -> Result<(), ElementFailure> {
        self.elements[e]
            .residual_tangent(&self.material, u_e, r_e, k_e)
            .map_err(|err| self.failure(e, err))
    }

    fn check_untangled(&self, e: usize, u_e: &[f64]) -> Result<(), ElementFailure> {
        self.untangled(e, u_e)
    }

    fn stress_measures(&self, e: usize, u_e: &[f64]) -> Result<(f64, f64), ElementFailure> {
        self.elements[e]
            .stress_measures(&self.material, u_e)
            .map_err(|err| self.failure(e, err))
    }

    fn cell_id(&self, e: usize) -> (usize, usize) {
        (self.body, self.cells[e])
    }
}

/// Q1E4 enhanced-strain quads (Simo & Armero 1992) with their enhanced parameters, kept per element
/// as the warm start of the local solve; a cut-back step returns to the last committed values.
pub struct Q1e4Set {
    base: TlSet,
    elements: Vec<Q1e4Element>,
    /// Current enhanced parameters. [n_el][4]
    alpha: Vec<[f64; 4]>,
    /// Enhanced parameters of the last converged step. [n_el][4]
    alpha_committed: Vec<[f64; 4]>,
}

impl Q1e4Set {
    /// An empty set of body `body`.
    pub fn new(body: usize, body_name: &str, material: Material) -> Self {
        Q1e4Set {
            base: TlSet::new(body, body_name, "Q1E4", material),
            elements: Vec::new(),
            alpha: Vec::new(),
            alpha_committed: Vec::new(),
        }
    }

    /// Adds an element (4 nodes in quad4 order) with its tangle check.
    pub fn push(&mut self, cell: usize, nodes: &[u32], element: Q1e4Element, check: MapCheck) {
        self.base.nodes.extend_from_slice(nodes);
        self.base.offsets.push(self.base.nodes.len());
        self.base.cells.push(cell);
        self.base.checks.push(check);
        self.elements.push(element);
        self.alpha.push([0.0; 4]);
        self.alpha_committed.push([0.0; 4]);
    }
}

fn as_array<const N: usize>(s: &[f64]) -> [f64; N] {
    let mut a = [0.0; N];
    a.copy_from_slice(&s[..N]);
    a
}

impl ElementSet for Q1e4Set {
    fn len(&self) -> usize {
        self.elements.len()
    }

    fn nodes(&self, e: usize) -> &[u32] {
        self.base.nodes(e)
    }

    fn evaluate(
        &mut self,
        e: usize,
        u_e: &[f64],
        r_e: &mut [f64],
        k_e: Option<&mut [f64]>,
    ) -> Result<(), ElementFailure> {
        let u: [f64; 8] = as_array(u_e);
        let mut r = [0.0; 8];
        let result = match k_e {
            Some(k) => {
                let mut kk = [0.0; 64];
                let res = self.elements[e].residual_tangent(
                    &self.base.material,
                    &u,
                    &mut self.alpha[e],
                    &mut r,
                    Some(&mut kk),
                );
                k[..64].copy_from_slice(&kk);
                res
            }
            None => self.elements[e].residual_tangent(
                &self.base.material,
                &u,
                &mut self.alpha[e],
                &mut r,
                None,
            ),
        };
        r_e[..8].copy_from_slice(&r);
        result.map_err(|err| self.base.failure(e, err))
    }

    fn check_untangled(&self, e: usize, u_e: &[f64]) -> Result<(), ElementFailure> {
        // the enhanced modes change F at the points, not the element's map of its nodes
        self.base.untangled(e, u_e)
    }

    fn stress_measures(&self, e: usize, u_e: &[f64]) -> Result<(f64, f64), ElementFailure> {
        let u: [f64; 8] = as_array(u_e);
        self.elements[e]
            .stress_measures(&self.base.material, &u, &self.alpha[e])
            .map_err(|err| self.base.failure(e, err))
    }

    fn commit(&mut self) {
        self.alpha_committed.copy_from_slice(&self.alpha);
    }

    fn rollback(&mut self) {
        self.alpha.copy_from_slice(&self.alpha_committed);
    }

    fn history_width(&self) -> usize {
        4
    }

    fn history(&self, e: usize) -> &[f64] {
        &self.alpha_committed[e]
    }

    fn set_history(&mut self, e: usize, values: &[f64]) {
        self.alpha_committed[e] = as_array(values);
        self.alpha[e] = self.alpha_committed[e];
    }

    fn cell_id(&self, e: usize) -> (usize, usize) {
        self.base.cell_id(e)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::NeoHookean;

    /// What a checkpoint reads is the committed history, and what a restart sets is both the
    /// committed and the current one (a cutback right after a restart returns to it).
    #[test]
    fn q1e4_history_is_the_committed_alpha_and_a_restart_sets_both() {
        let mat: Material = NeoHookean::from_young_poisson(1.0, 0.3).unwrap().into();
        let mut set = Q1e4Set::new(0, "b", mat);
        let x = [0.0, 0.0, 1.0, 0.0, 1.0, 1.0, 0.0, 1.0];
        set.push(
            0,
            &[0, 1, 2, 3],
            Q1e4Element::new(&x).unwrap(),
            MapCheck::linear(2, &x),
        );
        assert_eq!(set.history_width(), 4);
        let u = [0.0, 0.0, 0.1, 0.0, 0.12, -0.05, 0.0, -0.05];
        let (mut r, mut k) = ([0.0; 8], [0.0; 64]);
        set.evaluate(0, &u, &mut r, Some(&mut k)).unwrap();
        // not committed yet: the history is still the start
        assert_eq!(set.history(0), &[0.0; 4]);
        set.commit();
        let alpha = set.history(0).to_vec();
        assert!(alpha.iter().any(|a| a.abs() > 1e-6), "{alpha:?}");
        let mut other = Q1e4Set::new(0, "b", mat);
        other.push(
            0,
            &[0, 1, 2, 3],
            Q1e4Element::new(&x).unwrap(),
            MapCheck::linear(2, &x),
        );
        other.set_history(0, &alpha);
        other.rollback();
        assert_eq!(other.history(0), &alpha[..]);
        assert_eq!(other.alpha[0].to_vec(), alpha);
    }
}
