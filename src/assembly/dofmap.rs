//! Global numbering of unknowns: ties (periodic conditions), ownership, contiguous rows per rank,
//! the ghosted local index space of each rank, and which unknowns are constrained.
//!
//! Index spaces (STYLE.md): a *node* is a global node id over all bodies (`u32`); a [`GlobalDof`] is a
//! row of the distributed PETSc system; a [`LocalDof`] indexes this rank's ghosted local vector (owned
//! and ghost unknowns its elements touch). Element-local indices are plain `usize` inside kernels.
//!
//! Every node carries `dim` unknowns. Unknowns that are not displacements (the tangent unknowns of
//! Hermite surface nodes) are modelled as extra pseudo-nodes with their own `dim` unknowns, so
//! elements with varying node counts need nothing special here.

use crate::petsc::PetscInt;

/// A row of the global (distributed) system.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct GlobalDof(pub PetscInt);

/// An index into this rank's ghosted local vector.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct LocalDof(pub u32);

/// Errors in building the numbering.
#[derive(Debug, Clone, thiserror::Error)]
pub enum DofMapError {
    /// A tie names a node that does not exist.
    #[error("periodic tie names node {0}, which does not exist")]
    TieNode(u32),
    /// The problem is too large for PETSc's 32-bit indices.
    #[error(
        "{0} unknowns do not fit PETSc's 32-bit PetscInt; build PETSc with --with-64-bit-indices"
    )]
    TooLarge(usize),
    /// The partition vector does not match the cells.
    #[error("partition has {got} entries for {expected} cells")]
    PartitionSize { got: usize, expected: usize },
}

/// The numbering of all unknowns, identical on every rank (the mesh is replicated), plus this rank's
/// local (ghosted) view.
#[derive(Debug, Clone)]
pub struct DofMap {
    /// Unknowns per node.
    pub dim: usize,
    /// Representative node of each node after ties: the smallest node of its tie group (itself when
    /// untied).
    /// [n_nodes]
    pub rep: Vec<u32>,
    /// First global unknown of each representative node (`-1` for nodes that are not representatives
    /// or belong to no cell). [n_nodes]
    pub first_dof: Vec<PetscInt>,
    /// Owning rank of each representative node. [n_nodes]
    pub owner: Vec<u32>,
    /// Start of each rank's row block; `rank_start[size]` is the global count. [size + 1]
    pub rank_start: Vec<PetscInt>,
    /// This rank.
    pub rank: usize,
    /// Global unknowns in this rank's local vector, owned first (in order), then ghosts (sorted).
    /// `local_to_global[LocalDof]`. [n_local]
    pub local_to_global: Vec<PetscInt>,
}

impl DofMap {
    /// Numbers the unknowns.
    ///
    /// `cell_offsets`/`cell_nodes` is the CSR connectivity over global node ids, `cell_part` the rank of
    /// each cell, `ties` pairs `(slave, master)` whose unknowns are shared, `owned_cells` the cells of
    /// this rank (their nodes make up the local vector).
    #[allow(clippy::too_many_arguments)] // plain slices keep this testable without a mesh type
    pub fn new(
        dim: usize,
        n_nodes: usize,
        cell_offsets: &[usize],
        cell_nodes: &[u32],
        cell_part: &[u32],
        ties: &[(u32, u32)],
        size: usize,
        rank: usize,
    ) -> Result<DofMap, DofMapError> {
        let n_cells = cell_offsets.len().saturating_sub(1);
        if cell_part.len() != n_cells {
            return Err(DofMapError::PartitionSize {
                got: cell_part.len(),
                expected: n_cells,
            });
        }
        // Ties join nodes into groups (union-find, so chains, several ties on one node and mutual
        // pairs all work); a group's representative is its smallest node id.
        let mut rep: Vec<u32> = (0..n_nodes as u32).collect();
        fn find(p: &mut [u32], mut x: u32) -> u32 {
            while p[x as usize] != x {
                p[x as usize] = p[p[x as usize] as usize];
                x = p[x as usize];
            }
            x
        }
        for &(a, b) in ties {
            for n in [a, b] {
                if n as usize >= n_nodes {
                    return Err(DofMapError::TieNode(n));
                }
            }
            let (ra, rb) = (find(&mut rep, a), find(&mut rep, b));
            if ra != rb {
                rep[ra.max(rb) as usize] = ra.min(rb);
            }
        }
        for n in 0..n_nodes as u32 {
            rep[n as usize] = find(&mut rep, n);
        }
        // Owner of a representative: the lowest rank among the cells touching any node of its group.
        let mut owner = vec![u32::MAX; n_nodes];
        for c in 0..n_cells {
            let p = cell_part[c];
            for &n in &cell_nodes[cell_offsets[c]..cell_offsets[c + 1]] {
                let r = rep[n as usize] as usize;
                owner[r] = owner[r].min(p);
            }
        }
        // Count per rank, then number rank by rank, nodes in increasing id inside a rank.
        let mut count = vec![0usize; size];
        for n in 0..n_nodes {
            if rep[n] as usize == n && owner[n] != u32::MAX {
                count[owner[n] as usize] += 1;
            }
        }
        let total = count.iter().sum::<usize>() * dim;
        if total > PetscInt::MAX as usize {
            return Err(DofMapError::TooLarge(total));
        }
        let mut rank_start = vec![0 as PetscInt; size + 1];
        for r in 0..size {
            rank_start[r + 1] = rank_start[r] + (count[r] * dim) as PetscInt;
        }
        let mut next = rank_start.clone();
        let mut first_dof = vec![-1 as PetscInt; n_nodes];
        for n in 0..n_nodes {
            if rep[n] as usize == n && owner[n] != u32::MAX {
                let r = owner[n] as usize;
                first_dof[n] = next[r];
                next[r] += dim as PetscInt;
            }
        }
        // Local vector: owned rows in order, then the ghosts this rank's cells touch.
        let (lo, hi) = (rank_start[rank], rank_start[rank + 1]);
        let mut local_to_global: Vec<PetscInt> = (lo..hi).collect();
        let mut ghosts = Vec::new();
        for c in 0..n_cells {
            if cell_part[c] as usize != rank {
                continue;
            }
            for &n in &cell_nodes[cell_offsets[c]..cell_offsets[c + 1]] {
                let f = first_dof[rep[n as usize] as usize];
                if f < lo || f >= hi {
                    for k in 0..dim as PetscInt {
                        ghosts.push(f + k);
                    }
                }
            }
        }
        ghosts.sort_unstable();
        ghosts.dedup();
        local_to_global.extend(ghosts);
        Ok(DofMap {
            dim,
            rep,
            first_dof,
            owner,
            rank_start,
            rank,
            local_to_global,
        })
    }

