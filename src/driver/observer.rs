//! The step observer: Newton statistics, the step log, history rows, results and checkpoints of
//! every converged step, progress.

use super::gather::gather_rows;
use super::output::{contact_history, Output};
use super::{agree, comm_rank, log, Error, Verbosity};
use crate::assembly::Assembler;
use crate::contact::ContactSystem;
use crate::io::{self};
use crate::model::Model;
use crate::petsc::{Petsc, Vector};
use crate::scene::Case;
use crate::solver::{AfterStep, StepRecord};
use mpi::collective::SystemOperation;
use mpi::traits::*;
use std::io::IsTerminal;
use std::path::PathBuf;
use std::time::Instant;

/// Watches the load loop: Newton statistics, the step log, history rows and results of every
/// converged step, progress.
pub(super) struct StepObserver<'c, 'p> {
    pub(super) rank: i32,
    pub(super) v: Verbosity,
    pub(super) case: &'c Case,
    pub(super) output: Output<'p>,
    pub(super) bar: Option<indicatif::ProgressBar>,
    pub(super) t_start: Instant,
    pub(super) n_stages: f64,
    pub(super) total_steps: usize,
    pub(super) newton: io::NewtonStats,
    pub(super) step_log: Vec<io::StepLog>,
    /// Wall time spent recording steps (s).
    pub(super) t_output: f64,
    /// The signal that stopped the run, agreed by all ranks.
    pub(super) interrupted: Option<i32>,
    /// Checkpoint after every this many steps.
    pub(super) checkpoint_every: Option<usize>,
    /// Wall time of the run before a restart (s).
    pub(super) wall_offset: f64,
    /// Restarts of this run so far (this process's included).
    pub(super) restarts: usize,
    /// The mesh files this run read, hashed when it started (for its checkpoints).
    pub(super) mesh_hashes: Vec<(String, String, String)>,
    /// Rigid-partner half-passes (in the contact system's order) already warned of a control
    /// point inside the partner with no active contact point.
    pub(super) unseen_warned: Vec<usize>,
    /// Frictional half-passes already warned of a step's slip beyond [`SLIP_PER_STEP`].
    pub(super) slip_warned: Vec<usize>,
}

/// A control point deeper than this fraction of its surface's mean element size inside a rigid
/// partner, while none of the pair's points is active, is warned of.
const UNSEEN_DEPTH: f64 = 0.01;

/// A frictional point that moves tangentially against its partner by more than this many element
/// sizes of its surface within one step is warned of.
const SLIP_PER_STEP: f64 = 1.0;

/// `payload` as held by the lowest rank whose `value` equals `reduced` (the value reduced over all
/// ranks, e.g. their maximum), on every rank. Collective.
fn from_lowest_holder<const N: usize>(
    comm: &mpi::topology::SimpleCommunicator,
    value: f64,
    reduced: f64,
    payload: [f64; N],
) -> [f64; N] {
    let mine = if value == reduced {
        comm.rank()
    } else {
        i32::MAX
    };
    let mut holder = 0i32;
    comm.all_reduce_into(&mine, &mut holder, SystemOperation::min());
    let local = if comm.rank() == holder {
        payload
    } else {
        [0.0; N]
    };
    let mut out = [0.0f64; N];
    comm.all_reduce_into(&local[..], &mut out[..], SystemOperation::sum());
    out
}

/// The deepest point of `d` (this rank's part of a reduced half-pass whose depth over all ranks
/// is `depth`), from the lowest rank that holds it: its node and position [3]. Collective.
fn deepest_point(
    comm: &mpi::topology::SimpleCommunicator,
    d: &crate::contact::system::PassDepth,
    depth: f64,
) -> [f64; 4] {
    let p = d.position;
    from_lowest_holder(comm, d.depth, depth, [d.node as f64, p[0], p[1], p[2]])
}

/// Coordinates as `(x, y[, z])` with five significant digits.
fn coordinates(x: &[f64]) -> String {
    let v: Vec<String> = x.iter().map(|v| format!("{v:.4e}")).collect();
    format!("({})", v.join(", "))
}

