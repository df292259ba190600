//! Restarting from a checkpoint: reading it and restoring the solver's state.

use super::options::Solver;
use super::{agree, comm_rank, log, Error, RunOptions, Verbosity};
use crate::contact::ContactSystem;
use crate::model::Model;
use crate::petsc::Petsc;
use crate::scene::Case;
use std::path::PathBuf;

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

/// Puts a checkpoint's state into the solver: displacement (owned unknowns, from the node values),
/// element history (from the cell values), contact state (from the point rows). Collective.
pub(super) fn restore(
    petsc: &Petsc,
    model: &Model,
    solver: &mut Solver,
    state: &crate::checkpoint::State,
) -> Result<(), Error> {
    let dim = model.dim;
    let mismatch = |what: &str, got: usize, expected: usize| {
        Err(Error::Restart(format!(
            "the checkpoint's {what} has {got} values, the model needs {expected}"
        )))
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
            "element history",
            state.element_history.len(),
            model.n_cells() * w,
        );
    }
    if !state.displacement_before.is_empty()
        && state.displacement_before.len() != state.displacement.len()
    {
        return mismatch(
            "displacement before the last step",
            state.displacement_before.len(),
            state.displacement.len(),
        );
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
    solver.x_before = None;
    if !state.displacement_before.is_empty() {
        let mut b = solver.x.duplicate()?;
        b.set(0.0)?;
        scatter(&mut b, &state.displacement_before)?;
        solver.x_before = Some(b);
    }
    let cell_offset: Vec<usize> = model.bodies.iter().map(|b| b.cell_offset).collect();
    let mut local = Ok(());
    for set in &mut solver.asm.sets {
        let hw = set.history_width();
        if hw == 0 {
            continue;
        }
        if hw > w {
            local = mismatch("element history per cell", w, hw);
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
        solver.asm.preset_coupling_pattern(&all);
    }
    if local.is_ok() {
        if let Some(c) = solver.asm.coupling_set_mut::<ContactSystem>() {
            local = c
                .import_points(&state.contact_points)
                .map_err(|m| Error::Restart(format!("the checkpoint's contact state: {m}")));
        }
    }
    agree(petsc.comm(), local)
}
