//! The nonlinear system `F(u) = 0` of a whole model on this rank: gathers element unknowns from the
//! ghosted local vector (restriction), runs the element kernels, scatters into the residual and into a
//! [`MatrixSink`], and imposes Dirichlet rows. Implements [`NonlinearProblem`] for SNES.
//!
//! Constrained unknowns stay in the system: their residual row is `u_i - ubar_i` and their matrix row
//! is the identity, so Newton drives them to the prescribed value even from a guess that misses it.
//! Element contributions to those rows are dropped from the COO pattern (the cells' map sends them
//! nowhere, coupling blocks' rows are marked dropped).
//! Skew conditions ([`super::skew`]) are constrained rows too, but their element rows are moved to
//! the node's other rows with the constraint's weights, and their own row is the constraint.

use super::coupling_set::Block;
use super::dofmap::{DofMap, GlobalDof};
use super::element_set::{ElementFailure, ElementSet};
use super::rigid_coupling::NodeOffsets;
use super::sink::{CellMap, CooSink, CouplingRuns, MatrixSink};
use super::skew::SkewRows;
use crate::petsc::{
    Matrix, NonlinearProblem, Petsc, PetscError, PetscInt, ProblemError, Scatter, Vector,
};
use mpi::collective::SystemOperation;
use mpi::traits::*;
use std::time::Instant;

mod cells;
mod couplings;
mod damping;
mod measures;
mod pattern;

use couplings::CouplingHook;
use pattern::PetscSink;

/// How the Jacobian is put into PETSc (both are exact-preallocated; docs/performance/solver.md compares them).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MatrixAssembly {
    /// `MatSetPreallocationCOO` once per pattern, then one `MatSetValuesCOO` per Jacobian.
    Coo,
    /// Per-row counts + `MatMPIAIJSetPreallocation`, then `MatSetValues` per element.
    Preallocated,
}

/// Time spent in each phase, accumulated over the run (seconds, this rank).
#[derive(Debug, Clone, Copy, Default)]
pub struct Timers {
    /// Residual evaluations (kernels + scatter).
    pub residual: f64,
    /// Jacobian evaluations (kernels + matrix insertion).
    pub jacobian: f64,
    /// Building sparsity patterns.
    pub pattern: f64,
    /// Number of residual and Jacobian evaluations.
    pub n_residual: usize,
    /// Number of Jacobian evaluations.
    pub n_jacobian: usize,
    /// The coupling set (contact): gathering its nodes' displacements, its update (search,
    /// projection) and evaluation (part of
    /// `residual` and `jacobian`).
    pub contact: f64,
    /// Of `contact`: the coupling set's updates alone (contact: search and projection), without
    /// the gathers before them and the agreement after them.
    pub contact_update: f64,
    /// Of `contact`: the coupling set's evaluations alone (contact residual and blocks).
    pub contact_evaluate: f64,
    /// Of `contact`: refreshes of the coupling set's node list (contact: the ghost layer, and the
    /// gather rebuilt for it).
    pub contact_refresh: f64,
    /// Sparsity pattern rebuilds because the coupling set's needed blocks left the pattern.
    pub pattern_rebuilds: usize,
    /// COO entries of the largest pattern built on this rank.
    pub coo_entries: usize,
    /// Entries of this rank's element matrices (each cell's `n_e^2`), which the COO pattern
    /// merges into one entry per matrix entry.
    pub cell_entries: usize,
    /// Entries of the coupling blocks' shared regions (the union of their rows times the union
    /// of their columns; neighbouring regions overlap) in the largest pattern built on this rank.
    pub region_entries: usize,
    /// Columns of the coupling rows' column patterns (see
    /// [`CouplingRuns`](super::sink::CouplingRuns)) in the largest pattern built on this rank.
    pub run_columns: usize,
}

/// Per element set: the element unknowns' local and global indices, flattened.
struct Restriction {
    /// Start of element e's unknowns in `local`/`global`. [n_el + 1]
    offsets: Vec<usize>,
    /// Local (ghosted) index of each element unknown.
    local: Vec<u32>,
    /// Global index of each element unknown.
    global: Vec<PetscInt>,
}

