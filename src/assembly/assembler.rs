//! The nonlinear system `F(u) = 0` of a whole model on this rank: gathers element unknowns from the
//! ghosted local vector (restriction), runs the element kernels, scatters into the residual and into a
//! [`MatrixSink`], and imposes Dirichlet rows. Implements [`NonlinearProblem`] for SNES.
//!
//! Constrained unknowns stay in the system: their residual row is `u_i - ubar_i` and their matrix row
//! is the identity, so Newton drives them to the prescribed value even from a guess that misses it.
//! Element contributions to those rows are dropped in the COO pattern (negative row index).
//! Skew conditions ([`super::skew`]) are constrained rows too, but their element rows are moved to
//! the node's other rows with the constraint's weights, and their own row is the constraint.

use super::coupling::NodeOffsets;
use super::dofmap::{DofMap, GlobalDof};
use super::element_set::{ElementFailure, ElementSet};
use super::sink::{CooSink, MatrixSink};
use super::skew::{SkewRow, SkewRows};
use crate::contact::{ContactSystem, Coupling};
use crate::petsc::{
    Matrix, NonlinearProblem, Petsc, PetscError, PetscInt, ProblemError, Scatter, Vector,
};
use mpi::collective::SystemOperation;
use mpi::traits::*;
use std::time::Instant;

/// How the Jacobian is put into PETSc (both are exact-preallocated; BENCHMARKS.md compares them).
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
    /// Contact: gathering surface displacements, search, projection and contact assembly (part of
    /// `residual` and `jacobian`).
    pub contact: f64,
    /// Contact: sparsity pattern rebuilds because the coupled element pairs changed.
    pub pattern_rebuilds: usize,
}

/// Contact pairs on this rank and what the assembler keeps for them.
struct ContactHook<'p> {
    sys: ContactSystem,
    /// Gathers the displacement of every contact-surface node to every rank.
    scatter: Scatter<'p>,
    u_table: Vector<'p>,
    /// Coupling blocks of the current pattern, sorted; block `i` has COO slot `first_slot + i`.
    couplings: Vec<Coupling>,
    first_slot: usize,
    /// Side-neighbour rings reserved around each point's partner element (see
    /// [`ContactSystem::band_couplings`]).
    ring: usize,
    /// A Jacobian since the last pattern needed a coupling outside it.
    stale: bool,
    /// Coupling blocks found outside the pattern (each stopped a solve for a rebuild).
    pub missing_blocks: usize,
    /// Couplings the next pattern is built from instead of the current band (a restart).
    preset: Option<Vec<Coupling>>,
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
    /// [n_elements_total + 1] start of each element block in `coo_values`.
    coo_offsets: Vec<usize>,
    coo_values: Vec<f64>,
    pattern_ready: bool,
    /// Owned entries of the last residual before Dirichlet rows were imposed (reactions). [n_owned]
    raw_residual: Vec<f64>,
    /// Time per phase.
    pub timers: Timers,
    /// Contact pairs, if the model has any.
    contact: Option<ContactHook<'p>>,
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
    /// Contact-surface displacements with the coupled nodes' offsets added.
    u_table_off: Vec<f64>,
    /// Pseudo-transient damping `c D (u - u_prev)` on the free owned rows (c = 0: off).
    stab_c: f64,
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

/// Where an element row `gi` goes in the pattern: dropped (constrained), itself, or (a skew row)
/// its node's first other row, with the constraint.
fn row_target<'a>(
    constrained: &[bool],
    skew: &'a SkewRows,
    gi: PetscInt,
) -> (PetscInt, Option<&'a SkewRow>) {
    if gi < 0 || !constrained[gi as usize] {
        return (gi, None);
    }
    match skew.of(gi) {
        Some(r) if !r.others.is_empty() => (r.others[0].0, Some(r)),
        _ => (-1, None),
    }
}

/// Pattern bookkeeping of a skew row's entry at COO index `idx`, column `gj`: its weight on the
/// first other row, and entries for the further ones (pushed later as `extra`).
fn note_skew(
    r: &SkewRow,
    idx: usize,
    gj: PetscInt,
    scale: &mut Vec<(usize, f64)>,
    extra: &mut Vec<(PetscInt, PetscInt, usize, f64)>,
) {
    scale.push((idx, r.others[0].1));
    for &(o, a) in &r.others[1..] {
        extra.push((o, gj, idx, a));
    }
}

/// Collects the diagonal entries of element and contact matrices by global row. [n_global]
struct DiagSink {
    diag: Vec<f64>,
}

