//! What a built model is: its [`Body`]s and the [`Model`] they make up, as data with the
//! accessors that need nothing but that data. Built by `build.rs`.

use super::enrich::{EnrichedCell, Enrichment, TiedCell};
use crate::assembly::{DirichletBc, RigidCoupling, SkewBc};
use crate::contact::surface::{EnrichedLayer, LayerCell, SurfaceBody};
use crate::material::Material;
use crate::mesh::Mesh;
use crate::scene::ElementFamily;

/// One body: its mesh, where its nodes and cells start in the global numbering, family and material.
pub struct Body {
    /// Name in the case.
    pub name: String,
    /// Its mesh (body-local numbering).
    pub mesh: Mesh,
    /// Global id of its node 0.
    pub node_offset: u32,
    /// Global id of its cell 0.
    pub cell_offset: usize,
    /// Element family.
    pub family: ElementFamily,
    /// Material.
    pub material: Material,
    /// The cells below an enriched layer are Q1E4 (2D) instead of Q1C1.
    pub bulk_q1e4: bool,
    /// The enriched layer (enriched families): new nodes numbered after the mesh's, enriched cells
    /// beside the mesh's linear parents (`mesh.cell_kind` keeps meaning "linear parent").
    pub enrichment: Option<Enrichment>,
}

impl Body {
    /// Number of body nodes: mesh nodes, then the enrichment's new nodes.
    pub fn n_nodes(&self) -> usize {
        self.mesh.n_nodes() + self.enrichment.as_ref().map_or(0, |e| e.n_extra())
    }

    /// Body-local element node list of cell `c`: the enriched node list, the node list of a
    /// linear cell tied to the enriched surface, or the linear cell.
    pub fn element_nodes(&self, c: usize) -> &[u32] {
        match (self.enriched_cell(c), self.tied_cell(c)) {
            (Some(e), _) => &e.nodes,
            (None, Some(t)) => &t.nodes,
            (None, None) => self.mesh.cell(c),
        }
    }

    /// The tie of linear cell `c` to the enriched surface, if it touches it at a replaced node.
    pub fn tied_cell(&self, c: usize) -> Option<&TiedCell> {
        let en = self.enrichment.as_ref()?;
        en.tied_index[c].map(|i| &en.tied[i])
    }

    /// The enriched cell of mesh cell `c`, if any.
    pub fn enriched_cell(&self, c: usize) -> Option<&EnrichedCell> {
        let en = self.enrichment.as_ref()?;
        en.cell_index[c].map(|i| &en.cells[i])
    }

    /// This body as contact surfaces are built on it, `index` being its index in the model.
    pub fn surface_body(&self, index: usize) -> SurfaceBody<'_> {
        SurfaceBody {
            index,
            name: &self.name,
            mesh: &self.mesh,
            node_offset: self.node_offset,
            cell_offset: self.cell_offset,
            layer: self.enrichment.as_ref().map(|en| EnrichedLayer {
                face_set: &en.face_set,
                cells: en
                    .cells
                    .iter()
                    .map(|ec| LayerCell {
                        cell: ec.cell,
                        nodes: &ec.nodes,
                        corners: &ec.corners,
                        basis: &ec.basis,
                    })
                    .collect(),
                cell_index: &en.cell_index,
            }),
        }
    }

    /// Reference coordinates of body-local node `n` (mesh node or new node).
    pub fn node(&self, n: u32) -> &[f64] {
        let d = self.mesh.dim;
        match &self.enrichment {
            Some(e) if n as usize >= e.n_mesh_nodes => {
                let i = n as usize - e.n_mesh_nodes;
                &e.extra_coords[i * d..(i + 1) * d]
            }
            _ => self.mesh.node(n),
        }
    }
}

