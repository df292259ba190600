//! Mesh layer: the unstructured [`Mesh`] of linear parent cells (Quad4 / Hex8) with named node
//! and face sets, the structured generators for the cases of Corbett & Sauer 2014, section 4
//! ([`rectangle`], [`half_disk`], [`sector`], [`box3d`], [`hemisphere`], [`hemisphere_nurbs`],
//! [`quarter_sphere`]), a
//! Gmsh MSH 4.1 reader ([`gmsh`]) and rigid helpers ([`transform`]: translate, scale, merge).
//! A generator that knows the exact geometry of a contact surface attaches it to the face set as an
//! [`ExactPatch`] ([`Mesh::exact_surfaces`]), which the enriched layer then uses as is.
//!
//! Generators orient every cell that has a face on a contact surface so that this face is
//! local face 0 (quad: eta = -1; hex: zeta = -1); the NURBS enrichment of a later stage relies
//! on it. Face sets on a curve or patch are ordered along the surface (documented per generator).
//! [`Mesh::dual_graph`] feeds `crate::parallel::partition`.
use std::collections::{BTreeMap, HashMap};

pub mod box3d;
mod cell_kind;
mod error;
mod exact_patch;
pub mod gmsh;
pub mod half_disk;
pub mod hemisphere;
pub mod hemisphere_nurbs;
pub mod quarter_sphere;
pub mod rectangle;
pub mod sector;
mod spherical_shell;
pub mod transform;

pub use cell_kind::CellKind;
pub use error::MeshError;
pub use exact_patch::ExactPatch;

/// A mesh of linear parent cells with named node and face sets.
#[derive(Debug, Clone, PartialEq)]
pub struct Mesh {
    /// Spatial dimension, 2 or 3.
    pub dim: usize,
    /// Node coordinates, [n_nodes][dim].
    pub coords: Vec<f64>,
    /// CSR offsets into `cell_nodes`, [n_cells + 1] (variable node counts will come with
    /// enriched elements).
    pub cell_offsets: Vec<usize>,
    /// CSR node lists of the cells, in the local order of [`CellKind`].
    pub cell_nodes: Vec<u32>,
    /// Parent topology of each cell, [n_cells].
    pub cell_kind: Vec<CellKind>,
    /// Named node sets, each sorted and unique.
    pub node_sets: BTreeMap<String, Vec<u32>>,
    /// Named face sets of (cell, local face), ordered along the surface where it is a curve
    /// or a patch.
    pub face_sets: BTreeMap<String, Vec<(u32, u8)>>,
    /// Exact surfaces of face sets, keyed by face-set name (generators that know them, e.g.
    /// [`hemisphere_nurbs`]); the enriched layer uses them instead of recognising the geometry.
    pub exact_surfaces: BTreeMap<String, ExactPatch>,
    /// Nodes where the generator deliberately collapses cells (a degenerate point of the surface
    /// parametrisation, e.g. the merged rim points of [`hemisphere_nurbs`]), sorted: the only nodes
    /// that a cell may list twice ([`Mesh::validate`]). Empty for meshes read from files.
    pub collapsed_nodes: Vec<u32>,
    /// The file's own tag of each node, [n_nodes] (Gmsh node tags), for messages that name a node
    /// as the user knows it; empty for generated meshes, whose nodes are named by their index.
    pub node_tags: Vec<i64>,
}

/// Relative tolerance, in units of the cell's own scale `h^dim`, below which a corner Jacobian
/// counts as zero rather than negative (degenerate corners, see [`Mesh::validate`]).
const DEGENERATE_CORNER_TOL: f64 = 1e-10;

/// Largest coordinate magnitude a mesh may hold (any length unit from nanometres to light years
/// fits far inside). Squared distances, cell volumes `h^3` and forces built from them must stay
/// finite: at 1e300 a squared distance overflows to infinity and every tolerance built on it
/// with it, so geometric checks would blame the wrong thing (two far-apart nodes "at the same
/// point").
pub const MAX_COORDINATE: f64 = 1e30;

/// Relative distance, in units of the cell diameter, below which two different nodes of one cell
/// count as the same point (see [`MeshError::CoincidentNodes`]).
const COINCIDENT_NODE_TOL: f64 = 1e-10;

/// True for a finite coordinate within [`MAX_COORDINATE`] in magnitude.
pub fn coordinate_in_range(v: f64) -> bool {
    v.is_finite() && v.abs() <= MAX_COORDINATE
}

