//! Contact pairs of a case resolved against the model: each `body.face_set` becomes one
//! [`ContactSurface`] (shared by every pair that names it), each `[[contact]]` a [`PairDef`] with
//! its half-passes (two-half-pass between deformable surfaces: each surface integrated against the
//! other), law and rigid partner. Every error names the case file and the key.

use super::data::Body;
use super::error::ModelError;
use super::formulation::{formulation, gap_name};
use crate::contact::basis::FaceBasis;
use crate::contact::rigid::{RigidMotion, RigidShape};
use crate::contact::search::Aabb;
use crate::contact::surface::ContactSurface;
use crate::contact::{Friction, Law, PairDef, Partner, Passes};
use crate::scene::{BoxSpec, Case, ContactSpec, GapMode, RigidShapeKind, RigidSpec, SceneError};

fn err(case: &Case, key: String, msg: impl Into<String>) -> ModelError {
    ModelError::Contact {
        file: case.file.clone(),
        key,
        msg: msg.into(),
    }
}

fn positive(case: &Case, key: String, v: Option<f64>, what: &str) -> Result<f64, ModelError> {
    match v {
        None => Err(err(case, key, format!("missing: {what}"))),
        Some(x) if x.is_finite() && x > 0.0 => Ok(x),
        Some(x) => Err(err(
            case,
            key,
            format!("{what} must be positive and finite, found {x}"),
        )),
    }
}

fn vec3(case: &Case, key: String, v: &[f64], dim: usize) -> Result<[f64; 3], ModelError> {
    if v.len() != dim || v.iter().any(|x| !x.is_finite()) {
        return Err(err(
            case,
            key,
            format!("expected {dim} finite numbers, found {v:?}"),
        ));
    }
    let mut o = [0.0; 3];
    o[..dim].copy_from_slice(v);
    Ok(o)
}

fn unit(case: &Case, key: String, v: [f64; 3]) -> Result<[f64; 3], ModelError> {
    let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    if !(l > 0.0 && l.is_finite()) {
        return Err(err(case, key, "must be a non-zero vector"));
    }
    Ok(v.map(|c| c / l))
}