/// Everything a run needs, identical on every rank.
pub struct Model {
    /// Spatial dimension.
    pub dim: usize,
    /// Bodies in case order (alphabetical by name, as TOML tables are).
    pub bodies: Vec<Body>,
    /// Reference coordinates of every global node. [n_nodes][dim]
    pub coords: Vec<f64>,
    /// CSR connectivity over global node ids. [n_cells + 1]
    pub cell_offsets: Vec<usize>,
    /// [sum of cell sizes]
    pub cell_nodes: Vec<u32>,
    /// Body of each global cell. [n_cells]
    pub cell_body: Vec<u32>,
    /// Dirichlet conditions over global nodes.
    pub bcs: Vec<DirichletBc>,
    /// Periodic ties `(slave, master)` over global nodes (including those of rigid couplings).
    pub ties: Vec<(u32, u32)>,
    /// Node sets moving rigidly with a prescribed rotation and a free translation; their nodes
    /// are tied (in `ties`) and move with the offsets of [`crate::assembly::NodeOffsets`].
    pub couplings: Vec<RigidCoupling>,
    /// Skew conditions (`radial`, `sliding`); their `bcs` entries are empty.
    pub skews: Vec<SkewBc>,
    /// Reaction sets for the history: (column label `<body>_<set>`, global nodes).
    pub reactions: Vec<(String, Vec<u32>)>,
    /// Reaction sets whose moment the history reports: (label, global nodes, point [3]).
    pub reaction_moments: Vec<(String, Vec<u32>, [f64; 3])>,
    /// Contact surfaces named by the case's pairs (each once).
    pub contact_surfaces: Vec<crate::contact::surface::ContactSurface>,
    /// Contact pairs.
    pub contact_pairs: Vec<crate::contact::PairDef>,
    /// What is legal but suspicious in the input (e.g. mesh nodes in no cell), for the front end
    /// to print once.
    pub warnings: Vec<String>,
    /// Contact inputs that run but whose contact is likely absent or meaningless
    /// ([`Model::contact_checks`], which the front end runs): printed like [`warnings`](Self::warnings), also when quiet, as the
    /// contact warnings of the steps are.
    pub contact_warnings: Vec<String>,
    /// The penalties among those warnings whose `eps h / E` is absurd, as `` `key` = value of pair
    /// `name` (ratio) ``: a failed run names them.
    pub absurd_penalties: Vec<String>,
    /// What the front end reports about the built model beside its summary (e.g. the distance of a
    /// smooth enriched surface from the exact one), one line each.
    pub notes: Vec<String>,
}

impl Model {
    /// Number of global cells.
    pub fn n_cells(&self) -> usize {
        self.cell_body.len()
    }

    /// Number of global nodes.
    pub fn n_nodes(&self) -> usize {
        self.coords.len() / self.dim
    }

    /// Global node `n` as messages name it: its body, its number as the mesh knows it (the Gmsh
    /// tag for a mesh read from a file, see [`Mesh::node_label`]) or its index among the enriched
    /// layer's nodes, and its reference position, e.g. ``Gmsh node 1 of body `ball` at (0, 0, 0)``.
    pub fn node_label(&self, n: u32) -> String {
        node_label(&self.bodies, &self.coords, self.dim, n)
    }
}

/// Global node `n` of `bodies` (reference positions `coords` [n_nodes][dim]) as messages name it;
/// see [`Model::node_label`].
pub(crate) fn node_label(bodies: &[Body], coords: &[f64], dim: usize, n: u32) -> String {
    let x = coords
        .get(n as usize * dim..(n as usize + 1) * dim)
        .map(|x| format!(" at {}", position_text(x)))
        .unwrap_or_default();
    for b in bodies {
        let local = n.wrapping_sub(b.node_offset) as usize;
        if n < b.node_offset || local >= b.n_nodes() {
            continue;
        }
        let what = if local < b.mesh.n_nodes() {
            b.mesh.node_label(local as u32)
        } else {
            format!("enriched-layer node {}", local - b.mesh.n_nodes())
        };
        return format!("{what} of body `{}`{x}", b.name);
    }
    format!("node {n}{x}")
}

/// A position as messages print it, `(x, y[, z])`: ten significant digits, and a coordinate
/// below 1e-12 of the largest (the round-off of a zero, such as a cosine of 90 degrees) as 0.
pub(crate) fn position_text(x: &[f64]) -> String {
    let scale = x.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let v: Vec<String> = x
        .iter()
        .map(|&v| {
            let v = if v.abs() <= 1e-12 * scale {
                0.0
            } else {
                format!("{v:.9e}").parse::<f64>().unwrap_or(v)
            };
            format!("{v}")
        })
        .collect();
    format!("({})", v.join(", "))
}

#[cfg(test)]
mod tests {
    use super::position_text;

    #[test]
    fn positions_print_round_off_as_zero_and_ten_digits() {
        let c = (90f64).to_radians().cos();
        assert_eq!(position_text(&[c, 1.0, 0.5]), "(0, 1, 0.5)");
        assert_eq!(position_text(&[0.1 + 0.2, -2.0]), "(0.3, -2)");
        assert_eq!(position_text(&[1.0 / 3.0]), "(0.3333333333)");
        // a small body keeps its digits: only the round-off relative to its largest coordinate goes
        assert_eq!(position_text(&[2e-6, 1e-7]), "(0.000002, 0.0000001)");
        assert_eq!(position_text(&[0.0, 0.0]), "(0, 0)");
    }
}