impl<'c, 'p> StepObserver<'c, 'p> {
    pub(super) fn new(
        petsc: &Petsc,
        v: Verbosity,
        case: &'c Case,
        output: Output<'p>,
        t_start: Instant,
        checkpoint_every: Option<usize>,
        resumed: Option<&crate::checkpoint::RunLog>,
    ) -> Self {
        let rank = comm_rank(petsc);
        let total_steps: usize = case.stages.iter().map(|s| s.steps).sum();
        let bar =
            (rank == 0 && v == Verbosity::Normal && std::io::stderr().is_terminal()).then(|| {
                let b = indicatif::ProgressBar::new(total_steps as u64);
                b.set_style(
                    indicatif::ProgressStyle::with_template(
                        "{elapsed_precise} [{bar:30}] load {msg}",
                    )
                    .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
                );
                b
            });
        StepObserver {
            rank,
            v,
            case,
            output,
            bar,
            t_start,
            n_stages: case.stages.len() as f64,
            total_steps,
            newton: resumed.map(|l| l.newton).unwrap_or_default(),
            step_log: resumed.map(|l| l.steps.clone()).unwrap_or_default(),
            t_output: 0.0,
            interrupted: None,
            checkpoint_every,
            wall_offset: resumed.map_or(0.0, |l| l.wall_time),
            restarts: resumed.map_or(0, |l| l.restarts + 1),
            mesh_hashes: if rank == 0 && checkpoint_every.is_some() {
                crate::checkpoint::mesh_hashes(case)
            } else {
                Vec::new()
            },
            unseen_warned: Vec::new(),
            slip_warned: Vec::new(),
        }
    }

    /// Rank 0 warns, once per half-pass, of a control point of a contact surface that lies inside
    /// its partner (a rigid shape, or the body of the partner surface) deeper than
    /// [`UNSEEN_DEPTH`] of the surface's element size while none of the pair's points (of either
    /// half-pass) is active: contact that is silently not there (a smooth surface lies inside its control
    /// points and may not reach a partner the mesh goes through). Collective.
    fn warn_unseen_contact(&mut self, model: &Model, asm: &mut Assembler, rec: &StepRecord) {
        let Some(c) = asm.coupling_set::<ContactSystem>() else {
            return;
        };
        // the depths only of the half-passes whose pair has no active point on any rank (the
        // projections of their control points cost a global search each)
        let local = c.pair_active();
        let mut active = vec![0u64; local.len()];
        asm.comm()
            .all_reduce_into(&local[..], &mut active[..], SystemOperation::sum());
        let wanted: Vec<bool> = active
            .iter()
            .enumerate()
            .map(|(i, &a)| a == 0 && !self.unseen_warned.contains(&i))
            .collect();
        if !wanted.contains(&true) {
            return;
        }
        let Some(c) = asm.coupling_set_mut::<ContactSystem>() else {
            return;
        };
        let depths = c.unseen_penetrations(&wanted);
        let comm = asm.comm();
        for (i, d) in depths.into_iter().enumerate() {
            if !wanted[i] {
                continue;
            }
            let mut depth = 0.0f64;
            comm.all_reduce_into(&d.depth, &mut depth, SystemOperation::max());
            if depth <= UNSEEN_DEPTH * d.h {
                continue;
            }
            self.unseen_warned.push(i);
            let point = deepest_point(comm, &d, depth);
            if comm.rank() == 0 {
                let (inside, other) = match &d.partner {
                    None => ("the rigid partner".to_string(), "the partner".to_string()),
                    Some(p) => (
                        format!("the partner surface `{p}` (in its body)"),
                        format!("`{p}`"),
                    ),
                };
                eprintln!(
                    "warning: step {} (load {:.6}): contact `{}`: surface `{}`: {}, now at {}, lies \
                     {depth:.3e} inside {inside} ({:.1} % of the surface's element size) while \
                     no contact point of the pair is active: the pair's points do not reach \
                     {other} there and nothing holds the body (the points lie apart from this \
                     node, and a smooth surface lies inside its control points; a finer surface \
                     mesh brings them closer to it)",
                    rec.step,
                    rec.load,
                    d.pair,
                    d.surface,
                    model.node_label(point[0] as u32),
                    coordinates(&point[1..1 + self.case.case.dim]),
                    100.0 * depth / d.h
                );
            }
        }
    }

