//! `summary.json`: what a finished (or failed) run did, for scripts and studies. Written atomically.

use crate::io::atomic::write_atomic;
use crate::io::IoError;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// Newton statistics over the converged steps.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct NewtonStats {
    /// Converged load steps.
    pub steps: usize,
    /// Newton iterations summed over all converged steps (iterations of cut-back attempts excluded).
    pub total_iterations: u64,
    /// Largest number of Newton iterations one converged step needed.
    pub max_iterations_per_step: u32,
    /// Newton iterations of the attempts that failed and were cut back (not in `total_iterations`).
    #[serde(default)]
    pub failed_iterations: u64,
    /// Steps retried with the direct solver after an iterative linear solve failed (`[solver]
    /// linear = "iterative"`), counted once per retry.
    #[serde(default)]
    pub linear_fallbacks: u64,
    /// Linear (Krylov) iterations of all Newton solves (converged and failed attempts): divided
    /// by `total_iterations + failed_iterations`, the Krylov iterations per Newton iteration (1
    /// for the direct solver).
    #[serde(default)]
    pub linear_iterations: u64,
    /// Krylov solves stopped by their iteration limit and taken as inexact Newton directions
    /// (`[solver] krylov_accept`), of the converged steps.
    #[serde(default)]
    pub linear_accepted_at_limit: u64,
}

impl NewtonStats {
    /// Account for one converged step's linear solves: its fallbacks to the direct solver, its
    /// Krylov iterations and its solves accepted at the iteration limit.
    pub fn record_linear(&mut self, fallbacks: u64, iterations: u64, accepted_at_limit: u64) {
        self.linear_fallbacks += fallbacks;
        self.linear_iterations += iterations;
        self.linear_accepted_at_limit += accepted_at_limit;
    }

    /// Account for one converged step and the iterations of its failed attempts.
    pub fn record(&mut self, iterations: u32, failed_iterations: u64) {
        self.failed_iterations += failed_iterations;
        self.steps += 1;
        self.total_iterations += u64::from(iterations);
        self.max_iterations_per_step = self.max_iterations_per_step.max(iterations);
    }
}

/// Wall time by phase, seconds (max over ranks is the caller's choice to report).
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct PhaseTimes {
    /// Residual and Jacobian evaluation, including building the sparsity pattern.
    pub assembly: f64,
    /// Of `assembly`: residual evaluations.
    #[serde(default)]
    pub residual: f64,
    /// Of `assembly`: Jacobian evaluations (kernels and matrix insertion).
    #[serde(default)]
    pub jacobian: f64,
    /// Of `assembly`: building sparsity patterns and preallocating.
    #[serde(default)]
    pub pattern: f64,
    /// Of `assembly`: contact (gathering surface displacements, search, projection, contact
    /// residual and tangent blocks).
    #[serde(default)]
    pub contact: f64,
    pub solve: f64,
    pub output: f64,
    /// The whole run's wall time, including the parts before any restart (the phase times above
    /// are this process's only).
    pub total: f64,
    /// Of `total`: the parts before the last restart (0 for a run that was not restarted).
    #[serde(default)]
    pub before_restart: f64,
}

/// One converged load step in the summary.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StepLog {
    /// Step number, from 1.
    pub step: usize,
    /// Load parameter reached.
    pub load: f64,
    /// Newton iterations.
    pub iterations: u32,
    /// Failed attempts before convergence.
    pub cutbacks: u32,
    /// Residual norm before each Newton iteration and after the last.
    pub residual_history: Vec<f64>,
    /// Attempts cut back before the step converged: `[load tried, reason]`.
    #[serde(default)]
    pub failed_attempts: Vec<(f64, String)>,
    /// Damped pseudo-steps that rescued the step (0: a plain Newton solve).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub pseudo_steps: usize,
    /// Newton iterations of the failed attempts (not in `iterations`).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub failed_iterations: usize,
    /// Augmented Lagrangian rounds of the converged attempt (absent: none).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub augmentation_rounds: usize,
    /// Retries of the step with the direct solver after an iterative linear solve failed.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub linear_fallbacks: usize,
    /// Krylov solves stopped by their iteration limit and taken as inexact Newton directions.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub linear_accepted: usize,
}

fn is_zero(n: &usize) -> bool {
    *n == 0
}

