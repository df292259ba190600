//! Building a [`Model`] from a validated [`Case`].

use super::data::{Body, Model};
use super::enrich::{build_enrichment_with, EnrichedCell, Enrichment, TiedCell};
use super::error::ModelError;
use crate::assembly::{DirichletBc, ElementSet, Prescription, RigidCoupling, SkewBc, SkewKind};
use crate::fem::kernel::TlElement;
use crate::fem::q1e4::Q1e4Element;
use crate::fem::quadrature::tensor_rule;
use crate::fem::sets::{Q1e4Set, TlSet};
use crate::fem::untangle::{Corners, MapCheck};
use crate::fem::{hex8, quad4};
use crate::material::{LinearElastic, Material, NeoHookean};
use crate::mesh::{self, CellKind, Mesh};
use crate::scene::{
    validate_sets, BcSpec, Case, ElementFamily, EnrichedGeometry, Generator, MaterialModel,
    MeshSpec, SetKind,
};

/// Builds or reads one mesh and validates it; also returns its warnings (nodes in no cell).
fn generate(case: &Case, name: &str, spec: &MeshSpec) -> Result<(Mesh, Vec<String>), ModelError> {
    let err = |source| ModelError::Mesh {
        file: case.file.clone(),
        mesh: name.to_string(),
        source,
    };
    let mut warnings = Vec::new();
    let m = match spec {
        MeshSpec::Generated(g) => match g {
            Generator::Rectangle(p) => mesh::rectangle::rectangle(p.origin, p.size, p.divisions),
            Generator::HalfDisk(p) => {
                mesh::half_disk::half_disk(p.center, p.radius, p.n_arc, p.n_radial)
            }
            Generator::Sector(p) => mesh::sector::sector(
                p.center,
                p.r_inner,
                p.r_outer,
                [p.theta0_deg.to_radians(), p.theta1_deg.to_radians()],
                p.divisions[1],
                p.divisions[0],
            ),
            Generator::Box(p) => mesh::box3d::box3d(p.origin, p.size, p.divisions),
            Generator::Hemisphere(p) => mesh::hemisphere::hemisphere(
                p.center,
                p.outer_radius,
                p.thickness,
                p.n_surface,
                p.n_thickness,
            ),
            Generator::HemisphereNurbs(p) => mesh::hemisphere_nurbs::hemisphere_nurbs(
                p.center,
                p.outer_radius,
                p.thickness,
                p.n_surface,
                p.n_thickness,
            ),
            Generator::QuarterSphere(p) => mesh::quarter_sphere::quarter_sphere(
                p.center,
                p.radius,
                p.extent,
                p.divisions,
                p.grading,
            ),
            Generator::SphereCap(p) => mesh::quarter_sphere::sphere_cap(
                p.center,
                p.radius,
                p.extent,
                p.divisions,
                p.grading,
            ),
        },
        MeshSpec::File(f) => {
            mesh::gmsh::read_gmsh_with_warnings(&case.resolve_path(&f.file)).map(|(m, w)| {
                warnings.extend(w.into_iter().map(|w| format!("mesh `{name}`: {w}")));
                m
            })
        }
    }
    .map_err(err)?;
    m.validate().map_err(err)?;
    if matches!(spec, MeshSpec::Generated(_)) {
        let unused = m.unused_nodes();
        if !unused.is_empty() {
            warnings.push(format!(
                "mesh `{name}`: {} generated nodes are in no cell (first: {:?})",
                unused.len(),
                &unused[..unused.len().min(5)]
            ));
        }
    }
    Ok((m, warnings))
}

/// The total-Lagrangian kernel data of an enriched cell: its basis tabulated at the Gauss points of
/// section 3.4, mapped with the element's reference nodal coordinates (control points, mid nodes,
/// tangent pseudo-nodes entered as coordinates).
#[allow(non_snake_case)]
pub fn enriched_tl_element(
    body: &Body,
    ec: &EnrichedCell,
) -> Result<TlElement, crate::fem::ElementError> {
    enriched_tl_element_with(body, ec, &ec.quadrature_counts())
}