/// The assembled problem on this rank.
pub struct Assembler<'p> {
    petsc: &'p Petsc,
    /// The numbering.
    pub dofs: DofMap,
    /// The element sets owned by this rank.
    pub sets: Vec<Box<dyn ElementSet>>,
    restrict: Vec<Restriction>,
    /// Global flag per unknown: prescribed by a Dirichlet condition. [n_global]
    constrained: Vec<bool>,
    /// Owned constrained unknowns: (owned offset, prescribed value).
    prescribed: Vec<(usize, f64)>,
    x_local: Vector<'p>,
    f_local: Vector<'p>,
    scatter: Scatter<'p>,
    mode: MatrixAssembly,
    /// Connectivity of every cell of the model (only for [`MatrixAssembly::Preallocated`]).
    all_cells: (Vec<usize>, Vec<u32>),
    /// The cells' part of the COO pattern (built with the first pattern, kept across the
    /// coupling set's rebuilds).
    cells: Option<cells::CellPattern>,
    /// The diagonal block's entries in `coo_values`: the cells' and the coupling regions' entries
    /// come before it, the skew rows' after.
    coo_diag: (usize, usize),
    coo_values: Vec<f64>,
    pattern_ready: bool,
    /// Owned entries of the last residual before Dirichlet rows were imposed (reactions). [n_owned]
    raw_residual: Vec<f64>,
    /// Time per phase.
    pub timers: Timers,
    /// The coupling set (contact pairs), if the model has one.
    coupled: Option<CouplingHook<'p>>,
    u_e: Vec<f64>,
    r_e: Vec<f64>,
    k_e: Vec<f64>,
    /// Offsets of rigidly coupled nodes (empty without couplings).
    offsets: NodeOffsets,
    /// Per element set, per element unknown: `slot * dim + c` of a coupled node, `u32::MAX`
    /// otherwise (empty without couplings).
    rslot: Vec<Vec<u32>>,
    /// Element forces on each coupled node at the last evaluation, this rank's elements.
    /// [n_slots][dim]
    node_force: Vec<f64>,
    /// The coupling set's node displacements with the rigidly coupled nodes' offsets added.
    u_table_off: Vec<f64>,
    /// Pseudo-transient damping `c D (u - u_prev)` on the free owned rows (c = 0: off).
    stab_c: f64,
    /// A state with a deeper contact penetration is outside the domain (`[solver] max_penetration`).
    max_penetration: Option<f64>,
    /// `D`: the assembled diagonal of the stiffness at the state it was computed. [n_owned]
    stab_diag: Vec<f64>,
    /// `u_prev` on the owned rows. [n_owned]
    stab_prev: Vec<f64>,
    /// Skew constraints (empty without skew conditions).
    skew: SkewRows,
    /// Owned skew rows in owned offsets: `(d, [(o, a_o)])`.
    skew_owned: Vec<(usize, Vec<(usize, f64)>)>,
    /// COO entries of a skew row moved to its first other row: (entry, weight).
    skew_scale: Vec<(usize, f64)>,
    /// COO entries added for a skew row's further other rows: (source entry, entry, weight).
    skew_copy: Vec<(usize, usize, f64)>,
    /// First COO entry of the owned constraint rows' off-diagonal entries `-a_o`.
    skew_tail: usize,
}

/// Adds the coupled nodes' offsets to an element's unknowns (`slots` from `Assembler::rslot`).
fn add_offsets(offsets: &NodeOffsets, slots: &[u32], u_e: &mut [f64]) {
    let dim_slots = slots.iter().zip(u_e.iter_mut());
    for (&s, u) in dim_slots {
        if s != u32::MAX {
            let dim = offsets.dim();
            *u += offsets.value(s as usize / dim, s as usize % dim);
        }
    }
}

fn fatal(e: PetscError) -> ProblemError {
    ProblemError::Fatal(e.to_string())
}

