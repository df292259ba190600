//! Output grids of enriched layers: the contact surface sampled in the reference configuration
//! ("surface") and the control net ("control_net"), each point a fixed linear combination of
//! nodal values, so every written step maps nodal displacements to the grid's displacement.
//!
//! The bulk grid stays the mesh of linear parents: its surface corners on an enriched surface are
//! the display nodes (see `crate::model::enrich`), which sit on the exact curve at the element ends
//! and whose displacement [`Model::fill_display_nodes`] interpolates from the enriched elements.
use super::data::Model;
use crate::io::CellKind;
use std::collections::BTreeSet;

/// A grid whose points interpolate global nodes.
#[derive(Debug, Clone, PartialEq)]
pub struct SampledGrid {
    /// Grid name in the results file.
    pub name: &'static str,
    /// Cell kind of the grid.
    pub kind: CellKind,
    /// Reference coordinates of the points. [n_points][dim]
    pub coords: Vec<f64>,
    /// Point ids per cell. [n_cells][kind.nodes_per_cell()]
    pub connectivity: Vec<usize>,
    /// Each point as `(global node, weight)` pairs. [n_points]
    pub interp: Vec<Vec<(u32, f64)>>,
}

impl SampledGrid {
    /// Point values of a nodal field `u` [n_nodes][dim]: [n_points][dim].
    pub fn interpolate(&self, dim: usize, u: &[f64]) -> Vec<f64> {
        let mut out = vec![0.0; self.interp.len() * dim];
        for (p, w) in self.interp.iter().enumerate() {
            for &(a, wa) in w {
                for k in 0..dim {
                    out[p * dim + k] += wa * u[a as usize * dim + k];
                }
            }
        }
        out
    }
}

/// Overwrites the display nodes' values in `u` [n_nodes][dim] by their interpolation
/// `(node, [(element node, weight)])` (see [`Model::display_interpolation`]).
pub fn apply_display(display: &[(u32, Vec<(u32, f64)>)], dim: usize, u: &mut [f64]) {
    for (node, w) in display {
        let mut v = [0.0; 3];
        for &(a, wa) in w {
            for k in 0..dim {
                v[k] += wa * u[a as usize * dim + k];
            }
        }
        let i = *node as usize * dim;
        u[i..i + dim].copy_from_slice(&v[..dim]);
    }
}

impl Model {
    /// Connectivity of the linear parent cells over global nodes (the "bulk" output grid):
    /// [n_cells][4 or 8].
    pub fn parent_connectivity(&self) -> Vec<usize> {
        let mut conn = Vec::with_capacity(self.cell_nodes.len());
        for b in &self.bodies {
            for c in 0..b.mesh.n_cells() {
                conn.extend(b.mesh.cell(c).iter().map(|&n| (n + b.node_offset) as usize));
            }
        }
        conn
    }

    /// The enriched surfaces sampled at `n_sub + 1` points per element direction on the enriched
    /// face (2D: one polyline per element; 3D: `n_sub^2` quadrilaterals per element), `None`
    /// without enriched layers.
    #[allow(non_snake_case)]
    pub fn surface_grid(&self, n_sub: usize) -> Option<SampledGrid> {
        let n_sub = n_sub.max(1);
        let dim = self.dim;
        let mut g = SampledGrid {
            name: "surface",
            kind: if dim == 2 {
                CellKind::Polyline {
                    nodes_per_cell: n_sub + 1,
                }
            } else {
                CellKind::Polygon { nodes_per_cell: 4 }
            },
            coords: Vec::new(),
            connectivity: Vec::new(),
            interp: Vec::new(),
        };
        for b in &self.bodies {
            let Some(e) = &b.enrichment else { continue };
            for c in &e.cells {
                let n = c.n_nodes();
                let (mut N, mut dN) = (vec![0.0; n], vec![0.0; 3 * n]);
                let first = g.interp.len();
                let n_eta = if dim == 2 { 0 } else { n_sub };
                for j in 0..=n_eta {
                    for i in 0..=n_sub {
                        let xi = -1.0 + 2.0 * i as f64 / n_sub as f64;
                        let at = if dim == 2 {
                            vec![xi, -1.0]
                        } else {
                            vec![xi, -1.0 + 2.0 * j as f64 / n_sub as f64, -1.0]
                        };
                        c.shape(&at, &mut N, &mut dN);
                        let w: Vec<(u32, f64)> = c
                            .nodes
                            .iter()
                            .zip(&N)
                            .filter(|(_, w)| **w != 0.0)
                            .map(|(&a, &w)| (a + b.node_offset, w))
                            .collect();
                        for k in 0..dim {
                            g.coords.push(
                                w.iter()
                                    .map(|&(a, wa)| wa * self.coords[a as usize * dim + k])
                                    .sum(),
                            );
                        }
                        g.interp.push(w);
                    }
                }
                if dim == 2 {
                    g.connectivity.extend(first..=first + n_sub);
                } else {
                    let id = |i: usize, j: usize| first + i + (n_sub + 1) * j;
                    for j in 0..n_sub {
                        for i in 0..n_sub {
                            g.connectivity.extend([
                                id(i, j),
                                id(i + 1, j),
                                id(i + 1, j + 1),
                                id(i, j + 1),
                            ]);
                        }
                    }
                }
            }
        }
        (!g.interp.is_empty()).then_some(g)
    }

