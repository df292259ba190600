//! The assembled system is consistent with itself: the PETSc Jacobian that the assembler builds
//! (COO pattern, restriction, constrained rows, ties, enriched elements, Q1E4 condensation) equals a
//! central finite difference of the assembled residual, column by column, at a random deformed
//! state; and the MatSetValues path builds the same matrix as the COO path.
//!
//! One test per binary: MPI can be initialised once per process.

use nurbs_contact::assembly::{constrained_flags, prescribed_values, Assembler, DofMap};
use nurbs_contact::model::Model;
use nurbs_contact::petsc::{Matrix, NonlinearProblem, Petsc, Vector};
use nurbs_contact::scene::parse_case;
use std::path::Path;

/// Two bodies in one system: a Q1E4 strip with a periodic tie, and a half disk with its arc
/// enriched by Q1N2; Dirichlet conditions on both.
const CASE: &str = r#"
[case]
name = "fd"
dim = 2
[meshes.strip]
generator = "rectangle"
origin = [0.0, 0.0]
size = [3.0, 1.0]
divisions = [3, 2]
[meshes.disk]
generator = "half_disk"
center = [0.0, 3.0]
radius = 1.0
n_arc = 4
n_radial = 1
[bodies.strip]
mesh = "strip"
element = "Q1E4"
[bodies.strip.material]
model = "neo_hookean"
E = 1.0
nu = 0.3
[bodies.disk]
mesh = "disk"
element = "Q1N2"
enriched_surface = "arc"
[bodies.disk.material]
model = "neo_hookean"
E = 3.0
nu = 0.3
[[ties]]
body = "strip"
master = "left"
slave = "right"
offset = [3.0, 0.0]
[[bcs]]
body = "strip"
set = "bottom"
kind = "fixed"
[[bcs]]
body = "disk"
set = "top"
kind = "displacement"
value = [[0.05, -0.1]]
[[stages]]
name = "s"
steps = 1
"#;

/// A deterministic pseudo-random value in [-1, 1].
fn rnd(state: &mut u64) -> f64 {
    *state = state
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    ((*state >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
}

fn column(asm: &mut Assembler, x: &Vector, j: usize, h: f64) -> Vec<f64> {
    let mut xp = x.duplicate().unwrap();
    let mut xm = x.duplicate().unwrap();
    x.copy_to(&mut xp).unwrap();
    x.copy_to(&mut xm).unwrap();
    xp.write().unwrap()[j] += h;
    xm.write().unwrap()[j] -= h;
    let (mut fp, mut fm) = (x.duplicate().unwrap(), x.duplicate().unwrap());
    asm.residual(&xp, &mut fp).unwrap();
    asm.residual(&xm, &mut fm).unwrap();
    let (fp, fm) = (fp.read().unwrap().to_vec(), fm.read().unwrap().to_vec());
    fp.iter()
        .zip(&fm)
        .map(|(a, b)| (a - b) / (2.0 * h))
        .collect()
}

fn jacobian_columns(j: &Matrix, x: &Vector, n: usize) -> Vec<Vec<f64>> {
    (0..n)
        .map(|c| {
            let mut e = x.duplicate().unwrap();
            e.set(0.0).unwrap();
            e.write().unwrap()[c] = 1.0;
            let mut y = x.duplicate().unwrap();
            j.mult(&e, &mut y).unwrap();
            let v = y.read().unwrap().to_vec();
            v
        })
        .collect()
}

/// The largest entry-wise difference of two matrices given by columns.
fn max_abs_diff(a: &[Vec<f64>], b: &[Vec<f64>]) -> f64 {
    a.iter()
        .flatten()
        .zip(b.iter().flatten())
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()))
}

#[test]
fn assembled_jacobian_matches_finite_differences_of_the_assembled_residual() {
    let universe = mpi::initialize().expect("MPI init");
    let world = universe.world();
    let petsc = Petsc::init(&world, &["assembly_fd".to_string()]).expect("PETSc init");

    let case = parse_case(CASE, Path::new("fd.toml"), &[]).expect("case");
    let model = Model::build(&case).expect("model");
    let part = vec![0u32; model.n_cells()];
    let build = || {
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
        let sets = model.element_sets(&case.file, &part, 0).unwrap();
        let constrained = constrained_flags(&model.bcs, &dofs);
        (dofs, sets, constrained)
    };
    let (dofs, sets, constrained) = build();
    let n = dofs.n_global();
    assert!(
        model.ties.len() == 3,
        "the periodic tie joined the strip ends"
    );
    let mut x = Vector::new_mpi(&petsc, n).unwrap();
    let mut asm = Assembler::new(&petsc, &x, dofs, sets, constrained).unwrap();
    let values = prescribed_values(&model.bcs, &asm.dofs, &model.coords, 1.0).unwrap();
    asm.set_prescribed(&values);

    // A random but moderate deformed state (keeps every element far from inversion).
    let mut seed = 42u64;
    {
        let mut xa = x.write().unwrap();
        for v in xa.iter_mut() {
            *v = 0.03 * rnd(&mut seed);
        }
    }
    let mut j = Matrix::new_aij(&petsc, n).unwrap();
    asm.jacobian(&x, &mut j).unwrap();
    let cols = jacobian_columns(&j, &x, n);
    let scale = cols.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
    let mut worst = 0.0f64;
    for (c, col) in cols.iter().enumerate() {
        let fd = column(&mut asm, &x, c, 1e-6);
        for (a, b) in fd.iter().zip(col) {
            worst = worst.max((a - b).abs());
        }
    }
    assert!(
        worst < 1e-6 * scale,
        "Jacobian vs central differences: {worst:e} (scale {scale:e})"
    );

    // The classic MatSetValues path assembles the same matrix.
    let (dofs2, sets2, constrained2) = build();
    let mut asm2 = Assembler::new(&petsc, &x, dofs2, sets2, constrained2).unwrap();
    asm2.use_preallocated(model.cell_offsets.clone(), model.cell_nodes.clone());
    asm2.set_prescribed(&values);
    let mut j2 = Matrix::new_aij(&petsc, n).unwrap();
    asm2.jacobian(&x, &mut j2).unwrap();
    let cols2 = jacobian_columns(&j2, &x, n);
    let diff = max_abs_diff(&cols, &cols2);
    assert!(
        diff < 1e-13 * scale,
        "COO and MatSetValues Jacobians differ by {diff:e}"
    );

    // A second Jacobian on the same COO pattern, at another state, does not keep the first's
    // values (the cells' element entries add into shared COO entries from zero): it equals the
    // classic path's at that state.
    {
        let mut xa = x.write().unwrap();
        for v in xa.iter_mut() {
            *v += 0.02 * rnd(&mut seed);
        }
    }
    asm.jacobian(&x, &mut j).unwrap();
    asm2.jacobian(&x, &mut j2).unwrap();
    let diff = max_abs_diff(&jacobian_columns(&j, &x, n), &jacobian_columns(&j2, &x, n));
    assert!(
        diff < 1e-13 * scale,
        "second COO Jacobian and MatSetValues differ by {diff:e}"
    );
}
