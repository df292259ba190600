//! The coupling set beside the element sets (contact pairs, see [`CouplingSet`]): the gather of
//! its nodes' displacement (rebuilt when the set refreshes which nodes it holds), its blocks in the
//! sparsity pattern, and the pattern's rebuild between Newton solves when the needed blocks leave
//! the reserved band.
//!
//! The gather's node list may change in a *refresh* (contact: the ghost layer of partner surface
//! elements, see `crate::contact::system::ghost`): after every update the ranks max-reduce the
//! set's [`CouplingSet::ghost_status`]; if any rank asks, every rank all-gathers the sets' reach
//! (boxes), answers every other rank point to point (element ids), adopts the answers, and builds a
//! new scatter on the new node list, then gathers and updates again. Every update runs on every
//! rank together (each starts with the collective gather), so the scatter, a collective PETSc
//! object, is rebuilt at a moment all ranks share, inside or outside a Newton solve alike; the
//! sparsity pattern does not depend on the node list.

use super::{fatal, Assembler, MatrixAssembly};
use crate::assembly::coupling_set::{Augment, Block, CouplingSet};
use crate::assembly::{BlockScatter, CouplingRuns};
use crate::petsc::{Matrix, PetscError, PetscInt, ProblemError, Scatter, Snes, Vector};
use mpi::collective::SystemOperation;
use mpi::datatype::{Partition, PartitionMut};
use mpi::traits::*;
use std::time::Instant;

/// The coupling set on this rank and what the assembler keeps for it.
pub(super) struct CouplingHook<'p> {
    pub(super) set: Box<dyn CouplingSet>,
    /// Gathers the displacement of the set's nodes to this rank.
    pub(super) scatter: Scatter<'p>,
    pub(super) u_table: Vector<'p>,
    /// Blocks of the current pattern, sorted; block `i` has COO slot `first_slot + i`, its
    /// entries go where `block_scatter[i]` says.
    pub(super) blocks: Vec<Block>,
    pub(super) first_slot: usize,
    pub(super) block_scatter: Vec<BlockScatter>,
    /// The column patterns of the blocks' rows' runs of COO entries (regions of different keys
    /// share the entries of a matrix entry; see `build_pattern`).
    pub(super) runs: CouplingRuns,
    /// Neighbour rings reserved around the needed blocks (see [`CouplingSet::band_blocks`]).
    pub(super) ring: usize,
    /// A Jacobian since the last pattern needed a coupling outside it.
    pub(super) stale: bool,
    /// Blocks found outside the pattern (each stopped a solve for a rebuild).
    pub(super) missing_blocks: usize,
    /// Blocks the next pattern is built from instead of the current band (a restart).
    pub(super) preset: Option<Vec<Block>>,
    /// Augmentation rounds since the last commit or rollback (this load step's).
    pub(super) rounds: usize,
    /// Values of each gather that other ranks own (what this rank receives per gather, on the
    /// current node list).
    pub(super) remote_values: usize,
    /// Values received over all gathers so far (those repeated after a refresh included).
    pub(super) received_values: usize,
    /// Gathers so far (one per coupling update: residual, Jacobian, pattern refresh), not counting
    /// those repeated after a refresh.
    pub(super) gathers: usize,
    /// Refreshes of the set's node list so far (the same on every rank).
    pub(super) refreshes: usize,
}

/// Refreshes in a row one update may ask for before the run fails (each adds the elements the
/// last one lacked; a walk crosses at most `MAX_WALK` elements).
const MAX_REFRESH_ROUNDS: usize = 100;

impl<'p> Assembler<'p> {
    /// A rigidly coupled node on which this rank's coupling set may put a force, if any: the
    /// rigid coupling's reaction moment counts element forces only, so such overlaps are refused.
    pub fn rigidly_coupled_loaded_node(&self) -> Option<u32> {
        let c = self.coupled.as_ref()?;
        c.set
            .loaded_nodes()
            .into_iter()
            .find(|&n| self.offsets.slot(n).is_some())
    }