    /// Rank 0 warns of each half-pass whose surface starts (reference configuration, rigid
    /// partners at load 0) deeper than [`UNSEEN_DEPTH`] of its element size inside its partner,
    /// naming the pair, the surface and the deepest point with its element's closest node. Before
    /// the first step of a run that does not restart. Collective.
    pub(super) fn warn_initial_penetrations(&self, model: &Model, asm: &mut Assembler) {
        let Some(c) = asm.coupling_set_mut::<ContactSystem>() else {
            return;
        };
        let depths = c.initial_penetrations();
        let comm = asm.comm();
        for d in depths {
            let mut depth = 0.0f64;
            comm.all_reduce_into(&d.depth, &mut depth, SystemOperation::max());
            if depth <= UNSEEN_DEPTH * d.h {
                continue;
            }
            let point = deepest_point(comm, &d, depth);
            if comm.rank() == 0 {
                let inside = match &d.partner {
                    None => "the rigid partner".to_string(),
                    Some(p) => format!("the partner surface `{p}` (in its body)"),
                };
                eprintln!(
                    "warning: load 0: contact `{}`: surface `{}` starts {depth:.3e} inside \
                     {inside} ({:.1} % of the surface's element size), deepest at {} next to {}: \
                     the first step has to push the bodies apart by that much before the load \
                     acts, with the contact force of the whole overlap; place the surfaces \
                     touching or apart",
                    d.pair,
                    d.surface,
                    100.0 * depth / d.h,
                    coordinates(&point[1..1 + self.case.case.dim]),
                    model.node_label(point[0] as u32),
                );
            }
        }
    }

    /// Rank 0 warns, once per half-pass, of a converged step in which a point of a frictional
    /// pair moved tangentially against its partner by more than [`SLIP_PER_STEP`] element sizes
    /// of its surface since the last converged step: the return mapping follows the step along
    /// one straight chord, and the stick and slip within it are not resolved. Collective.
    fn warn_step_slip(&mut self, asm: &Assembler, rec: &StepRecord) {
        let Some(c) = asm.coupling_set::<ContactSystem>() else {
            return;
        };
        let comm = asm.comm();
        for (i, s) in c.step_slips().into_iter().enumerate() {
            let mut slip = 0.0f64;
            comm.all_reduce_into(&s.slip, &mut slip, SystemOperation::max());
            if slip <= SLIP_PER_STEP * s.h || self.slip_warned.contains(&i) {
                continue;
            }
            self.slip_warned.push(i);
            let at = from_lowest_holder(comm, s.slip, slip, s.position);
            if comm.rank() == 0 {
                let stage = self.case.stages.get(rec.load.ceil().max(1.0) as usize - 1);
                let advice = match stage {
                    Some(st) => format!(
                        "; give stage `{}` more steps (`stages.{}.steps` = {})",
                        st.name,
                        rec.load.ceil().max(1.0) as usize - 1,
                        st.steps
                    ),
                    None => String::new(),
                };
                eprintln!(
                    "warning: step {} (load {:.6}): contact `{}`: surface `{}`: a frictional \
                     point, now at {}, moved {slip:.3e} tangentially against its partner within \
                     the step, {:.1} times the surface's element size {:.3e}: friction follows \
                     each step along one straight chord, so the stick and slip within this \
                     step are not resolved{advice}",
                    rec.step,
                    rec.load,
                    s.pair,
                    s.surface,
                    coordinates(&at[..self.case.case.dim]),
                    slip / s.h,
                    s.h
                );
            }
        }
    }

    /// Records one converged step. Collective.
    pub(super) fn observe(
        &mut self,
        model: &Model,
        rec: &StepRecord,
        x: &Vector,
        before: Option<&Vector>,
        asm: &mut Assembler,
    ) -> Result<AfterStep, String> {
        let t0 = Instant::now();
        // A signal on any rank stops every rank after this step, which is then written whatever
        // the output schedule says.
        self.interrupted = crate::interrupt::agreed(asm.comm());
        self.newton
            .record(rec.iterations as u32, rec.failed_iterations as u64);
        self.newton.record_linear(
            rec.linear_fallbacks as u64,
            rec.linear_iterations as u64,
            rec.linear_accepted as u64,
        );
        self.step_log.push(io::StepLog {
            step: rec.step,
            load: rec.load,
            iterations: rec.iterations as u32,
            cutbacks: rec.cutbacks as u32,
            residual_history: rec.residual_history.clone(),
            failed_attempts: rec.failed_attempts.clone(),
            pseudo_steps: rec.pseudo_steps,
            failed_iterations: rec.failed_iterations,
            augmentation_rounds: rec.augmentation_rounds,
            linear_fallbacks: rec.linear_fallbacks,
            linear_accepted: rec.linear_accepted,
        });
        let reactions: Vec<f64> = model
            .reactions
            .iter()
            .flat_map(|(_, nodes)| asm.reaction(nodes))
            .collect();
        let mut extra_columns = Vec::new();
        for (_, nodes, center) in &model.reaction_moments {
            let m = asm
                .reaction_moment(nodes, x, &model.coords, *center)
                .map_err(|e| e.to_string())?;
            if model.dim == 2 {
                extra_columns.push(m[2]);
            } else {
                extra_columns.extend_from_slice(&m);
            }
        }
        extra_columns.extend(contact_history(asm, model.dim));
        self.warn_unseen_contact(model, asm, rec);
        self.warn_step_slip(asm, rec);
        if model
            .contact_pairs
            .iter()
            .any(|p| p.formulation.augmented().is_some())
        {
            extra_columns.push(rec.augmentation_rounds as f64);
        }
        if super::options::linear_route(self.case, &asm.dofs)
            == crate::scene::schema::LinearSolver::Iterative
        {
            extra_columns.push(rec.linear_fallbacks as f64);
        }
        let scheduled = self.scheduled(rec);
        self.output
            .step(
                rec,
                &reactions,
                &extra_columns,
                self.wall_offset + self.t_start.elapsed().as_secs_f64(),
                scheduled,
                x,
                asm,
            )
            .map_err(|e| e.to_string())?;
        if let Some(every) = self.checkpoint_every {
            if rec.step.is_multiple_of(every) || self.interrupted.is_some() {
                // before the interrupt's extra output step below: the checkpoint's copy of the
                // results holds the scheduled steps only, so a restart from it writes what an
                // uninterrupted run writes
                self.checkpoint(model, rec, x, before, asm)
                    .map_err(|e| format!("checkpoint: {e}"))?;
            }
        }
        if self.interrupted.is_some() && !scheduled {
            // the interrupted run's results end with its last converged step, whatever the schedule
            self.output
                .results_step(rec, x, asm, Ok(()))
                .map_err(|e| e.to_string())?;
        }
        self.t_output += t0.elapsed().as_secs_f64();
        self.progress(rec);
        Ok(match self.interrupted {
            Some(_) => AfterStep::Stop,
            None => AfterStep::Continue,
        })
    }