impl<'p> Assembler<'p> {
    /// Builds the restriction of every element and the ghost scatter.
    ///
    /// `constrained[g]` flags the unknowns that Dirichlet conditions prescribe (same on every rank).
    ///
    /// Collective.
    pub fn new(
        petsc: &'p Petsc,
        global_template: &Vector<'p>,
        dofs: DofMap,
        sets: Vec<Box<dyn ElementSet>>,
        constrained: Vec<bool>,
    ) -> Result<Self, PetscError> {
        let dim = dofs.dim;
        let mut restrict = Vec::with_capacity(sets.len());
        let mut max_n = 0;
        for set in &sets {
            let mut r = Restriction {
                offsets: vec![0],
                local: Vec::new(),
                global: Vec::new(),
            };
            for e in 0..set.len() {
                let nodes = set.nodes(e);
                max_n = max_n.max(nodes.len() * dim);
                for &n in nodes {
                    for c in 0..dim {
                        // Nodes of an owned element are always numbered and present locally.
                        let g = dofs.global(n, c).map_or(-1, |g| g.0);
                        let l = dofs.local(GlobalDof(g)).map_or(u32::MAX, |l| l.0);
                        r.global.push(g);
                        r.local.push(l);
                    }
                }
                r.offsets.push(r.global.len());
            }
            restrict.push(r);
        }
        let n_local = dofs.local_to_global.len();
        let x_local = Vector::new_seq(petsc, n_local)?;
        let f_local = Vector::new_seq(petsc, n_local)?;
        let scatter = Scatter::new(petsc, global_template, &x_local, &dofs.local_to_global)?;
        let n_owned = dofs.n_owned();
        Ok(Assembler {
            petsc,
            dofs,
            sets,
            restrict,
            constrained,
            prescribed: Vec::new(),
            x_local,
            f_local,
            scatter,
            mode: MatrixAssembly::Coo,
            all_cells: (Vec::new(), Vec::new()),
            cells: None,
            coo_diag: (0, 0),
            coo_values: Vec::new(),
            pattern_ready: false,
            raw_residual: vec![0.0; n_owned],
            timers: Timers::default(),
            coupled: None,
            u_e: vec![0.0; max_n],
            r_e: vec![0.0; max_n],
            k_e: vec![0.0; max_n * max_n],
            offsets: NodeOffsets::default(),
            rslot: Vec::new(),
            node_force: Vec::new(),
            u_table_off: Vec::new(),
            stab_c: 0.0,
            max_penetration: None,
            stab_diag: Vec::new(),
            stab_prev: Vec::new(),
            skew: SkewRows::default(),
            skew_owned: Vec::new(),
            skew_scale: Vec::new(),
            skew_copy: Vec::new(),
            skew_tail: 0,
        })
    }

    /// Adds rigid couplings: the offsets of their nodes relative to the tie representatives.
    pub fn set_couplings(&mut self, offsets: NodeOffsets) {
        let dim = self.dofs.dim;
        self.rslot = self
            .sets
            .iter()
            .map(|set| {
                (0..set.len())
                    .flat_map(|e| set.nodes(e).to_vec())
                    .flat_map(|n| {
                        let s = offsets.slot(n);
                        (0..dim).map(move |c| s.map_or(u32::MAX, |s| (s * dim + c) as u32))
                    })
                    .collect()
            })
            .collect();
        self.node_force = vec![0.0; offsets.len() * dim];
        self.offsets = offsets;
    }

    /// The rigid couplings' offsets at the current load.
    pub fn offsets(&self) -> &NodeOffsets {
        &self.offsets
    }

    /// Imposes skew conditions (COO assembly only): their dependent unknowns become constrained
    /// rows holding the constraint, and their element rows move to the node's other rows.
    pub fn set_skew(&mut self, skew: SkewRows) {
        let (lo, hi) = self.dofs.owned_range();
        self.skew_owned.clear();
        for r in skew.rows() {
            self.constrained[r.dep as usize] = true;
            if r.dep >= lo && r.dep < hi {
                let others = r
                    .others
                    .iter()
                    .map(|&(o, a)| ((o - lo) as usize, a))
                    .collect();
                self.skew_owned.push(((r.dep - lo) as usize, others));
            }
        }
        self.skew = skew;
        self.cells = None;
        self.pattern_ready = false;
    }

    /// Sets the values of the owned constrained unknowns for the next solve.
    pub fn set_prescribed(&mut self, values: &[(GlobalDof, f64)]) {
        let (lo, hi) = self.dofs.owned_range();
        self.prescribed.clear();
        for &(g, v) in values {
            if g.0 >= lo && g.0 < hi {
                self.prescribed.push(((g.0 - lo) as usize, v));
            }
        }
    }

    /// Sets the load parameter (rigid couplings turn, rigid contact partners move with it).
    pub fn set_load(&mut self, lambda: f64) {
        self.offsets.set_load(lambda);
        if let Some(c) = &mut self.coupled {
            c.set.set_load(lambda);
        }
    }

