//! What assembly needs from a group of elements of one family: their nodes and a kernel.
//!
//! A kernel maps an element's nodal unknowns to its residual and tangent and never sees global
//! numbering; assembly (restriction, sink) never sees shape functions or materials.

/// A kernel failed on an element; carries what the user needs to find it.
#[derive(Debug, Clone, thiserror::Error)]
#[error("{body} element {cell} ({family}): {reason}")]
pub struct ElementFailure {
    /// Body name.
    pub body: String,
    /// Cell index inside the body's mesh.
    pub cell: usize,
    /// Element family, e.g. `Q1C1`.
    pub family: String,
    /// The kernel's message (e.g. "inverted at quadrature point 3, J = -0.02").
    pub reason: String,
}

/// A batch of elements of one family on this rank, with their kernels and per-element data.
pub trait ElementSet: Send {
    /// Number of elements in the set.
    fn len(&self) -> usize;
    /// True when the set has no elements.
    fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// Global node ids of element `e`, in the kernel's node order. Each node has `dim` unknowns.
    fn nodes(&self, e: usize) -> &[u32];
    /// Residual `r_e` [n_nodes * dim] and optionally tangent `k_e` [n_nodes*dim][n_nodes*dim]
    /// (row-major) of element `e` for nodal displacements `u_e` [n_nodes * dim].
    fn evaluate(
        &mut self,
        e: usize,
        u_e: &[f64],
        r_e: &mut [f64],
        k_e: Option<&mut [f64]>,
    ) -> Result<(), ElementFailure>;
    /// Checks that element `e`'s current map is not folded over anywhere (see
    /// `crate::fem::untangle`), not only at the quadrature points that `evaluate` sees; run on a
    /// converged state before the load stepping accepts it. `u_e` as in `evaluate`.
    fn check_untangled(&self, e: usize, u_e: &[f64]) -> Result<(), ElementFailure>;
    /// Stress measures of element `e` for output: (tr sigma, von Mises), averaged over the element.
    fn stress_measures(&self, e: usize, u_e: &[f64]) -> Result<(f64, f64), ElementFailure>;
    /// Called once a load step has converged (e.g. to keep enhanced-strain parameters as warm start).
    fn commit(&mut self) {}
    /// Called when a load step is cut back: return to the state of the last `commit`.
    fn rollback(&mut self) {}
    /// Values of load-step history per element (e.g. 4 enhanced-strain parameters); 0: none.
    fn history_width(&self) -> usize {
        0
    }
    /// The committed history of element `e` [`history_width`](Self::history_width) (checkpoints).
    fn history(&self, _e: usize) -> &[f64] {
        &[]
    }
    /// Sets the history of element `e`, committed and current (a restart).
    fn set_history(&mut self, _e: usize, _values: &[f64]) {}
    /// Body-local cell id of element `e` (for output and messages).
    fn cell_id(&self, e: usize) -> (usize /*body*/, usize /*cell*/);
}
