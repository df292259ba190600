//! Contact tests without MPI: the consistent tangent of every half-pass against central
//! differences of its residual, for every surface family on either side, every law and every rigid
//! partner, at states where points project across element boundaries and onto C0 corners; and the
//! projection against analytic closest points.
//!
//! Here: the fixtures (the [`Harness`], the cases, the pressed states). The tests, by subject:
//! - `tangents`: two deformable surfaces, every law and family, 2D and 3D, one-pass;
//! - `rigid`: surfaces against rigid partners;
//! - `projection`: closest points against analytic ones, cohesive pairing, a failed projection;
//! - `friction`: frictional tangents in stick and slip, the anchors of intermediate commits;
//! - `element_mean`: the element-mean gap.
#![allow(clippy::needless_range_loop)] // index loops mirror the equations
#![allow(non_snake_case)]

use crate::assembly::{DenseSink, DofMap};
use crate::contact::ContactSystem;
use crate::model::Model;
use crate::scene::parse_case;
use std::path::Path;

mod element_mean;
mod friction;
mod projection;
mod rigid;
mod tangents;
mod weighted_gap;

/// A deterministic pseudo-random value in [-1, 1].
pub(crate) fn rnd(state: &mut u64) -> f64 {
    *state = state
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    ((*state >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
}

/// A model and its contact system on one rank.
pub(crate) struct Harness {
    pub model: Model,
    pub sys: ContactSystem,
    pub dofs: DofMap,
    pub table: Vec<i32>,
}

impl Harness {
    pub fn new(case: &str) -> Harness {
        let case = parse_case(case, Path::new("test.toml"), &[]).expect("case parses");
        let model = Model::build(&case).expect("model builds");
        let part = vec![0u32; model.n_cells()];
        let dofs = DofMap::new(
            model.dim,
            model.n_nodes(),
            &model.cell_offsets,
            &model.cell_nodes,
            &part,
            &model.ties,
            1,
            0,
        )
        .unwrap();
        let sys = ContactSystem::new(
            model.dim,
            model.contact_surfaces.clone(),
            model.contact_pairs.clone(),
            &model.coords,
            &dofs,
            &part,
            0,
        )
        .unwrap();
        let table = sys.table_dofs(&dofs);
        Harness {
            model,
            sys,
            dofs,
            table,
        }
    }

    pub fn n(&self) -> usize {
        self.dofs.n_global()
    }

    /// Contact residual at global displacement `u` (and Jacobian, dense).
    pub fn eval(&mut self, u: &[f64], jac: bool) -> (Vec<f64>, Option<Vec<f64>>) {
        let ut: Vec<f64> = self.table.iter().map(|&g| u[g as usize]).collect();
        self.sys.update(&ut).expect("projection");
        let n = self.n();
        let mut f = vec![0.0; n];
        let out = if jac {
            let mut sink = DenseSink::new(n);
            // every block the evaluation writes must be one the pattern gets from `couplings`
            let needed = self.sys.couplings();
            let slot = |c: &crate::contact::Coupling| {
                assert!(
                    needed.binary_search(c).is_ok(),
                    "block {c:?} is not in the couplings"
                );
                Some(0usize)
            };
            self.sys.assemble(&mut f, Some((&mut sink, &slot)));
            Some(sink.a)
        } else {
            self.sys.assemble(&mut f, None);
            None
        };
        // one-pass: the master rows come back through the table (the assembler scatters them)
        for (t, &g) in self.table.iter().enumerate() {
            f[g as usize] += self.sys.table_residual()[t];
        }
        (f, out)
    }

    /// Global displacement from a function of the reference position and body index.
    /// Every body shifted rigidly by `shift`, plus a reproducible perturbation of 2e-3 per unknown
    /// (unknown `i` draws from seed `i + seed`): a generic state near contact for tangent checks.
    pub fn shifted_noisy(&self, shift: &[f64], seed: u64) -> Vec<f64> {
        self.displacement(&|_, _| shift.to_vec())
            .iter()
            .enumerate()
            .map(|(i, v)| v + 2e-3 * rnd(&mut (i as u64 + seed)))
            .collect()
    }

    pub fn displacement(&self, f: &dyn Fn(usize, &[f64]) -> Vec<f64>) -> Vec<f64> {
        let dim = self.model.dim;
        let mut u = vec![0.0; self.n()];
        for (bi, b) in self.model.bodies.iter().enumerate() {
            let pseudo = b
                .enrichment
                .as_ref()
                .map(|e| e.pseudo_nodes.clone())
                .unwrap_or_default();
            for local in 0..b.n_nodes() as u32 {
                let g = local + b.node_offset;
                let x = &self.model.coords[g as usize * dim..(g as usize + 1) * dim];
                // Hermite tangents move with the gradient, not with the displacement: leave them
                let v = if pseudo.binary_search(&local).is_ok() {
                    vec![0.0; dim]
                } else {
                    f(bi, x)
                };
                for c in 0..dim {
                    if let Some(d) = self.dofs.global(g, c) {
                        u[d.0 as usize] = v[c];
                    }
                }
            }
        }
        u
    }
}

/// Largest deviation of the tangent from central differences of the residual, relative to the
/// largest tangent entry; also returns that entry.
pub(crate) fn tangent_error(h: &mut Harness, u: &[f64]) -> (f64, f64) {
    let n = h.n();
    let (_, K) = h.eval(u, true);
    let K = K.unwrap();
    let kmax = K.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let eps = 1e-7;
    let mut worst = 0.0f64;
    for j in 0..n {
        let (mut up, mut um) = (u.to_vec(), u.to_vec());
        up[j] += eps;
        um[j] -= eps;
        let (fp, _) = h.eval(&up, false);
        let (fm, _) = h.eval(&um, false);
        for i in 0..n {
            let fd = (fp[i] - fm[i]) / (2.0 * eps);
            worst = worst.max((fd - K[i * n + j]).abs());
        }
    }
    // the warm starts must not drift with the probes
    h.eval(u, false);
    (worst / kmax.max(1e-300), kmax)
}

/// Two bodies: a block `[-1.5, 1.5] x [-1, 0]` (top `top`) and a half disk of radius 1 centred at
/// (0, 1) (arc `arc`), with the given families and contact law lines.
fn case_2d(block: &str, disk: &str, law: &str) -> String {
    case_2d_arc(block, disk, law, 8)
}

fn case_2d_arc(block: &str, disk: &str, law: &str, n_arc: usize) -> String {
    format!(
        r#"
[case]
name = "fd2"
dim = 2
[meshes.block]
generator = "rectangle"
origin = [-1.5, -1.0]
size = [3.0, 1.0]
divisions = [7, 2]
[meshes.disk]
generator = "half_disk"
center = [0.0, 1.0]
radius = 1.0
n_arc = {n_arc}
n_radial = 1
[bodies.block]
mesh = "block"
element = "{block}"
enriched_surface = "top"
[bodies.block.material]
model = "neo_hookean"
E = 1.0
nu = 0.3
[bodies.disk]
mesh = "disk"
element = "{disk}"
enriched_surface = "arc"
[bodies.disk.material]
model = "neo_hookean"
E = 3.0
nu = 0.3
[[contact]]
surfaces = ["disk.arc", "block.top"]
{law}
[[stages]]
name = "s"
steps = 1
"#
    )
}

const FAMILIES_2D: [&str; 6] = ["Q1C1", "Q1N2", "Q1N2.1", "Q1N3", "Q1C2", "Q1CH"];

/// The disk pushed into the block by `depth` and shifted by `shift`, plus noise of size `noise`.
fn pressed(h: &Harness, depth: f64, shift: f64, noise: f64, seed: u64) -> Vec<f64> {
    let mut s = seed;
    let dim = h.model.dim;
    let u = h.displacement(&|b, _x| {
        let mut v = vec![0.0; dim];
        if h.model.bodies[b].name == "disk" {
            v[0] = shift;
            v[dim - 1] = -depth;
        }
        v
    });
    u.iter().map(|v| v + noise * rnd(&mut s)).collect()
}

/// Two 3D blocks: `lower` [-1,1]^2 x [-1,0] (top `zmax`) and `upper` shifted above it, or a
/// hemisphere shell above the lower block.
fn case_3d_blocks(lower: &str, upper: &str, law: &str) -> String {
    format!(
        r#"
[case]
name = "fd3"
dim = 3
[meshes.lower]
generator = "box"
origin = [-1.0, -1.0, -1.0]
size = [2.0, 2.0, 1.0]
divisions = [3, 3, 1]
[meshes.upper]
generator = "box"
origin = [-0.6, -0.7, 0.0]
size = [1.2, 1.3, 0.5]
divisions = [2, 2, 1]
[bodies.lower]
mesh = "lower"
element = "{lower}"
enriched_surface = "zmax"
[bodies.lower.material]
model = "neo_hookean"
E = 1.0
nu = 0.3
[bodies.upper]
mesh = "upper"
element = "{upper}"
enriched_surface = "zmin"
[bodies.upper.material]
model = "neo_hookean"
E = 1.0
nu = 0.3
[[contact]]
surfaces = ["upper.zmin", "lower.zmax"]
{law}
[[stages]]
name = "s"
steps = 1
"#
    )
}

fn case_3d_hemisphere(lower: &str, shell: &str, law: &str) -> String {
    format!(
        r#"
[case]
name = "fd3h"
dim = 3
[meshes.lower]
generator = "box"
origin = [-1.0, -1.0, -1.0]
size = [2.0, 2.0, 1.0]
divisions = [3, 3, 1]
[meshes.shell]
generator = "hemisphere_nurbs"
center = [0.0, 0.0, 1.0]
outer_radius = 1.0
thickness = 0.3333333333333333
n_surface = 4
n_thickness = 1
[bodies.lower]
mesh = "lower"
element = "{lower}"
enriched_surface = "zmax"
[bodies.lower.material]
model = "neo_hookean"
E = 1.0
nu = 0.3
[bodies.shell]
mesh = "shell"
element = "{shell}"
enriched_surface = "outer"
[bodies.shell.material]
model = "neo_hookean"
E = 5.0
nu = 0.3
[[contact]]
surfaces = ["shell.outer", "lower.zmax"]
{law}
[[stages]]
name = "s"
steps = 1
"#
    )
}

/// Moves the non-`lower` body down by `depth` and sideways by `shift`, plus noise.
fn pressed_3d(h: &Harness, depth: f64, shift: [f64; 2], noise: f64, seed: u64) -> Vec<f64> {
    let mut s = seed;
    let u = h.displacement(&|b, _x| {
        if h.model.bodies[b].name == "lower" {
            vec![0.0; 3]
        } else {
            vec![shift[0], shift[1], -depth]
        }
    });
    u.iter().map(|v| v + noise * rnd(&mut s)).collect()
}

/// A surface against a rigid partner: one body, one surface.
pub(crate) fn case_rigid(dim: usize, family: &str, rigid: &str) -> String {
    case_rigid_law(dim, family, rigid, "law = \"penalty\"\neps_n = 100.0")
}

/// [`case_rigid`] with another contact law (its keys as TOML lines).
fn case_rigid_law(dim: usize, family: &str, rigid: &str, law: &str) -> String {
    let (mesh, set) = if dim == 2 {
        (
            "generator = \"half_disk\"\ncenter = [0.0, 1.0]\nradius = 1.0\nn_arc = 8\nn_radial = 1",
            "arc",
        )
    } else {
        (
            "generator = \"box\"\norigin = [-1.0, -1.0, 0.0]\nsize = [2.0, 2.0, 1.0]\ndivisions = [3, 3, 1]",
            "zmin",
        )
    };
    format!(
        r#"
[case]
name = "fdr"
dim = {dim}
[meshes.m]
{mesh}
[bodies.b]
mesh = "m"
element = "{family}"
enriched_surface = "{set}"
[bodies.b.material]
model = "neo_hookean"
E = 1.0
nu = 0.3
[[contact]]
surfaces = ["b.{set}"]
rigid = {rigid}
{law}
[[stages]]
name = "s"
steps = 1
"#
    )
}

/// Per component: the sum of the contact residual over the bodies' nodes (Hermite tangent
/// pseudo-nodes left out: they carry no force component) and its largest entry.
pub(super) fn net_force(h: &Harness, f: &[f64]) -> ([f64; 3], [f64; 3]) {
    let (mut sum, mut scale) = ([0.0; 3], [0.0f64; 3]);
    for node in 0..h.model.n_nodes() as u32 {
        let pseudo = h.model.bodies.iter().any(|b| {
            b.enrichment.as_ref().is_some_and(|e| {
                node >= b.node_offset
                    && e.pseudo_nodes
                        .binary_search(&(node - b.node_offset))
                        .is_ok()
            })
        });
        if pseudo {
            continue;
        }
        for c in 0..h.model.dim {
            if let Some(g) = h.dofs.global(node, c) {
                sum[c] += f[g.0 as usize];
                scale[c] = scale[c].max(f[g.0 as usize].abs());
            }
        }
    }
    (sum, scale)
}