/// What is wrong with a coordinate `v` that is not finite or beyond [`MAX_COORDINATE`].
pub fn coordinate_problem(v: f64) -> String {
    if v.is_finite() {
        format!("{v:e} is beyond the largest coordinate accepted, {MAX_COORDINATE:e} in magnitude")
    } else {
        format!(
            "{v} is not a finite number (a value beyond 1.8e308, such as 1e999, reads as infinite)"
        )
    }
}

impl Mesh {
    /// An empty mesh of dimension `dim`.
    pub fn new(dim: usize) -> Self {
        Mesh {
            dim,
            coords: Vec::new(),
            cell_offsets: vec![0],
            cell_nodes: Vec::new(),
            cell_kind: Vec::new(),
            node_sets: BTreeMap::new(),
            face_sets: BTreeMap::new(),
            exact_surfaces: BTreeMap::new(),
            collapsed_nodes: Vec::new(),
            node_tags: Vec::new(),
        }
    }

    pub fn n_nodes(&self) -> usize {
        self.coords.len() / self.dim.max(1)
    }

    pub fn n_cells(&self) -> usize {
        self.cell_kind.len()
    }

    /// Global node numbers of cell `c`. Panics if `c >= n_cells()` (like slice indexing).
    pub fn cell(&self, c: usize) -> &[u32] {
        &self.cell_nodes[self.cell_offsets[c]..self.cell_offsets[c + 1]]
    }

    /// Node `n` as a message names it: `Gmsh node <tag>` for a mesh read from a file, else
    /// `mesh node <n>` (the generator's numbering, from 0).
    pub fn node_label(&self, n: u32) -> String {
        match self.node_tags.get(n as usize) {
            Some(t) => format!("Gmsh node {t}"),
            None => format!("mesh node {n}"),
        }
    }

    /// Coordinates of node `n`, [dim]. Panics if out of range (like slice indexing).
    pub fn node(&self, n: u32) -> &[f64] {
        let n = n as usize;
        &self.coords[n * self.dim..(n + 1) * self.dim]
    }

    /// Appends a node and returns its number.
    pub fn push_node(&mut self, x: &[f64]) -> u32 {
        let id = self.n_nodes() as u32;
        self.coords.extend_from_slice(&x[..self.dim]);
        id
    }

    /// Appends a cell and returns its number.
    pub fn push_cell(&mut self, kind: CellKind, nodes: &[u32]) -> u32 {
        let id = self.n_cells() as u32;
        self.cell_nodes.extend_from_slice(nodes);
        self.cell_offsets.push(self.cell_nodes.len());
        self.cell_kind.push(kind);
        id
    }

    /// Inserts a node set, sorting and de-duplicating it.
    pub fn insert_node_set(&mut self, name: &str, mut nodes: Vec<u32>) {
        nodes.sort_unstable();
        nodes.dedup();
        self.node_sets.insert(name.to_string(), nodes);
    }

    /// Nodal coordinates of cell `c`, [n_cell_nodes][dim].
    fn cell_coords(&self, c: usize) -> Vec<f64> {
        self.cell(c)
            .iter()
            .flat_map(|&n| self.node(n).to_vec())
            .collect()
    }