    /// Global number of unknowns.
    pub fn n_global(&self) -> usize {
        *self.rank_start.last().unwrap_or(&0) as usize
    }

    /// Unknowns owned by this rank.
    pub fn n_owned(&self) -> usize {
        (self.rank_start[self.rank + 1] - self.rank_start[self.rank]) as usize
    }

    /// This rank's row range `[lo, hi)`.
    pub fn owned_range(&self) -> (PetscInt, PetscInt) {
        (self.rank_start[self.rank], self.rank_start[self.rank + 1])
    }

    /// The global unknown of component `comp` of `node` (after ties), or `None` for a node in no cell.
    pub fn global(&self, node: u32, comp: usize) -> Option<GlobalDof> {
        let f = self.first_dof[self.rep[node as usize] as usize];
        (f >= 0).then(|| GlobalDof(f + comp as PetscInt))
    }

    /// Global unknown of every component of `nodes` [n * dim], node by node: the indices of a
    /// gather of those nodes' displacement. A node without unknowns reads unknown 0 (callers put no
    /// force on such nodes).
    pub fn gather_indices(&self, nodes: &[u32]) -> Vec<PetscInt> {
        nodes
            .iter()
            .flat_map(|&a| (0..self.dim).map(move |c| (a, c)))
            .map(|(a, c)| self.global(a, c).map_or(0, |g| g.0))
            .collect()
    }

    /// The local index of a global unknown in this rank's local vector, if present.
    pub fn local(&self, g: GlobalDof) -> Option<LocalDof> {
        let (lo, hi) = self.owned_range();
        if g.0 >= lo && g.0 < hi {
            return Some(LocalDof((g.0 - lo) as u32));
        }
        let ghosts = &self.local_to_global[self.n_owned()..];
        ghosts
            .binary_search(&g.0)
            .ok()
            .map(|k| LocalDof((self.n_owned() + k) as u32))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Three quads in a row, nodes 0..8: 0-1-2-3 bottom, 4-5-6-7 top.
    fn strip() -> (Vec<usize>, Vec<u32>) {
        (vec![0, 4, 8, 12], vec![0, 1, 5, 4, 1, 2, 6, 5, 2, 3, 7, 6])
    }

    #[test]
    fn numbering_is_contiguous_per_rank_and_covers_every_node_once() {
        let (off, nodes) = strip();
        let parts = [0, 1, 1];
        let maps: Vec<DofMap> = (0..2)
            .map(|r| DofMap::new(2, 8, &off, &nodes, &parts, &[], 2, r).unwrap())
            .collect();
        assert_eq!(maps[0].n_global(), 16);
        // Rank 0 owns nodes 0,1,4,5 (node 1 and 5 shared, lowest rank wins).
        assert_eq!(maps[0].n_owned(), 8);
        assert_eq!(maps[1].n_owned(), 8);
        let mut seen = std::collections::BTreeSet::new();
        for n in 0..8 {
            for c in 0..2 {
                assert!(seen.insert(maps[0].global(n, c).unwrap().0));
            }
        }
        assert_eq!(seen.len(), 16);
        // Rank 1 ghosts nodes 1 and 5 of rank 0.
        assert_eq!(maps[1].local_to_global.len(), 8 + 4);
        let g = maps[1].global(1, 1).unwrap();
        assert!(maps[1].local(g).is_some());
        assert!(maps[0].local(maps[0].global(3, 0).unwrap()).is_none());
    }

    #[test]
    fn tied_nodes_share_unknowns() {
        let (off, nodes) = strip();
        // Periodic: right end (3,7) tied to left end (0,4).
        let m = DofMap::new(2, 8, &off, &nodes, &[0, 0, 0], &[(3, 0), (7, 4)], 1, 0).unwrap();
        assert_eq!(m.n_global(), 12);
        assert_eq!(m.global(3, 1), m.global(0, 1));
        assert_eq!(m.global(7, 0), m.global(4, 0));
    }

    #[test]
    fn ties_form_groups_whatever_their_order_and_multiplicity() {
        let (off, nodes) = strip();
        // Mutual pair, and node 3 tied twice (to 0 and to 7): all of 0, 3, 7 share unknowns.
        let m = DofMap::new(
            2,
            8,
            &off,
            &nodes,
            &[0, 0, 0],
            &[(3, 0), (0, 3), (3, 7)],
            1,
            0,
        )
        .unwrap();
        assert_eq!(m.n_global(), 12);
        assert_eq!(m.global(0, 0), m.global(3, 0));
        assert_eq!(m.global(7, 1), m.global(0, 1));
        assert!(matches!(
            DofMap::new(2, 8, &off, &nodes, &[0, 0, 0], &[(3, 99)], 1, 0),
            Err(DofMapError::TieNode(99))
        ));
    }
}