    /// Evaluates every element; `with_tangent` also fills the matrix sink.
    fn element_loop(
        &mut self,
        x: &Vector,
        sink: Option<&mut dyn MatrixSink>,
    ) -> Result<Option<ElementFailure>, PetscError> {
        self.scatter.gather(x, &mut self.x_local)?;
        self.f_local.set(0.0)?;
        let xl = self.x_local.read()?;
        let mut fl = self.f_local.write()?;
        let mut failure = None;
        let mut slot = 0;
        let mut sink = sink;
        self.node_force.fill(0.0);
        let coupled = !self.offsets.is_empty();
        'sets: for (si, (set, r)) in self.sets.iter_mut().zip(&self.restrict).enumerate() {
            for e in 0..set.len() {
                let (a, b) = (r.offsets[e], r.offsets[e + 1]);
                let n = b - a;
                let loc = &r.local[a..b];
                for (k, &l) in loc.iter().enumerate() {
                    self.u_e[k] = xl[l as usize];
                }
                if coupled {
                    add_offsets(&self.offsets, &self.rslot[si][a..b], &mut self.u_e[..n]);
                }
                let k_e = if sink.is_some() {
                    Some(&mut self.k_e[..n * n])
                } else {
                    None
                };
                if let Err(f) = set.evaluate(e, &self.u_e[..n], &mut self.r_e[..n], k_e) {
                    failure = Some(f);
                    break 'sets;
                }
                for (k, &l) in loc.iter().enumerate() {
                    fl[l as usize] += self.r_e[k];
                }
                if coupled {
                    for (k, &s) in self.rslot[si][a..b].iter().enumerate() {
                        if s != u32::MAX {
                            self.node_force[s as usize] += self.r_e[k];
                        }
                    }
                }
                if let Some(s) = sink.as_deref_mut() {
                    s.add(slot, &r.global[a..b], &self.k_e[..n * n]);
                }
                slot += 1;
            }
        }
        if failure.is_none() {
            if let Some(c) = &mut self.coupled {
                let t0 = Instant::now();
                let (blocks, first) = (&c.blocks, c.first_slot);
                let slot_of = |b: &Block| blocks.binary_search(b).ok().map(|i| first + i);
                c.set.evaluate(
                    &mut fl[..],
                    sink.map(|s| (s, &slot_of as &dyn Fn(&Block) -> Option<usize>)),
                );
                let dt = t0.elapsed().as_secs_f64();
                self.timers.contact += dt;
                self.timers.contact_evaluate += dt;
            }
        }
        Ok(failure)
    }

    /// Makes a rank-local outcome collective: every rank learns the worst outcome of any rank
    /// (ok < domain error < fatal error) and returns it, so that no rank leaves for SNES's next
    /// collective call while another is still in this one. Called on every path of every evaluation.
    fn agree(&self, local: Result<(), ProblemError>) -> Result<(), ProblemError> {
        let code = match &local {
            Ok(()) => 0i32,
            Err(ProblemError::Domain(_)) => 1,
            Err(ProblemError::Fatal(_)) => 2,
        };
        let mut worst = 0i32;
        self.petsc
            .comm()
            .all_reduce_into(&code, &mut worst, SystemOperation::max());
        match (worst, local) {
            (0, _) => Ok(()),
            (w, Err(e)) if w == code => Err(e),
            (1, _) => Err(ProblemError::Domain(
                "an element on another rank failed".into(),
            )),
            _ => Err(ProblemError::Fatal(
                "stopped because of an error on another rank".into(),
            )),
        }
    }

    /// Runs the element loop, turning PETSc errors and panics into a rank-local outcome.
    fn guarded_loop(
        &mut self,
        x: &Vector,
        sink: Option<&mut dyn MatrixSink>,
    ) -> Result<(), ProblemError> {
        let outcome =
            std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| self.element_loop(x, sink)));
        match outcome {
            Ok(Ok(None)) => Ok(()),
            Ok(Ok(Some(failure))) => Err(ProblemError::Domain(failure.to_string())),
            Ok(Err(e)) => Err(fatal(e)),
            Err(p) => Err(ProblemError::Fatal(format!(
                "panic in an element kernel: {}",
                p.downcast_ref::<&str>()
                    .map(|s| s.to_string())
                    .or_else(|| p.downcast_ref::<String>().cloned())
                    .unwrap_or_default()
            ))),
        }
    }

    /// Tells every element set and the coupling set that the current state is converged.
    pub fn commit(&mut self) {
        for s in &mut self.sets {
            s.commit();
        }
        if let Some(c) = &mut self.coupled {
            c.set.commit();
            c.rounds = 0;
        }
    }

    /// Commits the state of an intermediate point of a solver device (the damped rescue): element
    /// history and the coupling set's warm starts, not its load-step history (contact: the friction
    /// anchors; see [`CouplingSet::commit_intermediate`](super::CouplingSet::commit_intermediate)).
    pub fn commit_intermediate(&mut self) {
        for s in &mut self.sets {
            s.commit();
        }
        if let Some(c) = &mut self.coupled {
            c.set.commit_intermediate();
        }
    }

    /// Returns every element set and the coupling set to the last committed state.
    pub fn rollback(&mut self) {
        for s in &mut self.sets {
            s.rollback();
        }
        if let Some(c) = &mut self.coupled {
            c.set.rollback();
            c.rounds = 0;
        }
    }

    /// Sets the contact penetration beyond which a state is outside the domain (`None`: no bound).
    pub fn set_max_penetration(&mut self, bound: Option<f64>) {
        self.max_penetration = bound;
    }

    /// A domain error when the coupling set's deepest penetration at the last evaluation exceeds
    /// `[solver] max_penetration` (rank-local; the caller agrees on it).
    fn penetration_bound(&self) -> Result<(), ProblemError> {
        let (Some(bound), Some(c)) = (self.max_penetration, &self.coupled) else {
            return Ok(());
        };
        match c.set.deepest() {
            Some((d, what)) if d > bound => Err(ProblemError::Domain(format!(
                "{what} penetrates its partner by {d:.6e}, more than `solver.max_penetration` = {bound:e}"
            ))),
            _ => Ok(()),
        }
    }

    /// The communicator of the system.
    pub fn comm(&self) -> &mpi::topology::SimpleCommunicator {
        self.petsc.comm()
    }
}