/// [`enriched_tl_element`] with `counts` Gauss points per reference direction instead of
/// section 3.4's (a finer rule integrates the rational terms of a curved layer more closely).
#[allow(non_snake_case)]
pub fn enriched_tl_element_with(
    body: &Body,
    ec: &EnrichedCell,
    counts: &[usize],
) -> Result<TlElement, crate::fem::ElementError> {
    let dim = body.mesh.dim;
    let n = ec.n_nodes();
    let rule = tensor_rule(counts)?;
    let X: Vec<f64> = ec
        .nodes
        .iter()
        .flat_map(|&a| body.node(a).to_vec())
        .collect();
    let mut dN_ref = vec![0.0; rule.n_points() * n * dim];
    let mut N = vec![0.0; n];
    for (qp, xi) in rule.points.chunks_exact(dim).enumerate() {
        ec.shape(xi, &mut N, &mut dN_ref[qp * n * dim..(qp + 1) * n * dim]);
    }
    TlElement::new(dim, &X, &dN_ref, &rule.weights)
}

/// The total-Lagrangian kernel data of a linear cell tied to the enriched surface: the linear
/// cell's 2-point Gauss rule and reference derivatives, mapped to its node list (see
/// [`TiedCell`]), with the nodes' reference coordinates (a tied node's position is the surface
/// point, the weighted sum of its control points).
#[allow(non_snake_case)]
pub fn tied_tl_element(body: &Body, tc: &TiedCell) -> Result<TlElement, crate::fem::ElementError> {
    let dim = body.mesh.dim;
    let rule = tensor_rule(&vec![2; dim])?;
    let table = match body.mesh.cell_kind[tc.cell] {
        CellKind::Quad4 => quad4::derivative_table(&rule.points),
        CellKind::Hex8 => hex8::derivative_table(&rule.points),
    };
    let X: Vec<f64> = tc
        .nodes
        .iter()
        .flat_map(|&a| body.node(a).to_vec())
        .collect();
    TlElement::new(dim, &X, &tc.expand(&table, dim), &rule.weights)
}

/// The Q1E4 element of linear quad `c` of body `b`, its global nodes and its tangle check.
#[allow(non_snake_case)]
fn q1e4_element(b: &Body, c: usize) -> Result<(Q1e4Element, Vec<u32>, MapCheck), String> {
    let nodes = b.mesh.cell(c);
    let mut X = [0.0; 8];
    for (a, &n) in nodes.iter().enumerate().take(4) {
        X[2 * a..2 * a + 2].copy_from_slice(b.mesh.node(n));
    }
    let el = Q1e4Element::new(&X).map_err(|e| e.to_string())?;
    Ok((
        el,
        nodes.iter().map(|&n| n + b.node_offset).collect(),
        MapCheck::linear(2, &X),
    ))
}

/// The tangle check of an enriched cell: its map sampled at the parent corners and on a grid
/// finer than its control net (see [`crate::fem::untangle`]).
#[allow(non_snake_case)]
pub fn enriched_check(body: &Body, ec: &EnrichedCell) -> MapCheck {
    let dim = body.mesh.dim;
    let X: Vec<f64> = ec
        .nodes
        .iter()
        .flat_map(|&a| body.node(a).to_vec())
        .collect();
    // the surface directions' point counts are the control points per direction (p + 1)
    let n = ec.quadrature_counts();
    let points = MapCheck::enriched_points(dim, &n[..dim - 1]);
    MapCheck::sampled(dim, X, &points, |xi, N, dN| ec.shape(xi, N, dN))
}

/// The tangle check of a linear cell tied to an enriched surface: its linear map through its
/// virtual corners, the tied ones following their control points.
#[allow(non_snake_case)]
pub fn tied_check(body: &Body, tc: &TiedCell) -> MapCheck {
    let X: Vec<f64> = tc
        .nodes
        .iter()
        .flat_map(|&a| body.node(a).to_vec())
        .collect();
    MapCheck::linear_with(body.mesh.dim, X, Corners::Tied(tc.map.clone()))
}

