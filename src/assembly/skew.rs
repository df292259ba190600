//! Skew (inclined) homogeneous conditions: one direction of a node's displacement is held,
//! `t_n . u_n = 0`, with `t_n` not along a coordinate axis. Two kinds:
//!
//! - *radial*: no displacement around an axis, `t_n = e_theta(X_n)`: the nodes move radially and
//!   along the axis, not around it (a base that expands about its centre but does not turn);
//! - *sliding*: no displacement along a fixed normal, `t_n = n`: a roller on an inclined plane.
//!
//! Each condition is a linear constraint that eliminates one *dependent* component `d` of the node
//! (the one where `|t_d|` is largest) in favour of the others:
//! `u_d = sum_o a_o u_o` with `a_o = -t_o / t_d`. The unknown vector keeps the true displacement in
//! every component, so nothing that reads it (contact, output, reactions) needs to know. The system
//! changes in two places only ([`super::Assembler`]):
//!
//! - the equation of every other component `o` of the node becomes `R_o + a_o R_d` (the virtual
//!   displacements are `e_o + a_o e_d`), i.e. row `d` of every element and contact block is added to
//!   the rows `o` with weight `a_o`;
//! - the equation of `d` is the constraint itself, `x_d - sum_o a_o x_o = 0`, linear, so after one
//!   Newton step it holds to rounding and the converged state is the constrained equilibrium.
//!
//! The raw internal force of the node stays available for reactions: at equilibrium it points
//! along `t_n` (the support's reaction).

use super::dofmap::DofMap;
use crate::petsc::PetscInt;
use std::collections::HashMap;

/// What direction a skew condition holds.
#[derive(Debug, Clone, PartialEq)]
pub enum SkewKind {
    /// No displacement around the unit `axis` (3D; 2D: the out-of-plane axis) through `center`.
    /// Nodes on the axis have no circumferential direction and are left free.
    Radial {
        /// Unit axis.
        axis: [f64; 3],
        /// A point on the axis.
        center: [f64; 3],
    },
    /// No displacement along the unit `normal`.
    Sliding {
        /// Unit normal.
        normal: [f64; 3],
    },
}

/// A skew condition on a node set.
#[derive(Debug, Clone, PartialEq)]
pub struct SkewBc {
    /// Where it comes from, for messages, e.g. `bcs.2 (cube/zmin)`.
    pub label: String,
    /// Global node ids.
    pub nodes: Vec<u32>,
    /// The held direction.
    pub kind: SkewKind,
}

impl SkewBc {
    /// The held unit direction at reference position `x` [dim] (only its first `dim` entries are
    /// non-zero), or `None` for a radial condition's node on the axis.
    pub fn direction(&self, x: &[f64]) -> Option<[f64; 3]> {
        let dim = x.len();
        let t = match &self.kind {
            SkewKind::Sliding { normal } => *normal,
            SkewKind::Radial { axis, center } => {
                let ax = if dim == 2 { [0.0, 0.0, 1.0] } else { *axis };
                let mut r = [0.0; 3];
                for i in 0..dim {
                    r[i] = x[i] - center[i];
                }
                let along: f64 = (0..3).map(|i| r[i] * ax[i]).sum();
                let radial = [0, 1, 2].map(|i| r[i] - along * ax[i]);
                let rn = radial.iter().map(|v| v * v).sum::<f64>().sqrt();
                let scale = r.iter().map(|v| v * v).sum::<f64>().sqrt().max(1.0);
                if rn <= 1e-12 * scale {
                    return None;
                }
                // e_theta = axis x e_r
                [
                    ax[1] * radial[2] - ax[2] * radial[1],
                    ax[2] * radial[0] - ax[0] * radial[2],
                    ax[0] * radial[1] - ax[1] * radial[0],
                ]
                .map(|v| v / rn)
            }
        };
        let mut out = [0.0; 3];
        out[..dim].copy_from_slice(&t[..dim]);
        let n = out.iter().map(|v| v * v).sum::<f64>().sqrt();
        (n > 0.0).then(|| out.map(|v| v / n))
    }
}

/// The constraint of one dependent unknown: `x[dep] = sum a x[o]` over `others`.
#[derive(Debug, Clone, PartialEq)]
pub struct SkewRow {
    /// The eliminated (dependent) unknown.
    pub dep: PetscInt,
    /// `(o, a_o)`: the node's other unknowns with a non-zero weight (possibly none: then the
    /// condition fixes `dep` at zero).
    pub others: Vec<(PetscInt, f64)>,
}