/// How the run ended: `"status": "converged"`, `"status": "failed", "reason": "..."` or
/// `"status": "interrupted", "signal": "SIGINT", "converged_steps": N`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "status", rename_all = "lowercase")]
pub enum RunStatus {
    Converged,
    Failed {
        reason: String,
    },
    /// Stopped by a signal after `converged_steps` steps, all of them recorded.
    Interrupted {
        signal: String,
        converged_steps: usize,
    },
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Summary {
    /// `[case].name`.
    pub case: String,
    /// `git describe --always --dirty` of the code, passed in by the caller.
    pub git_revision: String,
    pub ranks: usize,
    /// Global number of unknowns (free dofs).
    pub unknowns: u64,
    pub elements: u64,
    pub newton: NewtonStats,
    /// The linear solver that ran: `"direct"` or `"iterative"` (`[solver] linear`, `"auto"`
    /// resolved).
    #[serde(default)]
    pub linear_solver: String,
    /// How many times the run was continued from a checkpoint (`run --restart`).
    #[serde(default)]
    pub restarts: usize,
    pub wall_time: PhaseTimes,
    /// Peak resident memory of rank 0 as PETSc measured it (MB).
    pub peak_memory_mb: f64,
    /// Contact sparsity pattern: (re)builds between Newton solves, and coupling blocks that
    /// Jacobians left out because the pattern lacked them (summed over ranks). Absent without contact.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub contact_pattern: Option<ContactPatternStats>,
    /// What each rank holds for contact and receives per evaluation. Absent without contact.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub contact_data: Option<ContactDataStats>,
    /// How the cells were split between the ranks. Absent on one rank.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub partition: Option<PartitionStats>,
    /// Each rank's own assembly timers (`wall_time` holds the slowest rank's), to show load
    /// imbalance. Absent in summaries written before it existed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rank_times: Option<RankTimes>,
    /// One entry per converged load step, with its Newton residual history.
    pub steps: Vec<StepLog>,
    #[serde(flatten)]
    pub status: RunStatus,
}

/// Contact sparsity pattern statistics of a run.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ContactPatternStats {
    /// Patterns built after the first (each on a new matrix, between Newton solves).
    pub rebuilds: usize,
    /// Coupling blocks left out of Jacobians (summed over ranks and Jacobians).
    pub missing_blocks: usize,
    /// Side-neighbour rings reserved around each point's partner element.
    pub ring: usize,
    /// COO entries of the largest pattern a rank built (element, contact and diagonal blocks),
    /// summed over ranks: the pattern's memory is about 16 bytes per entry in PETSc's COO
    /// set-up. Absent in summaries written before it existed.
    #[serde(default)]
    pub coo_entries: u64,
    /// Entries of the cells' element matrices (constrained rows included), summed over ranks:
    /// 4 bytes each in the assembler (the COO entry each adds into); the COO pattern holds one
    /// entry per matrix entry that the cells reach, so they are well above the cells' part of
    /// `coo_entries`. Absent in summaries written before it existed.
    #[serde(default)]
    pub cell_entries: u64,
    /// Entries of the contact blocks' shared regions in the largest pattern a rank built, summed
    /// over ranks (neighbouring regions overlap: their entries over `coo_entries` tell by how
    /// much). Absent in summaries written before it existed.
    #[serde(default)]
    pub region_entries: u64,
    /// Columns of the contact rows' column patterns in the largest pattern a rank built, summed
    /// over ranks: each holds the column and its place in the row's run of COO entries (8 bytes);
    /// the rows of a node share a pattern. Absent in summaries written before it existed.
    #[serde(default)]
    pub run_columns: u64,
}

/// What each rank holds for contact and what it receives per evaluation (the measure of
/// distributed contact surfaces). Per-rank lists, in rank order.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct ContactDataStats {
    /// Contact-surface nodes whose displacement the rank gathers before every evaluation.
    pub table_nodes: Vec<u64>,
    /// Bytes of the surfaces as the rank holds them (elements, basis data, node table, current
    /// positions, search grids).
    pub surface_bytes: Vec<u64>,
    /// Bytes of the rank's contact points and their elements (and mortar nets).
    pub point_bytes: Vec<u64>,
    /// Bytes the rank receives from other ranks per gather (8 per value), the mean over the
    /// run's gathers (those repeated after a refresh of the ghost layer included).
    pub received_bytes_per_evaluation: Vec<u64>,
    /// Surface elements of other ranks the rank holds positions of at the end (its ghost layer).
    #[serde(default)]
    pub ghost_elements: Vec<u64>,
    /// Refreshes of the ghost layer over the run (collective: the same on every rank).
    #[serde(default)]
    pub refreshes: Vec<u64>,
    /// Gathers over the run (one per residual, Jacobian and pattern refresh), rank 0's count
    /// (the gather is collective, so every rank's is the same).
    pub evaluations: u64,
}

/// Per-rank wall seconds of the assembly's phases, in rank order. `residual`, `jacobian`,
/// `pattern` and `contact` are the timers of `wall_time` on each rank; `contact` includes the
/// gathers and the agreement after each update, i.e. the wait for the slowest rank, while
/// `contact_update` (search and projection) and `contact_evaluate` (the contact residual and
/// blocks) are the rank's own contact work alone, `contact_refresh` the refreshes of its ghost
/// layer (collective).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RankTimes {
    pub residual: Vec<f64>,
    pub jacobian: Vec<f64>,
    pub pattern: Vec<f64>,
    pub contact: Vec<f64>,
    pub contact_update: Vec<f64>,
    pub contact_evaluate: Vec<f64>,
    #[serde(default)]
    pub contact_refresh: Vec<f64>,
}

