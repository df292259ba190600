//! Restarting from a checkpoint: reading it and restoring the solver's state.

use super::options::Solver;
use super::{agree, comm_rank, log, Error, RunOptions, Verbosity};
use crate::contact::ContactSystem;
use crate::model::Model;
use crate::petsc::Petsc;
use crate::scene::Case;
use std::path::{Path, PathBuf};

/// How far a restored displacement may miss a prescribed value, relative to the largest
/// prescribed value (at least 1): Newton leaves the constrained rows exact to round-off.
const PRESCRIBED_TOL: f64 = 1e-8;

/// With `--restart DIR`: the last checkpoint in DIR and its state, after checking that the case
/// may continue it. Every rank reads it. Collective.
pub(super) fn read_checkpoint(
    petsc: &Petsc,
    opts: &RunOptions,
    case: &Case,
) -> Result<Option<(PathBuf, crate::checkpoint::State)>, Error> {
    let Some(dir) = &opts.restart else {
        return Ok(None);
    };
    let read = || -> Result<(PathBuf, crate::checkpoint::State, Vec<String>), Error> {
        let ckpt = crate::checkpoint::latest(dir).map_err(Error::Restart)?;
        let state = crate::checkpoint::read_state(&ckpt)?;
        let started = crate::checkpoint::stages_started(&state.position);
        let changed =
            crate::checkpoint::compare_cases(&state.case_toml, &case.to_toml_string()?, started)
                .and_then(|changed| {
                    crate::checkpoint::compare_meshes(
                        &state.log.mesh_hashes,
                        &crate::checkpoint::mesh_hashes(case),
                    )
                    .map(|()| changed)
                })
                .map_err(|m| {
                    Error::Restart(format!(
                        "{}: cannot continue the checkpoint {}: {m}",
                        case.file.display(),
                        ckpt.display()
                    ))
                })?;
        Ok((ckpt, state, changed))
    };
    let (ckpt, state, changed) = agree(petsc.comm(), read())?;
    if !changed.is_empty() && comm_rank(petsc) == 0 {
        // printed at any verbosity: the run from here is not the one the checkpoint began
        eprintln!(
            "note: continuing with solver settings that differ from the checkpoint's: {}",
            changed.join(", ")
        );
    }
    let r = (ckpt, state);
    log(comm_rank(petsc), opts.verbosity, Verbosity::Normal, || {
        format!(
            "restart from {} (step {}, load {:.6}, written on {} rank{})",
            r.0.display(),
            r.1.position.step,
            r.1.position.lambda,
            r.1.ranks,
            if r.1.ranks == 1 { "" } else { "s" }
        )
    });
    Ok(Some(r))
}

