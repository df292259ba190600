//! Output on rank 0: results.h5/.xdmf and history.csv, the contact history columns and contact
//! fields.

use super::gather::gather_varcount;
use super::{agree, Error};
use crate::assembly::{Assembler, DofMap, GlobalDof, NodeOffsets};
use crate::contact::system::POINT_RECORD;
use crate::contact::ContactSystem;
use crate::io::{self, FieldData, GridDef, HistoryRow, HistoryWriter, ResultsWriter, Summary};
use crate::model::Model;
use crate::petsc::{Petsc, PetscInt, Scatter, Vector};
use crate::scene::{Case, OutputField};
use crate::solver::StepRecord;
use mpi::collective::SystemOperation;
use mpi::traits::*;
use std::path::{Path, PathBuf};

/// `history.csv` columns after the reaction forces: reaction moments `M_<body>_<set>[_<x|y|z>]`
/// (2D: about z), then the contact columns, then (on the iterative linear route only, so that the
/// direct route's history is as before) `linear_fallbacks`: the step's retries with MUMPS after a
/// failed Krylov solve.
pub(super) fn history_extra_labels(model: &Model, iterative: bool) -> Vec<String> {
    let mut out = Vec::new();
    for (label, _, _) in &model.reaction_moments {
        if model.dim == 2 {
            out.push(format!("M_{label}"));
        } else {
            out.extend(["x", "y", "z"].map(|a| format!("M_{label}_{a}")));
        }
    }
    out.extend(contact_history_labels(model));
    if iterative {
        out.push("linear_fallbacks".to_string());
    }
    out
}

/// `history.csv` columns of the contact pairs, per pair and half-pass (named after the integrated
/// surface): resultant force `P_<pair>_<surface>_<x|y|z>` on that surface's body, moment of the
/// contact forces about the pair's moment point `M_<pair>_<surface>[_<x|y|z>]` (2D: about z),
/// active quadrature points and largest penetration; with friction, the resultant tangential force
/// `Pt_<pair>_<surface>_<x|y|z>` and the sticking and slipping points `stick_`/`slip_<pair>_<surface>`.
pub(super) fn contact_history_labels(model: &Model) -> Vec<String> {
    let dim = model.dim;
    let mut out = Vec::new();
    for pair in &model.contact_pairs {
        for (k, _) in &pair.passes {
            let tag = format!("{}_{}", pair.name, model.contact_surfaces[*k].name);
            for a in &["x", "y", "z"][..dim] {
                out.push(format!("P_{tag}_{a}"));
            }
            if dim == 2 {
                out.push(format!("M_{tag}"));
            } else {
                for a in ["x", "y", "z"] {
                    out.push(format!("M_{tag}_{a}"));
                }
            }
            out.push(format!("active_{tag}"));
            out.push(format!("penetration_{tag}"));
            if pair.friction.is_some() {
                for a in &["x", "y", "z"][..dim] {
                    out.push(format!("Pt_{tag}_{a}"));
                }
                out.push(format!("stick_{tag}"));
                out.push(format!("slip_{tag}"));
            }
        }
    }
    if model
        .contact_pairs
        .iter()
        .any(|p| p.formulation.augmented().is_some())
    {
        out.push("augmentation_rounds".to_string());
    }
    out
}

/// Values of [`contact_history_labels`] at the last residual evaluation, summed (maximum for the
/// penetration) over ranks.
///
/// Collective.
pub(super) fn contact_history(asm: &Assembler, dim: usize) -> Vec<f64> {
    let Some(c) = asm.coupling_set::<ContactSystem>() else {
        return Vec::new();
    };
    let (mut sums, mut maxes) = (Vec::new(), Vec::new());
    // per half-pass: the columns summed before its penetration and after it
    let mut layout = Vec::new();
    for ((_, passes), frictional) in c.results().into_iter().zip(c.frictional()) {
        for r in passes {
            let first = sums.len();
            sums.extend_from_slice(&r.force[..dim]);
            if dim == 2 {
                sums.push(r.moment[2]);
            } else {
                sums.extend_from_slice(&r.moment);
            }
            sums.push(r.n_active as f64);
            let mid = sums.len();
            if frictional {
                sums.extend_from_slice(&r.tangential[..dim]);
                sums.push(r.n_stick as f64);
                sums.push(r.n_slip as f64);
            }
            layout.push((first, mid, sums.len()));
            maxes.push(r.max_penetration);
        }
    }
    let comm = asm.comm();
    let (mut s, mut m) = (vec![0.0; sums.len()], vec![0.0; maxes.len()]);
    comm.all_reduce_into(&sums[..], &mut s[..], SystemOperation::sum());
    comm.all_reduce_into(&maxes[..], &mut m[..], SystemOperation::max());
    let mut out = Vec::new();
    for (&(first, mid, end), mx) in layout.iter().zip(&m) {
        out.extend_from_slice(&s[first..mid]);
        out.push(*mx);
        out.extend_from_slice(&s[mid..end]);
    }
    out
}

