//! Contact tests without MPI: the consistent tangent of every half-pass against central
//! differences of its residual, for every surface family on either side, every law and every rigid
//! partner, at states where points project across element boundaries and onto C0 corners; and the
//! projection against analytic closest points.
#![allow(clippy::needless_range_loop)] // index loops mirror the equations
#![allow(non_snake_case)]

use crate::assembly::{DenseSink, DofMap};
use crate::contact::ContactSystem;
use crate::model::Model;
use crate::scene::parse_case;
use std::path::Path;

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
            let slot = |_: &crate::contact::Coupling| Some(0usize);
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

#[test]
fn penalty_tangent_matches_central_differences_for_every_2d_family_pair() {
    for block in FAMILIES_2D {
        for disk in FAMILIES_2D {
            let mut h = Harness::new(&case_2d(block, disk, "law = \"penalty\"\neps_n = 100.0"));
            // a shift of a fraction of an element makes points project across element boundaries
            let u = pressed(&h, 0.08, 0.13, 2e-3, 11);
            let (err, kmax) = tangent_error(&mut h, &u);
            assert!(kmax > 1.0, "{block}/{disk}: no contact stiffness ({kmax})");
            assert!(err < 1e-6, "{block}/{disk}: tangent error {err:e}");
        }
    }
}

#[test]
fn van_der_waals_tangent_matches_central_differences_with_corner_projections() {
    // Q1C1 on both sides: points of the faceted arc outside the block, and block points outside the
    // disk, project onto convex corners; adhesion is active there, so the corner linearisation counts.
    for (block, disk) in [
        ("Q1C1", "Q1C1"),
        ("Q1N2", "Q1C1"),
        ("Q1C1", "Q1N2"),
        ("Q1N2.1", "Q1CH"),
    ] {
        let mut h = Harness::new(&case_2d(
            block,
            disk,
            "law = \"van_der_waals\"\na_h = 1.0\nr0 = 0.3\nsearch_distance = 1.0",
        ));
        let u = pressed(&h, -0.05, 0.07, 2e-3, 5);
        let (err, kmax) = tangent_error(&mut h, &u);
        assert!(
            kmax > 1e-3,
            "{block}/{disk}: no adhesion stiffness ({kmax})"
        );
        assert!(err < 1e-6, "{block}/{disk}: tangent error {err:e}");
    }
    // The faceted half disk with 4 arc elements has a vertex at its lowest point (0, 0); the
    // block's middle Q1N2 quadrature point lies right below it and projects onto that corner.
    for block in ["Q1N2", "Q1N2.1"] {
        let mut h = Harness::new(&case_2d_arc(
            block,
            "Q1C1",
            "law = \"van_der_waals\"\na_h = 1.0\nr0 = 0.3\nsearch_distance = 1.0",
            4,
        ));
        let u = pressed(&h, -0.05, 0.003, 1e-4, 9);
        let (err, _) = tangent_error(&mut h, &u);
        let corners: usize = h.sys.results()[0].1.iter().map(|r| r.n_edge).sum();
        assert!(corners >= 1, "{block}: no point projected onto a corner");
        assert!(err < 1e-6, "{block}/Q1C1 corner: tangent error {err:e}");
    }
}