/// Adds the node sets a body selects by position (`[bodies.<body>.node_sets]`) to its mesh.
fn select_node_sets(
    case: &Case,
    body: &str,
    sets: &std::collections::BTreeMap<String, crate::scene::NodeSelection>,
    mesh: &mut Mesh,
) -> Result<(), ModelError> {
    for (name, sel) in sets {
        let err = |field: &str, msg: String| ModelError::NodeSelection {
            file: case.file.clone(),
            key: if field.is_empty() {
                format!("bodies.{body}.node_sets.{name}")
            } else {
                format!("bodies.{body}.node_sets.{name}.{field}")
            },
            msg,
        };
        if mesh.node_sets.contains_key(name) || mesh.face_sets.contains_key(name) {
            return Err(err(
                "",
                format!("the mesh already has a set `{name}`; choose another name"),
            ));
        }
        let candidates: Vec<u32> = match &sel.within {
            None => (0..mesh.n_nodes() as u32).collect(),
            Some(w) => match mesh.node_sets.get(w) {
                Some(n) => n.clone(),
                None => mesh.node_set_from_faces(w).map_err(|_| {
                    err("within", format!("the mesh has no node or face set `{w}`"))
                })?,
            },
        };
        let dim = mesh.dim;
        let chosen: Vec<u32> = match (&sel.min, &sel.max, &sel.nearest) {
            (Some(lo), Some(hi), None) => candidates
                .into_iter()
                .filter(|&n| {
                    let x = mesh.node(n);
                    (0..dim).all(|c| x[c] >= lo[c] && x[c] <= hi[c])
                })
                .collect(),
            (None, None, Some(p)) => {
                let d2 = |n: u32| -> f64 {
                    mesh.node(n)
                        .iter()
                        .zip(p)
                        .map(|(a, b)| (a - b).powi(2))
                        .sum()
                };
                // ties go to the lower node number
                let best = candidates
                    .into_iter()
                    .fold(None::<(u32, f64)>, |best, n| match best {
                        Some((_, bd)) if d2(n) >= bd => best,
                        _ => Some((n, d2(n))),
                    });
                best.map(|(n, _)| vec![n]).unwrap_or_default()
            }
            _ => return Err(err("", "needs either `min` and `max` or `nearest`".into())),
        };
        if chosen.is_empty() {
            return Err(err("", "selects no node".into()));
        }
        let mut chosen = chosen;
        chosen.sort_unstable();
        mesh.node_sets.insert(name.clone(), chosen);
    }
    Ok(())
}

/// The nodes of a named set of a body: a node set, or the nodes of a face set.
/// Sets holding surface nodes of an enriched layer are remapped to its control points (see
/// `crate::model::enrich`).
fn set_nodes(body: &Body, set: &str) -> Option<Vec<u32>> {
    let local = match body.mesh.node_sets.get(set) {
        Some(n) => n.clone(),
        None => body.mesh.node_set_from_faces(set).ok()?,
    };
    let local = match &body.enrichment {
        Some(e) => e.remap(&local),
        None => local,
    };
    Some(local.iter().map(|&n| n + body.node_offset).collect())
}