/// Why skew conditions cannot be imposed. `node` names the node as the user knows it (its body,
/// mesh number or Gmsh tag and position).
#[derive(Debug, Clone, thiserror::Error)]
pub enum SkewError {
    /// A component the condition involves is also prescribed by a Dirichlet condition.
    #[error("{node} of {label} is also prescribed in component {component} by another condition; a skew condition needs the components it involves free")]
    Prescribed {
        label: String,
        node: String,
        component: usize,
    },
    /// The node shares its unknowns with other nodes (a periodic tie or a rigid coupling).
    #[error("{node} of {label} is tied to other nodes (a periodic tie or a free-translation rotation); a skew condition needs a node of its own")]
    Tied { label: String, node: String },
}

/// Relative length below which a held direction of a node lies in the span of its other held
/// directions (the same condition twice, or a plane held twice): it adds nothing and is dropped.
const DEPENDENT_DIRECTION: f64 = 1e-8;

/// Weights below this magnitude are zero (an axis-aligned direction leaves exact zeros, a
/// direction along a coordinate axis after elimination round-off of this size).
const ZERO_WEIGHT: f64 = 1e-14;

/// The rows that hold the unit directions `dirs` [k][3] of one node (the first `dim` entries):
/// the directions are orthogonalised (Gram-Schmidt; one in the span of the earlier ones is
/// dropped), then eliminated Gauss-Jordan, each pivot the largest remaining entry of its row, so
/// that every dependent component `d` is `u_d = sum_o a_o u_o` over the components `o` that are
/// not dependent. Returns `(d, [(o, a_o)])` per independent held direction.
#[allow(clippy::needless_range_loop)] // index loops mirror the elimination
fn node_rows(dirs: &[[f64; 3]], dim: usize) -> Vec<(usize, Vec<(usize, f64)>)> {
    let mut rows: Vec<[f64; 3]> = Vec::new();
    let mut units: Vec<[f64; 3]> = Vec::new();
    for t in dirs {
        let mut v = *t;
        for b in &units {
            let p: f64 = (0..dim).map(|i| v[i] * b[i]).sum();
            for i in 0..dim {
                v[i] -= p * b[i];
            }
        }
        let n = (0..dim).map(|i| v[i] * v[i]).sum::<f64>().sqrt();
        if n <= DEPENDENT_DIRECTION {
            continue;
        }
        // the first direction is kept as given (a single condition's weights are `-t_o / t_d`
        // to the bit), later ones as orthogonalised
        rows.push(v);
        units.push(v.map(|x| x / n));
    }
    let mut pivots: Vec<usize> = Vec::new();
    for r in 0..rows.len() {
        let d = (0..dim)
            .filter(|c| !pivots.contains(c))
            .max_by(|&a, &b| rows[r][a].abs().total_cmp(&rows[r][b].abs()))
            .expect("fewer independent directions than components");
        let piv = rows[r][d];
        for c in 0..dim {
            if c != d {
                rows[r][c] /= piv;
            }
        }
        rows[r][d] = 1.0;
        for q in 0..rows.len() {
            if q != r && rows[q][d] != 0.0 {
                let f = rows[q][d];
                for c in 0..dim {
                    rows[q][c] -= f * rows[r][c];
                }
                rows[q][d] = 0.0;
            }
        }
        pivots.push(d);
    }
    pivots
        .iter()
        .zip(&rows)
        .map(|(&d, row)| {
            let others = (0..dim)
                .filter(|c| !pivots.contains(c) && row[*c].abs() > ZERO_WEIGHT)
                .map(|o| (o, -row[o]))
                .collect();
            (d, others)
        })
        .collect()
}

/// All skew constraints over global unknowns (replicated on every rank, like the numbering).
#[derive(Debug, Clone, Default)]
pub struct SkewRows {
    rows: Vec<SkewRow>,
    index: HashMap<PetscInt, usize>,
}