#[test]
fn cohesive_tangent_matches_central_differences() {
    for (block, disk) in [("Q1C1", "Q1C1"), ("Q1N2", "Q1N2"), ("Q1N2.1", "Q1C2")] {
        // the flat top of the disk glued to the block's bottom... simpler: glue the arc where it
        // touches (within the search distance) and pull the disk up and sideways
        let mut h = Harness::new(&case_2d(
            block,
            disk,
            "law = \"cohesive\"\nt0 = 0.2\ng0 = 0.05\neps_n = 50.0\nsearch_distance = 0.3",
        ));
        let u = pressed(&h, -0.03, 0.02, 2e-3, 3);
        let (err, kmax) = tangent_error(&mut h, &u);
        assert!(
            kmax > 1e-3,
            "{block}/{disk}: no cohesive stiffness ({kmax})"
        );
        assert!(err < 1e-6, "{block}/{disk}: tangent error {err:e}");
    }
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

#[test]
fn penalty_tangent_matches_central_differences_in_3d() {
    for (lower, upper) in [
        ("Q1C1", "Q1C1"),
        ("Q1N2", "Q1C1"),
        ("Q1C1", "Q1N2"),
        ("Q1N2", "Q1N2"),
    ] {
        let mut h = Harness::new(&case_3d_blocks(
            lower,
            upper,
            "law = \"penalty\"\neps_n = 100.0",
        ));
        // the upper block's points sit over several lower elements and cross their edges
        let u = pressed_3d(&h, 0.04, [0.11, -0.07], 2e-3, 17);
        let (err, kmax) = tangent_error(&mut h, &u);
        assert!(kmax > 1.0, "{lower}/{upper}: no contact stiffness ({kmax})");
        assert!(err < 1e-6, "{lower}/{upper}: tangent error {err:e}");
    }
    for (lower, shell) in [("Q1C1", "Q1N2"), ("Q1N2", "Q1N2"), ("Q1N2", "Q1C1")] {
        let mut h = Harness::new(&case_3d_hemisphere(
            lower,
            shell,
            "law = \"penalty\"\neps_n = 100.0",
        ));
        let u = pressed_3d(&h, 0.06, [0.05, 0.08], 2e-3, 23);
        let (err, kmax) = tangent_error(&mut h, &u);
        assert!(kmax > 1.0, "{lower}/{shell}: no contact stiffness ({kmax})");
        assert!(err < 1e-6, "{lower}/{shell}: tangent error {err:e}");
    }
}

#[test]
fn van_der_waals_and_cohesive_tangents_match_central_differences_in_3d() {
    for (lower, upper) in [("Q1C1", "Q1C1"), ("Q1N2", "Q1N2")] {
        let mut h = Harness::new(&case_3d_blocks(
            lower,
            upper,
            "law = \"van_der_waals\"\na_h = 1.0\nr0 = 0.3\nsearch_distance = 1.0",
        ));
        let u = pressed_3d(&h, -0.05, [0.09, 0.05], 2e-3, 31);
        let (err, kmax) = tangent_error(&mut h, &u);
        assert!(kmax > 1e-3, "vdW {lower}/{upper}: no stiffness ({kmax})");
        assert!(err < 1e-6, "vdW {lower}/{upper}: tangent error {err:e}");
        let mut h = Harness::new(&case_3d_blocks(
            lower,
            upper,
            "law = \"cohesive\"\nt0 = 0.2\ng0 = 0.05\neps_n = 50.0\nsearch_distance = 0.3",
        ));
        let u = pressed_3d(&h, -0.02, [0.03, 0.01], 2e-3, 37);
        let (err, kmax) = tangent_error(&mut h, &u);
        assert!(
            kmax > 1e-3,
            "cohesive {lower}/{upper}: no stiffness ({kmax})"
        );
        assert!(
            err < 1e-6,
            "cohesive {lower}/{upper}: tangent error {err:e}"
        );
    }
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

#[test]
fn penalty_tangent_against_rigid_partners_matches_central_differences() {
    let rigid_2d = [
        "{ shape = \"plane\", point = [0.0, 0.0], normal = [0.2, 1.0] }",
        "{ shape = \"circle\", center = [0.3, -2.0], radius = 2.0 }",
        "{ shape = \"circle\", center = [0.0, 1.0], radius = 1.01, inside = true }",
    ];
    for fam in FAMILIES_2D {
        for r in rigid_2d {
            let mut h = Harness::new(&case_rigid(2, fam, r));
            let u = h.shifted_noisy(&[0.05, -0.06], 1);
            let (err, kmax) = tangent_error(&mut h, &u);
            assert!(kmax > 1.0, "{fam} {r}: no contact stiffness ({kmax})");
            assert!(err < 1e-6, "{fam} {r}: tangent error {err:e}");
        }
    }
    let rigid_3d = [
        "{ shape = \"plane\", point = [0.0, 0.0, 0.0], normal = [0.1, -0.2, 1.0] }",
        "{ shape = \"sphere\", center = [0.2, 0.1, -3.0], radius = 3.0 }",
        "{ shape = \"cylinder\", center = [0.0, 0.0, -2.0], axis = [1.0, 0.3, 0.0], radius = 2.0 }",
    ];
    for fam in ["Q1C1", "Q1N2"] {
        for r in rigid_3d {
            let mut h = Harness::new(&case_rigid(3, fam, r));
            let u = h.shifted_noisy(&[0.02, 0.01, -0.05], 7);
            let (err, kmax) = tangent_error(&mut h, &u);
            assert!(kmax > 1.0, "{fam} {r}: no contact stiffness ({kmax})");
            assert!(err < 1e-6, "{fam} {r}: tangent error {err:e}");
        }
    }
}

/// Current (here: reference) positions of every element of a surface.
fn positions(h: &Harness, s: usize) -> crate::contact::projection::Positions {
    let surf = &h.model.contact_surfaces[s];
    let mut pos = crate::contact::projection::Positions::default();
    pos.offsets.push(0);
    for e in &surf.elements {
        pos.x.extend(crate::contact::surface::reference_positions(
            &h.model.coords,
            h.model.dim,
            &e.nodes,
        ));
        pos.offsets.push(pos.x.len());
    }
    pos
}

fn grid_of(
    s: &crate::contact::surface::ContactSurface,
    pos: &crate::contact::projection::Positions,
    dist: f64,
) -> crate::contact::search::BinGrid {
    crate::contact::projection::surface_grid(s, pos, dist)
}

#[test]
fn projection_onto_the_nurbs_circle_and_sphere_matches_the_analytic_closest_point() {
    use crate::contact::projection::{global_search, walk};
    // the exact arc of the half disk (Q1N2 and Q1N2.1) and the exact hemisphere (Q1N2)
    let cases = [
        (
            case_2d("Q1C1", "Q1N2", "law = \"penalty\"\neps_n = 1.0"),
            0usize,
            [0.0, 1.0, 0.0],
        ),
        (
            case_2d("Q1C1", "Q1N2.1", "law = \"penalty\"\neps_n = 1.0"),
            0,
            [0.0, 1.0, 0.0],
        ),
        (
            case_3d_hemisphere("Q1C1", "Q1N2", "law = \"penalty\"\neps_n = 1.0"),
            0,
            [0.0, 0.0, 1.0],
        ),
    ];
    for (text, s, c) in cases {
        let h = Harness::new(&text);
        let surf = &h.model.contact_surfaces[s];
        assert!(
            surf.name.ends_with("arc") || surf.name.ends_with("outer"),
            "{}",
            surf.name
        );
        let dim = surf.dim;
        let pos = positions(&h, s);
        let grid = grid_of(surf, &pos, 0.5);
        let mut seed = 99u64;
        let mut scratch = Vec::new();
        let mut checked = 0;
        for _ in 0..400 {
            // a random point near the lower half of the circle / sphere (radius 0.7 .. 1.3)
            let mut d = [rnd(&mut seed), -1.0 - rnd(&mut seed).abs(), rnd(&mut seed)];
            if dim == 2 {
                d[2] = 0.0;
            } else {
                d.swap(1, 2);
            }
            let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            let r = 1.0 + 0.3 * rnd(&mut seed);
            let x = [0, 1, 2].map(|k| c[k] + r * d[k] / l);
            let exact = [0, 1, 2].map(|k| c[k] + d[k] / l);
            let Ok(Some(p)) = global_search(surf, &pos, &grid, &x, &mut scratch) else {
                continue; // beyond the rim or farther than the search distance
            };
            let el = &surf.elements[p.elem as usize];
            let xp = crate::contact::surface::frame(el, dim, pos.of(p.elem as usize), &p.xi).0;
            let err = (0..dim)
                .map(|k| (xp[k] - exact[k]).powi(2))
                .sum::<f64>()
                .sqrt();
            assert!(
                err < 1e-12,
                "{}: closest point off by {err:e} for x = {x:?}",
                surf.name
            );
            assert!(((r - 1.0).abs() - p.dist).abs() < 1e-12, "distance");
            // a warm start on a far element walks across neighbours to the same point
            let far = if p.elem as usize >= surf.elements.len() / 2 {
                0
            } else {
                surf.elements.len() - 1
            };
            if let Some(w) = walk(surf, &pos, &x, (far as u32, [0.0; 2])) {
                let xw = crate::contact::surface::frame(
                    &surf.elements[w.elem as usize],
                    dim,
                    pos.of(w.elem as usize),
                    &w.xi,
                )
                .0;
                let ew = (0..dim)
                    .map(|k| (xw[k] - exact[k]).powi(2))
                    .sum::<f64>()
                    .sqrt();
                assert!(
                    ew < 1e-12,
                    "{}: walk from element {far} off by {ew:e}",
                    surf.name
                );
            }
            checked += 1;
        }
        assert!(
            checked > 100,
            "{}: too few points projected ({checked})",
            surf.name
        );
    }
}

#[test]
fn projection_onto_a_faceted_corner_and_beyond_the_surface_end() {
    use crate::contact::projection::global_search;
    // the faceted half disk with 4 arc elements: vertices at angles 180, 225, 270, 315, 360 degrees
    let h = Harness::new(&case_2d_arc(
        "Q1C1",
        "Q1C1",
        "law = \"penalty\"\neps_n = 1.0",
        4,
    ));
    let surf = &h.model.contact_surfaces[0];
    let pos = positions(&h, 0);
    let grid = grid_of(surf, &pos, 1.0);
    let mut scratch = Vec::new();
    // straight below the lowest vertex (0, 0): its closest point is the vertex, no orthogonal one
    let p = global_search(surf, &pos, &grid, &[0.01, -0.3, 0.0], &mut scratch)
        .unwrap()
        .unwrap();
    assert!(
        !p.free[0],
        "a corner projection holds the coordinate on the boundary"
    );
    assert!(
        (p.dist - (0.01f64.powi(2) + 0.09).sqrt()).abs() < 1e-12,
        "distance to the vertex {}",
        p.dist
    );
    // beside the arc's end (the vertex at (1, 1)), outwards: beyond the surface, no partner
    let q = global_search(surf, &pos, &grid, &[1.3, 1.2, 0.0], &mut scratch).unwrap();
    assert!(
        q.is_none(),
        "a point beyond the end of the surface has no partner: {q:?}"
    );
}

#[test]
fn cohesive_debonded_box_leaves_its_points_unpaired() {
    let glued = "law = \"cohesive\"\nt0 = 0.2\ng0 = 0.05\neps_n = 50.0\nsearch_distance = 0.3";
    let mut h = Harness::new(&case_2d("Q1C1", "Q1C1", glued));
    let u = pressed(&h, -0.03, 0.0, 0.0, 1);
    h.eval(&u, false);
    let bonded: f64 = h.sys.results()[0].1.iter().map(|r| r.force[1].abs()).sum();
    assert!(
        bonded > 1e-4,
        "the pulled disk feels the cohesive traction ({bonded})"
    );
    let free = format!("{glued}\ndebonded = {{ min = [-2.0, -2.0], max = [2.0, 3.0] }}");
    let mut h = Harness::new(&case_2d("Q1C1", "Q1C1", &free));
    h.eval(&u, false);
    let none: f64 = h.sys.results()[0].1.iter().map(|r| r.force[1].abs()).sum();
    assert_eq!(none, 0.0, "every point lies in the debonded box");
}

#[test]
fn one_pass_tangent_matches_central_differences_and_balances_momentum() {
    for (block, disk) in [
        ("Q1C1", "Q1C1"),
        ("Q1N2", "Q1N2"),
        ("Q1N2.1", "Q1CH"),
        ("Q1C2", "Q1N3"),
    ] {
        let law = "law = \"penalty\"\neps_n = 100.0\nalgorithm = \"one_pass\"";
        let mut h = Harness::new(&case_2d(block, disk, law));
        let u = pressed(&h, 0.08, 0.13, 2e-3, 41);
        let (err, kmax) = tangent_error(&mut h, &u);
        assert!(kmax > 1.0, "{block}/{disk}: no contact stiffness ({kmax})");
        assert!(err < 1e-6, "one-pass {block}/{disk}: tangent error {err:e}");
        // the slave's force and the master's are equal and opposite: the summed residual vanishes
        let (f, _) = h.eval(&u, false);
        let dim = 2;
        for c in 0..dim {
            let mut sum = 0.0;
            let mut scale = 0.0f64;
            for node in 0..h.model.n_nodes() as u32 {
                if let Some(g) = h.dofs.global(node, c) {
                    // Hermite tangent pseudo-nodes carry no force component
                    let pseudo = h.model.bodies.iter().any(|b| {
                        b.enrichment.as_ref().is_some_and(|e| {
                            node >= b.node_offset
                                && e.pseudo_nodes
                                    .binary_search(&(node - b.node_offset))
                                    .is_ok()
                        })
                    });
                    if !pseudo {
                        sum += f[g.0 as usize];
                        scale = scale.max(f[g.0 as usize].abs());
                    }
                }
            }
            assert!(
                scale > 1e-3 && sum.abs() < 1e-12 * scale,
                "{block}/{disk}: net force {sum} (scale {scale})"
            );
        }
    }
}

#[test]
fn a_projection_that_fails_on_every_candidate_is_an_error_for_the_step() {
    // a non-finite partner geometry (what a diverged Newton iterate gives) makes every candidate's
    // projection fail: `update` reports it (the assembler turns it into a domain error, and the
    // load step is cut back as for an inverted element)
    let mut h = Harness::new(&case_2d("Q1C1", "Q1N2", "law = \"penalty\"\neps_n = 100.0"));
    let u = pressed(&h, 0.05, 0.0, 0.0, 1);
    h.eval(&u, false);
    let mut bad = u.clone();
    // every other node of the block's top (the partner of the disk's points) becomes NaN: each
    // element's box stays finite (so it is a candidate) but its geometry is not
    let block = &h.model.bodies[0];
    assert_eq!(block.name, "block");
    for g in h
        .model
        .set_nodes("block", "top")
        .unwrap()
        .into_iter()
        .step_by(2)
    {
        for c in 0..2 {
            bad[h.dofs.global(g, c).unwrap().0 as usize] = f64::NAN;
        }
    }
    let ut: Vec<f64> = h.table.iter().map(|&g| bad[g as usize]).collect();
    let e = h.sys.update(&ut).expect_err("the projection must fail");
    assert!(e.contains("projection") && e.contains("block.top"), "{e}");
    // and a finite state projects again
    let ut: Vec<f64> = h.table.iter().map(|&g| u[g as usize]).collect();
    h.sys.update(&ut).expect("finite state");
}

#[test]
fn van_der_waals_tangent_against_rigid_partners_matches_central_differences() {
    // the surface held a little above each rigid partner, within the adhesion range: every
    // family in 2D, both 3D families
    let law = "law = \"van_der_waals\"\na_h = 1.0\nr0 = 0.3\nsearch_distance = 1.0";
    let rigid_2d = [
        "{ shape = \"plane\", point = [0.0, 0.0], normal = [0.2, 1.0] }",
        "{ shape = \"circle\", center = [0.3, -2.0], radius = 2.0 }",
    ];
    for fam in FAMILIES_2D {
        for r in rigid_2d {
            let mut h = Harness::new(&case_rigid_law(2, fam, r, law));
            let u = h.shifted_noisy(&[0.05, 0.12], 3);
            let (err, kmax) = tangent_error(&mut h, &u);
            assert!(kmax > 1e-3, "{fam} {r}: no adhesion stiffness ({kmax})");
            assert!(err < 1e-6, "{fam} {r}: tangent error {err:e}");
        }
    }
    let rigid_3d = [
        "{ shape = \"plane\", point = [0.0, 0.0, 0.0], normal = [0.1, -0.2, 1.0] }",
        "{ shape = \"sphere\", center = [0.2, 0.1, -3.0], radius = 3.0 }",
    ];
    for fam in ["Q1C1", "Q1N2"] {
        for r in rigid_3d {
            let mut h = Harness::new(&case_rigid_law(3, fam, r, law));
            let u = h.shifted_noisy(&[0.02, 0.01, 0.15], 5);
            let (err, kmax) = tangent_error(&mut h, &u);
            assert!(kmax > 1e-3, "{fam} {r}: no adhesion stiffness ({kmax})");
            assert!(err < 1e-6, "{fam} {r}: tangent error {err:e}");
        }
    }
}

#[test]
fn adhesive_and_cohesive_tangents_match_central_differences_for_every_2d_family_on_either_side() {
    // each family once as the block and once as the disk, against a Q1N2 partner, with points
    // projecting across element boundaries (the sideways shift)
    let laws = [
        (
            "van_der_waals",
            "law = \"van_der_waals\"\na_h = 1.0\nr0 = 0.3\nsearch_distance = 1.0",
            -0.05,
        ),
        (
            "cohesive",
            "law = \"cohesive\"\nt0 = 0.2\ng0 = 0.05\neps_n = 50.0\nsearch_distance = 0.3",
            -0.03,
        ),
    ];
    for (name, law, depth) in laws {
        for fam in FAMILIES_2D {
            for (block, disk) in [(fam, "Q1N2"), ("Q1N2", fam)] {
                let mut h = Harness::new(&case_2d(block, disk, law));
                let u = pressed(&h, depth, 0.09, 2e-3, 13);
                let (err, kmax) = tangent_error(&mut h, &u);
                assert!(kmax > 1e-3, "{name} {block}/{disk}: no stiffness ({kmax})");
                assert!(err < 1e-6, "{name} {block}/{disk}: tangent error {err:e}");
            }
        }
    }
}

/// Friction: the pair is pressed to `u0` and that state committed (every active point anchors at
/// its projection), then the tangent at `u1` is checked against central differences at those fixed
/// anchors (the consistent tangent of a step). Returns (error, largest entry, sticking points,
/// slipping points) at `u1`.
fn friction_fd(h: &mut Harness, u0: &[f64], u1: &[f64]) -> (f64, f64, usize, usize) {
    h.eval(u0, false);
    h.sys.commit();
    let (err, kmax) = tangent_error(h, u1);
    h.eval(u1, false);
    let res = h.sys.results();
    let stick = res[0].1.iter().map(|r| r.n_stick).sum();
    let slip = res[0].1.iter().map(|r| r.n_slip).sum();
    (err, kmax, stick, slip)
}

/// The 2D pair pressed, then its disk shifted a little (most points stick) and far (most slip):
/// the frictional tangent against central differences in both.
fn friction_fd_2d(block: &str, disk: &str, law: &str) {
    for (shift, want_slip) in [(2e-4, false), (0.06, true)] {
        let mut h = Harness::new(&case_2d(block, disk, law));
        let u0 = pressed(&h, 0.08, 0.0, 2e-3, 11);
        let disk_i = h
            .model
            .bodies
            .iter()
            .position(|b| b.name == "disk")
            .unwrap();
        let u1 = shifted(&h, &u0, &|b| {
            if b == disk_i {
                vec![shift, 0.0]
            } else {
                vec![0.0; 2]
            }
        });
        let (err, kmax, stick, slip) = friction_fd(&mut h, &u0, &u1);
        let what = if want_slip { "slip" } else { "stick" };
        assert!(kmax > 1.0, "{block}/{disk} {what}: no stiffness ({kmax})");
        assert!(
            if want_slip {
                slip > stick
            } else {
                stick > slip
            },
            "{block}/{disk} {what}: {stick} sticking, {slip} slipping"
        );
        assert!(err < 1e-6, "{block}/{disk} {what}: tangent error {err:e}");
    }
}

/// The hemisphere on a block, pressed, then shifted a little and far: the frictional tangent
/// against central differences with sticking and with slipping points.
fn friction_fd_hemisphere(lower: &str, shell: &str, law: &str) {
    for (shift, want_slip) in [(1e-4, false), (0.05, true)] {
        let mut h = Harness::new(&case_3d_hemisphere(lower, shell, law));
        let u0 = pressed_3d(&h, 0.06, [0.05, 0.08], 2e-3, 23);
        let lo = h
            .model
            .bodies
            .iter()
            .position(|b| b.name == "lower")
            .unwrap();
        let u1 = shifted(&h, &u0, &|b| {
            if b == lo {
                vec![0.0; 3]
            } else {
                vec![-shift, shift, 0.0]
            }
        });
        let (err, _, stick, slip) = friction_fd(&mut h, &u0, &u1);
        let what = if want_slip { "slip" } else { "stick" };
        assert!(stick + slip > 0, "{lower}/{shell}: no frictional point");
        assert!(
            if want_slip { slip > 0 } else { stick > 0 },
            "{lower}/{shell} {what}: {stick} sticking, {slip} slipping"
        );
        assert!(err < 1e-6, "{lower}/{shell} {what}: tangent error {err:e}");
    }
}

/// `u` plus a rigid shift of the bodies `f` selects.
fn shifted(h: &Harness, u: &[f64], f: &dyn Fn(usize) -> Vec<f64>) -> Vec<f64> {
    let d = h.displacement(&|b, _| f(b));
    u.iter().zip(&d).map(|(a, b)| a + b).collect()
}

#[test]
fn friction_tangent_matches_central_differences_in_stick_and_slip_2d() {
    for (block, disk) in [
        ("Q1C1", "Q1C1"),
        ("Q1N2", "Q1N2"),
        ("Q1N2", "Q1C1"),
        ("Q1N2.1", "Q1CH"),
    ] {
        let law = "law = \"penalty\"\neps_n = 100.0\nmu = 0.3\neps_t = 80.0";
        friction_fd_2d(block, disk, law);
    }
}

#[test]
fn friction_tangent_matches_central_differences_in_stick_and_slip_3d() {
    for (lower, upper) in [("Q1C1", "Q1C1"), ("Q1N2", "Q1N2"), ("Q1N2", "Q1C1")] {
        let law = "law = \"penalty\"\neps_n = 100.0\nmu = 0.3";
        for (shift, want_slip) in [(1e-4, false), (0.05, true)] {
            let mut h = Harness::new(&case_3d_blocks(lower, upper, law));
            let u0 = pressed_3d(&h, 0.04, [0.11, -0.07], 2e-3, 17);
            let lo = h
                .model
                .bodies
                .iter()
                .position(|b| b.name == "lower")
                .unwrap();
            let u1 = shifted(&h, &u0, &|b| {
                if b == lo {
                    vec![0.0; 3]
                } else {
                    vec![shift, 0.6 * shift, 0.0]
                }
            });
            let (err, kmax, stick, slip) = friction_fd(&mut h, &u0, &u1);
            let what = if want_slip { "slip" } else { "stick" };
            assert!(kmax > 1.0, "{lower}/{upper} {what}: no stiffness ({kmax})");
            if want_slip {
                assert!(
                    slip > stick,
                    "{lower}/{upper}: {slip} slipping, {stick} sticking"
                );
            } else {
                assert!(
                    stick > slip,
                    "{lower}/{upper}: {stick} sticking, {slip} slipping"
                );
            }
            assert!(err < 1e-6, "{lower}/{upper} {what}: tangent error {err:e}");
        }
    }
    // the curved partner: a Q1N2 hemisphere on a block
    let law = "law = \"penalty\"\neps_n = 100.0\nmu = 0.3";
    for (lower, shell) in [("Q1N2", "Q1N2"), ("Q1C1", "Q1N2")] {
        friction_fd_hemisphere(lower, shell, law);
    }
}

#[test]
fn friction_tangent_against_rigid_partners_matches_central_differences() {
    let rigid_2d = [
        "{ shape = \"plane\", point = [0.0, 0.0], normal = [0.2, 1.0], translation = [[0.3, 0.1]] }",
        "{ shape = \"circle\", center = [0.3, -2.0], radius = 2.0 }",
    ];
    let rigid_3d = [
        "{ shape = \"plane\", point = [0.0, 0.0, 0.0], normal = [0.1, -0.2, 1.0] }",
        "{ shape = \"sphere\", center = [0.2, 0.1, -3.0], radius = 3.0, rotation_deg = [10.0] }",
    ];
    for (dim, fams, shapes) in [
        (2, &["Q1C1", "Q1N2", "Q1N2.1"][..], &rigid_2d),
        (3, &["Q1C1", "Q1N2"][..], &rigid_3d),
    ] {
        for fam in fams {
            for r in shapes {
                for (shift, want_slip) in [(1e-4, false), (0.3, true)] {
                    let text = case_rigid(dim, fam, r)
                        .replace("eps_n = 100.0", "eps_n = 100.0\nmu = 0.4\neps_t = 50.0");
                    let mut h = Harness::new(&text);
                    // the rigid partner sits at its load-0.5 position (translated, rotated)
                    h.sys.set_load(0.5);
                    let down = if dim == 2 {
                        vec![0.05, -0.06]
                    } else {
                        vec![0.02, 0.01, -0.05]
                    };
                    let u0 = h.shifted_noisy(&down, 1);
                    // rigid shift along x (the partner moves too: its anchors with it)
                    let u1 = shifted(&h, &u0, &|_| {
                        let mut v = vec![0.0; dim];
                        v[0] = shift;
                        v
                    });
                    h.eval(&u0, false);
                    h.sys.commit();
                    h.sys.set_load(0.6);
                    let (err, kmax) = tangent_error(&mut h, &u1);
                    h.eval(&u1, false);
                    let res = &h.sys.results()[0].1[0];
                    let what = if want_slip { "slip" } else { "stick" };
                    assert!(kmax > 1.0, "{fam} {r} {what}: no stiffness ({kmax})");
                    if want_slip {
                        assert!(res.n_slip > 0, "{fam} {r}: {res:?}");
                    } else {
                        assert!(res.n_stick > 0, "{fam} {r}: {res:?}");
                    }
                    assert!(err < 1e-6, "{fam} {r} {what}: tangent error {err:e}");
                }
            }
        }
    }
}

/// The rescue's intermediate commits (`commit_warm_starts`) keep the friction anchors of the last
/// converged step, while a step's `commit` moves the slipping points' anchors; the warm starts
/// follow both (`export_points` rows: key 0..4, warm start 4..8, anchor 8..12; see
/// `system/checkpoint.rs`).
#[test]
fn intermediate_commits_keep_the_friction_anchors() {
    let law = "law = \"penalty\"\neps_n = 100.0\nmu = 0.3\neps_t = 80.0";
    let mut h = Harness::new(&case_2d("Q1N2", "Q1N2", law));
    let u0 = pressed(&h, 0.08, 0.0, 2e-3, 11);
    let disk_i = h
        .model
        .bodies
        .iter()
        .position(|b| b.name == "disk")
        .unwrap();
    let u1 = shifted(&h, &u0, &|b| {
        if b == disk_i {
            vec![0.06, 0.0]
        } else {
            vec![0.0; 2]
        }
    });
    h.eval(&u0, false);
    h.sys.commit();
    let at_u0 = h.sys.export_points();
    h.eval(&u1, false);
    let slip: usize = h.sys.results()[0].1.iter().map(|r| r.n_slip).sum();
    assert!(slip > 0, "the shift must make points slip");
    h.sys.commit_warm_starts();
    let intermediate = h.sys.export_points();
    h.sys.commit();
    let converged = h.sys.export_points();
    let row = crate::contact::system::CHECKPOINT_ROW;
    let split = |v: &[f64]| -> (Vec<f64>, Vec<f64>) {
        let (mut warm, mut anchors) = (Vec::new(), Vec::new());
        for r in v.chunks_exact(row) {
            warm.extend_from_slice(&r[4..8]);
            anchors.extend_from_slice(&r[8..12]);
        }
        (warm, anchors)
    };
    let ((w0, a0), (wi, ai), (wc, ac)) = (split(&at_u0), split(&intermediate), split(&converged));
    assert_eq!(ai, a0, "an intermediate commit moved friction anchors");
    assert_ne!(
        ac, a0,
        "a converged step's commit moves the slipping points' anchors"
    );
    assert_ne!(
        wi, w0,
        "an intermediate commit keeps the warm starts it reached"
    );
    assert_eq!(wi, wc);
}

#[test]
fn element_mean_gap_tangent_matches_central_differences() {
    // `gap = "element_mean"`: every point's traction depends on the gaps of all points of its
    // element and so on all their partners; deformable partners (smooth and faceted, whose edge
    // projections take the normal along the gap), 2D and 3D, and rigid partners
    let law = "law = \"penalty\"\neps_n = 100.0\ngap = \"element_mean\"";
    for (block, disk) in [
        ("Q1C1", "Q1C1"),
        ("Q1N2", "Q1N2"),
        ("Q1C1", "Q1N2"),
        ("Q1N2.1", "Q1CH"),
    ] {
        let mut h = Harness::new(&case_2d(block, disk, law));
        let u = pressed(&h, 0.08, 0.13, 2e-3, 11);
        let (err, kmax) = tangent_error(&mut h, &u);
        assert!(kmax > 1.0, "{block}/{disk}: no contact stiffness ({kmax})");
        assert!(err < 1e-6, "{block}/{disk}: tangent error {err:e}");
    }
    for (lower, upper) in [("Q1N2", "Q1N2"), ("Q1C1", "Q1N2")] {
        let mut h = Harness::new(&case_3d_blocks(lower, upper, law));
        let u = pressed_3d(&h, 0.04, [0.11, -0.07], 2e-3, 17);
        let (err, kmax) = tangent_error(&mut h, &u);
        assert!(kmax > 1.0, "{lower}/{upper}: no contact stiffness ({kmax})");
        assert!(err < 1e-6, "{lower}/{upper}: tangent error {err:e}");
    }
    let mut h = Harness::new(&case_3d_hemisphere("Q1N2", "Q1N2", law));
    let u = pressed_3d(&h, 0.06, [0.05, 0.08], 2e-3, 23);
    let (err, kmax) = tangent_error(&mut h, &u);
    assert!(kmax > 1.0 && err < 1e-6, "hemisphere: {err:e} ({kmax})");
    for (dim, fam, r) in [
        (
            2,
            "Q1N2",
            "{ shape = \"circle\", center = [0.3, -2.0], radius = 2.0 }",
        ),
        (
            2,
            "Q1C1",
            "{ shape = \"plane\", point = [0.0, 0.0], normal = [0.2, 1.0] }",
        ),
        (
            3,
            "Q1N2",
            "{ shape = \"sphere\", center = [0.2, 0.1, -3.0], radius = 3.0 }",
        ),
    ] {
        let mut h = Harness::new(&case_rigid_law(dim, fam, r, law));
        let shift = if dim == 2 {
            vec![0.05, -0.06]
        } else {
            vec![0.02, 0.01, -0.05]
        };
        let u = h.shifted_noisy(&shift, 3);
        let (err, kmax) = tangent_error(&mut h, &u);
        assert!(kmax > 1.0, "{fam} {r}: no contact stiffness ({kmax})");
        assert!(err < 1e-6, "{fam} {r}: tangent error {err:e}");
    }
}

#[test]
fn element_mean_gap_gives_every_point_of_an_element_the_same_pressure() {
    // the residual side: the points of one element carry the mean over the element (weights
    // w J0) of the pointwise penalty pressures eps_n <-g_N>
    let mut h = Harness::new(&case_2d(
        "Q1N2",
        "Q1N2",
        "law = \"penalty\"\neps_n = 100.0\ngap = \"element_mean\"",
    ));
    let u = pressed(&h, 0.08, 0.13, 0.0, 1);
    h.eval(&u, false);
    let (mut active, mut spread) = (0, 0.0f64);
    for pass in 0..2 {
        for points in h.sys.points_per_element(0, pass) {
            let w: f64 = points.iter().map(|p| p.2).sum();
            let paired: Vec<(f64, f64, f64)> =
                points.into_iter().filter(|p| !p.1.is_nan()).collect();
            if paired.is_empty() {
                continue;
            }
            // the mean of the pointwise penalty pressures over the element's area
            let expected = 100.0 * paired.iter().map(|p| (-p.1).max(0.0) * p.2).sum::<f64>() / w;
            for &(p, _, _) in &paired {
                assert!(
                    (p - expected).abs() < 1e-12 * (1.0 + expected),
                    "{p} vs {expected}"
                );
            }
            if expected > 0.0 {
                active += 1;
                let (lo, hi) = paired
                    .iter()
                    .fold((f64::MAX, f64::MIN), |(a, b), p| (a.min(p.1), b.max(p.1)));
                spread = spread.max(hi - lo);
            }
        }
    }
    // elements in contact whose points have different gaps: the pressure is not the pointwise one
    assert!(
        active > 2 && spread > 1e-4,
        "{active} elements, gap spread {spread:e}"
    );
}

#[test]
fn element_mean_gap_friction_tangent_matches_central_differences_in_stick_and_slip() {
    // the slip traction mu p s depends on the element's pressure: its rows take the mean's
    // variation along n + mu s
    let law = "law = \"penalty\"\neps_n = 100.0\nmu = 0.3\neps_t = 80.0\ngap = \"element_mean\"";
    for (block, disk) in [("Q1N2", "Q1N2"), ("Q1C1", "Q1C1")] {
        friction_fd_2d(block, disk, law);
    }
    let law3 = "law = \"penalty\"\neps_n = 100.0\nmu = 0.3\ngap = \"element_mean\"";
    friction_fd_hemisphere("Q1N2", "Q1N2", law3);
}