/// The line `check` and `run` print for `enriched_geometry = "smooth"`.
fn smooth_note(body: &str, set: &str, family: ElementFamily, e: &Enrichment) -> String {
    let head = format!(
        "bodies.{body}: enriched surface `{set}` ({family}, {} elements)",
        e.cells.len()
    );
    match (family, e.smooth_deviation) {
        (ElementFamily::Q1N { p, .. }, Some(d)) if e.interpolated_reference => format!(
            "{head}: no exact geometry known (not a line, circle or plane): smooth C^{} fit of \
             the cubic interpolant of its nodes, largest distance from it {d:.3e}",
            p - 1
        ),
        (ElementFamily::Q1N { p, .. }, Some(d)) => format!(
            "{head}: smooth C^{} fit, largest distance from the exact surface {d:.3e}",
            p - 1
        ),
        (ElementFamily::Q1N { .. }, None) => {
            format!("{head}: the exact surface has no C^0 joints (smooth already), kept exact")
        }
        _ if e.interpolated_reference => format!(
            "{head}: no exact geometry known (not a line or circle): {family} interpolates \
             the cubic interpolant of its nodes"
        ),
        _ => format!(
            "{head}: enriched_geometry = \"smooth\" applies to Q1Np only; {family} keeps the \
             exact surface (its interpolation is C^0/C^1 by construction)"
        ),
    }
}