    /// Checks the mesh: array sizes, node counts per kind, node indices in range, positive
    /// reference Jacobian at the cell centre, at the 2-point Gauss points and at the corners,
    /// and that every set refers to existing nodes / faces.
    ///
    /// Also rejected, because each would change the answer without any other sign: a cell that
    /// lists one node twice ([`MeshError::RepeatedNode`], unless the node is one of the
    /// generator's declared [`Mesh::collapsed_nodes`]), a cell with two different nodes at one
    /// point ([`MeshError::CoincidentNodes`]), and two cells with the same node set
    /// ([`MeshError::DuplicateCell`]). Nodes in no cell are allowed (they carry no unknowns); see
    /// [`Mesh::unused_nodes`].
    ///
    /// A corner Jacobian that is zero up to `1e-10 h^dim` (h = cell diameter) is accepted:
    /// the hemisphere's four rim-corner cells (see [`hemisphere`]) have collinear rim edges
    /// and therefore det J = 0 exactly at their rim corner nodes, and the degenerate hexes of
    /// [`hemisphere_nurbs`] (a repeated node pair at a collapsed rim point) have det J = 0 on that
    /// collapsed face, while it stays positive at the centre and all Gauss points. A negative corner Jacobian beyond that tolerance is an
    /// [`MeshError::InvertedCell`].
    pub fn validate(&self) -> Result<(), MeshError> {
        if self.dim != 2 && self.dim != 3 {
            return Err(MeshError::Inconsistent(format!(
                "dimension {} is not 2 or 3",
                self.dim
            )));
        }
        if !self.coords.len().is_multiple_of(self.dim) {
            return Err(MeshError::Inconsistent(format!(
                "coords has {} entries, not a multiple of dim {}",
                self.coords.len(),
                self.dim
            )));
        }
        // before anything geometric: a non-finite or huge coordinate breaks every tolerance
        for (node, x) in self.coords.chunks_exact(self.dim).enumerate() {
            if let Some(v) = x.iter().find(|v| !coordinate_in_range(**v)) {
                return Err(MeshError::BadCoordinate {
                    node: node as u32,
                    x: x.to_vec(),
                    why: coordinate_problem(*v),
                });
            }
        }
        let n_cells = self.n_cells();
        if self.cell_offsets.len() != n_cells + 1
            || self.cell_offsets.first() != Some(&0)
            || self.cell_offsets.last() != Some(&self.cell_nodes.len())
            || self.cell_offsets.windows(2).any(|w| w[0] > w[1])
        {
            return Err(MeshError::Inconsistent(format!(
                "cell_offsets (len {}) is not a CSR offset array for {} cells and {} cell nodes",
                self.cell_offsets.len(),
                n_cells,
                self.cell_nodes.len()
            )));
        }
        let n_nodes = self.n_nodes();
        if self.collapsed_nodes.windows(2).any(|w| w[0] >= w[1])
            || self.collapsed_nodes.iter().any(|&n| n as usize >= n_nodes)
        {
            return Err(MeshError::Inconsistent(
                "collapsed_nodes is not sorted and unique, or refers to missing nodes".into(),
            ));
        }
        for c in 0..n_cells {
            let kind = self.cell_kind[c];
            if kind.dim() != self.dim {
                return Err(MeshError::CellDimension {
                    cell: c,
                    kind,
                    dim: self.dim,
                });
            }
            let nodes = self.cell(c);
            if nodes.len() != kind.n_nodes() {
                return Err(MeshError::CellNodeCount {
                    cell: c,
                    kind,
                    expected: kind.n_nodes(),
                    got: nodes.len(),
                });
            }
            if let Some(&node) = nodes.iter().find(|&&n| n as usize >= n_nodes) {
                return Err(MeshError::NodeIndexOutOfRange {
                    cell: c,
                    node,
                    n_nodes,
                });
            }
            self.check_cell_nodes_distinct(c)?;
            self.check_cell_jacobian(c)?;
        }
        self.check_no_duplicate_cells()?;
        for (set, nodes) in &self.node_sets {
            if let Some(&node) = nodes.iter().find(|&&n| n as usize >= n_nodes) {
                return Err(MeshError::NodeSetOutOfRange {
                    set: set.clone(),
                    node,
                    n_nodes,
                });
            }
            if let Some(p) = nodes.windows(2).position(|w| w[0] >= w[1]) {
                return Err(MeshError::NodeSetUnsorted {
                    set: set.clone(),
                    position: p + 1,
                });
            }
        }
        for (set, patch) in &self.exact_surfaces {
            let (nu, nv) = patch.n_faces();
            let n_faces = self.face_sets.get(set).map(|f| f.len());
            if n_faces != Some(nu * nv)
                || patch.nodes.len() != (nu + 1) * (nv + 1)
                || patch.nodes.iter().any(|&n| n as usize >= n_nodes)
            {
                return Err(MeshError::Inconsistent(format!(
                    "exact surface of face set '{set}' does not match the set ({nu} x {nv} faces \
                     expected) or refers to missing nodes"
                )));
            }
        }
        for (set, faces) in &self.face_sets {
            for &(cell, face) in faces {
                let ok = (cell as usize) < n_cells
                    && (face as usize) < self.cell_kind[cell as usize].n_faces();
                if !ok {
                    return Err(MeshError::FaceSetOutOfRange {
                        set: set.clone(),
                        cell,
                        face,
                    });
                }
            }
        }
        Ok(())
    }

    /// A cell's nodes are distinct, both as numbers (except declared collapsed nodes) and as points.
    fn check_cell_nodes_distinct(&self, c: usize) -> Result<(), MeshError> {
        let kind = self.cell_kind[c];
        let nodes = self.cell(c);
        for (i, &a) in nodes.iter().enumerate() {
            if nodes[..i].contains(&a) && self.collapsed_nodes.binary_search(&a).is_err() {
                return Err(MeshError::RepeatedNode {
                    cell: c,
                    kind,
                    node: a,
                    nodes: nodes.to_vec(),
                });
            }
        }
        let tol2 = (COINCIDENT_NODE_TOL * self.cell_diameter(c)).powi(2);
        for (i, &a) in nodes.iter().enumerate() {
            for &b in &nodes[i + 1..] {
                let d2: f64 = self
                    .node(a)
                    .iter()
                    .zip(self.node(b))
                    .map(|(p, q)| (p - q).powi(2))
                    .sum();
                if a != b && d2 <= tol2 {
                    return Err(MeshError::CoincidentNodes {
                        cell: c,
                        kind,
                        a: a.min(b),
                        b: a.max(b),
                        x: self.node(a).to_vec(),
                    });
                }
            }
        }
        Ok(())
    }