    /// Whether the results hold step `rec` by their schedule: every `output.every`-th step and the
    /// last one.
    fn scheduled(&self, rec: &StepRecord) -> bool {
        (rec.load - self.n_stages).abs() < 1e-12 || rec.step.is_multiple_of(self.case.output.every)
    }

    /// The run was asked to stop within the step after the converged step `rec`, which `x` and
    /// `asm` hold again: that step ends the run as an interrupt after it would have (written to
    /// the results whatever the schedule, and checkpointed with checkpoints on). Collective.
    pub(super) fn stopped_after(
        &mut self,
        model: &Model,
        rec: &StepRecord,
        x: &Vector,
        before: Option<&Vector>,
        asm: &mut Assembler,
    ) -> Result<AfterStep, String> {
        let t0 = Instant::now();
        self.interrupted = crate::interrupt::agreed(asm.comm());
        let scheduled = self.scheduled(rec);
        if let Some(every) = self.checkpoint_every {
            if !rec.step.is_multiple_of(every) {
                self.checkpoint(model, rec, x, before, asm)
                    .map_err(|e| format!("checkpoint: {e}"))?;
            }
        }
        if !scheduled {
            self.output
                .results_step(rec, x, asm, Ok(()))
                .map_err(|e| e.to_string())?;
        }
        self.t_output += t0.elapsed().as_secs_f64();
        Ok(AfterStep::Stop)
    }