impl Model {
    /// Builds meshes, bodies, conditions and ties of a validated case.
    pub fn build(case: &Case) -> Result<Model, ModelError> {
        let dim = case.case.dim;
        let mut bodies = Vec::new();
        let mut warnings: Vec<String> = Vec::new();
        let mut notes: Vec<String> = Vec::new();
        let (mut node_offset, mut cell_offset) = (0u32, 0usize);
        for (name, spec) in &case.bodies {
            let mesh_spec = &case.meshes[&spec.mesh];
            let (mesh, w) = generate(case, &spec.mesh, mesh_spec)?;
            // two bodies on one mesh: say it once
            warnings.extend(
                w.into_iter()
                    .filter(|w| !warnings.contains(w))
                    .collect::<Vec<_>>(),
            );
            let mut mesh = mesh;
            select_node_sets(case, name, &spec.node_sets, &mut mesh)?;
            let m = &spec.material;
            let material = match m.model {
                MaterialModel::NeoHookean => {
                    NeoHookean::from_young_poisson(m.E, m.nu).map(Material::from)
                }
                MaterialModel::LinearElastic => {
                    LinearElastic::from_young_poisson(m.E, m.nu).map(Material::from)
                }
            }
            .map_err(|e| ModelError::Material {
                file: case.file.clone(),
                body: name.clone(),
                msg: e.to_string(),
            })?;
            bodies.push(Body {
                name: name.clone(),
                mesh,
                node_offset: 0,
                cell_offset: 0,
                family: spec.element,
                bulk_q1e4: spec.element.is_enriched() && spec.bulk == Some(ElementFamily::Q1E4),
                material,
                enrichment: None,
            });
        }
        validate_sets(case, &|b, s, kind| {
            bodies
                .iter()
                .find(|x| x.name == b)
                .is_some_and(|body| match kind {
                    SetKind::Node => {
                        body.mesh.node_sets.contains_key(s) || body.mesh.face_sets.contains_key(s)
                    }
                    SetKind::Face => body.mesh.face_sets.contains_key(s),
                })
        })?;
        // enriched layers, then the global numbering (new nodes follow each body's mesh nodes)
        for b in &mut bodies {
            let spec = &case.bodies[&b.name];
            if let (true, Some(set)) = (b.family.is_enriched(), &spec.enriched_surface) {
                let geometry = spec.enriched_geometry.unwrap_or_default();
                let e = build_enrichment_with(&mut b.mesh, set, b.family, geometry).map_err(
                    |source| ModelError::Enrichment {
                        file: case.file.clone(),
                        body: b.name.clone(),
                        source,
                    },
                )?;
                if geometry == EnrichedGeometry::Smooth {
                    notes.push(smooth_note(&b.name, set, b.family, &e));
                }
                if let (true, Some(t)) = (b.bulk_q1e4, e.tied.first()) {
                    return Err(ModelError::Unsupported {
                        file: case.file.clone(),
                        key: format!("bodies.{}.bulk", b.name),
                        msg: format!(
                            "cell {} touches the enriched surface `{set}` only at a node and is \
                             tied to it, which Q1E4 bulk cells do not support yet; use the \
                             default Q1C1 bulk",
                            t.cell
                        ),
                    });
                }
                if !e.tied.is_empty() {
                    notes.push(format!(
                        "bodies.{}: {} linear cells touch the enriched surface `{set}` only at \
                         nodes; those nodes follow the surface's interpolation",
                        b.name,
                        e.tied.len()
                    ));
                }
                b.enrichment = Some(e);
            }
            b.node_offset = node_offset;
            b.cell_offset = cell_offset;
            node_offset += b.n_nodes() as u32;
            cell_offset += b.mesh.n_cells();
        }
        let find = |b: &str| bodies.iter().find(|x| x.name == b);

        let mut coords = Vec::with_capacity(node_offset as usize * dim);
        let (mut cell_offsets, mut cell_nodes, mut cell_body) =
            (vec![0usize], Vec::new(), Vec::new());
        for (bi, b) in bodies.iter().enumerate() {
            if b.mesh.dim != dim {
                return Err(ModelError::Unsupported {
                    file: case.file.clone(),
                    key: format!("bodies.{}.mesh", b.name),
                    msg: format!("mesh is {}D but case.dim = {dim}", b.mesh.dim),
                });
            }
            coords.extend_from_slice(&b.mesh.coords);
            if let Some(e) = &b.enrichment {
                coords.extend_from_slice(&e.extra_coords);
            }
            for c in 0..b.mesh.n_cells() {
                cell_nodes.extend(b.element_nodes(c).iter().map(|&n| n + b.node_offset));
                cell_offsets.push(cell_nodes.len());
                cell_body.push(bi as u32);
            }
        }

        let mut bcs = Vec::new();
        let mut couplings = Vec::new();
        let mut skews = Vec::new();
        for (i, bc) in case.bcs.iter().enumerate() {
            let body = find(bc.body()).ok_or_else(|| ModelError::Unsupported {
                file: case.file.clone(),
                key: format!("bcs.{i}.body"),
                msg: format!("no body `{}`", bc.body()),
            })?;
            let nodes = set_nodes(body, bc.set()).unwrap_or_default();
            let label = format!("bcs.{i} ({}/{})", bc.body(), bc.set());
            let (components, kind) = match bc {
                BcSpec::Fixed(f) => (
                    f.components(dim).iter().map(|c| c.index()).collect(),
                    Prescription::Fixed,
                ),
                BcSpec::Displacement(d) => (
                    d.components(dim).iter().map(|c| c.index()).collect(),
                    Prescription::Displacement(d.value.clone()),
                ),
                BcSpec::Rotation(r) if r.free_translation => {
                    // a rigid coupling: no prescribed component, the rotation enters as offsets
                    // of the tied nodes (the empty condition keeps `bcs` aligned with the case)
                    let a = r.axis.unwrap_or([0.0, 0.0, 1.0]);
                    let norm = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
                    couplings.push(RigidCoupling {
                        label: label.clone(),
                        nodes: nodes.clone(),
                        axis: a.map(|x| x / norm),
                        angles: r.angle_deg.iter().map(|d| d.to_radians()).collect(),
                    });
                    (Vec::new(), Prescription::Fixed)
                }
                BcSpec::Radial(r) => {
                    let a = r.axis.unwrap_or([0.0, 0.0, 1.0]);
                    let norm = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
                    let mut center = [0.0; 3];
                    center[..r.center.len().min(3)]
                        .copy_from_slice(&r.center[..r.center.len().min(3)]);
                    skews.push(SkewBc {
                        label: label.clone(),
                        nodes: nodes.clone(),
                        kind: SkewKind::Radial {
                            axis: a.map(|x| x / norm),
                            center,
                        },
                    });
                    (Vec::new(), Prescription::Fixed)
                }
                BcSpec::Sliding(sl) => {
                    let norm = sl.normal.iter().map(|x| x * x).sum::<f64>().sqrt();
                    let mut normal = [0.0; 3];
                    for (n, x) in normal.iter_mut().zip(&sl.normal) {
                        *n = x / norm;
                    }
                    skews.push(SkewBc {
                        label: label.clone(),
                        nodes: nodes.clone(),
                        kind: SkewKind::Sliding { normal },
                    });
                    (Vec::new(), Prescription::Fixed)
                }
                BcSpec::Rotation(r) => {
                    let a = r.axis.unwrap_or([0.0, 0.0, 1.0]);
                    let norm = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
                    let mut center = [0.0; 3];
                    center[..r.center.len().min(3)]
                        .copy_from_slice(&r.center[..r.center.len().min(3)]);
                    (
                        (0..dim).collect(),
                        Prescription::Rotation {
                            axis: a.map(|x| x / norm),
                            center,
                            angles: r.angle_deg.iter().map(|d| d.to_radians()).collect(),
                            translations: r
                                .translation
                                .iter()
                                .map(|t| {
                                    let mut v = [0.0; 3];
                                    v[..t.len().min(3)].copy_from_slice(&t[..t.len().min(3)]);
                                    v
                                })
                                .collect(),
                        },
                    )
                }
            };
            bcs.push(DirichletBc {
                label,
                nodes,
                components,
                kind,
            });
        }

        let mut ties = Vec::new();
        for (i, t) in case.ties.iter().enumerate() {
            let tie_err = |msg: String| ModelError::Tie {
                file: case.file.clone(),
                index: i,
                msg,
            };
            let body = find(&t.body).ok_or_else(|| tie_err(format!("no body `{}`", t.body)))?;
            let masters = set_nodes(body, &t.master).unwrap_or_default();
            let slaves = set_nodes(body, &t.slave).unwrap_or_default();
            if masters.len() != slaves.len() {
                return Err(tie_err(format!(
                    "master `{}` has {} nodes but slave `{}` has {}",
                    t.master,
                    masters.len(),
                    t.slave,
                    slaves.len()
                )));
            }
            // One-to-one: every slave matches exactly one master within the tolerance, and no master
            // serves two slaves (a loose tolerance would otherwise tie the wrong nodes silently).
            let mut used = vec![false; masters.len()];
            for &s in &slaves {
                let xs = &coords[s as usize * dim..(s as usize + 1) * dim];
                let hits: Vec<usize> = (0..masters.len())
                    .filter(|&i| {
                        let m = masters[i] as usize;
                        let xm = &coords[m * dim..(m + 1) * dim];
                        (0..dim).all(|k| (xs[k] - t.offset[k] - xm[k]).abs() <= t.tolerance)
                    })
                    .collect();
                match hits.as_slice() {
                    [i] if !used[*i] => {
                        used[*i] = true;
                        if masters[*i] != s {
                            ties.push((s, masters[*i]));
                        }
                    }
                    [i] => {
                        return Err(tie_err(format!(
                            "master node at {:?} of `{}` would be tied to two slave nodes of `{}`",
                            &coords[masters[*i] as usize * dim..(masters[*i] as usize + 1) * dim],
                            t.master,
                            t.slave
                        )))
                    }
                    [] => {
                        return Err(tie_err(format!(
                            "slave node at {xs:?} of `{}` has no master node in `{}` at offset {:?}",
                            t.slave, t.master, t.offset
                        )))
                    }
                    _ => {
                        return Err(tie_err(format!(
                            "slave node at {xs:?} of `{}` matches {} master nodes of `{}` within tolerance {}: use a smaller `tolerance`",
                            t.slave,
                            hits.len(),
                            t.master,
                            t.tolerance
                        )))
                    }
                }
            }
        }

        // A rigidly coupled node shares the unknowns of its coupling's first node; it may not be
        // prescribed or tied otherwise (that would move the whole set, or break its rigidity).
        for (ci, c) in couplings.iter().enumerate() {
            let coupled: std::collections::HashSet<u32> = c.nodes.iter().copied().collect();
            let other = bcs
                .iter()
                .filter(|b| !b.components.is_empty())
                .find_map(|b| {
                    b.nodes
                        .iter()
                        .find(|n| coupled.contains(n))
                        .map(|&n| (n, &b.label))
                })
                .map(|(n, l)| (n, l.clone()))
                .or_else(|| {
                    ties.iter()
                        .find_map(|&(a, b)| [a, b].into_iter().find(|n| coupled.contains(n)))
                        .map(|n| (n, "a periodic tie".to_string()))
                })
                .or_else(|| {
                    couplings[..ci].iter().find_map(|o| {
                        o.nodes
                            .iter()
                            .find(|n| coupled.contains(n))
                            .map(|&n| (n, o.label.clone()))
                    })
                });
            if let Some((n, by)) = other {
                return Err(ModelError::Unsupported {
                    file: case.file.clone(),
                    key: c.label.split(' ').next().unwrap_or("bcs").to_string(),
                    msg: format!(
                        "{} moves with the free-translation rotation {} and is also constrained by {by}; a rigidly coupled set may not overlap other conditions or ties",
                        super::data::node_label(&bodies, &coords, dim, n),
                        c.label
                    ),
                });
            }
            if let Some(&first) = c.nodes.first() {
                ties.extend(c.nodes[1..].iter().map(|&n| (n, first)));
            }
        }

        let mut reactions = Vec::new();
        let mut reaction_moments = Vec::new();
        for (i, r) in case.output.reactions.iter().enumerate() {
            if let Some(body) = find(&r.body) {
                let nodes = set_nodes(body, &r.set).unwrap_or_default();
                if let Some(c) = &r.moment_about {
                    if c.len() != dim || c.iter().any(|v| !v.is_finite()) {
                        return Err(ModelError::Unsupported {
                            file: case.file.clone(),
                            key: format!("output.reactions.{i}.moment_about"),
                            msg: format!("expected {dim} finite numbers, found {c:?}"),
                        });
                    }
                    let mut p = [0.0; 3];
                    p[..dim].copy_from_slice(c);
                    reaction_moments.push((format!("{}_{}", r.body, r.set), nodes.clone(), p));
                }
                reactions.push((format!("{}_{}", r.body, r.set), nodes));
            }
        }

        let (contact_surfaces, contact_pairs) =
            super::contact::build_contact(case, dim, &bodies, &coords)?;
        Ok(Model {
            dim,
            bodies,
            coords,
            cell_offsets,
            cell_nodes,
            cell_body,
            bcs,
            ties,
            couplings,
            skews,
            reactions,
            reaction_moments,
            contact_surfaces,
            contact_pairs,
            warnings,
            contact_warnings: Vec::new(),
            absurd_penalties: Vec::new(),
            notes,
        })
    }