/// The contact fields on rank 0 as (name, components, nodal values [n_nodes * components]): the
/// contact pressure (per current area), the nominal contact pressure (per reference area) and the
/// normal gap, and with friction the tangential traction (`dim` components, on the surface's body)
/// and the fractions of sticking and slipping contact; all L2 projections of the pointwise values
/// on each contact surface's own interpolation (Sauer 2013; [`ContactSystem::l2_rhs`](crate::contact::ContactSystem::l2_rhs),
/// [`ContactSystem::l2_rhs_friction`](crate::contact::ContactSystem::l2_rhs_friction)). `None` without contact or off rank 0. A node shared by two
/// contact surfaces shows the last surface's value.
///
/// Collective.
pub(super) fn contact_fields(
    asm: &Assembler,
    n_nodes: usize,
    root: bool,
    ties: &[Vec<(u32, u32)>],
) -> Option<Vec<(&'static str, usize, Vec<f64>)>> {
    let c = asm.coupling_set::<ContactSystem>()?;
    let (fp, fg) = c.l2_rhs();
    let frictional = c.frictional().iter().any(|&f| f);
    let ff = if frictional {
        c.l2_rhs_friction()
    } else {
        Vec::new()
    };
    let comm = asm.comm();
    let sum = |f: &[f64]| {
        let mut s = vec![0.0; f.len()];
        comm.all_reduce_into(f, &mut s[..], SystemOperation::sum());
        s
    };
    let (sp, sg, sf) = (sum(&fp), sum(&fg), sum(&ff));
    // the element mass matrices, each from the rank that owns the element
    let (mc, mn) = (sum(&c.l2_mass(false)), sum(&c.l2_mass(true)));
    if !root {
        return None;
    }
    let nt = c.all_surface_nodes().len();
    let dim = asm.dofs.dim;
    let mut out = vec![
        ("contact_pressure", 1, vec![0.0; n_nodes]),
        ("contact_pressure_nominal", 1, vec![0.0; n_nodes]),
        ("contact_gap", 1, vec![0.0; n_nodes]),
    ];
    if frictional {
        out.push(("tangential_traction", dim, vec![0.0; n_nodes * dim]));
        out.push(("stick_fraction", 1, vec![0.0; n_nodes]));
        out.push(("slip_fraction", 1, vec![0.0; n_nodes]));
    }
    let nb = dim + 2;
    for s in 0..c.surfaces().len() {
        // (field in `out`, component, projection)
        let (ps, gs) = (&sp[s * nt..(s + 1) * nt], &sg[s * nt..(s + 1) * nt]);
        // the scalar fields are symmetric across a symmetry plane (the traction's components
        // are not all): projected with the surface's ties
        let tie: &[(u32, u32)] = ties.get(s).map_or(&[], |t| &t[..]);
        let mut proj = vec![
            (0, 0, c.l2_project(s, ps, &mc, tie)),
            (1, 0, c.l2_project(s, ps, &mn, tie)),
            (2, 0, c.l2_project(s, gs, &mc, tie)),
        ];
        if frictional {
            // blocks of `sf` per surface: the traction's components, stick, slip
            for b in 0..nb {
                let (field, comp) = match b {
                    _ if b < dim => (3, b),
                    _ if b == dim => (4, 0),
                    _ => (5, 0),
                };
                let f = &sf[(s * nb + b) * nt..(s * nb + b + 1) * nt];
                let t = if b < dim { &[][..] } else { tie };
                proj.push((field, comp, c.l2_project(s, f, &mc, t)));
            }
        }
        for t in c.surface_nodes(s) {
            let node = c.all_surface_nodes()[t as usize] as usize;
            for (field, comp, v) in &proj {
                let (_, w, vals) = &mut out[*field];
                vals[node * *w + comp] = v[t as usize];
            }
        }
    }
    Some(out)
}