    /// Adds the coupling set: its nodes' displacement is gathered to this rank before each
    /// evaluation; `ring` neighbour rings are reserved around its needed blocks.
    ///
    /// Collective.
    pub fn set_coupling_set(
        &mut self,
        set: Box<dyn CouplingSet>,
        global_template: &Vector<'p>,
        ring: usize,
    ) -> Result<(), PetscError> {
        let (scatter, u_table, remote_values) = self.gather_of(set.as_ref(), global_template)?;
        self.coupled = Some(CouplingHook {
            set,
            scatter,
            u_table,
            blocks: Vec::new(),
            first_slot: 0,
            block_scatter: Vec::new(),
            runs: CouplingRuns::new(),
            ring,
            stale: false,
            missing_blocks: 0,
            preset: None,
            rounds: 0,
            remote_values,
            received_values: 0,
            gathers: 0,
            refreshes: 0,
        });
        self.pattern_ready = false;
        Ok(())
    }

    /// The gather of `set`'s nodes from vectors laid out as `global`: its scatter, the sequential
    /// vector it fills, and how many of its values other ranks own.
    ///
    /// Collective.
    fn gather_of(
        &self,
        set: &dyn CouplingSet,
        global: &Vector,
    ) -> Result<(Scatter<'p>, Vector<'p>, usize), PetscError> {
        let idx: Vec<PetscInt> = self.dofs.gather_indices(set.nodes());
        let (lo, hi) = self.dofs.owned_range();
        // constrained unknowns gather a dummy entry; count the free ones other ranks own
        let dofs = &self.dofs;
        let remote_values = set
            .nodes()
            .iter()
            .flat_map(|&a| (0..dofs.dim).filter_map(move |c| dofs.global(a, c)))
            .filter(|g| !(lo..hi).contains(&g.0))
            .count();
        let u_table = Vector::new_seq(self.petsc, idx.len())?;
        let scatter = Scatter::new(self.petsc, global, &u_table, &idx)?;
        Ok((scatter, u_table, remote_values))
    }

    /// The refresh of the coupling set's node list (module doc), with `moved` as reduced over the
    /// ranks; the gather is rebuilt on the new list, laid out as `x`.
    ///
    /// Collective.
    fn refresh_coupling_nodes(&mut self, x: &Vector, moved: bool) -> Result<(), PetscError> {
        let comm = self.petsc.comm();
        let (size, rank) = (comm.size() as usize, comm.rank() as usize);
        let Some(c) = &mut self.coupled else {
            return Ok(());
        };
        // every rank's reach (a leading entry keeps every contribution non-empty)
        let mut mine = vec![0.0];
        mine.extend(c.set.reach());
        let n = mine.len() as i32;
        let mut counts = vec![0i32; size];
        comm.all_gather_into(&n, &mut counts[..]);
        let displs: Vec<i32> = counts
            .iter()
            .scan(0, |acc, &k| {
                let d = *acc;
                *acc += k;
                Some(d)
            })
            .collect();
        let mut reach = vec![0.0; counts.iter().sum::<i32>() as usize];
        {
            let mut part = PartitionMut::new(&mut reach[..], &counts[..], &displs[..]);
            comm.all_gather_varcount_into(&mine[..], &mut part);
        }
        // this rank's answer to every other rank (each with a leading entry)
        let mut send: Vec<u32> = Vec::new();
        let mut send_counts = vec![0i32; size];
        for q in 0..size {
            let first = send.len();
            send.push(0);
            if q != rank {
                let (a, b) = (displs[q] as usize + 1, (displs[q] + counts[q]) as usize);
                send.extend(c.set.answer(&reach[a..b]));
            }
            send_counts[q] = (send.len() - first) as i32;
        }
        let mut recv_counts = vec![0i32; size];
        comm.all_to_all_into(&send_counts[..], &mut recv_counts[..]);
        let offsets = |v: &[i32]| -> Vec<i32> {
            v.iter()
                .scan(0, |acc, &k| {
                    let d = *acc;
                    *acc += k;
                    Some(d)
                })
                .collect()
        };
        let (sd, rd) = (offsets(&send_counts), offsets(&recv_counts));
        let mut recv = vec![0u32; recv_counts.iter().sum::<i32>() as usize];
        {
            let sp = Partition::new(&send[..], &send_counts[..], &sd[..]);
            let mut rp = PartitionMut::new(&mut recv[..], &recv_counts[..], &rd[..]);
            comm.all_to_all_varcount_into(&sp, &mut rp);
        }
        let mut answers = Vec::with_capacity(recv.len());
        for q in 0..size {
            let (a, b) = (rd[q] as usize + 1, (rd[q] + recv_counts[q]) as usize);
            answers.extend_from_slice(&recv[a..b]);
        }
        let mut set = self.coupled.take().expect("checked above");
        set.set.adopt(&answers, moved);
        let built = self.gather_of(set.set.as_ref(), x);
        let out = built.map(|(scatter, u_table, remote)| {
            set.scatter = scatter;
            set.u_table = u_table;
            set.remote_values = remote;
            set.refreshes += 1;
        });
        self.coupled = Some(set);
        out
    }