    /// No two cells have the same node set. Sorts (hash of the sorted node list, cell) pairs, so
    /// the extra memory is 16 bytes per cell; the first duplicate in cell order is reported.
    fn check_no_duplicate_cells(&self) -> Result<(), MeshError> {
        use std::hash::{Hash, Hasher};
        let sorted = |c: usize| {
            let mut n = self.cell(c).to_vec();
            n.sort_unstable();
            n
        };
        let mut keyed: Vec<(u64, u32)> = (0..self.n_cells())
            .map(|c| {
                let mut h = std::collections::hash_map::DefaultHasher::new();
                sorted(c).hash(&mut h);
                (h.finish(), c as u32)
            })
            .collect();
        keyed.sort_unstable();
        let mut found: Option<(usize, usize)> = None;
        for run in keyed.chunk_by(|a, b| a.0 == b.0).filter(|r| r.len() > 1) {
            // same hash: compare the node sets; the run is in cell order
            for (i, &(_, later)) in run.iter().enumerate() {
                let later = later as usize;
                let key = sorted(later);
                if let Some(&(_, first)) =
                    run[..i].iter().find(|&&(_, f)| sorted(f as usize) == key)
                {
                    if found.is_none_or(|(c, _)| later < c) {
                        found = Some((later, first as usize));
                    }
                }
            }
        }
        match found {
            Some((cell, first)) => Err(MeshError::DuplicateCell {
                cell,
                first,
                nodes: self.cell(cell).to_vec(),
            }),
            None => Ok(()),
        }
    }

    /// Nodes that no cell uses, in increasing order. They are harmless to the solve (they carry no
    /// unknowns) but often a sign of a mesh exported with construction points or of a mistake, so
    /// readers report them as a warning.
    pub fn unused_nodes(&self) -> Vec<u32> {
        let mut used = vec![false; self.n_nodes()];
        for &n in &self.cell_nodes {
            if let Some(u) = used.get_mut(n as usize) {
                *u = true;
            }
        }
        (0..self.n_nodes() as u32)
            .filter(|&n| !used[n as usize])
            .collect()
    }

    fn check_cell_jacobian(&self, c: usize) -> Result<(), MeshError> {
        let kind = self.cell_kind[c];
        let d = kind.dim();
        let x = self.cell_coords(c);
        let pad = |xi: &[f64]| {
            let mut p = [0.0; 3];
            p[..d].copy_from_slice(xi);
            p
        };
        let mut interior = vec![0.0; d];
        interior.extend(kind.gauss2_points());
        for xi in interior.chunks(d) {
            let det = kind.jacobian_det(&x, xi);
            if det.is_nan() || det <= 0.0 {
                return Err(MeshError::InvertedCell {
                    cell: c,
                    kind,
                    xi: pad(xi),
                    det,
                });
            }
        }
        let h = self.cell_diameter(c);
        for a in 0..kind.n_nodes() {
            let xi = kind.node_reference(a);
            let det = kind.jacobian_det(&x, xi);
            if det.is_nan() || det <= -DEGENERATE_CORNER_TOL * h.powi(d as i32) {
                return Err(MeshError::InvertedCell {
                    cell: c,
                    kind,
                    xi: pad(xi),
                    det,
                });
            }
        }
        Ok(())
    }

    /// Largest distance between two nodes of cell `c`.
    pub fn cell_diameter(&self, c: usize) -> f64 {
        let nodes = self.cell(c);
        let mut h2: f64 = 0.0;
        for (i, &a) in nodes.iter().enumerate() {
            for &b in &nodes[i + 1..] {
                let d2: f64 = self
                    .node(a)
                    .iter()
                    .zip(self.node(b))
                    .map(|(p, q)| (p - q).powi(2))
                    .sum();
                h2 = h2.max(d2);
            }
        }
        h2.sqrt()
    }

    /// Area (2D) or volume (3D) of cell `c`, exact for Quad4 / Hex8 (2-point Gauss rule).
    pub fn cell_measure(&self, c: usize) -> f64 {
        let kind = self.cell_kind[c];
        let x = self.cell_coords(c);
        // reference cell [-1,1]^d has volume 2^d = sum of the 2^d unit Gauss weights
        kind.gauss2_points()
            .chunks(kind.dim())
            .map(|xi| kind.jacobian_det(&x, xi))
            .sum()
    }