/// The contact quadrature points of all ranks on rank 0, [`POINT_RECORD`] values each (see
/// [`ContactSystem::point_records`](crate::contact::ContactSystem::point_records)), sorted by their key so that the order does not depend on the
/// partition; `None` on the other ranks and without contact.
///
/// Collective.
pub(super) fn gather_points(asm: &Assembler) -> Option<Vec<f64>> {
    let c = asm.coupling_set::<ContactSystem>()?;
    let comm = asm.comm();
    // a leading entry keeps every contribution non-empty (Open MPI rejects an all-empty Gatherv)
    let mut buf = vec![0.0];
    buf.extend(c.point_records());
    let (all, lens, displs) = gather_varcount(comm, &buf[..])?;
    let mut recs: Vec<&[f64]> = Vec::new();
    for (d, l) in displs.iter().zip(&lens) {
        let (a, b) = (*d as usize + 1, (*d + *l) as usize);
        recs.extend(all[a..b].chunks_exact(POINT_RECORD));
    }
    recs.sort_by(|a, b| a[..3].partial_cmp(&b[..3]).expect("integer keys"));
    Some(recs.concat())
}

/// Sample points per enriched element edge in the "surface" output grid.
pub(super) const SURFACE_SAMPLES: usize = 8;

/// Results of a run on rank 0 (the other ranks only take part in the gathers).
pub(super) struct Output<'p> {
    pub(super) root: bool,
    pub(super) dim: usize,
    pub(super) n_nodes: usize,
    pub(super) n_cells: usize,
    /// Where the results, history and summary are written.
    pub(super) out_dir: PathBuf,
    /// Where the checkpoints go (`checkpoints/` in it): the run directory.
    pub(super) checkpoint_dir: PathBuf,
    pub(super) fields: Vec<OutputField>,
    pub(super) results: Option<ResultsWriter>,
    pub(super) history: Option<HistoryWriter>,
    /// Gathers the whole displacement on rank 0, in node order.
    pub(super) gather: Scatter<'p>,
    pub(super) u_root: Vector<'p>,
    /// Nodes that carry no unknowns (display nodes, nodes in no cell): zeroed after the gather,
    /// before display nodes are interpolated. [n_nodes]
    pub(super) without_unknowns: Vec<bool>,
    /// Cells of each body start here in the global cell numbering.
    pub(super) cell_offset: Vec<usize>,
    pub(super) case_toml: String,
    /// Display nodes of enriched surfaces (global id, interpolation from element nodes).
    pub(super) display: Vec<(u32, Vec<(u32, f64)>)>,
    /// Enriched-surface grids ("surface", "control_net") written beside "bulk".
    pub(super) sampled: Vec<crate::model::SampledGrid>,
    /// Reference positions of the contact quadrature points ("contact_points" grid, rank 0;
    /// empty without contact) [n][dim].
    pub(super) point_ref: Vec<f64>,
    /// Per contact surface, the ties of its scalar fields' L2 projections at the symmetry planes
    /// (the `sliding` conditions' planes) that cut it ([`crate::contact::system::symmetry_ties`]).
    pub(super) symmetry_ties: Vec<Vec<(u32, u32)>>,
}