    /// Before a Newton solve from `x`: if the blocks needed at `x` (or those a Jacobian of the
    /// last solves needed) are not all in the sparsity pattern, builds a new pattern reserving a
    /// band around them, on a new matrix that replaces `jac` (and, in `snes`, the matrix the last
    /// solves used, which is freed before the new pattern is built to keep the peak memory of a
    /// rebuild down: [`Snes::release_operators`]). PETSc's COO preallocation is set once
    /// per matrix (setting it again on a parallel matrix corrupted memory in PETSc 3.18), and
    /// never inside a Newton solve. Returns whether the pattern was rebuilt.
    ///
    /// Collective.
    pub fn refresh_pattern(
        &mut self,
        x: &Vector,
        jac: &mut Matrix<'p>,
        snes: &mut Snes<'p>,
    ) -> Result<bool, PetscError> {
        if self.coupled.is_none() {
            return Ok(false);
        }
        // a failed projection here only means the solve will cut back; the pattern uses the rest
        let _ = self.coupling_update(x);
        let need = match &self.coupled {
            Some(c) => {
                !self.pattern_ready
                    || c.stale
                    || c.set
                        .needed_blocks()
                        .iter()
                        .any(|b| c.blocks.binary_search(b).is_err())
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
        let next = Matrix::new_aij(self.petsc, self.dofs.n_owned())?;
        snes.release_operators(&next)?;
        *jac = next;
        if self.pattern_ready {
            self.timers.pattern_rebuilds += 1;
        }
        self.timers.pattern += t0.elapsed().as_secs_f64();
        self.build_pattern(jac)?;
        if let Some(c) = &mut self.coupled {
            c.stale = false;
        }
        Ok(true)
    }

    /// The coupling set, as its concrete type `T` (`None`: no set, or one of another type).
    pub fn coupling_set<T: CouplingSet>(&self) -> Option<&T> {
        let set: &dyn CouplingSet = self.coupled.as_ref()?.set.as_ref();
        set.as_any().downcast_ref::<T>()
    }

    /// The coupling set, as its concrete type `T`, to import its state (checkpoints).
    pub fn coupling_set_mut<T: CouplingSet>(&mut self) -> Option<&mut T> {
        let set: &mut dyn CouplingSet = self.coupled.as_mut()?.set.as_mut();
        set.as_any_mut().downcast_mut::<T>()
    }

    /// Pattern statistics of this rank's coupling set: (ring, blocks left out of Jacobians).
    pub fn coupling_pattern_stats(&self) -> Option<(usize, usize)> {
        self.coupled.as_ref().map(|c| (c.ring, c.missing_blocks))
    }

    /// The coupling blocks of the current sparsity pattern, if it is built and still holds every
    /// block the last Jacobian needed (checkpoints: a restart rebuilds the same pattern, so the
    /// matrix and its factorisation, and hence the round-off, are the same).
    pub fn coupling_pattern(&self) -> Option<&[Block]> {
        let c = self.coupled.as_ref()?;
        (self.pattern_ready && !c.stale).then_some(&c.blocks[..])
    }

    /// The coupling set's gathers: values other ranks own received over all gathers, gathers so
    /// far (not counting those repeated after a refresh), refreshes of the node list.
    pub fn coupling_traffic(&self) -> Option<(usize, usize, usize)> {
        self.coupled
            .as_ref()
            .map(|c| (c.received_values, c.gathers, c.refreshes))
    }

    /// The blocks the next pattern is built from (a restart: those of
    /// [`coupling_pattern`](Self::coupling_pattern) on every rank; this rank keeps its own).
    /// An error names the first block that names none of the set's (a corrupt checkpoint).
    pub fn preset_coupling_pattern(&mut self, all: &[Block]) -> Result<(), String> {
        if let Some(c) = &mut self.coupled {
            for (i, b) in all.iter().enumerate() {
                c.set
                    .check_block(b)
                    .map_err(|why| format!("coupling {i} {b:?}: {why}"))?;
            }
            let mut own: Vec<Block> = all
                .iter()
                .copied()
                .filter(|b| c.set.owns_block(b))
                .collect();
            own.sort_unstable();
            own.dedup();
            c.preset = Some(own);
            self.pattern_ready = false;
        }
        Ok(())
    }

    /// Gathers the displacement of the coupling set's nodes and updates the set there (contact:
    /// projects every point of this rank). A failed update is a rank-local domain error.
    ///
    /// Collective.
    pub(super) fn coupling_update(&mut self, x: &Vector) -> Result<(), ProblemError> {
        if self.coupled.is_none() {
            return Ok(());
        }
        let t0 = Instant::now();
        let mut rounds = 0;
        let out = loop {
            let out = self.gather_and_update(x, rounds == 0);
            let status = match (&self.coupled, &out) {
                (Some(c), Ok(_) | Err(ProblemError::Domain(_))) => c.set.ghost_status(),
                _ => [0, 0],
            };
            let mut any = [0u8; 2];
            self.petsc
                .comm()
                .all_reduce_into(&status[..], &mut any[..], SystemOperation::max());
            if any == [0, 0] {
                break out;
            }
            rounds += 1;
            if rounds > MAX_REFRESH_ROUNDS {
                break Err(ProblemError::Fatal(format!(
                    "the coupling set still lacks data after {MAX_REFRESH_ROUNDS} refreshes of its \
                     nodes (contact: the ghost layer)"
                )));
            }
            let t1 = Instant::now();
            self.refresh_coupling_nodes(x, any[0] != 0).map_err(fatal)?;
            self.timers.contact_refresh += t1.elapsed().as_secs_f64();
        };
        self.timers.contact += t0.elapsed().as_secs_f64();
        out
    }

    /// One gather of the coupling set's nodes at `x` and the set's update there (`count`: an
    /// evaluation's first, not one repeated after a refresh).
    fn gather_and_update(&mut self, x: &Vector, count: bool) -> Result<(), ProblemError> {
        let Some(c) = &mut self.coupled else {
            return Ok(());
        };
        c.scatter.gather(x, &mut c.u_table).map_err(fatal)?;
        c.gathers += count as usize;
        c.received_values += c.remote_values;
        let u = c.u_table.read().map_err(fatal)?;
        let u: &[f64] = if self.offsets.is_empty() {
            &u
        } else {
            let dim = self.dofs.dim;
            self.u_table_off.clear();
            self.u_table_off.extend_from_slice(&u);
            for (t, &n) in c.set.nodes().iter().enumerate() {
                if let Some(s) = self.offsets.slot(n) {
                    for k in 0..dim {
                        self.u_table_off[t * dim + k] += self.offsets.value(s, k);
                    }
                }
            }
            &self.u_table_off
        };
        let t0 = Instant::now();
        let out = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| c.set.update(u)));
        self.timers.contact_update += t0.elapsed().as_secs_f64();
        match out {
            Ok(Ok(())) => Ok(()),
            Ok(Err(msg)) => Err(ProblemError::Domain(msg)),
            Err(_) => Err(ProblemError::Fatal(
                "panic in the coupling set's update (the contact search)".into(),
            )),
        }
    }