    /// Total area (2D) or volume (3D) of the mesh.
    pub fn measure(&self) -> f64 {
        (0..self.n_cells()).map(|c| self.cell_measure(c)).sum()
    }

    /// Global node numbers of local face `face` of cell `cell`, in the outward orientation of
    /// [`CellKind::face_local_nodes`].
    pub fn face_nodes(&self, cell: usize, face: u8) -> Result<Vec<u32>, MeshError> {
        if cell >= self.n_cells() {
            return Err(MeshError::CellOutOfRange {
                cell,
                n_cells: self.n_cells(),
            });
        }
        let kind = self.cell_kind[cell];
        let local = kind
            .face_local_nodes(face)
            .ok_or(MeshError::FaceOutOfRange { cell, kind, face })?;
        let nodes = self.cell(cell);
        Ok(local.iter().map(|&a| nodes[a]).collect())
    }

    /// Sorted unique nodes of the faces in face set `name`.
    pub fn node_set_from_faces(&self, name: &str) -> Result<Vec<u32>, MeshError> {
        let faces = self
            .face_sets
            .get(name)
            .ok_or_else(|| MeshError::UnknownSet(name.to_string()))?;
        let mut nodes = Vec::new();
        for &(c, f) in faces {
            nodes.extend(self.face_nodes(c as usize, f)?);
        }
        nodes.sort_unstable();
        nodes.dedup();
        Ok(nodes)
    }

    /// Adds the node set `name` holding the one node nearest to `point` ([dim]), searched
    /// among the node set `among` (or all nodes). Ties go to the lower node number.
    pub fn add_nearest_node_set(
        &mut self,
        name: &str,
        point: &[f64],
        among: Option<&str>,
    ) -> Result<u32, MeshError> {
        let candidates: Vec<u32> = match among {
            Some(set) => self
                .node_sets
                .get(set)
                .ok_or_else(|| MeshError::UnknownSet(set.to_string()))?
                .clone(),
            None => (0..self.n_nodes() as u32).collect(),
        };
        let dist2 = |n: u32| -> f64 {
            self.node(n)
                .iter()
                .zip(point)
                .map(|(a, b)| (a - b).powi(2))
                .sum()
        };
        let mut best: Option<(u32, f64)> = None;
        for n in candidates {
            let d = dist2(n);
            if best.is_none_or(|(_, bd)| d < bd) {
                best = Some((n, d));
            }
        }
        let (n, _) =
            best.ok_or_else(|| MeshError::UnknownSet(format!("{name} (no candidate nodes)")))?;
        self.node_sets.insert(name.to_string(), vec![n]);
        Ok(n)
    }

    /// Renumbers the local nodes of `cell` by a proper rotation of the reference cell so that
    /// its current local face `face` becomes local face 0, and renames the faces of this cell
    /// in every face set accordingly. The Jacobian sign is unchanged.
    pub fn orient_face_to_local0(&mut self, cell: usize, face: u8) -> Result<(), MeshError> {
        if cell >= self.n_cells() {
            return Err(MeshError::CellOutOfRange {
                cell,
                n_cells: self.n_cells(),
            });
        }
        let kind = self.cell_kind[cell];
        let (perm, face_map) = kind
            .rotation_to_face0(face)
            .ok_or(MeshError::FaceOutOfRange { cell, kind, face })?;
        let old = self.cell(cell).to_vec();
        let start = self.cell_offsets[cell];
        for (i, &a) in perm.iter().enumerate() {
            self.cell_nodes[start + i] = old[a];
        }
        for faces in self.face_sets.values_mut() {
            for entry in faces.iter_mut().filter(|e| e.0 as usize == cell) {
                entry.1 = face_map[entry.1 as usize];
            }
        }
        Ok(())
    }