    /// Writes a checkpoint of the converged step `rec`: the state gathered to rank 0 in global
    /// numbering, written there with copies of the output so far; `before` is the converged state
    /// before it (kept when the secant predictor will extrapolate from it). Collective.
    pub(super) fn checkpoint(
        &mut self,
        model: &Model,
        rec: &StepRecord,
        x: &Vector,
        before: Option<&Vector>,
        asm: &mut Assembler,
    ) -> Result<(), Error> {
        let t0 = Instant::now();
        let root = self.rank == 0;
        let out = &mut self.output;
        let mut gathered = |v: &Vector| -> Result<Vec<f64>, Error> {
            out.gather.gather(v, &mut out.u_root)?;
            Ok(if root {
                out.u_root.read()?.to_vec()
            } else {
                Vec::new()
            })
        };
        let displacement = gathered(x)?;
        // the same on every rank: the position is the load stepping's, `before` its vector
        let mut position = rec.position;
        let displacement_before = match before {
            Some(b) if position.predictor.last.is_some() => gathered(b)?,
            _ => {
                position.predictor.last = None;
                Vec::new()
            }
        };
        let comm = asm.comm();
        // element history per cell, each rank filling its own cells, summed on rank 0
        let local_width = asm
            .sets
            .iter()
            .map(|s| s.history_width())
            .max()
            .unwrap_or(0);
        let mut width = 0usize;
        comm.all_reduce_into(&local_width, &mut width, SystemOperation::max());
        let n_cells = model.n_cells();
        let mut history = vec![0.0; n_cells * width];
        for set in &asm.sets {
            let hw = set.history_width();
            for e in 0..set.len() {
                let (body, cell) = set.cell_id(e);
                let g = out.cell_offset[body] + cell;
                history[g * width..g * width + hw].copy_from_slice(set.history(e));
            }
        }
        let mut element_history = vec![0.0; if root { history.len() } else { 0 }];
        if width > 0 {
            let r = comm.process_at_rank(0);
            if root {
                r.reduce_into_root(
                    &history[..],
                    &mut element_history[..],
                    SystemOperation::sum(),
                );
            } else {
                r.reduce_into(&history[..], SystemOperation::sum());
            }
        }
        let contact_points = match asm.coupling_set::<ContactSystem>() {
            Some(c) => gather_rows(comm, &c.export_points()),
            None => Vec::new(),
        };
        // the contact sparsity pattern, if every rank has a current one
        let pattern = asm.coupling_pattern();
        let (have, mut all) = (i32::from(pattern.is_some()), 0i32);
        comm.all_reduce_into(&have, &mut all, SystemOperation::min());
        let contact_pattern = if asm.coupling_set::<ContactSystem>().is_some() && all == 1 {
            let rows: Vec<f64> = pattern
                .unwrap_or_default()
                .iter()
                .flat_map(|&(p, e, l)| [p as f64, e as f64, l as f64])
                .collect();
            gather_rows(comm, &rows)
        } else {
            Vec::new()
        };
        let local = if root {
            let state = crate::checkpoint::State {
                case_toml: out.case_toml.clone(),
                position,
                displacement,
                displacement_before,
                element_history,
                element_history_width: width,
                contact_points,
                contact_pattern,
                ranks: comm.size() as usize,
                log: crate::checkpoint::RunLog {
                    newton: self.newton,
                    steps: self.step_log.clone(),
                    wall_time: self.wall_offset + self.t_start.elapsed().as_secs_f64(),
                    results_layout: out.results.as_ref().map(|r| r.layout()).unwrap_or_default(),
                    restarts: self.restarts,
                    mesh_hashes: self.mesh_hashes.clone(),
                },
            };
            let results = match &out.results {
                Some(r) => {
                    r.flush()?;
                    Some(r.partial_file().to_path_buf())
                }
                None => None,
            };
            let history_file = out.out_dir.join("history.csv");
            crate::checkpoint::write(
                &out.checkpoint_dir,
                &state,
                results.as_deref(),
                &history_file,
            )
            .map_err(Error::from)
        } else {
            Ok((PathBuf::new(), 0))
        };
        let (dir, bytes) = agree(comm, local)?;
        let secs = t0.elapsed().as_secs_f64();
        self.t_output += secs;
        log(self.rank, self.v, Verbosity::Verbose, || {
            format!(
                "checkpoint after step {}: {} ({:.3} MB) in {secs:.3} s",
                rec.step,
                dir.display(),
                bytes as f64 / 1e6
            )
        });
        Ok(())
    }

    /// The progress bar, or without one (not a terminal, or -v) one plain line per step; with -v
    /// the line also carries the Newton residual history of the step, after a line per cutback.
    pub(super) fn progress(&self, rec: &StepRecord) {
        let (rank, v) = (self.rank, self.v);
        if let Some(b) = &self.bar {
            b.set_position(((rec.load / self.n_stages) * self.total_steps as f64).round() as u64);
            b.set_message(format!(
                "{:.4} | step {} | {} it | |F| {:.2e}",
                rec.load, rec.step, rec.iterations, rec.residual
            ));
        }
        for (load, why) in &rec.failed_attempts {
            log(rank, v, Verbosity::Verbose, || {
                format!("  cutback: load {load:.6} failed: {why}")
            });
        }
        if self.bar.is_none() {
            log(rank, v, Verbosity::Normal, || {
                let mut line = format!(
                    "step {:4}  stage {}  load {:.6}  newton {:2}  |F| {:.3e}  cutbacks {}",
                    rec.step, rec.stage, rec.load, rec.iterations, rec.residual, rec.cutbacks
                );
                if rec.pseudo_steps > 0 {
                    line += &format!("  (rescued by {} damped pseudo-steps)", rec.pseudo_steps);
                }
                if v >= Verbosity::Verbose {
                    let h: Vec<String> = rec
                        .residual_history
                        .iter()
                        .map(|r| format!("{r:.2e}"))
                        .collect();
                    line += &format!("  history [{}]", h.join(" "));
                }
                line
            });
        }
    }
}