impl NonlinearProblem for Assembler<'_> {
    fn stop_requested(&self) -> bool {
        self.pattern_outdated()
    }

    /// A SIGINT or SIGTERM that any rank received ([`crate::interrupt::agreed`]: one reduction).
    fn interrupted(&self) -> bool {
        crate::interrupt::agreed(self.comm()).is_some()
    }

    // `PetscInt` is `i32` in the Debian build; a 64-bit build widens here
    #[allow(clippy::useless_conversion)]
    fn interface_dofs(&self) -> Vec<crate::petsc::PetscInt> {
        self.coupled.as_ref().map_or_else(Vec::new, |c| {
            c.set
                .interface_dofs()
                .into_iter()
                .filter(|&d| d >= 0)
                .map(crate::petsc::PetscInt::from)
                .collect()
        })
    }

    fn residual(&mut self, x: &Vector, f: &mut Vector) -> Result<(), ProblemError> {
        let t0 = Instant::now();
        if let Err(e) = self.prepare_couplings(x, false) {
            self.timers.residual += t0.elapsed().as_secs_f64();
            return Err(e);
        }
        let local = self
            .guarded_loop(x, None)
            .and_then(|()| self.penetration_bound());
        if let Err(e) = self.agree(local) {
            self.timers.residual += t0.elapsed().as_secs_f64();
            return Err(e);
        }
        f.set(0.0).map_err(fatal)?;
        self.scatter.add_back(&self.f_local, f).map_err(fatal)?;
        // rows the coupling set could not put in the local vector (one-pass contact's master
        // surfaces), through the reverse of its gather
        if let Some(c) = &mut self.coupled {
            if let Some(r) = c.set.node_residual() {
                c.u_table.write().map_err(fatal)?.copy_from_slice(r);
                c.scatter.add_back(&c.u_table, f).map_err(fatal)?;
            }
        }
        {
            let xa = x.read().map_err(fatal)?;
            let mut fa = f.write().map_err(fatal)?;
            self.raw_residual.copy_from_slice(&fa);
            if self.stab_c > 0.0 {
                let (lo, _) = self.dofs.owned_range();
                for i in 0..fa.len() {
                    if !self.constrained[lo as usize + i] {
                        fa[i] += self.stab_c * self.stab_diag[i] * (xa[i] - self.stab_prev[i]);
                    }
                }
            }
            for &(i, v) in &self.prescribed {
                fa[i] = xa[i] - v;
            }
            // Skew conditions: the dependent row's force acts on the node's other rows (virtual
            // displacements `e_o + a_o e_d`); its own row is the constraint.
            for (d, others) in &self.skew_owned {
                let mut c = xa[*d];
                for &(o, a) in others {
                    fa[o] += a * self.raw_residual[*d];
                    c -= a * xa[o];
                }
                fa[*d] = c;
            }
        }
        self.timers.residual += t0.elapsed().as_secs_f64();
        self.timers.n_residual += 1;
        Ok(())
    }

    fn jacobian(&mut self, x: &Vector, j: &mut Matrix) -> Result<(), ProblemError> {
        // The pattern is timed on its own (`timers.pattern`), not as part of this evaluation.
        let t0 = Instant::now();
        self.prepare_couplings(x, true)?;
        if !self.pattern_ready {
            self.build_pattern(j).map_err(fatal)?;
        }
        let local = match self.mode {
            MatrixAssembly::Coo => {
                let Some(cells) = self.cells.take() else {
                    return Err(ProblemError::Fatal(
                        "the Jacobian's pattern has no cells' part".into(),
                    ));
                };
                let mut values = std::mem::take(&mut self.coo_values);
                let (tail, end) = self.coo_diag;
                // elements and coupling blocks add into shared entries, and reserved blocks that
                // are not needed now must not keep old values
                values[..tail].fill(0.0);
                let mut scattered = Vec::new();
                let mut runs = CouplingRuns::new();
                let mut first_scattered = usize::MAX;
                if let Some(c) = &mut self.coupled {
                    scattered = std::mem::take(&mut c.block_scatter);
                    runs = std::mem::take(&mut c.runs);
                    first_scattered = c.first_slot;
                }
                let res = {
                    let map = CellMap {
                        offsets: &cells.offsets,
                        map: &cells.map,
                    };
                    let mut sink =
                        CooSink::new(map, &mut values, &scattered, &runs, first_scattered);
                    self.guarded_loop(x, Some(&mut sink))
                };
                self.cells = Some(cells);
                if let Some(c) = &mut self.coupled {
                    c.block_scatter = scattered;
                    c.runs = runs;
                }
                // Skew rows' element entries onto the other rows of their node.
                for &(src, dst, a) in &self.skew_copy {
                    values[dst] = a * values[src];
                }
                for &(i, a) in &self.skew_scale {
                    values[i] *= a;
                }
                let mut k = self.skew_tail;
                for (_, others) in &self.skew_owned {
                    for &(_, a) in others {
                        values[k] = -a;
                        k += 1;
                    }
                }
                // Identity rows of the constrained unknowns, damping on the free ones.
                let (lo, _) = self.dofs.owned_range();
                for (i, v) in values[tail..end].iter_mut().enumerate() {
                    *v = if self.constrained[lo as usize + i] {
                        1.0
                    } else if self.stab_c > 0.0 {
                        self.stab_c * self.stab_diag[i]
                    } else {
                        0.0
                    };
                }
                self.coo_values = values;
                res
            }
            MatrixAssembly::Preallocated => match j.zero() {
                Err(e) => Err(fatal(e)),
                Ok(()) => {
                    // The element loop needs `&mut self` while the sink reads `constrained`: move it out.
                    let constrained = std::mem::take(&mut self.constrained);
                    let mut sink = PetscSink {
                        mat: j,
                        constrained: &constrained,
                        rows: Vec::new(),
                        err: None,
                    };
                    let res = self.guarded_loop(x, Some(&mut sink));
                    let err = sink.err.take();
                    self.constrained = constrained;
                    match err {
                        Some(e) => Err(fatal(e)),
                        None => res,
                    }
                }
            },
        };
        if let Err(e) = self.agree(local) {
            self.timers.jacobian += t0.elapsed().as_secs_f64();
            return Err(e);
        }
        match self.mode {
            MatrixAssembly::Coo => j.set_values_coo(&self.coo_values).map_err(fatal)?,
            MatrixAssembly::Preallocated => {
                let (lo, hi) = self.dofs.owned_range();
                for g in lo..hi {
                    let i = (g - lo) as usize;
                    if self.constrained[g as usize] {
                        j.add_values(&[g], &[g], &[1.0]).map_err(fatal)?;
                    } else if self.stab_c > 0.0 {
                        j.add_values(&[g], &[g], &[self.stab_c * self.stab_diag[i]])
                            .map_err(fatal)?;
                    }
                }
                j.assemble().map_err(fatal)?;
            }
        }
        self.timers.jacobian += t0.elapsed().as_secs_f64();
        self.timers.n_jacobian += 1;
        Ok(())
    }
}