    /// Turns hex `cell` about the normal of its local face 0 by `k` quarter turns, so that its
    /// local node `k` becomes node 0 (`new[i] = old[(i + k) % 4]` on both faces 0 and 1), and
    /// renames the faces of this cell in every face set accordingly. A proper rotation: the
    /// Jacobian sign is unchanged. Quads have no such freedom (their face 0 is an edge); `k = 0`
    /// is a no-op.
    pub fn rotate_about_face0(&mut self, cell: usize, k: usize) -> Result<(), MeshError> {
        if cell >= self.n_cells() {
            return Err(MeshError::CellOutOfRange {
                cell,
                n_cells: self.n_cells(),
            });
        }
        let k = k % 4;
        if k == 0 || self.cell_kind[cell] != CellKind::Hex8 {
            return Ok(());
        }
        let old = self.cell(cell).to_vec();
        let face_set_of = |nodes: &[u32], f: u8| -> Vec<u32> {
            let mut v: Vec<u32> = CellKind::Hex8
                .face_local_nodes(f)
                .map(|l| l.iter().map(|&a| nodes[a]).collect())
                .unwrap_or_default();
            v.sort_unstable();
            v
        };
        let start = self.cell_offsets[cell];
        for i in 0..4 {
            self.cell_nodes[start + i] = old[(i + k) % 4];
            self.cell_nodes[start + 4 + i] = old[4 + (i + k) % 4];
        }
        let new = self.cell(cell).to_vec();
        for faces in self.face_sets.values_mut() {
            for entry in faces.iter_mut().filter(|e| e.0 as usize == cell) {
                let set = face_set_of(&old, entry.1);
                if let Some(h) = (0..6u8).find(|&h| face_set_of(&new, h) == set) {
                    entry.1 = h;
                }
            }
        }
        Ok(())
    }

    /// Cell-to-cell adjacency in CSR form `(xadj [n_cells + 1], adjncy)`: two cells are
    /// neighbours if they share at least `min_shared_nodes` nodes (2 in 2D, 4 in 3D for face
    /// neighbours). Neighbour lists are sorted; a cell is never its own neighbour.
    pub fn dual_graph(&self, min_shared_nodes: usize) -> (Vec<usize>, Vec<u32>) {
        let n_nodes = self.n_nodes();
        // node -> cells (CSR), cell nodes assumed in range (validate() checks it)
        let mut count = vec![0usize; n_nodes + 1];
        for &n in &self.cell_nodes {
            if (n as usize) < n_nodes {
                count[n as usize + 1] += 1;
            }
        }
        for i in 0..n_nodes {
            count[i + 1] += count[i];
        }
        let mut fill = count.clone();
        let mut node_cells = vec![0u32; count[n_nodes]];
        for c in 0..self.n_cells() {
            for &n in self.cell(c) {
                if (n as usize) < n_nodes {
                    node_cells[fill[n as usize]] = c as u32;
                    fill[n as usize] += 1;
                }
            }
        }
        let mut xadj = Vec::with_capacity(self.n_cells() + 1);
        xadj.push(0);
        let mut adjncy = Vec::new();
        let mut shared: HashMap<u32, usize> = HashMap::new();
        for c in 0..self.n_cells() {
            shared.clear();
            let mut nodes = self.cell(c).to_vec();
            nodes.sort_unstable();
            nodes.dedup();
            for n in nodes.into_iter().filter(|&n| (n as usize) < n_nodes) {
                for &other in &node_cells[count[n as usize]..count[n as usize + 1]] {
                    if other as usize != c {
                        *shared.entry(other).or_insert(0) += 1;
                    }
                }
            }
            let mut nbrs: Vec<u32> = shared
                .iter()
                .filter(|&(_, &k)| k >= min_shared_nodes.max(1))
                .map(|(&o, _)| o)
                .collect();
            nbrs.sort_unstable();
            adjncy.extend(nbrs);
            xadj.push(adjncy.len());
        }
        (xadj, adjncy)
    }
}

#[cfg(test)]
mod tests {
    use super::rectangle::rectangle;
    use super::*;

    #[test]
    fn validate_names_non_finite_and_huge_coordinates_before_any_geometric_check() {
        for (v, words) in [
            (f64::INFINITY, "inf is not a finite number"),
            (f64::NAN, "NaN is not a finite number"),
            (
                -1e300,
                "-1e300 is beyond the largest coordinate accepted, 1e30",
            ),
        ] {
            let mut m = rectangle([0.0, 0.0], [2.0, 1.0], [2, 1]).unwrap();
            m.coords[2 * 4 + 1] = v;
            match m.validate() {
                Err(e @ MeshError::BadCoordinate { node: 4, .. }) => {
                    assert!(e.to_string().contains(words), "{e}")
                }
                other => panic!("expected BadCoordinate for node 4, got {other:?}"),
            }
        }
        // the largest accepted magnitude passes this check (and reaches the geometric ones)
        let mut m = rectangle([0.0, 0.0], [2.0, 1.0], [2, 1]).unwrap();
        m.coords.iter_mut().for_each(|c| *c *= 1e29);
        m.validate().unwrap();
    }

