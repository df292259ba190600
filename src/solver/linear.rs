//! The iterative linear route's near-null space: the rigid-body modes of each body, built from the
//! reference coordinates of the nodes (and control points) that carry its unknowns, for GAMG.

use crate::assembly::DofMap;
use crate::model::Model;
use crate::petsc::{NullSpace, Petsc, PetscError, Vector};

/// Rigid-body modes per body: 3 in 2D (two translations, the rotation), 6 in 3D.
pub fn modes_per_body(dim: usize) -> usize {
    if dim == 2 {
        3
    } else {
        6
    }
}

/// The owned entries of body `b`'s rigid-body modes, `[mode][owned row]`, for every body that has
/// owned unknowns on this rank (a mode of body A is zero on body B's unknowns). Rows of `constrained`
/// unknowns are zeroed when `zero_constrained` (they are identity rows of the Jacobian).
pub fn rigid_body_mode_entries(
    model: &Model,
    dofs: &DofMap,
    constrained: &[bool],
    zero_constrained: bool,
) -> Vec<Vec<Vec<f64>>> {
    let dim = dofs.dim;
    let (lo, hi) = dofs.owned_range();
    let n_owned = (hi - lo) as usize;
    let k = modes_per_body(dim);
    let mut out = vec![vec![vec![0.0; n_owned]; k]; model.bodies.len()];
    for (b, body) in model.bodies.iter().enumerate() {
        let first = body.node_offset as usize;
        for n in first..first + body.n_nodes() {
            if dofs.rep[n] as usize != n {
                continue;
            }
            let f = dofs.first_dof[n];
            if f < lo || f >= hi {
                continue;
            }
            let row = (f - lo) as usize;
            let x = &model.coords[n * dim..(n + 1) * dim];
            let modes = &mut out[b];
            for c in 0..dim {
                modes[c][row + c] = 1.0;
            }
            if dim == 2 {
                modes[2][row] = -x[1];
                modes[2][row + 1] = x[0];
            } else {
                // rotations about x, y, z: omega x X
                modes[3][row + 1] = -x[2];
                modes[3][row + 2] = x[1];
                modes[4][row] = x[2];
                modes[4][row + 2] = -x[0];
                modes[5][row] = -x[1];
                modes[5][row + 1] = x[0];
            }
            if zero_constrained {
                for c in 0..dim {
                    if constrained[f as usize + c] {
                        for m in modes.iter_mut() {
                            m[row + c] = 0.0;
                        }
                    }
                }
            }
        }
    }
    out
}

/// The near-null space of the Jacobian: every body's rigid-body modes (see
/// [`rigid_body_mode_entries`]), orthonormalised by modified Gram-Schmidt (twice) over all of
/// them; a mode that is (numerically) a combination of the others is left out, as is a body with
/// no unknowns. `like` gives the row layout.
///
/// Collective.
pub fn rigid_body_null_space<'p>(
    petsc: &'p Petsc,
    like: &Vector<'p>,
    model: &Model,
    dofs: &DofMap,
    constrained: &[bool],
    zero_constrained: bool,
) -> Result<NullSpace<'p>, PetscError> {
    let entries = rigid_body_mode_entries(model, dofs, constrained, zero_constrained);
    let mut basis: Vec<Vector<'p>> = Vec::new();
    for body in entries {
        for mode in body {
            let mut v = like.duplicate()?;
            v.write()?.copy_from_slice(&mode);
            let before = v.norm2()?;
            if before == 0.0 {
                continue;
            }
            for _ in 0..2 {
                for q in &basis {
                    let d = q.dot(&v)?;
                    v.axpy(-d, q)?;
                }
            }
            let after = v.norm2()?;
            if after <= 1e-8 * before {
                continue;
            }
            v.scale(1.0 / after)?;
            basis.push(v);
        }
    }
    NullSpace::new(petsc, &basis)
}