    /// The control nets of the enriched surfaces as 2-point segments between neighbouring
    /// position-type nodes of each element (control points, or Q1C2 / Q1CH surface nodes);
    /// `None` without enriched layers.
    pub fn control_net(&self) -> Option<SampledGrid> {
        let mut segments = BTreeSet::new();
        for b in &self.bodies {
            let Some(e) = &b.enrichment else { continue };
            for c in &e.cells {
                let ids: Vec<u32> = c.nodes[..c.n_position]
                    .iter()
                    .map(|&a| a + b.node_offset)
                    .collect();
                // row length of the element's control grid: p+1 in 3D, all of them in 2D
                let row = match &c.basis {
                    crate::fem::enriched::EnrichedBasis::Nurbs(d) if d.q > 0 => d.p + 1,
                    _ => ids.len(),
                };
                for (k, &a) in ids.iter().enumerate() {
                    if k % row + 1 < row {
                        segments.insert((a.min(ids[k + 1]), a.max(ids[k + 1])));
                    }
                    if k + row < ids.len() {
                        segments.insert((a.min(ids[k + row]), a.max(ids[k + row])));
                    }
                }
            }
        }
        if segments.is_empty() {
            return None;
        }
        let dim = self.dim;
        let mut g = SampledGrid {
            name: "control_net",
            kind: CellKind::Polyline { nodes_per_cell: 2 },
            coords: Vec::new(),
            connectivity: Vec::new(),
            interp: Vec::new(),
        };
        let points: BTreeSet<u32> = segments.iter().flat_map(|&(a, b)| [a, b]).collect();
        let points: Vec<u32> = points.into_iter().collect();
        for &a in &points {
            g.coords
                .extend_from_slice(&self.coords[a as usize * dim..(a as usize + 1) * dim]);
            g.interp.push(vec![(a, 1.0)]);
        }
        for (a, b) in segments {
            for n in [a, b] {
                g.connectivity.extend(points.binary_search(&n).ok());
            }
        }
        Some(g)
    }
}

#[cfg(test)]
mod tests {
    use crate::model::Model;
    use crate::scene::parse_case;
    use std::path::Path;

    fn half_disk(element: &str) -> Model {
        let text = format!(
            r#"
[case]
name = "t"
dim = 2
[meshes.m]
generator = "half_disk"
center = [0.0, 0.0]
radius = 1.0
n_arc = 8
n_radial = 2
[bodies.b]
mesh = "m"
element = "{element}"
enriched_surface = "arc"
[bodies.b.material]
model = "neo_hookean"
E = 1.0
nu = 0.3
[[stages]]
name = "s"
steps = 1
"#
        );
        Model::build(&parse_case(&text, Path::new("t.toml"), &[]).unwrap()).unwrap()
    }

    #[test]
    fn sampled_surface_lies_on_the_circle_and_moves_with_the_nodes() {
        let m = half_disk("Q1N2.1");
        let g = m.surface_grid(8).unwrap();
        assert_eq!(g.interp.len(), 8 * 9);
        assert_eq!(g.connectivity.len(), 8 * 9);
        for x in g.coords.chunks(2) {
            assert!((x[0].hypot(x[1]) - 1.0).abs() < 1e-12);
        }
        // a rigid translation of every node translates every sample point
        let u: Vec<f64> = (0..m.n_nodes()).flat_map(|_| [0.3, -0.2]).collect();
        for v in g.interpolate(2, &u).chunks(2) {
            assert!((v[0] - 0.3).abs() < 1e-12 && (v[1] + 0.2).abs() < 1e-12);
        }
        // Q1N2.1 on 8 elements: C^1 cubic, 2 * 8 + 2 control points, plus one at the C^0 joint of
        // the two exact 90-degree segments (knot multiplicity 3 at 270 degrees); a chain of segments
        let net = m.control_net().unwrap();
        assert_eq!(net.interp.len(), 19);
        assert_eq!(net.connectivity.len(), 2 * 18);
    }

    #[test]
    fn linear_bodies_have_no_surface_grids_and_bulk_grid_is_the_linear_mesh() {
        let m = half_disk("Q1C1");
        assert!(m.surface_grid(8).is_none() && m.control_net().is_none());
        let e = half_disk("Q1N2");
        assert_eq!(e.parent_connectivity(), m.parent_connectivity());
    }
}