impl<'p> Output<'p> {
    #[allow(clippy::too_many_arguments)]
    pub(super) fn new(
        petsc: &'p Petsc,
        model: &Model,
        case: &Case,
        dofs: &DofMap,
        out_dir: &Path,
        checkpoint_dir: &Path,
        root: bool,
        resume: Option<(&Path, &crate::checkpoint::RunLog)>,
        points: Option<&[f64]>,
    ) -> Result<Self, Error> {
        let (dim, n_nodes) = (model.dim, model.n_nodes());
        let point_ref: Vec<f64> = points
            .unwrap_or_default()
            .chunks_exact(POINT_RECORD)
            .flat_map(|r| r[3..3 + dim].to_vec())
            .collect();
        // Rank 0 asks for every unknown in node order; nodes outside every cell read entry 0 and are
        // zeroed after the gather.
        let without_unknowns: Vec<bool> = (0..n_nodes as u32)
            .map(|n| dofs.global(n, 0).is_none())
            .collect();
        let idx: Vec<PetscInt> = if root {
            (0..n_nodes as u32)
                .flat_map(|n| (0..dim).map(move |c| (n, c)))
                .map(|(n, c)| dofs.global(n, c).map_or(0, |g: GlobalDof| g.0))
                .collect()
        } else {
            Vec::new()
        };
        let u_root = Vector::new_seq(petsc, idx.len())?;
        let template = Vector::new_mpi(petsc, dofs.n_owned())?;
        let gather = Scatter::new(petsc, &template, &u_root, &idx)?;
        let mut out = Output {
            root,
            dim,
            n_nodes,
            n_cells: model.n_cells(),
            out_dir: out_dir.to_path_buf(),
            checkpoint_dir: checkpoint_dir.to_path_buf(),
            fields: case.output.fields.clone(),
            results: None,
            history: None,
            gather,
            u_root,
            cell_offset: model.bodies.iter().map(|b| b.cell_offset).collect(),
            case_toml: case.to_toml_string()?,
            without_unknowns: Vec::new(),
            display: model.display_interpolation(),
            sampled: [model.surface_grid(SURFACE_SAMPLES), model.control_net()]
                .into_iter()
                .flatten()
                .collect(),
            point_ref,
            symmetry_ties: {
                let planes = crate::contact::system::symmetry_planes(
                    &model.skews,
                    &model.bcs,
                    &model.coords,
                    dim,
                );
                model
                    .contact_surfaces
                    .iter()
                    .map(|surf| {
                        crate::contact::system::symmetry_ties(surf, &planes, &model.coords, dim)
                    })
                    .collect()
            },
        };
        let iterative = super::options::linear_route(case, dofs)
            == crate::scene::schema::LinearSolver::Iterative;
        let created = if root {
            out.create_files(model, case, iterative, out_dir, resume)
        } else {
            Ok(())
        };
        agree(petsc.comm(), created)?;
        out.without_unknowns = without_unknowns;
        Ok(out)
    }

    /// Rank 0: the output directory and writers; results of an earlier run there are removed first,
    /// so a rerun that dies cannot leave an old summary beside its new history.
    pub(super) fn create_files(
        &mut self,
        model: &Model,
        case: &Case,
        iterative: bool,
        out_dir: &Path,
        resume: Option<(&Path, &crate::checkpoint::RunLog)>,
    ) -> Result<(), Error> {
        let dim = self.dim;
        let out = self;
        {
            std::fs::create_dir_all(out_dir).map_err(|source| io::IoError::File {
                path: out_dir.to_path_buf(),
                op: "create the output directory",
                source,
            })?;
            for stale in ["summary.json", "case.toml"] {
                let p = out_dir.join(stale);
                if p.exists() {
                    std::fs::remove_file(&p).map_err(|source| io::IoError::File {
                        path: p.clone(),
                        op: "remove the result of an earlier run",
                        source,
                    })?;
                }
            }
            // linear parents; on enriched surfaces their corners are display nodes
            let conn = model.parent_connectivity();
            let kind = if dim == 2 {
                io::CellKind::Quadrilateral
            } else {
                io::CellKind::Hexahedron
            };
            let grid = GridDef {
                name: "bulk",
                dim,
                coords: &model.coords,
                kind,
                connectivity: &conn,
            };
            let mut grids = vec![grid];
            grids.extend(out.sampled.iter().map(|g| GridDef {
                name: g.name,
                dim,
                coords: &g.coords,
                kind: g.kind,
                connectivity: &g.connectivity,
            }));
            let n_points = out.point_ref.len() / dim;
            let point_conn: Vec<usize> = (0..n_points).collect();
            if n_points > 0 {
                grids.push(GridDef {
                    name: "contact_points",
                    dim,
                    coords: &out.point_ref,
                    kind: io::CellKind::Polyvertex,
                    connectivity: &point_conn,
                });
            }
            out.results = Some(match resume {
                Some((ckpt, log)) => ResultsWriter::resume(
                    out_dir,
                    &ckpt.join("results.h5"),
                    &grids,
                    &log.results_layout,
                )?,
                None => ResultsWriter::create(out_dir, &grids)?,
            });
            let labels: Vec<(&str, &str)> = case
                .output
                .reactions
                .iter()
                .map(|r| (r.body.as_str(), r.set.as_str()))
                .collect();
            let extra = history_extra_labels(model, iterative);
            out.history = Some(match resume {
                Some((ckpt, _)) => {
                    HistoryWriter::resume(out_dir, &ckpt.join("history.csv"), dim, &labels, &extra)?
                }
                None => HistoryWriter::create(out_dir, dim, &labels, &extra)?,
            });
        }
        Ok(())
    }