    /// Global nodes of set `set` of body `body` (a node set or the nodes of a face set; remapped
    /// to control points on an enriched surface), `None` if there is no such body or set.
    pub fn set_nodes(&self, body: &str, set: &str) -> Option<Vec<u32>> {
        set_nodes(self.bodies.iter().find(|b| b.name == body)?, set)
    }

    /// Overwrites the displacement of every display node (surface node replaced by control
    /// points) with the value interpolated from its enriched element. `u`: [n_nodes][dim].
    pub fn fill_display_nodes(&self, u: &mut [f64]) {
        super::sampling::apply_display(&self.display_interpolation(), self.dim, u);
    }

    /// Display nodes of all enriched layers with their interpolation, in global ids.
    pub fn display_interpolation(&self) -> Vec<(u32, Vec<(u32, f64)>)> {
        let mut out = Vec::new();
        for b in &self.bodies {
            if let Some(e) = &b.enrichment {
                let o = b.node_offset;
                out.extend(
                    e.display
                        .iter()
                        .map(|(n, w)| (n + o, w.iter().map(|&(a, wa)| (a + o, wa)).collect())),
                );
            }
        }
        out
    }

    /// All cells of all bodies as one mesh (for partitioning and output).
    pub fn combined_mesh(&self) -> Mesh {
        let mut m = Mesh::new(self.dim);
        m.coords = self.coords.clone();
        for (bi, b) in self.bodies.iter().enumerate() {
            for c in 0..b.mesh.n_cells() {
                let nodes: Vec<u32> = b
                    .mesh
                    .cell(c)
                    .iter()
                    .map(|&n| n + self.bodies[bi].node_offset)
                    .collect();
                m.push_cell(b.mesh.cell_kind[c], &nodes);
            }
        }
        m
    }

