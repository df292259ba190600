//! What assembly needs from a set of couplings that no mesh cell holds: blocks of the residual
//! and tangent that join elements of different bodies or distant parts of one body, and that come
//! and go with the state. Contact pairs are one (`crate::contact::ContactSystem`); a mortar
//! constraint or a Lagrange-multiplier set would be others. It is the seam beside
//! [`super::ElementSet`]:
//!
//! - a coupling set reads the displacement of a list of global nodes ([`CouplingSet::nodes`]),
//!   which the assembler gathers to this rank before every evaluation ([`CouplingSet::update`]);
//!   the list changes only in a refresh the assembler runs on every rank together when the set
//!   asks for one after an update ([`CouplingSet::ghost_status`]);
//! - its matrix entries come in *blocks*, each named by a [`Block`] key the set chooses; the
//!   assembler reserves COO slots for the blocks of a band around those needed now
//!   ([`CouplingSet::band_blocks`]) and rebuilds the pattern, between Newton solves, when a
//!   needed block ([`CouplingSet::needed_blocks`]) falls outside it;
//! - [`CouplingSet::evaluate`] adds the set's residual to this rank's ghosted local vector and
//!   its blocks to a [`MatrixSink`] at the slots the assembler gives them.
//!
//! A set never sees PETSc or MPI (the assembler agrees on outcomes across ranks), and assembly
//! never sees what a set couples (surfaces, laws, projections).

use super::sink::MatrixSink;
use std::any::Any;

/// The key of one block of matrix entries of a coupling set, chosen by the set (contact: the
/// half-pass, its surface element and the partner element). Blocks are sorted by key. Blocks
/// whose keys share the first two components share their COO entries in the pattern (the union of
/// their rows times the union of their columns), so a set should put blocks with many common rows
/// and columns (contact: those of one surface element) under such a common prefix.
pub type Block = (u32, u32, u32);

/// The COO slot of a block in the current pattern (`None`: not in it).
pub type SlotOf<'a> = dyn Fn(&Block) -> Option<usize> + 'a;

/// What [`CouplingSet::augment`] decided after a converged solve.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Augment {
    /// Every constraint is satisfied to its tolerance (or the set does not augment): accept.
    Satisfied,
    /// Multipliers were updated: solve again.
    Updated,
    /// A constraint is still violated after its most rounds: the step fails (cut back), for this
    /// reason.
    Exhausted(String),
}

/// Couplings evaluated on this rank, beside the element sets.
pub trait CouplingSet: Any + Send {
    /// Global node ids whose displacement the set reads, in the order of the `u` that
    /// [`update`](Self::update) receives ([n][dim] per node).
    fn nodes(&self) -> &[u32];

    /// The load parameter (prescribed motions of the set, e.g. rigid partners, move with it).
    fn set_load(&mut self, lambda: f64);

    /// Moves to the displacement `u` of [`nodes`](Self::nodes) (with rigid-coupling offsets added).
    /// An error is rank-local and recoverable (the step is cut back), e.g. a failed projection.
    fn update(&mut self, u: &[f64]) -> Result<(), String>;

    /// The blocks the state of the last [`update`](Self::update) needs, sorted.
    fn needed_blocks(&self) -> Vec<Block>;

    /// The blocks a new pattern reserves: those needed now and a band of `ring` neighbours around
    /// them, so that the pattern survives small changes of the coupling. Sorted.
    fn band_blocks(&mut self, ring: usize) -> Vec<Block>;

    /// Global unknowns of the interface the set joins at its last [`update`](Self::update) (any
    /// rank's; negative entries are ignored), for the iterative route's interface correction
    /// (`[solver] preconditioner = "gamg_interface"`). Default: none.
    fn interface_dofs(&self) -> Vec<i32> {
        Vec::new()
    }

    /// Whether this rank evaluates `block` (a pattern from another rank, e.g. a restart, is
    /// filtered by it).
    fn owns_block(&self, block: &Block) -> bool;

    /// Why `block` names no block of this set (an index beyond its passes or elements), for a
    /// pattern read from a checkpoint; `Ok` for every block the set itself produces.
    fn check_block(&self, _block: &Block) -> Result<(), String> {
        Ok(())
    }

    /// Global row and column unknowns of `block` (negative: none); its entries in the sink are
    /// row-major `[rows][cols]`.
    fn block_dofs(&self, block: &Block) -> (Vec<i32>, Vec<i32>);