impl SkewRows {
    /// The constraints of `skews`, numbered by `dofs`; `coords` [n_nodes][dim] the reference
    /// positions, `constrained` [n_global] the unknowns Dirichlet conditions prescribe, `name`
    /// a global node as messages name it.
    ///
    /// A node under several conditions (a line or point where symmetry planes meet) holds all
    /// their directions: `k` independent ones eliminate `k` of its components ([`node_rows`]);
    /// axis-aligned directions reduce to fixed components, a condition given twice counts once.
    pub fn new(
        skews: &[SkewBc],
        dofs: &DofMap,
        coords: &[f64],
        constrained: &[bool],
        name: &dyn Fn(u32) -> String,
    ) -> Result<SkewRows, SkewError> {
        let dim = dofs.dim;
        let mut group = vec![0u32; dofs.rep.len()];
        for &r in &dofs.rep {
            group[r as usize] += 1;
        }
        // the held directions of each node, with the condition of each, in order of appearance
        let mut order: Vec<u32> = Vec::new();
        let mut held: HashMap<u32, Vec<(&str, [f64; 3])>> = HashMap::new();
        for s in skews {
            for &n in &s.nodes {
                let x = &coords[n as usize * dim..(n as usize + 1) * dim];
                let Some(t) = s.direction(x) else {
                    continue;
                };
                let list = held.entry(n).or_insert_with(|| {
                    order.push(n);
                    Vec::new()
                });
                if !list.iter().any(|(l, _)| *l == s.label) {
                    list.push((&s.label, t));
                }
            }
        }
        let mut out = SkewRows::default();
        for n in order {
            let list = &held[&n];
            if dofs.rep[n as usize] != n || group[n as usize] > 1 {
                return Err(SkewError::Tied {
                    label: list[0].0.to_string(),
                    node: name(n),
                });
            }
            let Some(g0) = dofs.global(n, 0) else {
                continue; // a node in no cell
            };
            for &(label, t) in list {
                for c in (0..dim).filter(|&c| t[c].abs() > ZERO_WEIGHT) {
                    if constrained[(g0.0 + c as PetscInt) as usize] {
                        return Err(SkewError::Prescribed {
                            label: label.to_string(),
                            node: name(n),
                            component: c,
                        });
                    }
                }
            }
            let dirs: Vec<[f64; 3]> = list.iter().map(|&(_, t)| t).collect();
            for (d, others) in node_rows(&dirs, dim) {
                let dep = g0.0 + d as PetscInt;
                out.index.insert(dep, out.rows.len());
                out.rows.push(SkewRow {
                    dep,
                    others: others
                        .into_iter()
                        .map(|(o, a)| (g0.0 + o as PetscInt, a))
                        .collect(),
                });
            }
        }
        Ok(out)
    }

    /// True when there is no constraint.
    pub fn is_empty(&self) -> bool {
        self.rows.is_empty()
    }

    /// Every constraint.
    pub fn rows(&self) -> &[SkewRow] {
        &self.rows
    }

    /// The constraint whose dependent unknown is `g`, if any.
    pub fn of(&self, g: PetscInt) -> Option<&SkewRow> {
        self.index.get(&g).map(|&i| &self.rows[i])
    }