    /// Records one converged step (history row; results when `write`). Collective.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn step(
        &mut self,
        rec: &StepRecord,
        reactions: &[f64],
        extra: &[f64],
        wall: f64,
        write: bool,
        x: &Vector,
        asm: &mut Assembler,
    ) -> Result<(), Error> {
        // Rank-local failures (a full disk on rank 0) are kept until every rank has been through the
        // collectives below, then agreed, so that all ranks stop together.
        let mut local: Result<(), Error> = Ok(());
        if let Some(h) = &mut self.history {
            local = h
                .write_row(&HistoryRow {
                    step: rec.step,
                    stage: rec.stage,
                    load_factor: rec.load,
                    newton_iterations: rec.iterations as u32,
                    residual: rec.residual,
                    cutbacks: rec.cutbacks as u32,
                    reactions,
                    extra,
                    wall_time: wall,
                })
                .map_err(Error::from);
        }
        if write {
            self.results_step(rec, x, asm, local)
        } else {
            agree(asm.comm(), local)
        }
    }

    /// Writes one output step of results.h5 (`local`: an earlier rank-local failure of this step,
    /// agreed with the others at the end). Collective.
    pub(super) fn results_step(
        &mut self,
        rec: &StepRecord,
        x: &Vector,
        asm: &mut Assembler,
        mut local: Result<(), Error>,
    ) -> Result<(), Error> {
        self.gather.gather(x, &mut self.u_root)?;
        // Element measures: each rank fills its cells, a sum-reduction assembles them on rank 0.
        let measures = asm.stress_measures(x)?;
        let comm = asm.comm();
        let mut cells = vec![0.0; 3 * self.n_cells];
        let rank = comm.rank() as f64;
        for (body, cell, tr, vm) in measures {
            let g = self.cell_offset[body] + cell;
            cells[g] = tr;
            cells[self.n_cells + g] = vm;
            cells[2 * self.n_cells + g] = rank;
        }
        let root_proc = comm.process_at_rank(0);
        let contact = contact_fields(asm, self.n_nodes, self.root, &self.symmetry_ties);
        let points = gather_points(asm);
        if self.root {
            let mut global = vec![0.0; 3 * self.n_cells];
            root_proc.reduce_into_root(&cells[..], &mut global[..], SystemOperation::sum());
            if local.is_ok() {
                local = self.write_results(
                    rec.load,
                    &global,
                    contact.as_ref(),
                    points.as_deref(),
                    asm.offsets(),
                );
            }
        } else {
            root_proc.reduce_into(&cells[..], SystemOperation::sum());
        }
        agree(asm.comm(), local)
    }

    /// Rank 0: writes one output step from the gathered displacement and cell measures.
    pub(super) fn write_results(
        &mut self,
        load: f64,
        cell_measures: &[f64],
        contact: Option<&Vec<(&'static str, usize, Vec<f64>)>>,
        points: Option<&[f64]>,
        offsets: &NodeOffsets,
    ) -> Result<(), Error> {
        let mut u = self.u_root.read()?.to_vec();
        // rigidly coupled nodes: the representative's displacement plus the rotation's offset
        for s in 0..offsets.len() {
            let n = offsets.node(s) as usize;
            for c in 0..self.dim {
                u[n * self.dim + c] += offsets.value(s, c);
            }
        }
        for (n, _) in self.without_unknowns.iter().enumerate().filter(|(_, &w)| w) {
            u[n * self.dim..(n + 1) * self.dim].fill(0.0);
        }
        crate::model::apply_display(&self.display, self.dim, &mut u);
        let sampled_u: Vec<Vec<f64>> = self
            .sampled
            .iter()
            .map(|g| g.interpolate(self.dim, &u))
            .collect();
        let (i1, rest) = cell_measures.split_at(self.n_cells);
        let (vm, ranks) = rest.split_at(self.n_cells);
        let mut fields = Vec::new();
        for f in &self.fields {
            fields.push(match f {
                OutputField::Displacement => {
                    FieldData::node_vector("bulk", "displacement", self.dim, &u)
                }
                OutputField::I1 => FieldData::cell_scalar("bulk", "I1", i1),
                OutputField::VonMises => FieldData::cell_scalar("bulk", "von_mises", vm),
                OutputField::Rank => FieldData::cell_scalar("bulk", "rank", ranks),
            });
        }
        for (g, v) in self.sampled.iter().zip(&sampled_u) {
            fields.push(FieldData::node_vector(g.name, "displacement", self.dim, v));
        }
        // contact pressure, gap and friction: nodal values of the L2 projections on the contact
        // surfaces' own interpolation, shown on the bulk grid (display nodes interpolated) and the
        // sampled grids
        let mut contact_nodal = Vec::new();
        for (name, w, v) in contact.into_iter().flatten() {
            let mut v = v.clone();
            crate::model::apply_display(&self.display, *w, &mut v);
            let sampled: Vec<Vec<f64>> =
                self.sampled.iter().map(|g| g.interpolate(*w, &v)).collect();
            contact_nodal.push((*name, *w, v, sampled));
        }
        for (name, w, v, sampled) in &contact_nodal {
            fields.push(FieldData::node_vector("bulk", name, *w, v));
            for (g, sv) in self.sampled.iter().zip(sampled) {
                fields.push(FieldData::node_vector(g.name, name, *w, sv));
            }
        }
        // the contact quadrature points: displacement from the reference position, pressure, gap,
        // half-pass, and with friction the state (0 none, 1 stick, 2 slip), tangential traction
        // and tangential gap to the anchor
        let dim = self.dim;
        let recs: Vec<&[f64]> = points
            .unwrap_or_default()
            .chunks_exact(POINT_RECORD)
            .collect();
        let pf = |f: &dyn Fn(&[f64]) -> Vec<f64>| -> Vec<f64> {
            recs.iter().flat_map(|r| f(r)).collect()
        };
        let point_fields: Vec<(&str, usize, Vec<f64>)> = if recs.is_empty() {
            Vec::new()
        } else {
            vec![
                (
                    "displacement",
                    dim,
                    pf(&|r| (0..dim).map(|c| r[6 + c] - r[3 + c]).collect()),
                ),
                ("half_pass", 1, pf(&|r| vec![r[0]])),
                ("contact_pressure", 1, pf(&|r| vec![r[9]])),
                ("contact_gap", 1, pf(&|r| vec![r[10]])),
                ("friction_state", 1, pf(&|r| vec![r[11]])),
                (
                    "tangential_traction",
                    dim,
                    pf(&|r| r[12..12 + dim].to_vec()),
                ),
                ("tangential_gap", dim, pf(&|r| r[15..15 + dim].to_vec())),
            ]
        };
        for (name, w, v) in &point_fields {
            fields.push(FieldData::node_vector("contact_points", name, *w, v));
        }
        debug_assert_eq!(u.len(), self.n_nodes * self.dim);
        if let Some(r) = &mut self.results {
            r.write_step(load, &fields)?;
        }
        Ok(())
    }

    /// Finalises results (renamed into place) and writes the summary. Collective for nothing.
    pub(super) fn finish(mut self, summary: &Summary) -> Result<(), Error> {
        if !self.root {
            return Ok(());
        }
        if let Some(r) = self.results.take() {
            r.finish()?;
        }
        // history.csv is flushed row by row under its final name: nothing to finish.
        self.history.take();
        io::write_atomic(&self.out_dir.join("case.toml"), self.case_toml.as_bytes())?;
        io::write_summary(&self.out_dir, summary)?;
        Ok(())
    }
}