/// The surfaces and pairs of `case.contact` on `bodies` (in the global numbering of `coords`, the
/// reference coordinates of every global node [n_nodes][dim]).
pub fn build_contact(
    case: &Case,
    dim: usize,
    bodies: &[Body],
    coords: &[f64],
) -> Result<(Vec<ContactSurface>, Vec<PairDef>), ModelError> {
    let mut surfaces: Vec<ContactSurface> = Vec::new();
    let mut pairs = Vec::new();
    let mut seen: Vec<(Vec<usize>, usize)> = Vec::new();
    // every pair's formulation first, with all their incompatibilities at once
    let mut formulations = Vec::new();
    let mut issues = Vec::new();
    for (i, spec) in case.contact.iter().enumerate() {
        match formulation(spec, i) {
            Ok(f) => formulations.push(f),
            Err(mut e) => issues.append(&mut e),
        }
    }
    if !issues.is_empty() {
        return Err(ModelError::Scene(SceneError::Invalid {
            file: case.file.clone(),
            issues,
        }));
    }
    for (i, spec) in case.contact.iter().enumerate() {
        let key = |k: &str| format!("contact.{i}.{k}");
        // surfaces
        if spec.surfaces.is_empty() || spec.surfaces.len() > 2 {
            return Err(err(
                case,
                key("surfaces"),
                format!(
                    "give one surface with a `rigid` partner or two surfaces, found {}",
                    spec.surfaces.len()
                ),
            ));
        }
        let mut idx = Vec::new();
        for name in &spec.surfaces {
            let (b, set) = name.split_once('.').ok_or_else(|| {
                err(
                    case,
                    key("surfaces"),
                    format!("`{name}` is not of the form `body.face_set`"),
                )
            })?;
            let bi = bodies.iter().position(|x| x.name == b).ok_or_else(|| {
                err(
                    case,
                    key("surfaces"),
                    format!("no body `{b}` (in `{name}`)"),
                )
            })?;
            let body = &bodies[bi];
            if !body.mesh.face_sets.contains_key(set) {
                let what = if body.mesh.node_sets.contains_key(set) {
                    "is a node set, not a face set"
                } else {
                    "does not exist"
                };
                let mut known: Vec<&str> = body.mesh.face_sets.keys().map(|s| s.as_str()).collect();
                known.sort_unstable();
                return Err(err(
                    case,
                    key("surfaces"),
                    format!(
                        "set `{set}` of body `{b}` {what}; its face sets: {}",
                        known.join(", ")
                    ),
                ));
            }
            let full = format!("{b}.{set}");
            let s = match surfaces.iter().position(|s| s.name == full) {
                Some(s) => s,
                None => {
                    let s = ContactSurface::build(&body.surface_body(bi), set, coords)
                        .map_err(|e| err(case, key("surfaces"), e.0))?;
                    surfaces.push(s);
                    surfaces.len() - 1
                }
            };
            idx.push(s);
        }
        if idx.len() == 2 && idx[0] == idx[1] {
            return Err(err(
                case,
                key("surfaces"),
                "a surface cannot be paired with itself (self-contact is not supported)",
            ));
        }
        let mut sorted = idx.clone();
        sorted.sort_unstable();
        if spec.rigid.is_none() {
            if let Some((_, j)) = seen.iter().find(|(s, _)| *s == sorted) {
                return Err(err(
                    case,
                    key("surfaces"),
                    format!("the same surfaces are already paired by `contact.{j}`"),
                ));
            }
            seen.push((sorted, i));
        }
        let formulation = formulations[i];
        let law = formulation.law;
        let reference_box = |name: &str, b: &Option<BoxSpec>| -> Result<Option<Aabb>, ModelError> {
            match b {
                None => Ok(None),
                Some(b) => {
                    let lo = vec3(case, key(&format!("{name}.min")), &b.min, dim)?;
                    let hi = vec3(case, key(&format!("{name}.max")), &b.max, dim)?;
                    if (0..dim).any(|k| lo[k] > hi[k]) {
                        return Err(err(case, key(name), "`min` exceeds `max`"));
                    }
                    Ok(Some(Aabb { lo, hi }))
                }
            }
        };
        let debonded = reference_box("debonded", &spec.debonded)?;
        let region = reference_box("region", &spec.region)?;
        let h_max = idx.iter().map(|&s| surfaces[s].h).fold(0.0, f64::max);
        let search_distance = match spec.search_distance {
            None => 2.0 * h_max,
            Some(_) => positive(
                case,
                key("search_distance"),
                spec.search_distance,
                "the search distance",
            )?,
        };
        let moment_point = match &spec.moment_point {
            None => [0.0; 3],
            Some(p) => vec3(case, key("moment_point"), p, dim)?,
        };
        let friction = friction(case, i, spec, &law)?;
        nonnegative_basis(case, i, spec, &idx, &surfaces)?;
        // partners
        let passes = match (&spec.rigid, idx.len()) {
            (Some(r), 1) => {
                let (shape, motion) = rigid(case, i, r, dim)?;
                vec![(idx[0], Partner::Rigid(shape, motion))]
            }
            (Some(_), _) => {
                return Err(err(
                    case,
                    key("rigid"),
                    "a rigid partner goes with exactly one surface",
                ))
            }
            (None, 2) if formulation.passes == Passes::OnePass => {
                vec![(idx[0], Partner::Surface(idx[1]))]
            }
            (None, 2) => vec![
                (idx[0], Partner::Surface(idx[1])),
                (idx[1], Partner::Surface(idx[0])),
            ],
            (None, _) => {
                return Err(err(
                    case,
                    key("surfaces"),
                    "one surface needs a `rigid` partner",
                ))
            }
        };
        pairs.push(PairDef {
            name: pair_name(spec, i),
            formulation,
            passes,
            search_distance,
            moment_point,
            debonded,
            region,
            friction,
        });
    }
    Ok((surfaces, pairs))
}

/// The surface basis as the weights of pair `i`'s nodal pressure (`weighted`, `weighted_mean`) needs
/// a non-negative basis on the pair's surfaces `idx`.
fn nonnegative_basis(
    case: &Case,
    i: usize,
    spec: &ContactSpec,
    idx: &[usize],
    surfaces: &[ContactSurface],
) -> Result<(), ModelError> {
    let gap = spec.algorithm_and_gap().1;
    if !matches!(gap, GapMode::Weighted | GapMode::WeightedMean) {
        return Ok(());
    }
    // the key that chose the gap
    let key = if spec.formulation.is_some() && spec.gap.is_none() {
        "formulation"
    } else {
        "gap"
    };
    let negative = idx.iter().find(|&&s| {
        surfaces[s]
            .elements
            .iter()
            .any(|e| matches!(e.basis, FaceBasis::Lagrange2 | FaceBasis::Hermite { .. }))
    });
    match negative {
        Some(&s) => Err(err(
            case,
            format!("contact.{i}.{key}"),
            format!(
                "`{}` needs a non-negative basis on the surface: `{}` is a Q1C2 or Q1CH surface, \
                 whose basis functions go negative (Q1C2) or carry slopes (Q1CH), so the \
                 weighted gap is no average of the point gaps (use Q1C1, Q1Np or Q1Np.t there, \
                 or `weighted_linear`)",
                gap_name(gap),
                surfaces[s].name
            ),
        )),
        None => Ok(()),
    }
}