/// Puts the state of the checkpoint `ckpt` into the solver: displacement (owned unknowns, from
/// the node values), element history (from the cell values), contact state (from the point rows).
/// A state that does not fit the model (sizes), that breaks the boundary conditions at its own
/// load, or whose displacement folds an element over, is refused as a bad checkpoint naming the
/// file and the dataset. Collective.
pub(super) fn restore(
    petsc: &Petsc,
    model: &Model,
    solver: &mut Solver,
    ckpt: &Path,
    state: &crate::checkpoint::State,
) -> Result<(), Error> {
    let dim = model.dim;
    let file = ckpt.join("state.h5");
    let bad = |dataset: &str, message: String| {
        Error::Restart(format!(
            "{}: a bad checkpoint: dataset `{dataset}`: {message}",
            file.display()
        ))
    };
    let mismatch = |dataset: &str, got: usize, expected: usize| {
        Err(bad(
            dataset,
            format!("{got} values, the model needs {expected}"),
        ))
    };
    if state.displacement.len() != model.n_nodes() * dim {
        return mismatch(
            "displacement",
            state.displacement.len(),
            model.n_nodes() * dim,
        );
    }
    let w = state.element_history_width;
    if state.element_history.len() != model.n_cells() * w {
        return mismatch(
            "element_history",
            state.element_history.len(),
            model.n_cells() * w,
        );
    }
    if !state.displacement_before.is_empty()
        && state.displacement_before.len() != state.displacement.len()
    {
        return mismatch(
            "displacement_before",
            state.displacement_before.len(),
            state.displacement.len(),
        );
    }
    if !state
        .contact_points
        .len()
        .is_multiple_of(crate::contact::system::CHECKPOINT_ROW)
    {
        return Err(bad(
            "contact_points",
            format!(
                "{} values, not rows of {}",
                state.contact_points.len(),
                crate::contact::system::CHECKPOINT_ROW
            ),
        ));
    }
    let dofs = &solver.asm.dofs;
    let (lo, hi) = dofs.owned_range();
    // node values into the owned unknowns of `v`
    let scatter = |v: &mut crate::petsc::Vector, nodal: &[f64]| -> Result<(), Error> {
        let mut w = v.write()?;
        for n in 0..model.n_nodes() {
            for c in 0..dim {
                if let Some(g) = dofs.global(n as u32, c).filter(|g| (lo..hi).contains(&g.0)) {
                    w[(g.0 - lo) as usize] = nodal[n * dim + c];
                }
            }
        }
        Ok(())
    };
    scatter(&mut solver.x, &state.displacement)?;
    // the displacement of a converged step meets the boundary conditions at its load (Newton
    // makes the constrained rows exact), and folds no element over
    let lambda = state.position.lambda;
    let prescribed = crate::assembly::prescribed_values(&model.bcs, dofs, &model.coords, lambda)
        .map_err(|e| bad("position", format!("at its load {lambda}: {e}")))?;
    let mut local = Ok(());
    {
        let xa = solver.x.read()?;
        let scale = prescribed.iter().fold(1.0f64, |m, (_, v)| m.max(v.abs()));
        for (g, v) in prescribed.iter().filter(|(g, _)| (lo..hi).contains(&g.0)) {
            let u = xa[(g.0 - lo) as usize];
            if (u - v).abs() > PRESCRIBED_TOL * scale {
                let n = (0..model.n_nodes())
                    .find(|&n| (0..dim).any(|c| dofs.global(n as u32, c) == Some(*g)));
                let (node, c) = n
                    .and_then(|n| {
                        (0..dim)
                            .find(|&c| dofs.global(n as u32, c) == Some(*g))
                            .map(|c| (n, c))
                    })
                    .unwrap_or((usize::MAX, 0));
                local = Err(bad(
                    "displacement",
                    format!(
                        "{}, component {}: {u:e} where the boundary conditions \
                         prescribe {v:e} at the checkpoint's load {lambda}",
                        model.node_label(node as u32),
                        ["x", "y", "z"][c]
                    ),
                ));
                break;
            }
        }
    }
    agree(petsc.comm(), local)?;
    let mut local = Ok(());
    solver.x_before = None;
    if !state.displacement_before.is_empty() {
        let mut b = solver.x.duplicate()?;
        b.set(0.0)?;
        scatter(&mut b, &state.displacement_before)?;
        solver.x_before = Some(b);
    }
    let cell_offset: Vec<usize> = model.bodies.iter().map(|b| b.cell_offset).collect();
    for set in &mut solver.asm.sets {
        let hw = set.history_width();
        if hw == 0 {
            continue;
        }
        if hw > w {
            local = mismatch("element_history (per cell)", w, hw);
            break;
        }
        for e in 0..set.len() {
            let (body, cell) = set.cell_id(e);
            let g = cell_offset[body] + cell;
            set.set_history(e, &state.element_history[g * w..g * w + hw]);
        }
    }
    if !state.contact_pattern.is_empty() {
        let all: Vec<crate::contact::Coupling> = state
            .contact_pattern
            .chunks_exact(3)
            .map(|r| (r[0] as u32, r[1] as u32, r[2] as u32))
            .collect();
        if let Err(why) = solver.asm.preset_coupling_pattern(&all) {
            local = Err(bad("contact_pattern", why));
        }
    }
    if local.is_ok() {
        if let Some(c) = solver.asm.coupling_set_mut::<ContactSystem>() {
            local = c
                .import_points(&state.contact_points)
                .map_err(|m| bad("contact_points", m));
        }
    }
    agree(petsc.comm(), local)?;
    if let Some(fold) = solver.asm.find_tangled(&solver.x)? {
        return Err(bad(
            "displacement",
            format!("it folds an element over: {fold}"),
        ));
    }
    Ok(())
}