impl MatrixSink for DiagSink {
    fn add(&mut self, slot: usize, dofs: &[i32], k_e: &[f64]) {
        self.add_block(slot, dofs, dofs, k_e);
    }
    fn add_block(&mut self, _slot: usize, rows: &[i32], cols: &[i32], k: &[f64]) {
        let m = cols.len();
        for (a, &i) in rows.iter().enumerate() {
            if i < 0 {
                continue;
            }
            for (b, &j) in cols.iter().enumerate() {
                if i == j {
                    self.diag[i as usize] += k[a * m + b];
                }
            }
        }
    }
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
            coo_offsets: Vec::new(),
            coo_values: Vec::new(),
            pattern_ready: false,
            raw_residual: vec![0.0; n_owned],
            timers: Timers::default(),
            contact: None,
            u_e: vec![0.0; max_n],
            r_e: vec![0.0; max_n],
            k_e: vec![0.0; max_n * max_n],
            offsets: NodeOffsets::default(),
            rslot: Vec::new(),
            node_force: Vec::new(),
            u_table_off: Vec::new(),
            stab_c: 0.0,
            stab_diag: Vec::new(),
            stab_prev: Vec::new(),
            skew: SkewRows::default(),
            skew_owned: Vec::new(),
            skew_scale: Vec::new(),
            skew_copy: Vec::new(),
            skew_tail: 0,
        })
    }

    /// Computes `D`, the assembled diagonal of the stiffness at `x` (elements and contact), for
    /// [`Assembler::set_damping`]. Entries are floored at `1e-12` of the largest so that `D > 0`.
    ///
    /// Collective.
    pub fn compute_damping_diagonal(&mut self, x: &Vector) -> Result<(), ProblemError> {
        let cu = self.prepare_contact(x, false);
        self.agree(cu)?;
        let mut sink = DiagSink {
            diag: vec![0.0; self.dofs.n_global()],
        };
        let local = self.guarded_loop(x, Some(&mut sink));
        self.agree(local)?;
        let mut global: Vec<f64> = vec![0.0; sink.diag.len()];
        self.petsc
            .comm()
            .all_reduce_into(&sink.diag[..], &mut global[..], SystemOperation::sum());
        let (lo, hi) = self.dofs.owned_range();
        let max = global.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        self.stab_diag = global[lo as usize..hi as usize]
            .iter()
            .map(|d| d.abs().max(1e-12 * max).max(f64::MIN_POSITIVE))
            .collect();
        Ok(())
    }

    /// Turns the pseudo-transient damping on (`c > 0`, about the state `u_prev`, with the diagonal
    /// of the last [`Assembler::compute_damping_diagonal`]) or off (`c = 0`). The residual gains
    /// `c D_i (u_i - u_prev_i)` and the Jacobian `c D_i` on every free owned row; reactions
    /// (`raw_residual`) do not see it.
    pub fn set_damping(&mut self, c: f64, u_prev: &Vector) -> Result<(), PetscError> {
        self.stab_c = if self.stab_diag.is_empty() { 0.0 } else { c };
        self.stab_prev.clear();
        if self.stab_c > 0.0 {
            self.stab_prev.extend_from_slice(&u_prev.read()?);
        }
        Ok(())
    }

    /// The damping force `|c D (u - u_prev)|` (2-norm over all ranks) at `x`, zero when off.
    ///
    /// Collective.
    pub fn damping_force_norm(&self, x: &Vector) -> Result<f64, PetscError> {
        let mut local = 0.0f64;
        if self.stab_c > 0.0 {
            let xa = x.read()?;
            let (lo, _) = self.dofs.owned_range();
            for i in 0..xa.len() {
                if !self.constrained[lo as usize + i] {
                    let f = self.stab_c * self.stab_diag[i] * (xa[i] - self.stab_prev[i]);
                    local += f * f;
                }
            }
        }
        let mut global = 0.0f64;
        self.petsc
            .comm()
            .all_reduce_into(&local, &mut global, SystemOperation::sum());
        Ok(global.sqrt())
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

    /// A rigidly coupled node on which this rank's contact points may put a force, if any: the
    /// coupling's reaction moment counts element forces only, so such overlaps are refused.
    pub fn coupled_contact_node(&self) -> Option<u32> {
        let c = self.contact.as_ref()?;
        c.sys
            .loaded_nodes()
            .into_iter()
            .find(|&n| self.offsets.slot(n).is_some())
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

    /// Adds contact pairs: their surfaces' displacement is gathered to every rank before each
    /// evaluation.
    ///
    /// Collective.
    pub fn set_contact(
        &mut self,
        sys: ContactSystem,
        global_template: &Vector<'p>,
        ring: usize,
    ) -> Result<(), PetscError> {
        let idx: Vec<PetscInt> = sys.table_dofs(&self.dofs);
        let u_table = Vector::new_seq(self.petsc, idx.len())?;
        let scatter = Scatter::new(self.petsc, global_template, &u_table, &idx)?;
        self.contact = Some(ContactHook {
            sys,
            scatter,
            u_table,
            couplings: Vec::new(),
            first_slot: 0,
            ring,
            stale: false,
            missing_blocks: 0,
            preset: None,
        });
        self.pattern_ready = false;
        Ok(())
    }

    /// Before a Newton solve from `x`: if the contact couplings at `x` (or those a Jacobian of the
    /// last solves needed) are not all in the sparsity pattern, builds a new pattern reserving a
    /// band around them, on a new matrix that replaces `jac`. PETSc's COO preallocation is set once
    /// per matrix (setting it again on a parallel matrix corrupted memory in PETSc 3.18), and
    /// never inside a Newton solve. Returns whether the pattern was rebuilt.
    ///
    /// Collective.
    pub fn refresh_pattern(
        &mut self,
        x: &Vector,
        jac: &mut Matrix<'p>,
    ) -> Result<bool, PetscError> {
        if self.contact.is_none() {
            return Ok(false);
        }
        // a failed projection here only means the solve will cut back; the pattern uses the rest
        let _ = self.contact_update(x);
        let need = match &self.contact {
            Some(c) => {
                !self.pattern_ready
                    || c.stale
                    || c.sys
                        .couplings()
                        .iter()
                        .any(|cp| c.couplings.binary_search(cp).is_err())
            }
            None => false,
        } as i32;
        let mut any = 0i32;
        self.petsc
            .comm()
            .all_reduce_into(&need, &mut any, SystemOperation::max());
        if any == 0 {
            return Ok(false);
        }
        let t0 = Instant::now();
        *jac = Matrix::new_aij(self.petsc, self.dofs.n_owned())?;
        if self.pattern_ready {
            self.timers.pattern_rebuilds += 1;
        }
        self.timers.pattern += t0.elapsed().as_secs_f64();
        self.build_pattern(jac)?;
        if let Some(c) = &mut self.contact {
            c.stale = false;
        }
        Ok(true)
    }

    /// The contact pairs, if any.
    pub fn contact(&self) -> Option<&ContactSystem> {
        self.contact.as_ref().map(|c| &c.sys)
    }

    /// Contact pattern statistics of this rank: (ring, coupling blocks left out of Jacobians).
    pub fn contact_pattern_stats(&self) -> Option<(usize, usize)> {
        self.contact.as_ref().map(|c| (c.ring, c.missing_blocks))
    }

    /// The contact coupling blocks of the current sparsity pattern, if it is built and still
    /// holds every coupling the last Jacobian needed (checkpoints: a restart rebuilds the same
    /// pattern, so the matrix and its factorisation, and hence the round-off, are the same).
    pub fn contact_pattern(&self) -> Option<&[Coupling]> {
        let c = self.contact.as_ref()?;
        (self.pattern_ready && !c.stale).then_some(&c.couplings[..])
    }

    /// The couplings the next contact pattern is built from (a restart: those of
    /// [`contact_pattern`](Self::contact_pattern) on every rank; this rank keeps its own).
    pub fn preset_contact_pattern(&mut self, all: &[Coupling]) {
        if let Some(c) = &mut self.contact {
            let mut own: Vec<Coupling> = all
                .iter()
                .copied()
                .filter(|&(p, e, _)| c.sys.integrates(p, e))
                .collect();
            own.sort_unstable();
            own.dedup();
            c.preset = Some(own);
            self.pattern_ready = false;
        }
    }

    /// The contact system, to export or import its state (checkpoints).
    pub fn contact_mut(&mut self) -> Option<&mut ContactSystem> {
        self.contact.as_mut().map(|c| &mut c.sys)
    }

    /// Sets the load parameter (rigid contact partners move with it).
    pub fn set_load(&mut self, lambda: f64) {
        self.offsets.set_load(lambda);
        if let Some(c) = &mut self.contact {
            c.sys.set_load(lambda);
        }
    }

    /// Gathers the contact surfaces' displacement and projects every contact point of this rank.
    /// A failed projection is a rank-local domain error.
    ///
    /// Collective.
    fn contact_update(&mut self, x: &Vector) -> Result<(), ProblemError> {
        let Some(c) = &mut self.contact else {
            return Ok(());
        };
        let t0 = Instant::now();
        c.scatter.gather(x, &mut c.u_table).map_err(fatal)?;
        let u = c.u_table.read().map_err(fatal)?;
        let u: &[f64] = if self.offsets.is_empty() {
            &u
        } else {
            let dim = self.dofs.dim;
            self.u_table_off.clear();
            self.u_table_off.extend_from_slice(&u);
            for (t, &n) in c.sys.table().iter().enumerate() {
                if let Some(s) = self.offsets.slot(n) {
                    for k in 0..dim {
                        self.u_table_off[t * dim + k] += self.offsets.value(s, k);
                    }
                }
            }
            &self.u_table_off
        };
        let out = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| c.sys.update(u)));
        self.timers.contact += t0.elapsed().as_secs_f64();
        match out {
            Ok(Ok(())) => Ok(()),
            Ok(Err(msg)) => Err(ProblemError::Domain(msg)),
            Err(_) => Err(ProblemError::Fatal("panic in the contact search".into())),
        }
    }

    /// Builds (or rebuilds, when contact changes the coupling) the sparsity pattern of `j` and
    /// preallocates it exactly.
    ///
    /// Collective.
    pub fn build_pattern(&mut self, j: &mut Matrix) -> Result<(), PetscError> {
        let t0 = Instant::now();
        let (lo, hi) = self.dofs.owned_range();
        match self.mode {
            MatrixAssembly::Coo => {
                let mut rows: Vec<PetscInt> = Vec::new();
                let mut cols: Vec<PetscInt> = Vec::new();
                let mut scale = Vec::new();
                let mut extra = Vec::new();
                self.coo_offsets.clear();
                self.coo_offsets.push(0);
                for r in &self.restrict {
                    for e in 0..r.offsets.len() - 1 {
                        let g = &r.global[r.offsets[e]..r.offsets[e + 1]];
                        for &gi in g {
                            let (row, sk) = row_target(&self.constrained, &self.skew, gi);
                            for &gj in g {
                                if let Some(sr) = sk {
                                    note_skew(sr, rows.len(), gj, &mut scale, &mut extra);
                                }
                                rows.push(row);
                                cols.push(gj);
                            }
                        }
                        self.coo_offsets.push(rows.len());
                    }
                }
                // Contact coupling blocks: rows of a surface element, columns of it and its partner.
                if let Some(c) = &mut self.contact {
                    c.couplings = match c.preset.take() {
                        Some(p) => p,
                        None => c.sys.band_couplings(c.ring),
                    };
                    c.first_slot = self.coo_offsets.len() - 1;
                    for cp in &c.couplings {
                        let (rws, cls) = c.sys.block_dofs(cp);
                        for &gi in &rws {
                            let (row, sk) = row_target(&self.constrained, &self.skew, gi);
                            for &gj in &cls {
                                if let Some(sr) = sk {
                                    note_skew(sr, rows.len(), gj, &mut scale, &mut extra);
                                }
                                rows.push(row);
                                cols.push(gj);
                            }
                        }
                        self.coo_offsets.push(rows.len());
                    }
                }
                // A final block with the diagonal of every owned row: identity rows of the
                // constrained unknowns, the pseudo-transient damping (or zero) on the free ones.
                for g in lo..hi {
                    rows.push(g);
                    cols.push(g);
                }
                self.coo_offsets.push(rows.len());
                // Skew constraint rows `x_d - sum a_o x_o`: their off-diagonal entries, then the
                // element entries of skew rows on their further other rows.
                self.skew_tail = rows.len();
                for (d, others) in &self.skew_owned {
                    for &(o, _) in others {
                        rows.push(lo + *d as PetscInt);
                        cols.push(lo + o as PetscInt);
                    }
                }
                self.skew_copy.clear();
                for (o, gj, src, a) in extra {
                    self.skew_copy.push((src, rows.len(), a));
                    rows.push(o);
                    cols.push(gj);
                }
                self.skew_scale = scale;
                self.coo_values = vec![0.0; rows.len()];
                j.set_preallocation_coo(&mut rows, &mut cols)?;
            }
            MatrixAssembly::Preallocated => {
                let (d_nnz, o_nnz) = self.row_counts();
                j.preallocate_aij(&d_nnz, &o_nnz)?;
            }
        }
        self.pattern_ready = true;
        self.timers.pattern += t0.elapsed().as_secs_f64();
        Ok(())
    }

    /// Exact per-row nonzero counts of the owned rows, split into the diagonal block and the rest.
    /// Owned rows also receive entries from other ranks' elements, so this scans the connectivity of
    /// every cell of the model (`all_cells`, replicated on each rank), a setup cost paid per pattern.
    fn row_counts(&self) -> (Vec<PetscInt>, Vec<PetscInt>) {
        let (lo, hi) = self.dofs.owned_range();
        let n_owned = (hi - lo) as usize;
        let dim = self.dofs.dim;
        let mut cols_of: Vec<Vec<PetscInt>> = vec![Vec::new(); n_owned];
        let (offsets, nodes) = (&self.all_cells.0, &self.all_cells.1);
        let mut g = Vec::new();
        for c in 0..offsets.len().saturating_sub(1) {
            g.clear();
            for &n in &nodes[offsets[c]..offsets[c + 1]] {
                for k in 0..dim {
                    g.push(self.dofs.global(n, k).map_or(-1, |d| d.0));
                }
            }
            for &gi in &g {
                if gi >= lo && gi < hi && !self.constrained[gi as usize] {
                    cols_of[(gi - lo) as usize].extend(g.iter().copied().filter(|&x| x >= 0));
                }
            }
        }
        let mut d = vec![0 as PetscInt; n_owned];
        let mut o = vec![0 as PetscInt; n_owned];
        for (i, c) in cols_of.iter_mut().enumerate() {
            if self.constrained[(lo + i as PetscInt) as usize] {
                d[i] = 1;
                continue;
            }
            c.sort_unstable();
            c.dedup();
            for &col in c.iter() {
                if col >= lo && col < hi {
                    d[i] += 1;
                } else {
                    o[i] += 1;
                }
            }
        }
        (d, o)
    }

    /// Switches to the classic `MatSetValues` path (for comparison with COO in benchmarks); it needs
    /// the connectivity of every cell of the model, `(offsets, global nodes)`, to count row nonzeros.
    pub fn use_preallocated(&mut self, offsets: Vec<usize>, nodes: Vec<u32>) {
        self.mode = MatrixAssembly::Preallocated;
        self.all_cells = (offsets, nodes);
        self.pattern_ready = false;
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
            if let Some(c) = &mut self.contact {
                let t0 = Instant::now();
                let (couplings, first) = (&c.couplings, c.first_slot);
                let slot_of = |cp: &Coupling| couplings.binary_search(cp).ok().map(|i| first + i);
                c.sys.assemble(
                    &mut fl[..],
                    sink.map(|s| (s, &slot_of as &dyn Fn(&Coupling) -> Option<usize>)),
                );
                self.timers.contact += t0.elapsed().as_secs_f64();
            }
        }
        Ok(failure)
    }

    /// Projects the contact points at `x` and agrees on the outcome. In a Jacobian evaluation,
    /// a coupling outside the sparsity pattern (a point whose partner element moved beyond the
    /// reserved band) is left out of that Jacobian and marks the pattern outdated; the solve stops
    /// after that Newton step ([`NonlinearProblem::stop_requested`]) and the load stepping
    /// rebuilds the pattern on a new matrix and continues Newton from the iterate reached
    /// ([`Assembler::pattern_outdated`]); the pattern is never changed inside a solve.
    ///
    /// Collective.
    fn prepare_contact(&mut self, x: &Vector, jacobian: bool) -> Result<(), ProblemError> {
        if self.contact.is_none() {
            return Ok(());
        }
        let cu = self.contact_update(x);
        self.agree(cu)?;
        if !jacobian || !self.pattern_ready {
            return Ok(());
        }
        if self.mode == MatrixAssembly::Preallocated {
            return Err(ProblemError::Fatal(
                "contact needs the COO assembly path (drop --matsetvalues)".into(),
            ));
        }
        // Coupling blocks outside the pattern are left out of this Jacobian (the sink has no slot
        // for them): the Newton step is taken with the rest, and the solve stops after it
        // (`stop_requested`) for the pattern to be rebuilt between solves.
        let missing = match &self.contact {
            Some(c) => c
                .sys
                .couplings()
                .iter()
                .filter(|cp| c.couplings.binary_search(cp).is_err())
                .count(),
            None => 0,
        };
        let mut any = 0u64;
        self.petsc
            .comm()
            .all_reduce_into(&(missing as u64), &mut any, SystemOperation::max());
        if any > 0 {
            if let Some(c) = &mut self.contact {
                c.stale = true;
                c.missing_blocks += missing;
            }
        }
        Ok(())
    }

    /// True when the last solve stopped because the contact couplings left the sparsity pattern
    /// (the same on every rank): rebuild it ([`Assembler::refresh_pattern`]) and continue.
    pub fn pattern_outdated(&self) -> bool {
        self.contact.as_ref().is_some_and(|c| c.stale)
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

    /// Sum over `nodes` of the internal force at the last residual evaluation: the reaction that the
    /// Dirichlet conditions exert there, per component. Ties count each shared node once.
    ///
    /// Collective.
    pub fn reaction(&self, nodes: &[u32]) -> Vec<f64> {
        let dim = self.dofs.dim;
        let (lo, hi) = self.dofs.owned_range();
        let mut reps: Vec<u32> = nodes.iter().map(|&n| self.dofs.rep[n as usize]).collect();
        reps.sort_unstable();
        reps.dedup();
        let mut local = vec![0.0; dim];
        for n in reps {
            for (c, lc) in local.iter_mut().enumerate() {
                if let Some(g) = self.dofs.global(n, c) {
                    if g.0 >= lo && g.0 < hi {
                        *lc += self.raw_residual[(g.0 - lo) as usize];
                    }
                }
            }
        }
        let mut global = vec![0.0; dim];
        self.petsc
            .comm()
            .all_reduce_into(&local[..], &mut global[..], SystemOperation::sum());
        global
    }

    /// Moment about `center` [3] of the reaction forces on `nodes` at the last residual evaluation,
    /// taken at the nodes' current positions `X + u` (`coords` [n_nodes][dim] the reference
    /// positions, `x` the current displacement). Tied nodes count once. Returns [3] (2D: only the
    /// z component is non-zero).
    ///
    /// Collective.
    pub fn reaction_moment(
        &self,
        nodes: &[u32],
        x: &Vector,
        coords: &[f64],
        center: [f64; 3],
    ) -> Result<[f64; 3], PetscError> {
        let dim = self.dofs.dim;
        if !nodes.is_empty() && nodes.iter().all(|&n| self.offsets.slot(n).is_some()) {
            return Ok(self.coupled_moment(nodes, coords, center));
        }
        let (lo, hi) = self.dofs.owned_range();
        let mut reps: Vec<u32> = nodes.iter().map(|&n| self.dofs.rep[n as usize]).collect();
        reps.sort_unstable();
        reps.dedup();
        let xa = x.read()?;
        let mut local = [0.0; 3];
        for n in reps {
            // the owner of the node's first unknown owns them all (contiguous per node)
            let Some(g0) = self.dofs.global(n, 0) else {
                continue;
            };
            if g0.0 < lo || g0.0 >= hi {
                continue;
            }
            let (mut r, mut d) = ([0.0; 3], [0.0; 3]);
            for c in 0..dim {
                let i = (g0.0 - lo) as usize + c;
                r[c] = self.raw_residual[i];
                d[c] = coords[n as usize * dim + c] + xa[i] - center[c];
            }
            local[0] += d[1] * r[2] - d[2] * r[1];
            local[1] += d[2] * r[0] - d[0] * r[2];
            local[2] += d[0] * r[1] - d[1] * r[0];
        }
        let mut global = [0.0; 3];
        self.petsc
            .comm()
            .all_reduce_into(&local[..], &mut global[..], SystemOperation::sum());
        Ok(global)
    }

    /// Moment about `center` of the forces on rigidly coupled `nodes`: each node's own element
    /// force (which the tie sums into the representative's row) at its current position, from the
    /// last evaluation (its ghosted displacement and this rank's element forces; the ranks' parts
    /// add up).
    ///
    /// Collective.
    fn coupled_moment(&self, nodes: &[u32], coords: &[f64], center: [f64; 3]) -> [f64; 3] {
        let dim = self.dofs.dim;
        let mut local = [0.0; 3];
        if let Ok(xl) = self.x_local.read() {
            for &n in nodes {
                let Some(s) = self.offsets.slot(n) else {
                    continue;
                };
                let f = &self.node_force[s * dim..(s + 1) * dim];
                if f.iter().all(|&v| v == 0.0) {
                    continue;
                }
                let rep = self.dofs.rep[n as usize];
                let (mut r, mut d) = ([0.0; 3], [0.0; 3]);
                for c in 0..dim {
                    let u = self
                        .dofs
                        .global(rep, c)
                        .and_then(|g| self.dofs.local(g))
                        .map_or(0.0, |l| xl[l.0 as usize]);
                    r[c] = f[c];
                    d[c] = coords[n as usize * dim + c] + u + self.offsets.value(s, c) - center[c];
                }
                local[0] += d[1] * r[2] - d[2] * r[1];
                local[1] += d[2] * r[0] - d[0] * r[2];
                local[2] += d[0] * r[1] - d[1] * r[0];
            }
        }
        let mut global = [0.0; 3];
        self.petsc
            .comm()
            .all_reduce_into(&local[..], &mut global[..], SystemOperation::sum());
        global
    }

    /// Element stress measures of every owned element: (body, cell, tr sigma, von Mises). An element
    /// whose measures cannot be evaluated reports NaN rather than failing, so that the collective
    /// output that follows stays in step on every rank.
    ///
    /// Collective.
    pub fn stress_measures(
        &mut self,
        x: &Vector,
    ) -> Result<Vec<(usize, usize, f64, f64)>, PetscError> {
        self.scatter.gather(x, &mut self.x_local)?;
        let xl = self.x_local.read()?;
        let mut out = Vec::new();
        for (si, (set, r)) in self.sets.iter().zip(&self.restrict).enumerate() {
            for e in 0..set.len() {
                let (a, b) = (r.offsets[e], r.offsets[e + 1]);
                for (k, &l) in r.local[a..b].iter().enumerate() {
                    self.u_e[k] = xl[l as usize];
                }
                if !self.offsets.is_empty() {
                    add_offsets(&self.offsets, &self.rslot[si][a..b], &mut self.u_e[..b - a]);
                }
                let (tr, vm) = set
                    .stress_measures(e, &self.u_e[..b - a])
                    .unwrap_or((f64::NAN, f64::NAN));
                let (body, cell) = set.cell_id(e);
                out.push((body, cell, tr, vm));
            }
        }
        Ok(out)
    }

    /// The first element, in (body, body-local cell) order over all ranks, whose map at `x` is
    /// folded over somewhere ([`ElementSet::check_untangled`]): its failure's message (body,
    /// cell, family, where), the same on every rank whatever the partition; `None` when there is
    /// none. Run on a converged state before it is accepted (once per step, not per residual).
    ///
    /// Collective.
    pub fn find_tangled(&mut self, x: &Vector) -> Result<Option<String>, PetscError> {
        self.scatter.gather(x, &mut self.x_local)?;
        let mut first: Option<((usize, usize), ElementFailure)> = None;
        {
            let xl = self.x_local.read()?;
            for (si, (set, r)) in self.sets.iter().zip(&self.restrict).enumerate() {
                for e in 0..set.len() {
                    let key = set.cell_id(e);
                    if first.as_ref().is_some_and(|(k, _)| *k <= key) {
                        continue;
                    }
                    let (a, b) = (r.offsets[e], r.offsets[e + 1]);
                    for (k, &l) in r.local[a..b].iter().enumerate() {
                        self.u_e[k] = xl[l as usize];
                    }
                    if !self.offsets.is_empty() {
                        add_offsets(&self.offsets, &self.rslot[si][a..b], &mut self.u_e[..b - a]);
                    }
                    if let Err(f) = set.check_untangled(e, &self.u_e[..b - a]) {
                        first = Some((key, f));
                    }
                }
            }
        }
        // the lowest (body, cell) over the ranks; the rank that has it sends its message
        let comm = self.petsc.comm();
        let mine = first
            .as_ref()
            .map_or(u64::MAX, |((b, c), _)| ((*b as u64) << 40) | *c as u64);
        let mut lowest = u64::MAX;
        comm.all_reduce_into(&mine, &mut lowest, SystemOperation::min());
        if lowest == u64::MAX {
            return Ok(None);
        }
        let candidate = if mine == lowest {
            comm.rank()
        } else {
            i32::MAX
        };
        let mut root = 0i32;
        comm.all_reduce_into(&candidate, &mut root, SystemOperation::min());
        let mut bytes = first
            .map(|(_, f)| f.to_string().into_bytes())
            .unwrap_or_default();
        let mut len = bytes.len() as u64;
        comm.process_at_rank(root).broadcast_into(&mut len);
        bytes.resize(len as usize, 0);
        comm.process_at_rank(root).broadcast_into(&mut bytes[..]);
        Ok(Some(String::from_utf8_lossy(&bytes).into_owned()))
    }

    /// Tells every element set and the contact state that the current state is converged.
    pub fn commit(&mut self) {
        for s in &mut self.sets {
            s.commit();
        }
        if let Some(c) = &mut self.contact {
            c.sys.commit();
        }
    }

    /// Commits the state of an intermediate point of a solver device (the damped rescue): element
    /// history and contact warm starts, not the friction anchors (load-step history that only a
    /// converged load step may move; see [`ContactSystem::commit_warm_starts`]).
    pub fn commit_intermediate(&mut self) {
        for s in &mut self.sets {
            s.commit();
        }
        if let Some(c) = &mut self.contact {
            c.sys.commit_warm_starts();
        }
    }

    /// Returns every element set and the contact state to the last committed state.
    pub fn rollback(&mut self) {
        for s in &mut self.sets {
            s.rollback();
        }
        if let Some(c) = &mut self.contact {
            c.sys.rollback();
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

    fn residual(&mut self, x: &Vector, f: &mut Vector) -> Result<(), ProblemError> {
        let t0 = Instant::now();
        if let Err(e) = self.prepare_contact(x, false) {
            self.timers.residual += t0.elapsed().as_secs_f64();
            return Err(e);
        }
        let local = self.guarded_loop(x, None);
        if let Err(e) = self.agree(local) {
            self.timers.residual += t0.elapsed().as_secs_f64();
            return Err(e);
        }
        f.set(0.0).map_err(fatal)?;
        self.scatter.add_back(&self.f_local, f).map_err(fatal)?;
        // one-pass contact: the master surfaces' rows, through the contact table's scatter
        if let Some(c) = &mut self.contact {
            if c.sys.has_one_pass() {
                c.u_table
                    .write()
                    .map_err(fatal)?
                    .copy_from_slice(c.sys.table_residual());
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
        self.prepare_contact(x, true)?;
        if !self.pattern_ready {
            self.build_pattern(j).map_err(fatal)?;
        }
        let local = match self.mode {
            MatrixAssembly::Coo => {
                let mut values = std::mem::take(&mut self.coo_values);
                let offsets = std::mem::take(&mut self.coo_offsets);
                // reserved contact blocks that no point uses now must not keep old values
                if let Some(c) = &self.contact {
                    let (a, b) = (offsets[c.first_slot], offsets[offsets.len() - 2]);
                    values[a..b].fill(0.0);
                }
                let res = {
                    let mut sink = CooSink {
                        offsets: &offsets,
                        values: &mut values,
                    };
                    self.guarded_loop(x, Some(&mut sink))
                };
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
                let (tail, end) = (offsets[offsets.len() - 2], offsets[offsets.len() - 1]);
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
                self.coo_offsets = offsets;
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

/// Inserts element matrices with `MatSetValues` (the classic path, for comparison with COO).
struct PetscSink<'a, 'm, 'p> {
    mat: &'m mut Matrix<'p>,
    constrained: &'a [bool],
    rows: Vec<PetscInt>,
    err: Option<PetscError>,
}

impl MatrixSink for PetscSink<'_, '_, '_> {
    fn add(&mut self, slot: usize, dofs: &[i32], k_e: &[f64]) {
        self.add_block(slot, dofs, dofs, k_e);
    }
    fn add_block(&mut self, _slot: usize, rows: &[i32], cols: &[i32], k: &[f64]) {
        self.rows.clear();
        self.rows.extend(rows.iter().map(|&g| {
            if g >= 0 && self.constrained[g as usize] {
                -1
            } else {
                g
            }
        }));
        if let Err(e) = self.mat.add_values(&self.rows, cols, k) {
            self.err.get_or_insert(e);
        }
    }
}

/// Newton at the kink of the penalty law (see `crate::contact::system::active_set`).
impl Assembler<'_> {
    /// Contact points whose status keeps changing are frozen after this many Newton iterates of a
    /// step attempt (0: never).
    pub fn set_contact_freeze_after(&mut self, iterates: usize) {
        if let Some(c) = &mut self.contact {
            c.sys.set_freeze_after(iterates);
        }
    }

    /// After a converged Newton solve at `x`: compares every frozen contact point's status with
    /// the law's at `x` (re-evaluated there) and releases them all when they agree (the state is
    /// then the law's equilibrium: the same residual, bit for bit), else updates the disagreeing
    /// ones for a resumed solve. The same answer on every rank.
    ///
    /// Collective.
    pub fn settle_active_set(&mut self, x: &Vector) -> crate::contact::Settle {
        // the same setting on every rank: no communication when it is off
        if self
            .contact
            .as_ref()
            .is_none_or(|c| c.sys.freeze_after() == 0)
        {
            return crate::contact::Settle::Free;
        }
        let frozen = self.contact.as_ref().map_or(0, |c| c.sys.frozen_points()) as u64;
        let mut any = 0u64;
        self.petsc
            .comm()
            .all_reduce_into(&frozen, &mut any, SystemOperation::max());
        if any == 0 {
            return crate::contact::Settle::Free;
        }
        // the gaps at `x` itself (the last evaluation of the solve is there, but make sure)
        let cu = self.contact_update(x);
        let ok = self.agree(cu).is_ok() && {
            let local = self.guarded_loop(x, None);
            self.agree(local).is_ok()
        };
        let local = match (&self.contact, ok) {
            (Some(c), true) => c.sys.inconsistent_points() as u64,
            (Some(_), false) => 1,
            (None, _) => 0,
        };
        let mut total = 0u64;
        self.petsc
            .comm()
            .all_reduce_into(&local, &mut total, SystemOperation::sum());
        match &mut self.contact {
            Some(c) => c.sys.settle_active_set(true, total as usize),
            None => crate::contact::Settle::Free,
        }
    }
}