    #[test]
    fn validate_catches_inverted_cell() {
        let mut m = rectangle([0.0, 0.0], [2.0, 1.0], [2, 1]).unwrap();
        m.validate().unwrap();
        // swap two opposite-side nodes of cell 1 -> clockwise orientation
        let s = m.cell_offsets[1];
        m.cell_nodes.swap(s + 1, s + 3);
        match m.validate() {
            Err(MeshError::InvertedCell { cell, det, .. }) => {
                assert_eq!(cell, 1);
                assert!(det < 0.0);
            }
            other => panic!("expected InvertedCell, got {other:?}"),
        }
    }

    #[test]
    fn validate_catches_out_of_range_node_and_bad_sets() {
        let mut m = rectangle([0.0, 0.0], [2.0, 1.0], [2, 1]).unwrap();
        let mut bad = m.clone();
        bad.cell_nodes[5] = 99;
        assert!(matches!(
            bad.validate(),
            Err(MeshError::NodeIndexOutOfRange {
                cell: 1,
                node: 99,
                n_nodes: 6
            })
        ));
        let mut bad = m.clone();
        bad.node_sets.insert("x".into(), vec![1, 6]);
        assert!(matches!(
            bad.validate(),
            Err(MeshError::NodeSetOutOfRange { node: 6, .. })
        ));
        m.face_sets.insert("y".into(), vec![(0, 4)]);
        let err = m.validate().unwrap_err();
        assert!(matches!(
            err,
            MeshError::FaceSetOutOfRange {
                cell: 0,
                face: 4,
                ..
            }
        ));
        assert!(err.to_string().contains("'y'"));
    }

    #[test]
    fn validate_catches_duplicate_cells_in_any_node_order() {
        let mut m = rectangle([0.0, 0.0], [3.0, 1.0], [3, 1]).unwrap();
        let c1 = m.cell(1).to_vec();
        // cell 3 = cell 1 rotated (same orientation, same node set)
        m.push_cell(CellKind::Quad4, &[c1[1], c1[2], c1[3], c1[0]]);
        let e = m.validate().unwrap_err();
        assert!(
            matches!(
                e,
                MeshError::DuplicateCell {
                    cell: 3,
                    first: 1,
                    ..
                }
            ),
            "{e:?}"
        );
        assert!(e.to_string().contains("cell 3 duplicates cell 1"), "{e}");
        assert_eq!(e.cell(), Some(3));
        // listed three times: the first duplicate in cell order is named
        let mut m = rectangle([0.0, 0.0], [3.0, 1.0], [3, 1]).unwrap();
        let c0 = m.cell(0).to_vec();
        m.push_cell(CellKind::Quad4, &c0);
        m.push_cell(CellKind::Quad4, &c0);
        assert!(matches!(
            m.validate(),
            Err(MeshError::DuplicateCell {
                cell: 3,
                first: 0,
                ..
            })
        ));
    }

    #[test]
    fn validate_catches_repeated_and_coincident_nodes() {
        // a quad with a repeated node is a triangle: accepted by the Jacobian test alone
        let mut m = rectangle([0.0, 0.0], [2.0, 1.0], [2, 1]).unwrap();
        let s = m.cell_offsets[1];
        m.cell_nodes[s + 3] = m.cell_nodes[s + 2];
        let e = m.validate().unwrap_err();
        assert!(
            matches!(e, MeshError::RepeatedNode { cell: 1, .. }),
            "{e:?}"
        );
        assert!(e.to_string().contains("collapsed"), "{e}");
        // two different nodes at one point: the same triangle, hidden in the coordinates
        let mut m = rectangle([0.0, 0.0], [2.0, 1.0], [2, 1]).unwrap();
        let (a, b) = (m.cell(1)[2], m.cell(1)[3]);
        let xa = m.node(a).to_vec();
        m.coords[b as usize * 2..b as usize * 2 + 2].copy_from_slice(&xa);
        let e = m.validate().unwrap_err();
        assert!(
            matches!(e, MeshError::CoincidentNodes { cell: 1, .. }),
            "{e:?}"
        );
        // a hex collapsed to a point
        let mut m = super::box3d::box3d([0.0; 3], [1.0; 3], [1, 1, 1]).unwrap();
        m.coords.iter_mut().for_each(|x| *x = 0.0);
        assert!(matches!(
            m.validate(),
            Err(MeshError::CoincidentNodes { cell: 0, .. })
        ));
    }