    /// Adds the residual of this rank's part of the set to `f_local` (this rank's ghosted local
    /// vector) and, with `jac`, each block's entries to the sink at the slot `slot_of` gives it.
    /// Uses the state of the last [`update`](Self::update).
    fn evaluate(&mut self, f_local: &mut [f64], jac: Option<(&mut dyn MatrixSink, &SlotOf)>);

    /// The deepest penetration of this rank's part of the set at the last
    /// [`evaluate`](Self::evaluate), with what it belongs to (contact: the pair and the surface
    /// whose point it is); `None` when nothing penetrates.
    fn deepest(&self) -> Option<(f64, String)> {
        None
    }

    /// Residual entries on [`nodes`](Self::nodes) ([n][dim]) that `evaluate` could not put in
    /// `f_local` because this rank may not hold those nodes (contact's one-pass master surfaces);
    /// the assembler adds them through the gather's reverse scatter. `None`: there are none.
    fn node_residual(&self) -> Option<&[f64]>;

    /// Global nodes on which this rank's part of the set may put a force.
    fn loaded_nodes(&self) -> Vec<u32>;

    /// The current state is a converged load step.
    fn commit(&mut self);

    /// The current state is an intermediate point of a solver device (e.g. the damped rescue): keep
    /// warm starts, not load-step history.
    fn commit_intermediate(&mut self);

    /// Back to the state of the last [`commit`](Self::commit).
    fn rollback(&mut self);

    /// Whether the set does anything after a converged solve ([`augment`](Self::augment):
    /// contact: an augmented pair, or 3D segments to place again). The same on every rank; cheap,
    /// unlike [`augmentation_violations`](Self::augmentation_violations).
    fn augments(&self) -> bool {
        false
    }

    /// Augmented Lagrangian: this rank's largest constraint violation per group of the set
    /// (contact: per pair) at the last evaluation; empty when the set does not augment.
    fn augmentation_violations(&self) -> Vec<f64> {
        Vec::new()
    }

    /// Whether the set, after a converged solve, may change its discretisation for another solve
    /// and does nothing else in [`augment`](Self::augment) (contact: 3D segments, placed again
    /// where the converged state moved them, and no augmented pair): the solver may then let the
    /// first solve of a step stop short of its tolerance, have the set placed there, and solve on
    /// (`crate::solver::settle`).
    fn places_after_solve(&self) -> bool {
        false
    }

    /// After a converged solve, with the violations max-reduced over every rank and the rounds
    /// this step has made: accept, update the multipliers for another solve, or give up.
    fn augment(&mut self, _violations: &[f64], _rounds: usize) -> Augment {
        Augment::Satisfied
    }

    /// After an [`update`](Self::update): `[moved, missed]`, whether the data this rank holds no
    /// longer covers what its part of the set may need (`moved`: something moved past the margin
    /// of the last refresh; `missed`: the update needed data it does not hold and must be
    /// repeated after a refresh). The assembler max-reduces it over the ranks and, if either is
    /// set anywhere, refreshes ([`reach`](Self::reach), [`answer`](Self::answer),
    /// [`adopt`](Self::adopt)), rebuilds the gather on the new [`nodes`](Self::nodes) and updates
    /// again. `[0, 0]`: a set whose nodes never change.
    fn ghost_status(&self) -> [u8; 2] {
        [0, 0]
    }

    /// What this rank's part needs, as values the other ranks' [`answer`](Self::answer) reads
    /// (contact: boxes); all-gathered.
    fn reach(&self) -> Vec<f64> {
        Vec::new()
    }

    /// What this rank sends a rank whose [`reach`](Self::reach) is `reach` (contact: the ids of
    /// its own surface elements inside it); sent point to point.
    fn answer(&self, _reach: &[f64]) -> Vec<u32> {
        Vec::new()
    }

    /// Takes the other ranks' answers (concatenated); `moved` as reduced from
    /// [`ghost_status`](Self::ghost_status). [`nodes`](Self::nodes) may change.
    fn adopt(&mut self, _answers: &[u32], _moved: bool) {}

    /// The set as [`Any`], for the driver to reach its concrete type (results, checkpoints).
    fn as_any(&self) -> &dyn Any;

    /// See [`as_any`](Self::as_any).
    fn as_any_mut(&mut self) -> &mut dyn Any;
}