/// Coulomb friction of pair `i`: `mu`, `eps_t`, `friction_stages`.
fn friction(
    case: &Case,
    i: usize,
    spec: &ContactSpec,
    law: &Law,
) -> Result<Option<Friction>, ModelError> {
    let key = |k: &str| format!("contact.{i}.{k}");
    let Some(mu) = spec.mu else {
        for (k, given) in [
            ("eps_t", spec.eps_t.is_some()),
            ("friction_stages", !spec.friction_stages.is_empty()),
        ] {
            if given {
                return Err(err(
                    case,
                    key(k),
                    "a friction parameter, but no `mu` is given",
                ));
            }
        }
        return Ok(None);
    };
    let mu = positive(case, key("mu"), Some(mu), "the friction coefficient")?;
    let eps_t = match (law, spec.eps_t) {
        (_, Some(_)) => positive(case, key("eps_t"), spec.eps_t, "the tangential penalty")?,
        (Law::Penalty { eps_n }, None)
        | (
            Law::Cohesive {
                eps_n,
                quadratic: false,
                ..
            },
            None,
        ) => *eps_n,
        (Law::Cohesive { .. }, None) => {
            return Err(err(
                case,
                key("eps_t"),
                "missing: the tangential penalty (the quadratic penetration penalty's `eps_n` has other units)",
            ))
        }
        (Law::VanDerWaals { .. }, None) => 0.0,
    };
    if matches!(law, Law::VanDerWaals { .. }) {
        return Err(err(
            case,
            key("mu"),
            "friction goes with the `penalty` law and the `cohesive` law's penalty, not with `van_der_waals`",
        ));
    }
    let n_stages = case.stages.len();
    if !spec.friction_stages.is_empty() && spec.friction_stages.len() != n_stages {
        return Err(err(
            case,
            key("friction_stages"),
            format!(
                "give one switch per stage ({n_stages}), found {}",
                spec.friction_stages.len()
            ),
        ));
    }
    Ok(Some(Friction {
        mu,
        eps_t,
        stages: spec.friction_stages.clone(),
    }))
}

/// The history name of pair `i`.
pub fn pair_name(spec: &ContactSpec, i: usize) -> String {
    spec.name.clone().unwrap_or_else(|| format!("contact{i}"))
}

fn rigid(
    case: &Case,
    i: usize,
    r: &RigidSpec,
    dim: usize,
) -> Result<(RigidShape, RigidMotion), ModelError> {
    let key = |k: &str| format!("contact.{i}.rigid.{k}");
    let need = |v: &Option<Vec<f64>>, k: &str| -> Result<[f64; 3], ModelError> {
        match v {
            Some(v) => vec3(case, key(k), v, dim),
            None => Err(err(case, key(k), "missing")),
        }
    };
    let shape = match r.shape {
        RigidShapeKind::Plane => RigidShape::Plane {
            point: need(&r.point, "point")?,
            normal: unit(case, key("normal"), need(&r.normal, "normal")?)?,
        },
        RigidShapeKind::Circle | RigidShapeKind::Sphere => {
            let want = if r.shape == RigidShapeKind::Circle {
                2
            } else {
                3
            };
            if dim != want {
                return Err(err(
                    case,
                    key("shape"),
                    format!(
                        "a {} is for {want}D cases; this case is {dim}D",
                        if want == 2 { "circle" } else { "sphere" }
                    ),
                ));
            }
            RigidShape::Sphere {
                center: need(&r.center, "center")?,
                radius: positive(case, key("radius"), r.radius, "the radius")?,
                inside: r.inside,
            }
        }
        RigidShapeKind::Cylinder => {
            if dim != 3 {
                return Err(err(
                    case,
                    key("shape"),
                    "a cylinder is for 3D cases (use a circle in 2D)",
                ));
            }
            RigidShape::Cylinder {
                center: need(&r.center, "center")?,
                axis: unit(
                    case,
                    key("axis"),
                    r.axis.ok_or_else(|| err(case, key("axis"), "missing"))?,
                )?,
                radius: positive(case, key("radius"), r.radius, "the radius")?,
                inside: r.inside,
            }
        }
    };
    let n_stages = case.stages.len();
    if !r.translation.is_empty() && r.translation.len() != n_stages {
        return Err(err(
            case,
            key("translation"),
            format!(
                "give one translation per stage ({n_stages}), found {}",
                r.translation.len()
            ),
        ));
    }
    if !r.rotation_deg.is_empty() && r.rotation_deg.len() != n_stages {
        return Err(err(
            case,
            key("rotation_deg"),
            format!(
                "give one angle per stage ({n_stages}), found {}",
                r.rotation_deg.len()
            ),
        ));
    }
    let translations = r
        .translation
        .iter()
        .enumerate()
        .map(|(s, t)| vec3(case, format!("contact.{i}.rigid.translation.{s}"), t, dim))
        .collect::<Result<Vec<_>, _>>()?;
    let center = match &r.rotation_center {
        None => [0.0; 3],
        Some(c) => vec3(case, key("rotation_center"), c, dim)?,
    };
    let axis = if dim == 2 {
        [0.0, 0.0, 1.0]
    } else {
        unit(
            case,
            key("rotation_axis"),
            r.rotation_axis.unwrap_or([0.0, 0.0, 1.0]),
        )?
    };
    Ok((
        shape,
        RigidMotion {
            translations,
            angles: r.rotation_deg.iter().map(|d| d.to_radians()).collect(),
            axis,
            center,
        },
    ))
}