    /// Updates the coupling set at `x` and agrees on the outcome. In a Jacobian evaluation, a
    /// block outside the sparsity pattern (contact: a point whose partner element moved beyond the
    /// reserved band) is left out of that Jacobian and marks the pattern outdated; the solve stops
    /// after that Newton step ([`crate::petsc::NonlinearProblem::stop_requested`]) and the load stepping
    /// rebuilds the pattern on a new matrix and continues Newton from the iterate reached
    /// ([`Assembler::pattern_outdated`]); the pattern is never changed inside a solve.
    ///
    /// Collective.
    pub(super) fn prepare_couplings(
        &mut self,
        x: &Vector,
        jacobian: bool,
    ) -> Result<(), ProblemError> {
        if self.coupled.is_none() {
            return Ok(());
        }
        let cu = self.coupling_update(x);
        self.agree(cu)?;
        if !jacobian || !self.pattern_ready {
            return Ok(());
        }
        if self.mode == MatrixAssembly::Preallocated {
            return Err(ProblemError::Fatal(
                "contact needs the COO assembly path (drop --matsetvalues)".into(),
            ));
        }
        // Blocks outside the pattern are left out of this Jacobian (the sink has no slot for
        // them): the Newton step is taken with the rest, and the solve stops after it
        // (`stop_requested`) for the pattern to be rebuilt between solves.
        let missing = match &self.coupled {
            Some(c) => {
                let needed = c.set.needed_blocks();
                let outside = |b: &&Block| c.blocks.binary_search(b).is_err();
                let missing = needed.iter().filter(outside).count();
                if missing > 0 && debug_pattern() {
                    let out: Vec<_> = needed.iter().filter(outside).collect();
                    // of them, blocks of an element with blocks in the pattern (a point slid
                    // beyond the band rather than arriving from beyond the search distance)
                    let slid = out
                        .iter()
                        .filter(|b| {
                            let i = c.blocks.partition_point(|p| (p.0, p.1) < (b.0, b.1));
                            c.blocks.get(i).is_some_and(|p| (p.0, p.1) == (b.0, b.1))
                        })
                        .count();
                    eprintln!(
                        "pattern: {missing} of {} needed blocks outside the pattern ({slid} of \
                         elements with blocks in it), e.g. {:?}",
                        needed.len(),
                        &out[..out.len().min(6)]
                    );
                }
                missing
            }
            None => 0,
        };
        let mut any = 0u64;
        self.petsc
            .comm()
            .all_reduce_into(&(missing as u64), &mut any, SystemOperation::max());
        if any > 0 {
            if let Some(c) = &mut self.coupled {
                c.stale = true;
                c.missing_blocks += missing;
            }
        }
        Ok(())
    }