/// The cell partition of a run on several ranks (METIS, two constraints with contact).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct PartitionStats {
    /// Cells per rank, in rank order.
    pub cells: Vec<u64>,
    /// Contact quadrature points per rank (the points of the half-passes' surface elements of
    /// its cells), in rank order.
    pub contact_points: Vec<u64>,
    /// Of them, the points of cells whose contact surface faces a partner, per rank: what
    /// `partition = "contact"` balances ([`crate::contact::pair::facing_points`]).
    #[serde(default)]
    pub facing_points: Vec<u64>,
    /// Faces shared by cells of different ranks.
    pub cut_faces: u64,
    /// Which partition ran (`[solver] partition`: "contact" or "cells").
    pub kind: String,
    /// Pairs of cells whose contact surface elements face each other across a pair
    /// ([`crate::contact::pair::facing_cells`]), and how many of them lie on different ranks.
    pub facing_pairs: u64,
    pub cut_facing_pairs: u64,
}

/// Write `dir/summary.json` atomically; returns its path.
pub fn write_summary(dir: &Path, summary: &Summary) -> Result<PathBuf, IoError> {
    let path = dir.join("summary.json");
    let mut text = serde_json::to_string_pretty(summary).map_err(|source| IoError::Json {
        path: path.clone(),
        source,
    })?;
    text.push('\n');
    write_atomic(&path, text.as_bytes())?;
    Ok(path)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(status: RunStatus) -> Summary {
        let mut newton = NewtonStats::default();
        for (it, failed) in [(4, 30), (7, 0), (5, 12)] {
            newton.record(it, failed);
        }
        Summary {
            case: "block_compression_3d".to_string(),
            git_revision: "abc1234-dirty".to_string(),
            ranks: 2,
            unknowns: 375,
            elements: 64,
            newton,
            linear_solver: "direct".to_string(),
            restarts: 0,
            wall_time: PhaseTimes {
                assembly: 1.5,
                residual: 0.5,
                jacobian: 0.75,
                pattern: 0.25,
                solve: 2.25,
                output: 0.125,
                total: 4.0,
                before_restart: 0.0,
                contact: 0.0,
            },
            peak_memory_mb: 54.0,
            contact_pattern: None,
            contact_data: None,
            partition: None,
            rank_times: None,
            steps: vec![StepLog {
                step: 1,
                load: 0.5,
                iterations: 4,
                cutbacks: 1,
                residual_history: vec![1.0, 1e-3, 1e-9],
                failed_attempts: vec![(1.0, "DIVERGED_LINE_SEARCH".into())],
                pseudo_steps: 0,
                failed_iterations: 30,
                augmentation_rounds: 0,
                linear_fallbacks: 0,
                linear_accepted: 0,
            }],
            status,
        }
    }

    #[test]
    fn newton_stats_track_total_and_max() {
        let s = sample(RunStatus::Converged).newton;
        assert_eq!(
            (
                s.steps,
                s.total_iterations,
                s.max_iterations_per_step,
                s.failed_iterations
            ),
            (3, 16, 7, 42)
        );
    }

    #[test]
    fn summary_json_has_flat_status_and_round_trips() {
        let dir = std::env::temp_dir().join(format!("io_summary_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        for status in [
            RunStatus::Converged,
            RunStatus::Failed {
                reason: "step 3: 8 cutbacks exhausted".to_string(),
            },
            RunStatus::Interrupted {
                signal: "SIGTERM".to_string(),
                converged_steps: 2,
            },
        ] {
            let s = sample(status);
            let path = write_summary(&dir, &s).unwrap();
            assert!(!dir.join("summary.json.partial").exists());
            let text = std::fs::read_to_string(&path).unwrap();
            let v: serde_json::Value = serde_json::from_str(&text).unwrap();
            assert_eq!(v["case"], "block_compression_3d");
            assert_eq!(v["newton"]["max_iterations_per_step"], 7);
            assert_eq!(v["wall_time"]["solve"], 2.25);
            match &s.status {
                RunStatus::Converged => {
                    assert_eq!(v["status"], "converged");
                    assert!(v.get("reason").is_none());
                }
                RunStatus::Failed { reason } => {
                    assert_eq!(v["status"], "failed");
                    assert_eq!(v["reason"], reason.as_str());
                }
                RunStatus::Interrupted {
                    signal,
                    converged_steps,
                } => {
                    assert_eq!(v["status"], "interrupted");
                    assert_eq!(v["signal"], signal.as_str());
                    assert_eq!(v["converged_steps"], *converged_steps);
                }
            }
            let back: Summary = serde_json::from_str(&text).unwrap();
            assert_eq!(back, s);
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