    #[test]
    fn only_declared_collapsed_nodes_may_repeat() {
        let mut m = super::hemisphere_nurbs::hemisphere_nurbs([0.0; 3], 1.0, 0.2, 4, 2).unwrap();
        // two merged rim points per layer, 3 layers
        assert_eq!(m.collapsed_nodes.len(), 6);
        m.validate().unwrap();
        m.collapsed_nodes.clear();
        assert!(matches!(m.validate(), Err(MeshError::RepeatedNode { .. })));
        // the paper's hemisphere has degenerate corners but no repeated node
        let h = super::hemisphere::hemisphere([0.0; 3], 1.0, 0.2, 3, 2).unwrap();
        assert!(h.collapsed_nodes.is_empty());
        h.validate().unwrap();
        let mut bad = rectangle([0.0, 0.0], [1.0, 1.0], [1, 1]).unwrap();
        bad.collapsed_nodes = vec![7];
        assert!(matches!(bad.validate(), Err(MeshError::Inconsistent(_))));
    }

    #[test]
    fn merged_meshes_keep_their_collapsed_nodes() {
        let shell = super::hemisphere_nurbs::hemisphere_nurbs([0.0; 3], 1.0, 0.2, 2, 1).unwrap();
        let block = super::box3d::box3d([5.0; 3], [1.0; 3], [1, 1, 1]).unwrap();
        let (m, r) = super::transform::merge(&[("b", &block), ("s", &shell)]).unwrap();
        m.validate().unwrap();
        let expect: Vec<u32> = shell
            .collapsed_nodes
            .iter()
            .map(|&n| n + r[1].first_node)
            .collect();
        assert_eq!(m.collapsed_nodes, expect);
    }

    #[test]
    fn unused_nodes_are_listed_and_generators_leave_none() {
        let mut m = rectangle([0.0, 0.0], [2.0, 1.0], [2, 1]).unwrap();
        assert!(m.unused_nodes().is_empty());
        let n = m.push_node(&[5.0, 5.0]);
        assert_eq!(m.unused_nodes(), vec![n]);
        m.validate().unwrap();
        let meshes = [
            super::half_disk::half_disk([0.0, 0.0], 1.0, 8, 2).unwrap(),
            super::sector::sector([0.0, 0.0], 1.0, 2.0, [0.0, 3.0], 6, 2).unwrap(),
            super::box3d::box3d([0.0; 3], [1.0; 3], [2, 2, 2]).unwrap(),
            super::hemisphere::hemisphere([0.0; 3], 1.0, 0.2, 3, 2).unwrap(),
            super::hemisphere_nurbs::hemisphere_nurbs([0.0; 3], 1.0, 0.2, 4, 2).unwrap(),
        ];
        for m in &meshes {
            assert!(m.unused_nodes().is_empty());
            m.validate().unwrap();
        }
    }

    #[test]
    fn dual_graph_of_3x2_grid_has_face_neighbours_only() {
        let m = rectangle([0.0, 0.0], [3.0, 2.0], [3, 2]).unwrap();
        let (xadj, adjncy) = m.dual_graph(2);
        // cell numbering row-major: cell 0 neighbours 1 and 3; cell 4 (middle of top row) 1,3,5
        assert_eq!(&adjncy[xadj[0]..xadj[1]], &[1, 3]);
        assert_eq!(&adjncy[xadj[4]..xadj[5]], &[1, 3, 5]);
        assert_eq!(adjncy.len(), 2 * 7); // 7 interior edges
        let (_, adj_vertex) = m.dual_graph(1);
        assert_eq!(adj_vertex.len(), 2 * (7 + 4)); // plus 4 diagonal pairs
    }

    #[test]
    fn orient_face_to_local0_moves_face_set_entry() {
        let mut m = rectangle([0.0, 0.0], [1.0, 1.0], [1, 1]).unwrap();
        let top_nodes = m.face_nodes(0, m.face_sets["top"][0].1).unwrap();
        m.orient_face_to_local0(0, m.face_sets["top"][0].1).unwrap();
        assert_eq!(m.face_sets["top"][0].1, 0);
        assert_eq!(m.face_nodes(0, 0).unwrap(), top_nodes);
        m.validate().unwrap();
    }

    #[test]
    fn nearest_node_set_searches_only_the_given_set() {
        let mut m = rectangle([0.0, 0.0], [4.0, 2.0], [4, 2]).unwrap();
        let n = m
            .add_nearest_node_set("p", &[2.2, 1.9], Some("bottom"))
            .unwrap();
        assert_eq!(m.node(n), &[2.0, 0.0]);
        assert_eq!(m.node_sets["p"], vec![n]);
        let n = m.add_nearest_node_set("q", &[2.2, 1.9], None).unwrap();
        assert_eq!(m.node(n), &[2.0, 2.0]);
        assert!(matches!(
            m.add_nearest_node_set("r", &[0.0, 0.0], Some("nope")),
            Err(MeshError::UnknownSet(_))
        ));
    }
}