    /// Constraints given directly (tests of the assembly's patterns).
    #[cfg(test)]
    pub(crate) fn from_rows(rows: Vec<SkewRow>) -> Self {
        let index = rows.iter().enumerate().map(|(i, r)| (r.dep, i)).collect();
        SkewRows { rows, index }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn named(n: u32) -> String {
        format!("node {n}")
    }

    fn radial() -> SkewBc {
        SkewBc {
            label: "bcs.0 (cube/zmin)".into(),
            nodes: vec![0, 1, 2, 3],
            kind: SkewKind::Radial {
                axis: [0.0, 0.0, 1.0],
                center: [0.0, 0.0, 0.0],
            },
        }
    }

    #[test]
    fn radial_direction_is_circumferential_and_free_on_the_axis() {
        let s = radial();
        let t = s.direction(&[2.0, 0.0, 5.0]).unwrap();
        assert!(t[0].abs() < 1e-15 && (t[1] - 1.0).abs() < 1e-15 && t[2] == 0.0);
        let t = s.direction(&[1.0, 1.0, -3.0]).unwrap();
        let h = std::f64::consts::FRAC_1_SQRT_2;
        assert!(
            (t[0] + h).abs() < 1e-15 && (t[1] - h).abs() < 1e-15,
            "{t:?}"
        );
        assert!(s.direction(&[0.0, 0.0, 7.0]).is_none());
        // 2D: about the out-of-plane axis through the centre
        let s2 = SkewBc {
            kind: SkewKind::Radial {
                axis: [1.0, 0.0, 0.0], // ignored in 2D
                center: [1.0, 0.0, 0.0],
            },
            ..radial()
        };
        let t = s2.direction(&[1.0, 3.0]).unwrap();
        assert!((t[0] + 1.0).abs() < 1e-15 && t[1].abs() < 1e-15, "{t:?}");
    }

    #[test]
    fn rows_eliminate_the_largest_component_and_keep_t_dot_u_zero() {
        // four nodes of one cell in 3D around the z axis, one of them on it
        let coords = [
            0.0, 0.0, 0.0, // on the axis: free
            1.0, 0.0, 0.0, // t = (0, 1, 0): u_y = 0, no others
            1.0, 2.0, 0.0, // t ~ (-2, 1, 0): u_x = 0.5 u_y
            -3.0, 1.0, 0.0, // t ~ (-1, -3, 0): u_y = -u_x / 3
        ];
        let dofs = DofMap::new(3, 4, &[0, 4], &[0, 1, 2, 3], &[0], &[], 1, 0).unwrap();
        let rows = SkewRows::new(&[radial()], &dofs, &coords, &[false; 12], &named).unwrap();
        assert_eq!(rows.rows().len(), 3);
        let r1 = rows.of(4).unwrap();
        assert!(r1.others.is_empty());
        let r2 = rows.of(6).unwrap();
        assert_eq!(r2.others.len(), 1);
        assert_eq!(r2.others[0].0, 7);
        assert!((r2.others[0].1 - 0.5).abs() < 1e-15);
        let r3 = rows.of(10).unwrap();
        assert_eq!(r3.others[0].0, 9);
        assert!((r3.others[0].1 + 1.0 / 3.0).abs() < 1e-15);
        // any u_o with u_d from the row satisfies t . u = 0
        for (node, r) in [(2usize, r2), (3, r3)] {
            let t = radial().direction(&coords[node * 3..node * 3 + 3]).unwrap();
            let mut u = [0.3, -0.7, 0.2];
            let d = (r.dep - 3 * node as PetscInt) as usize;
            u[d] = r
                .others
                .iter()
                .map(|&(o, a)| a * u[(o - 3 * node as PetscInt) as usize])
                .sum();
            let tu: f64 = (0..3).map(|i| t[i] * u[i]).sum();
            assert!(tu.abs() < 1e-15, "node {node}: t.u = {tu}");
        }
    }

    #[test]
    fn sliding_on_an_inclined_plane_keeps_two_others_in_3d() {
        let s = SkewBc {
            label: "s".into(),
            nodes: vec![0],
            kind: SkewKind::Sliding {
                normal: [1.0, 2.0, 3.0].map(|v| v / 14f64.sqrt()),
            },
        };
        let dofs = DofMap::new(3, 1, &[0, 1], &[0], &[0], &[], 1, 0).unwrap();
        let rows = SkewRows::new(&[s], &dofs, &[0.5, 0.5, 0.5], &[false; 3], &named).unwrap();
        let r = rows.of(2).unwrap();
        assert_eq!(r.others.len(), 2);
        assert_eq!((r.others[0].0, r.others[1].0), (0, 1));
        assert!((r.others[0].1 + 1.0 / 3.0).abs() < 1e-15);
        assert!((r.others[1].1 + 2.0 / 3.0).abs() < 1e-15);
    }

    #[test]
    fn conflicts_name_the_node_and_the_condition() {
        let coords = [0.0, 0.0, 0.0, 1.0, 2.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0];
        let dofs = DofMap::new(3, 4, &[0, 4], &[0, 1, 2, 3], &[0], &[], 1, 0).unwrap();
        // node 1's x prescribed elsewhere
        let mut constrained = vec![false; 12];
        constrained[3] = true;
        let e = SkewRows::new(&[radial()], &dofs, &coords, &constrained, &named).unwrap_err();
        let msg = e.to_string();
        assert!(
            msg.contains("node 1") && msg.contains("bcs.0 (cube/zmin)"),
            "{msg}"
        );
        // a z constraint is not involved: accepted
        let mut constrained = vec![false; 12];
        for n in 0..4 {
            constrained[n * 3 + 2] = true;
        }
        assert!(SkewRows::new(&[radial()], &dofs, &coords, &constrained, &named).is_ok());
        // tied nodes are refused
        let tied = DofMap::new(3, 4, &[0, 4], &[0, 1, 2, 3], &[0], &[(3, 1)], 1, 0).unwrap();
        let e = SkewRows::new(&[radial()], &tied, &coords, &[false; 12], &named).unwrap_err();
        assert!(e.to_string().contains("tied"), "{e}");
    }

    fn sliding(label: &str, nodes: Vec<u32>, normal: [f64; 3]) -> SkewBc {
        let n = normal.iter().map(|v| v * v).sum::<f64>().sqrt();
        SkewBc {
            label: label.into(),
            nodes,
            kind: SkewKind::Sliding {
                normal: normal.map(|v| v / n),
            },
        }
    }

    /// `u` of node `node` with its free components from `free` and its dependent ones from the
    /// rows (the unknowns of node `node` are `3 node + c`).
    fn constrained_u(rows: &SkewRows, node: usize, free: [f64; 3]) -> [f64; 3] {
        let g = |c: usize| (3 * node + c) as PetscInt;
        let mut u = free;
        for (c, uc) in u.iter_mut().enumerate() {
            if let Some(r) = rows.of(g(c)) {
                *uc = r
                    .others
                    .iter()
                    .map(|&(o, a)| {
                        assert!(rows.of(o).is_none(), "a row depends on a dependent unknown");
                        a * free[(o - g(0)) as usize]
                    })
                    .sum();
            }
        }
        u
    }

    #[test]
    fn symmetry_planes_meeting_at_a_line_or_point_hold_every_normal() {
        // node 0 on x = 0 and y = 0 (a line), node 1 on all three planes (a point), node 2 on
        // x = 0 only, node 3 on x = 0 given twice and on an inclined plane
        let coords = [0.0; 12];
        let dofs = DofMap::new(3, 4, &[0, 4], &[0, 1, 2, 3], &[0], &[], 1, 0).unwrap();
        let skews = [
            sliding("bcs.1 (body/symx)", vec![0, 1, 2, 3], [1.0, 0.0, 0.0]),
            sliding("bcs.2 (body/symy)", vec![0, 1], [0.0, 1.0, 0.0]),
            sliding("bcs.3 (body/symz)", vec![1], [0.0, 0.0, 2.0]),
            sliding("bcs.4 (body/again)", vec![3], [-3.0, 0.0, 0.0]),
            sliding("bcs.5 (body/tilted)", vec![3], [1.0, 1.0, 1.0]),
        ];
        let rows = SkewRows::new(&skews, &dofs, &coords, &[false; 12], &named).unwrap();
        // axis-aligned planes reduce to fixed components: dependent rows without others
        for g in [0, 1, 3, 4, 5, 6] {
            let r = rows.of(g).unwrap_or_else(|| panic!("unknown {g} not held"));
            assert!(r.others.is_empty(), "unknown {g}: {:?}", r.others);
        }
        for g in [2, 7, 8] {
            assert!(rows.of(g).is_none(), "unknown {g} held");
        }
        // node 3: x held (once, however often given) and (1, 1, 1): two rows, one free component
        let held3: Vec<_> = (9..12).filter_map(|g| rows.of(g)).collect();
        assert_eq!(held3.len(), 2);
        let u = constrained_u(&rows, 3, [0.3, -0.7, 0.2]);
        let s3 = 1.0 / 3f64.sqrt();
        assert!(u[0].abs() < 1e-15, "{u:?}");
        assert!((s3 * (u[0] + u[1] + u[2])).abs() < 1e-15, "{u:?}");
        assert!(u.iter().any(|v| v.abs() > 0.1), "{u:?}");
    }

    #[test]
    fn two_inclined_planes_leave_only_their_common_line_free() {
        let coords = [0.0; 3];
        let dofs = DofMap::new(3, 1, &[0, 1], &[0], &[0], &[], 1, 0).unwrap();
        let (n1, n2) = ([1.0, 2.0, 3.0], [0.0, -1.0, 4.0]);
        let skews = [sliding("a", vec![0], n1), sliding("b", vec![0], n2)];
        let rows = SkewRows::new(&skews, &dofs, &coords, &[false; 3], &named).unwrap();
        assert_eq!(rows.rows().len(), 2);
        for free in [
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
            [0.3, -0.2, 0.9],
        ] {
            let u = constrained_u(&rows, 0, free);
            for n in [n1, n2] {
                let d: f64 = (0..3).map(|i| n[i] * u[i]).sum();
                assert!(d.abs() < 1e-14, "n . u = {d} for {u:?}");
            }
        }
        // the free direction is the planes' common line n1 x n2 = (11, -4, -1)
        let u = constrained_u(&rows, 0, [1.0, 1.0, 1.0]);
        let line = [11.0, -4.0, -1.0];
        let k = u[0] / line[0];
        assert!((0..3).all(|i| (u[i] - k * line[i]).abs() < 1e-14), "{u:?}");
    }
}