    /// The element sets of the cells `cell_part` assigns to `rank`, one per body.
    #[allow(non_snake_case)]
    pub fn element_sets(
        &self,
        case_file: &std::path::Path,
        cell_part: &[u32],
        rank: usize,
    ) -> Result<Vec<Box<dyn ElementSet>>, ModelError> {
        let mut sets: Vec<Box<dyn ElementSet>> = Vec::new();
        for (bi, b) in self.bodies.iter().enumerate() {
            let dim = self.dim;
            let elem_err = |cell: usize, msg: String| ModelError::Element {
                file: case_file.to_path_buf(),
                body: b.name.clone(),
                cell,
                family: format!("{:?}", b.family),
                msg,
            };
            let mine =
                (0..b.mesh.n_cells()).filter(|&c| cell_part[b.cell_offset + c] as usize == rank);
            match b.family {
                ElementFamily::Q1C1
                | ElementFamily::Q1N { .. }
                | ElementFamily::Q1C2
                | ElementFamily::Q1CH => {
                    // the bulk of an enriched body is Q1C1, or Q1E4 when the case says so
                    let mut set = TlSet::new(bi, &b.name, &b.family.to_string(), b.material);
                    let mut q1e4 = b
                        .bulk_q1e4
                        .then(|| Q1e4Set::new(bi, &b.name, b.material));
                    for c in mine {
                        if let (Some(q), None) = (q1e4.as_mut(), b.enriched_cell(c)) {
                            let (el, g, check) =
                                q1e4_element(b, c).map_err(|m| elem_err(c, m))?;
                            q.push(c, &g, el, check);
                            continue;
                        }
                        let (el, check) = match (b.enriched_cell(c), b.tied_cell(c)) {
                            (Some(ec), _) => (enriched_tl_element(b, ec), enriched_check(b, ec)),
                            (None, Some(tc)) => (tied_tl_element(b, tc), tied_check(b, tc)),
                            (None, None) => {
                                let X: Vec<f64> = b
                                    .mesh
                                    .cell(c)
                                    .iter()
                                    .flat_map(|&n| b.mesh.node(n).to_vec())
                                    .collect();
                                let el = match b.mesh.cell_kind[c] {
                                    CellKind::Quad4 => quad4::tl_element(&X, 2),
                                    CellKind::Hex8 => hex8::tl_element(&X, 2),
                                };
                                (el, MapCheck::linear(dim, &X))
                            }
                        };
                        let el = el.map_err(|e| elem_err(c, e.to_string()))?;
                        let g: Vec<u32> =
                            b.element_nodes(c).iter().map(|&n| n + b.node_offset).collect();
                        set.push(c, &g, el, check);
                    }
                    sets.push(Box::new(set));
                    if let Some(q) = q1e4 {
                        sets.push(Box::new(q));
                    }
                }
                ElementFamily::Q1E4 if dim == 2 => {
                    let mut set = Q1e4Set::new(bi, &b.name, b.material);
                    for c in mine {
                        let (el, g, check) = q1e4_element(b, c).map_err(|m| elem_err(c, m))?;
                        set.push(c, &g, el, check);
                    }
                    sets.push(Box::new(set));
                }
                other => {
                    return Err(ModelError::Unsupported {
                        file: case_file.to_path_buf(),
                        key: format!("bodies.{}.element", b.name),
                        msg: format!("element family {other:?} is not available in this build yet (enriched contact-surface elements are being integrated)"),
                    })
                }
            }
        }
        Ok(sets)
    }
}