    /// True when the last solve stopped because the needed blocks left the sparsity pattern (the
    /// same on every rank): rebuild it ([`Assembler::refresh_pattern`]) and continue.
    pub fn pattern_outdated(&self) -> bool {
        self.coupled.as_ref().is_some_and(|c| c.stale)
    }
}

/// Augmented Lagrangian rounds after a converged solve (contact: see
/// `crate::contact::system::augment`).
impl Assembler<'_> {
    /// After a converged Newton solve at `x`: re-evaluates the coupling set there, reduces its
    /// constraint violations over every rank and lets it decide (see [`CouplingSet::augment`]).
    /// The same answer on every rank.
    ///
    /// Collective.
    pub fn augment(&mut self, x: &Vector) -> Augment {
        // the same on every rank (the set's groups are replicated): no communication when off
        if self.coupled.as_ref().is_none_or(|c| !c.set.augments()) {
            return Augment::Satisfied;
        }
        // the gaps and pressures at `x` itself (the last evaluation of the solve is there, but
        // make sure)
        let cu = self.coupling_update(x);
        let ok = self.agree(cu).is_ok() && {
            let local = self.guarded_loop(x, None);
            self.agree(local).is_ok()
        };
        if !ok {
            return Augment::Exhausted(
                "the converged state could not be evaluated for the augmented Lagrangian update"
                    .into(),
            );
        }
        let Some(c) = &mut self.coupled else {
            return Augment::Satisfied;
        };
        let local = c.set.augmentation_violations();
        let mut global = vec![0.0; local.len()];
        self.petsc
            .comm()
            .all_reduce_into(&local[..], &mut global[..], SystemOperation::max());
        let out = c.set.augment(&global, c.rounds);
        if out == Augment::Updated {
            c.rounds += 1;
        }
        out
    }

    /// Whether the coupling set's rounds after a converged solve only change its discretisation
    /// ([`CouplingSet::places_after_solve`]; the same on every rank).
    pub fn places_after_solve(&self) -> bool {
        self.coupled
            .as_ref()
            .is_some_and(|c| c.set.places_after_solve())
    }

    /// Augmentation rounds of the current load step so far (0 without augmentation).
    pub fn augmentation_rounds(&self) -> usize {
        self.coupled.as_ref().map_or(0, |c| c.rounds)
    }
}

/// True when `NURBS_CONTACT_DEBUG_PATTERN` is set (read once): each Jacobian that lacks coupling
/// blocks prints them.
fn debug_pattern() -> bool {
    static ON: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    *ON.get_or_init(|| std::env::var_os("NURBS_CONTACT_DEBUG_PATTERN").is_some())
}
