//! What the assembler measures on a state for output and checks: reactions and their moment,
//! element stress measures, and the first tangled element.

use super::{add_offsets, Assembler};
use crate::assembly::ElementFailure;
use crate::petsc::{PetscError, Vector};
use mpi::collective::SystemOperation;
use mpi::traits::*;

impl Assembler<'_> {
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

    /// Euclidean norm of the forces at the last residual evaluation before the Dirichlet and skew
    /// rows are replaced by their constraints (internal and contact forces less the external
    /// ones): at an equilibrium, the reactions. The force scale of the state, against which the
    /// load stepping judges a residual (`crate::solver::judge`).
    ///
    /// Collective.
    pub fn force_norm(&self) -> f64 {
        let local: f64 = self.raw_residual.iter().map(|r| r * r).sum();
        let mut global = 0.0f64;
        self.petsc
            .comm()
            .all_reduce_into(&local, &mut global, SystemOperation::sum());
        global.sqrt()
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
}
