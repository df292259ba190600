//! Semantic checks of a parsed [`Case`]: everything serde cannot see (value ranges, references between
//! tables, counts that depend on the number of stages, dimension rules). All problems are collected and
//! reported together, each with its key path.

use crate::mesh::{coordinate_in_range, MAX_COORDINATE};
use crate::scene::element_family::ElementFamily;
use crate::scene::error::Issue;
use crate::scene::schema::{BcSpec, Case, Component, EnrichedGeometry, Generator, MeshSpec};
use crate::scene::SceneError;
use std::collections::BTreeSet;

/// What kind of named set a reference needs: boundary conditions, ties and reactions act on node
/// sets, enrichment on a face set.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum SetKind {
    Node,
    Face,
}

/// Check value ranges and cross references of a case; every issue names its key.
pub fn validate(case: &Case) -> Result<(), SceneError> {
    let mut v = Issues::default();
    let dim = case.case.dim;
    let dim_ok = dim == 2 || dim == 3;
    if !dim_ok {
        v.push("case.dim", format!("must be 2 or 3, got {dim}"));
    }
    check_case_name(&case.case.name, &mut v);

    check_meshes(case, dim_ok, &mut v);
    check_bodies(case, dim_ok, &mut v);
    check_stages(case, &mut v);
    check_bcs(case, dim_ok, &mut v);
    check_ties(case, dim_ok, &mut v);
    check_controls(case, &mut v);
    if let Some(d) = case.solver.max_penetration {
        v.positive("solver.max_penetration".into(), d);
        if case.contact.is_empty() {
            v.push(
                "solver.max_penetration",
                "bounds contact penetration, but the case has no [[contact]] pair",
            );
        }
    }
    let f = case.solver.first_update;
    if !(f > 0.0 && f <= 1.0) {
        v.push(
            "solver.first_update",
            format!(
                "must be in (0, 1] (the fraction of each solve's first Newton update taken), \
                 got {f}"
            ),
        );
    }
    let a = case.solver.krylov_accept;
    if !(0.0..1.0).contains(&a) {
        v.push(
            "solver.krylov_accept",
            format!(
                "must be in [0, 1) (a fraction of a Krylov solve's first residual norm; 0 \
                 disables it), got {a}"
            ),
        );
    }
    if v.0.is_empty() {
        // sizes only mean something once every count is known to be sane
        check_sizes(case, &mut v);
    }
    v.finish(case)
}

/// Smallest and largest Young's modulus accepted: any unit system from GPa (soft gels, 1e-6) to Pa
/// (diamond, 1.2e12). Below, the first residuals of a moderate load approach the solver's absolute
/// tolerance (Newton would "converge" without moving); above, forces overflow long before E does.
pub const YOUNG_RANGE: (f64, f64) = (1e-6, 1e13);

/// How close to -1 or 0.5 Poisson's ratio may come: at 0.5 - 1e-6 the Lame ratio lambda/mu is
/// already 5e5, beyond which a displacement formulation only measures round-off.
pub const POISSON_MARGIN: f64 = 1e-6;

/// The case name becomes a directory under `out/` (without `--out`): it must be one plain path
/// component, so that no name can write elsewhere.
fn check_case_name(name: &str, v: &mut Issues) {
    let plain = |c: char| c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.');
    if name.is_empty() {
        v.push("case.name", "must not be empty");
    } else if name == "." || name == ".." {
        v.push(
            "case.name",
            format!("`{name}` is not a name (it names a directory relative to out/)"),
        );
    } else if let Some(c) = name.chars().find(|&c| !plain(c)) {
        v.push(
            "case.name",
            format!(
                "`{name}` must be a plain name of letters, digits, `-`, `_` and `.` (it names the \
                 output directory out/<name>), found {c:?}"
            ),
        );
    }
}

/// Refuses generated meshes too large to run: more unknowns than PETSc's 32-bit indices hold, or
/// more memory (mesh arrays plus Jacobian, see [`crate::scene::size`]) than this machine has. Runs
/// before any mesh is built, from the parameters alone.
fn check_sizes(case: &Case, v: &mut Issues) {
    use crate::scene::size::{human_bytes, machine_memory_bytes, CaseSize, MAX_UNKNOWNS};
    let Some(CaseSize {
        total: s,
        mesh_bytes,
        matrix_bytes,
        linear_bytes,
        iterative,
        largest_key: key,
    }) = CaseSize::of(case)
    else {
        return;
    };
    let what = format!(
        "{:.3e} nodes, {:.3e} cells, {:.3e} unknowns; estimated memory {} (mesh arrays {} on \
         every rank + matrix {} + {} linear solver {})",
        s.nodes,
        s.cells,
        s.unknowns(),
        human_bytes(mesh_bytes + matrix_bytes + linear_bytes),
        human_bytes(mesh_bytes),
        human_bytes(matrix_bytes),
        if iterative { "iterative" } else { "direct" },
        human_bytes(linear_bytes)
    );
    if s.unknowns() > MAX_UNKNOWNS {
        v.push(
            key,
            format!(
                "the problem is too large: {what}; PETSc's 32-bit indices hold at most {} unknowns",
                MAX_UNKNOWNS as i64
            ),
        );
    } else if let Some(mem) =
        machine_memory_bytes().filter(|&m| mesh_bytes + matrix_bytes + linear_bytes > m)
    {
        v.push(
            key,
            format!(
                "the problem is too large: {what}, more than this machine's {}",
                human_bytes(mem)
            ),
        );
    }
}

/// Check that every set a case names exists on its body, once meshes are built.
/// `has_set(body, set, kind)` answers whether `body`'s mesh has a set of that name and kind.
pub fn validate_sets(
    case: &Case,
    has_set: &dyn Fn(&str, &str, SetKind) -> bool,
) -> Result<(), SceneError> {
    let mut v = Issues::default();
    let mut need = |key: String, body: &str, set: &str, kind: SetKind| {
        if !has_set(body, set, kind) {
            let what = match kind {
                SetKind::Node => "node set",
                SetKind::Face => "face set",
            };
            v.push(key, format!("body `{body}` has no {what} `{set}`"));
        }
    };
    for (name, b) in &case.bodies {
        if let Some(s) = &b.enriched_surface {
            need(
                format!("bodies.{name}.enriched_surface"),
                name,
                s,
                SetKind::Face,
            );
        }
    }
    for (i, bc) in case.bcs.iter().enumerate() {
        need(format!("bcs.{i}.set"), bc.body(), bc.set(), SetKind::Node);
    }
    for (i, t) in case.ties.iter().enumerate() {
        need(
            format!("ties.{i}.master"),
            &t.body,
            &t.master,
            SetKind::Node,
        );
        need(format!("ties.{i}.slave"), &t.body, &t.slave, SetKind::Node);
    }
    for (i, r) in case.output.reactions.iter().enumerate() {
        need(
            format!("output.reactions.{i}.set"),
            &r.body,
            &r.set,
            SetKind::Node,
        );
    }
    v.finish(case)
}

#[derive(Default)]
struct Issues(Vec<Issue>);

impl Issues {
    fn push(&mut self, key: impl Into<String>, message: impl Into<String>) {
        self.0.push(Issue {
            key: key.into(),
            line: None,
            message: message.into(),
        });
    }

    fn positive(&mut self, key: String, x: f64) {
        if !(x.is_finite() && x > 0.0) {
            self.push(key, format!("must be a positive number, got {x}"));
        }
    }

    fn finite(&mut self, key: String, xs: &[f64]) {
        if let Some(x) = xs.iter().find(|x| !x.is_finite()) {
            self.push(key, format!("must be finite, got {x}"));
        }
    }

    /// A point (`origin`, `center`): finite and within the mesh layer's coordinate range.
    fn point(&mut self, key: String, xs: &[f64]) {
        if let Some(x) = xs.iter().find(|x| !coordinate_in_range(**x)) {
            self.push(key, format!("must be {}", range_problem(*x)));
        }
    }

    /// Lengths (the components of a `size`, or one radius) added to a point `at` (its `origin`
    /// or `center`, checked by [`Issues::point`]): positive, and the mesh they span within the
    /// coordinate range (checked before any geometry: beyond it squared distances overflow and
    /// the geometric checks blame the wrong thing). One issue per key at most.
    fn extent(&mut self, key: String, lens: &[f64], at: &[f64]) {
        if let Some(len) = lens.iter().find(|l| !(l.is_finite() && **l > 0.0)) {
            self.push(key, format!("must be a positive number, got {len}"));
            return;
        }
        let Some(len) = lens.iter().copied().reduce(f64::max) else {
            return;
        };
        if let Some(x) = at
            .iter()
            .filter(|c| coordinate_in_range(**c))
            .map(|c| c.abs() + len)
            .chain([len])
            .find(|x| !coordinate_in_range(*x))
        {
            self.push(
                key,
                format!(
                    "is out of range: the mesh would reach the coordinate {x:e}, beyond the \
                     largest accepted, {MAX_COORDINATE:e} in magnitude (squared distances and \
                     volumes would overflow); use a smaller length unit"
                ),
            );
        }
    }

    fn divisions(&mut self, key: String, n: &[usize]) {
        if n.contains(&0) {
            self.push(key, format!("every division count must be > 0, got {n:?}"));
        }
    }

    fn finish(self, case: &Case) -> Result<(), SceneError> {
        if self.0.is_empty() {
            Ok(())
        } else {
            Err(SceneError::Invalid {
                file: case.file.clone(),
                issues: self.0,
            })
        }
    }
}

/// What is wrong with a point coordinate `x`: not finite, or beyond [`MAX_COORDINATE`].
fn range_problem(x: f64) -> String {
    if x.is_finite() {
        format!(
            "at most {MAX_COORDINATE:e} in magnitude (squared distances and volumes would \
             overflow), got {x:e}; use a smaller length unit"
        )
    } else {
        format!("finite, got {x}")
    }
}

fn check_meshes(case: &Case, dim_ok: bool, v: &mut Issues) {
    if case.meshes.is_empty() {
        v.push("meshes", "at least one mesh is required");
    }
    for (name, mesh) in &case.meshes {
        let k = |field: &str| format!("meshes.{name}.{field}");
        match mesh {
            MeshSpec::File(f) => {
                let p = case.resolve_path(&f.file);
                match std::fs::metadata(&p) {
                    Ok(m) if m.is_dir() => v.push(
                        k("file"),
                        format!("{} is a directory, not a mesh file", p.display()),
                    ),
                    Ok(_) => {}
                    Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                        v.push(k("file"), format!("mesh file {} not found", p.display()))
                    }
                    Err(e) => v.push(
                        k("file"),
                        format!("cannot read mesh file {}: {e}", p.display()),
                    ),
                }
            }
            MeshSpec::Generated(g) => {
                if dim_ok && g.dim() != case.case.dim {
                    v.push(
                        k("generator"),
                        format!(
                            "generator `{}` builds a {}D mesh but case.dim = {}",
                            g.name(),
                            g.dim(),
                            case.case.dim
                        ),
                    );
                }
                match g {
                    Generator::Rectangle(p) => {
                        v.point(k("origin"), &p.origin);
                        v.extent(k("size"), &p.size, &p.origin);
                        v.divisions(k("divisions"), &p.divisions);
                    }
                    Generator::Box(p) => {
                        v.point(k("origin"), &p.origin);
                        v.extent(k("size"), &p.size, &p.origin);
                        v.divisions(k("divisions"), &p.divisions);
                    }
                    Generator::HalfDisk(p) => {
                        v.point(k("center"), &p.center);
                        v.extent(k("radius"), &[p.radius], &p.center);
                        if p.n_arc < 4 {
                            v.push(
                                k("n_arc"),
                                format!(
                                    "the O-grid needs at least 4 cells along the arc, got {}",
                                    p.n_arc
                                ),
                            );
                        }
                        v.divisions(k("n_radial"), &[p.n_radial]);
                    }
                    Generator::Sector(p) => {
                        v.point(k("center"), &p.center);
                        v.finite(k("theta0_deg"), &[p.theta0_deg, p.theta1_deg]);
                        if !(p.r_inner.is_finite() && p.r_inner > 0.0) {
                            v.push(k("r_inner"), format!("must be > 0, got {}", p.r_inner));
                        }
                        if !(p.r_outer.is_finite() && p.r_outer > p.r_inner) {
                            v.push(
                                k("r_outer"),
                                format!("must exceed r_inner = {}, got {}", p.r_inner, p.r_outer),
                            );
                        } else {
                            v.extent(k("r_outer"), &[p.r_outer], &p.center);
                        }
                        let span = p.theta1_deg - p.theta0_deg;
                        if !(span > 0.0 && span < 360.0) {
                            v.push(
                                k("theta1_deg"),
                                format!(
                                    "theta1_deg - theta0_deg must be in (0, 360) degrees, got \
                                     {span} degrees (a full ring would have two separate, \
                                     coincident end edges)"
                                ),
                            );
                        }
                        v.divisions(k("divisions"), &p.divisions);
                    }
                    Generator::QuarterSphere(p) | Generator::SphereCap(p) => {
                        v.point(k("center"), &p.center);
                        v.extent(k("radius"), &[p.radius], &p.center);
                        if !(p.extent > 0.0 && p.extent < p.radius) {
                            v.push(
                                k("extent"),
                                format!("must be in (0, radius = {}), got {}", p.radius, p.extent),
                            );
                        }
                        v.divisions(k("divisions"), &p.divisions);
                        if let Some(g) = p.grading.iter().find(|g| !(g.is_finite() && **g > 0.0)) {
                            v.push(
                                k("grading"),
                                format!("every grading must be positive and finite, got {g}"),
                            );
                        }
                    }
                    Generator::Hemisphere(p) | Generator::HemisphereNurbs(p) => {
                        v.point(k("center"), &p.center);
                        v.extent(k("outer_radius"), &[p.outer_radius], &p.center);
                        if !(p.thickness > 0.0 && p.thickness < p.outer_radius) {
                            v.push(
                                k("thickness"),
                                format!(
                                    "must be in (0, outer_radius = {}), got {}",
                                    p.outer_radius, p.thickness
                                ),
                            );
                        }
                        v.divisions(k("n_surface"), &[p.n_surface]);
                        if matches!(g, Generator::HemisphereNurbs(_))
                            && !p.n_surface.is_multiple_of(2)
                        {
                            v.push(
                                k("n_surface"),
                                format!(
                                    "must be even for hemisphere_nurbs (2 exact base elements per \
                                     direction), got {}",
                                    p.n_surface
                                ),
                            );
                        }
                        v.divisions(k("n_thickness"), &[p.n_thickness]);
                    }
                }
            }
        }
    }
}

fn check_bodies(case: &Case, dim_ok: bool, v: &mut Issues) {
    if case.bodies.is_empty() {
        v.push("bodies", "at least one body is required");
    }
    for (name, b) in &case.bodies {
        let k = |field: &str| format!("bodies.{name}.{field}");
        if !case.meshes.contains_key(&b.mesh) {
            v.push(k("mesh"), format!("undefined mesh `{}`", b.mesh));
        }
        if dim_ok && case.case.dim == 3 && !b.element.supports_3d() {
            v.push(
                k("element"),
                format!("element family {} is 2D only but case.dim = 3", b.element),
            );
        }
        match (b.element.is_enriched(), &b.enriched_surface) {
            (true, None) => v.push(
                k("enriched_surface"),
                format!(
                    "element family {} needs an enriched_surface (a face set)",
                    b.element
                ),
            ),
            // a linear family ignores enriched_surface, so one case file runs every family
            // (`--set bodies.<name>.element=Q1C1`)
            (_, Some(s)) if s.trim().is_empty() => {
                v.push(k("enriched_surface"), "must name a face set")
            }
            _ => {}
        }
        if b.enriched_geometry == Some(EnrichedGeometry::Smooth) && b.enriched_surface.is_none() {
            v.push(
                k("enriched_geometry"),
                "\"smooth\" fits the enriched surface: it needs bodies.<name>.enriched_surface",
            );
        }
        match b.bulk {
            None | Some(ElementFamily::Q1C1) => {}
            Some(ElementFamily::Q1E4) if case.case.dim == 2 => {}
            Some(ElementFamily::Q1E4) => v.push(
                k("bulk"),
                "Q1E4 is a 2D element; a 3D body's bulk is Q1C1".to_string(),
            ),
            Some(other) => v.push(
                k("bulk"),
                format!("the bulk below an enriched layer is Q1C1 or Q1E4, got {other}"),
            ),
        }
        for (set, sel) in &b.node_sets {
            let ks = |f: &str| format!("bodies.{name}.node_sets.{set}.{f}");
            let dim = case.case.dim;
            match (&sel.min, &sel.max, &sel.nearest) {
                (Some(lo), Some(hi), None) => {
                    for (f, x) in [("min", lo), ("max", hi)] {
                        if dim_ok && x.len() != dim {
                            v.push(ks(f), format!("needs {dim} coordinates, got {}", x.len()));
                        }
                        v.finite(ks(f), x);
                    }
                    if lo.iter().zip(hi).any(|(a, b)| a > b) {
                        v.push(ks("min"), "exceeds `max`");
                    }
                }
                (None, None, Some(p)) => {
                    if dim_ok && p.len() != dim {
                        v.push(
                            ks("nearest"),
                            format!("needs {dim} coordinates, got {}", p.len()),
                        );
                    }
                    v.finite(ks("nearest"), p);
                }
                _ => v.push(
                    format!("bodies.{name}.node_sets.{set}"),
                    "needs either a box (`min` and `max`) or a point (`nearest`)",
                ),
            }
        }
        let m = &b.material;
        let (e_min, e_max) = YOUNG_RANGE;
        if !(m.E.is_finite() && m.E > 0.0) {
            v.push(
                k("material.E"),
                format!("Young's modulus must be > 0, got {}", m.E),
            );
        } else if !(e_min..=e_max).contains(&m.E) {
            v.push(
                k("material.E"),
                format!(
                    "Young's modulus {:e} is outside the range [{e_min:e}, {e_max:e}] that the \
                     solver's tolerances are made for (from GPa to Pa); rescale the units",
                    m.E
                ),
            );
        }
        if !(m.nu > -1.0 && m.nu < 0.5) {
            v.push(
                k("material.nu"),
                format!("Poisson's ratio must be in (-1, 0.5), got {}", m.nu),
            );
        } else if !(m.nu >= -1.0 + POISSON_MARGIN && m.nu <= 0.5 - POISSON_MARGIN) {
            v.push(
                k("material.nu"),
                format!(
                    "Poisson's ratio {} is within {POISSON_MARGIN:e} of its limit (-1 or 0.5): \
                     the Lame constants differ by more than 1e5 and the solve would measure \
                     round-off; use a value in [{}, {}]",
                    m.nu,
                    -1.0 + POISSON_MARGIN,
                    0.5 - POISSON_MARGIN
                ),
            );
        }
    }
}

fn check_stages(case: &Case, v: &mut Issues) {
    if case.stages.is_empty() {
        v.push("stages", "at least one [[stages]] entry is required");
    }
    let mut names = BTreeSet::new();
    for (i, s) in case.stages.iter().enumerate() {
        if s.steps == 0 {
            v.push(format!("stages.{i}.steps"), "must be > 0");
        }
        if !names.insert(s.name.as_str()) {
            v.push(
                format!("stages.{i}.name"),
                format!("duplicate stage name `{}`", s.name),
            );
        }
    }
}

fn check_components(key: String, comps: &Option<Vec<Component>>, dim: usize, v: &mut Issues) {
    let Some(comps) = comps else { return };
    if comps.is_empty() {
        v.push(key.clone(), "must list at least one component");
    }
    if let Some(c) = comps.iter().find(|c| c.index() >= dim) {
        v.push(
            key.clone(),
            format!("component {c:?} does not exist in {dim}D"),
        );
    }
    let unique: BTreeSet<_> = comps.iter().collect();
    if unique.len() != comps.len() {
        v.push(key, "lists a component twice");
    }
}

fn check_bcs(case: &Case, dim_ok: bool, v: &mut Issues) {
    let dim = case.case.dim;
    let n_stages = case.stages.len();
    for (i, bc) in case.bcs.iter().enumerate() {
        let k = |field: &str| format!("bcs.{i}.{field}");
        if !case.bodies.contains_key(bc.body()) {
            v.push(k("body"), format!("undefined body `{}`", bc.body()));
        }
        if !dim_ok {
            continue;
        }
        match bc {
            BcSpec::Fixed(f) => check_components(k("components"), &f.components, dim, v),
            BcSpec::Displacement(d) => {
                check_components(k("components"), &d.components, dim, v);
                let n_comp = d.components(dim).len();
                if d.value.len() != n_stages {
                    v.push(
                        k("value"),
                        format!(
                            "needs one vector per stage ({n_stages} stages), got {}",
                            d.value.len()
                        ),
                    );
                }
                for (s, vec) in d.value.iter().enumerate() {
                    if vec.len() != n_comp {
                        v.push(
                            format!("bcs.{i}.value.{s}"),
                            format!(
                                "needs {n_comp} entries (one per component), got {}",
                                vec.len()
                            ),
                        );
                    }
                    v.finite(format!("bcs.{i}.value.{s}"), vec);
                }
            }
            BcSpec::Rotation(r) => {
                check_axis_center(
                    v,
                    &k,
                    dim,
                    r.axis,
                    &r.center,
                    (
                        "a 3D rotation needs an axis",
                        "2D rotations are in-plane; remove axis",
                    ),
                );
                if r.angle_deg.len() != n_stages {
                    v.push(
                        k("angle_deg"),
                        format!(
                            "needs one angle per stage ({n_stages} stages), got {}",
                            r.angle_deg.len()
                        ),
                    );
                }
                v.finite(k("angle_deg"), &r.angle_deg);
                if !r.translation.is_empty() && r.translation.len() != n_stages {
                    v.push(
                        k("translation"),
                        format!(
                            "needs one vector per stage ({n_stages} stages), got {}",
                            r.translation.len()
                        ),
                    );
                }
                for (s, t) in r.translation.iter().enumerate() {
                    if t.len() != dim {
                        v.push(
                            format!("bcs.{i}.translation.{s}"),
                            format!("needs {dim} coordinates, got {}", t.len()),
                        );
                    }
                    v.finite(format!("bcs.{i}.translation.{s}"), t);
                }
                if r.free_translation && !r.translation.is_empty() {
                    v.push(
                        k("free_translation"),
                        "a free translation cannot also be prescribed: remove `translation`",
                    );
                }
            }
            BcSpec::Radial(r) => check_axis_center(
                v,
                &k,
                dim,
                r.axis,
                &r.center,
                (
                    "a 3D radial condition needs an axis",
                    "2D radial conditions are about the out-of-plane axis; remove axis",
                ),
            ),
            BcSpec::Sliding(sl) => {
                let n2: f64 = sl.normal.iter().map(|x| x * x).sum();
                if sl.normal.len() != dim {
                    v.push(
                        k("normal"),
                        format!("needs {dim} coordinates, got {}", sl.normal.len()),
                    );
                } else if !(n2.is_finite() && n2 > 0.0) {
                    v.push(
                        k("normal"),
                        format!("must be a non-zero vector, got {:?}", sl.normal),
                    );
                }
            }
        }
    }
}

/// `axis` (3D only, non-zero) and `center` (`dim` finite coordinates) of a rotation or radial
/// condition; `msgs` = (no axis in 3D, an axis in 2D).
fn check_axis_center(
    v: &mut Issues,
    k: &dyn Fn(&str) -> String,
    dim: usize,
    axis: Option<[f64; 3]>,
    center: &[f64],
    msgs: (&str, &str),
) {
    match (dim, axis) {
        (3, None) => v.push(k("axis"), msgs.0),
        (3, Some(a)) => {
            let n2: f64 = a.iter().map(|x| x * x).sum();
            if !(n2.is_finite() && n2 > 0.0) {
                v.push(k("axis"), format!("must be a non-zero vector, got {a:?}"));
            }
        }
        (_, Some(_)) => v.push(k("axis"), msgs.1),
        _ => {}
    }
    if center.len() != dim {
        v.push(
            k("center"),
            format!("needs {dim} coordinates, got {}", center.len()),
        );
    }
    v.finite(k("center"), center);
}

fn check_ties(case: &Case, dim_ok: bool, v: &mut Issues) {
    for (i, t) in case.ties.iter().enumerate() {
        let k = |field: &str| format!("ties.{i}.{field}");
        if !case.bodies.contains_key(&t.body) {
            v.push(k("body"), format!("undefined body `{}`", t.body));
        }
        if t.master == t.slave {
            v.push(
                k("slave"),
                format!("must differ from master `{}`", t.master),
            );
        }
        if dim_ok && t.offset.len() != case.case.dim {
            v.push(
                k("offset"),
                format!(
                    "needs {} coordinates, got {}",
                    case.case.dim,
                    t.offset.len()
                ),
            );
        }
        v.finite(k("offset"), &t.offset);
        v.positive(k("tolerance"), t.tolerance);
    }
}

fn check_controls(case: &Case, v: &mut Issues) {
    let s = &case.steps;
    if !(s.growth.is_finite() && s.growth >= 1.0) {
        v.push("steps.growth", format!("must be >= 1, got {}", s.growth));
    }
    if s.easy_iterations == 0 {
        v.push("steps.easy_iterations", "must be > 0");
    }
    let o = &case.output;
    if o.every == 0 {
        v.push("output.every", "must be > 0");
    }
    let mut seen: BTreeSet<&str> = BTreeSet::new();
    for f in &o.fields {
        if !seen.insert(f.name()) {
            v.push("output.fields", format!("lists `{}` twice", f.name()));
        }
    }
    for (i, r) in o.reactions.iter().enumerate() {
        if !case.bodies.contains_key(&r.body) {
            v.push(
                format!("output.reactions.{i}.body"),
                format!("undefined body `{}`", r.body),
            );
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::examples::{BLOCK_COMPRESSION_3D, IRONING_2D, STRIP_BENDING_2D};
    use crate::scene::parse_case;
    use std::path::Path;

    fn issues(text: &str, overrides: &[&str]) -> Vec<Issue> {
        let o: Vec<String> = overrides.iter().map(|s| s.to_string()).collect();
        match parse_case(text, Path::new("c.toml"), &o) {
            Err(SceneError::Invalid { issues, .. }) => issues,
            other => panic!("expected validation issues, got {other:?}"),
        }
    }

    fn has(issues: &[Issue], key: &str, words: &str) -> bool {
        issues
            .iter()
            .any(|i| i.key == key && i.message.contains(words))
    }

    #[test]
    fn generator_dimension_must_match_case_dim() {
        let i = issues(BLOCK_COMPRESSION_3D, &["case.dim=2"]);
        assert!(
            has(&i, "meshes.block.generator", "builds a 3D mesh"),
            "{i:?}"
        );
        let i = issues(BLOCK_COMPRESSION_3D, &["case.dim=4"]);
        assert!(has(&i, "case.dim", "must be 2 or 3"), "{i:?}");
    }

    #[test]
    fn hemisphere_nurbs_rejects_odd_n_surface() {
        let text = include_str!("../../cases/hemisphere_rotate_3d.toml");
        let i = issues(text, &["meshes.shell.n_surface=7"]);
        assert!(
            has(
                &i,
                "meshes.shell.n_surface",
                "must be even for hemisphere_nurbs"
            ),
            "{i:?}"
        );
        let o = ["meshes.shell.n_surface=6".to_string()];
        assert!(parse_case(text, Path::new("c.toml"), &o).is_ok());
    }

    #[test]
    fn two_d_only_families_are_rejected_in_3d() {
        for fam in ["Q1E4", "Q1C2", "Q1CH"] {
            let i = issues(
                BLOCK_COMPRESSION_3D,
                &[
                    &format!("bodies.block.element={fam}"),
                    "bodies.block.enriched_surface=zmax",
                ],
            );
            assert!(has(&i, "bodies.block.element", "2D only"), "{fam}: {i:?}");
        }
    }

    #[test]
    fn enriched_surface_is_required_for_enriched_families_and_ignored_by_linear_ones() {
        let i = issues(BLOCK_COMPRESSION_3D, &["bodies.block.element=Q1N2"]);
        assert!(
            has(
                &i,
                "bodies.block.enriched_surface",
                "needs an enriched_surface"
            ),
            "{i:?}"
        );
        let o = ["bodies.strip.enriched_surface=ymax".to_string()];
        assert!(
            parse_case(STRIP_BENDING_2D, Path::new("c.toml"), &o).is_ok(),
            "a linear family ignores enriched_surface"
        );
        let i = issues(STRIP_BENDING_2D, &["bodies.strip.enriched_surface=\" \""]);
        assert!(
            has(&i, "bodies.strip.enriched_surface", "must name a face set"),
            "{i:?}"
        );
    }

    #[test]
    fn smooth_enriched_geometry_needs_an_enriched_surface_and_a_known_value() {
        let i = issues(
            STRIP_BENDING_2D,
            &["bodies.strip.enriched_geometry=\"smooth\""],
        );
        assert!(
            has(
                &i,
                "bodies.strip.enriched_geometry",
                "needs bodies.<name>.enriched_surface"
            ),
            "{i:?}"
        );
        for g in ["exact", "smooth"] {
            let o = [
                "bodies.strip.enriched_surface=ymax".to_string(),
                format!("bodies.strip.enriched_geometry=\"{g}\""),
            ];
            assert!(
                parse_case(STRIP_BENDING_2D, Path::new("c.toml"), &o).is_ok(),
                "{g}"
            );
        }
        let o = ["bodies.strip.enriched_geometry=\"wavy\"".to_string()];
        let e = parse_case(STRIP_BENDING_2D, Path::new("c.toml"), &o).unwrap_err();
        assert!(e.to_string().contains("wavy"), "{e}");
    }

    #[test]
    fn mesh_extents_beyond_the_coordinate_range_are_named_by_key() {
        let i = issues(
            BLOCK_COMPRESSION_3D,
            &["meshes.block.size=[1e300, 1.0, 1.0]"],
        );
        assert!(has(&i, "meshes.block.size", "is out of range"), "{i:?}");
        let i = issues(
            BLOCK_COMPRESSION_3D,
            &["meshes.block.origin=[0.0, -1e300, 0.0]"],
        );
        assert!(has(&i, "meshes.block.origin", "at most 1e30"), "{i:?}");
        // a finite origin plus a finite size that together pass the range
        let i = issues(
            BLOCK_COMPRESSION_3D,
            &[
                "meshes.block.origin=[9e29, 0.0, 0.0]",
                "meshes.block.size=[2e29, 1.0, 1.0]",
            ],
        );
        assert!(has(&i, "meshes.block.size", "1.1e30"), "{i:?}");
        let i = issues(IRONING_2D, &["meshes.cylinder.radius=1e300"]);
        assert!(
            has(&i, "meshes.cylinder.radius", "is out of range"),
            "{i:?}"
        );
    }

    #[test]
    fn divisions_and_sizes_must_be_positive() {
        let i = issues(
            BLOCK_COMPRESSION_3D,
            &[
                "meshes.block.divisions=[4, 0, 4]",
                "meshes.block.size=[1.0, -1.0, 1.0]",
            ],
        );
        assert!(has(&i, "meshes.block.divisions", "> 0"), "{i:?}");
        assert!(has(&i, "meshes.block.size", "positive"), "{i:?}");
        let i = issues(
            IRONING_2D,
            &["meshes.cylinder.n_arc=0", "meshes.cylinder.radius=0.0"],
        );
        assert!(has(&i, "meshes.cylinder.n_arc", "at least 4"), "{i:?}");
        assert!(has(&i, "meshes.cylinder.radius", "positive"), "{i:?}");
    }

    #[test]
    fn rotation_needs_nonzero_axis_in_3d_and_none_in_2d() {
        let rot3 = BLOCK_COMPRESSION_3D.replacen(
            "kind = \"displacement\"\ncomponents = [\"z\"]\nvalue = [[-0.2]]",
            "kind = \"rotation\"\naxis = [0.0, 0.0, 0.0]\ncenter = [0.5, 0.5, 1.0]\nangle_deg = [90.0]",
            1,
        );
        assert_ne!(rot3, BLOCK_COMPRESSION_3D);
        let i = issues(&rot3, &[]);
        assert!(has(&i, "bcs.1.axis", "non-zero"), "{i:?}");
        let i = issues(
            STRIP_BENDING_2D,
            &["bcs.1.axis=[0.0, 0.0, 1.0]", "bcs.1.center=[1.0]"],
        );
        assert!(has(&i, "bcs.1.axis", "in-plane"), "{i:?}");
        assert!(has(&i, "bcs.1.center", "needs 2 coordinates"), "{i:?}");
        let i = issues(STRIP_BENDING_2D, &["bcs.1.angle_deg=[90.0]"]);
        assert!(
            has(
                &i,
                "bcs.1.angle_deg",
                "one angle per stage (2 stages), got 1"
            ),
            "{i:?}"
        );
    }

    #[test]
    fn components_must_exist_in_the_dimension() {
        let i = issues(STRIP_BENDING_2D, &["bcs.0.components=[\"x\", \"z\"]"]);
        assert!(has(&i, "bcs.0.components", "does not exist in 2D"), "{i:?}");
        let i = issues(STRIP_BENDING_2D, &["bcs.0.components=[\"x\", \"x\"]"]);
        assert!(has(&i, "bcs.0.components", "twice"), "{i:?}");
    }

    #[test]
    fn ties_need_dim_offset_and_distinct_sets() {
        let i = issues(
            IRONING_2D,
            &[
                "ties.0.offset=[10.0]",
                "ties.0.slave=xmin",
                "ties.0.body=plate",
            ],
        );
        assert!(has(&i, "ties.0.offset", "needs 2 coordinates"), "{i:?}");
        assert!(has(&i, "ties.0.slave", "must differ"), "{i:?}");
        assert!(has(&i, "ties.0.body", "undefined body `plate`"), "{i:?}");
    }

    #[test]
    fn step_and_output_controls_are_checked() {
        let i = issues(
            BLOCK_COMPRESSION_3D,
            &[
                "steps={ growth = 0.5 }",
                "output.every=0",
                "output.reactions=[{ body = \"x\", set = \"zmin\" }]",
            ],
        );
        assert!(has(&i, "steps.growth", ">= 1"), "{i:?}");
        assert!(has(&i, "output.every", "> 0"), "{i:?}");
        assert!(
            has(&i, "output.reactions.0.body", "undefined body `x`"),
            "{i:?}"
        );
    }

    #[test]
    fn all_issues_are_reported_together() {
        let i = issues(
            BLOCK_COMPRESSION_3D,
            &[
                "bodies.block.material.nu=0.7",
                "bodies.block.material.E=-1.0",
                "stages.0.steps=0",
            ],
        );
        assert_eq!(i.len(), 3, "{i:?}");
    }

    #[test]
    fn case_name_must_be_one_plain_path_component() {
        for bad in ["../x", "/tmp/x", "a/b", "..", ".", "a b", "x\\y", ""] {
            let i = issues(BLOCK_COMPRESSION_3D, &[&format!("case.name={bad:?}")]);
            assert!(i.iter().any(|i| i.key == "case.name"), "{bad}: {i:?}");
        }
        for good in ["block-2.v1_final", "..x", "A9"] {
            let o = [format!("case.name={good:?}")];
            assert!(
                parse_case(BLOCK_COMPRESSION_3D, Path::new("c.toml"), &o).is_ok(),
                "{good}"
            );
        }
    }

    #[test]
    fn material_constants_must_be_in_a_sane_range() {
        for (e, ok) in [
            ("1e308", false),
            ("1e14", false),
            ("1e-7", false),
            ("1e13", true),
            ("1e-6", true),
            ("2.1e11", true),
        ] {
            let o = [format!("bodies.block.material.E={e}")];
            let r = parse_case(BLOCK_COMPRESSION_3D, Path::new("c.toml"), &o);
            assert_eq!(r.is_ok(), ok, "E = {e}: {r:?}");
            if !ok {
                let i = issues(BLOCK_COMPRESSION_3D, &[&o[0]]);
                assert!(
                    has(&i, "bodies.block.material.E", "outside the range"),
                    "{i:?}"
                );
            }
        }
        for (nu, ok) in [
            ("0.4999999", false),
            ("-0.9999999", false),
            ("0.499999", true),
            ("-0.99", true),
        ] {
            let o = [format!("bodies.block.material.nu={nu}")];
            let r = parse_case(BLOCK_COMPRESSION_3D, Path::new("c.toml"), &o);
            assert_eq!(r.is_ok(), ok, "nu = {nu}: {r:?}");
        }
        let i = issues(
            BLOCK_COMPRESSION_3D,
            &["bodies.block.material.nu=0.4999999"],
        );
        assert!(has(&i, "bodies.block.material.nu", "within 1e-6"), "{i:?}");
    }

    #[test]
    fn krylov_accept_is_a_fraction_below_one() {
        for bad in ["-1e-3", "1.0", "2.0", "nan"] {
            let i = issues(
                BLOCK_COMPRESSION_3D,
                &[&format!("solver.krylov_accept={bad}")],
            );
            assert!(
                has(&i, "solver.krylov_accept", "must be in [0, 1)"),
                "{bad}: {i:?}"
            );
        }
        for good in ["0.0", "1e-3", "0.5"] {
            let o = [format!("solver.krylov_accept={good}")];
            let c = parse_case(BLOCK_COMPRESSION_3D, Path::new("c.toml"), &o);
            assert!(c.is_ok(), "{good}: {c:?}");
        }
    }

    #[test]
    fn first_update_is_a_fraction_up_to_one() {
        for bad in ["0.0", "-0.5", "1.5", "nan"] {
            let i = issues(
                BLOCK_COMPRESSION_3D,
                &[&format!("solver.first_update={bad}")],
            );
            assert!(
                has(&i, "solver.first_update", "must be in (0, 1]"),
                "{bad}: {i:?}"
            );
        }
        for good in ["1.0", "0.5", "1e-3"] {
            let o = [format!("solver.first_update={good}")];
            let c = parse_case(BLOCK_COMPRESSION_3D, Path::new("c.toml"), &o);
            assert!(c.is_ok(), "{good}: {c:?}");
        }
    }

    #[test]
    fn max_penetration_is_positive_and_needs_contact() {
        let hertz = include_str!("../../cases/hertz_2d.toml");
        for bad in ["0.0", "-1e-3"] {
            let i = issues(hertz, &[&format!("solver.max_penetration={bad}")]);
            assert!(has(&i, "solver.max_penetration", "positive"), "{i:?}");
        }
        let o = ["solver.max_penetration=1e-3".to_string()];
        assert!(parse_case(hertz, Path::new("c.toml"), &o).is_ok());
        let i = issues(BLOCK_COMPRESSION_3D, &["solver.max_penetration=1e-3"]);
        assert!(
            has(&i, "solver.max_penetration", "no [[contact]] pair"),
            "{i:?}"
        );
    }

    #[test]
    fn full_ring_sector_is_rejected_in_degrees() {
        let text = IRONING_2D.replace(
            "[meshes.cylinder]",
            "[meshes.ring]\ngenerator = \"sector\"\ncenter = [0.0, 0.0]\nr_inner = 1.0\n\
             r_outer = 2.0\ntheta0_deg = 0.0\ntheta1_deg = 360.0\ndivisions = [2, 8]\n\n\
             [meshes.cylinder]",
        );
        let i = issues(&text, &[]);
        assert!(
            has(&i, "meshes.ring.theta1_deg", "got 360 degrees")
                && has(&i, "meshes.ring.theta1_deg", "(0, 360) degrees"),
            "{i:?}"
        );
        let i = issues(
            &text,
            &["meshes.ring.r_inner=0.0", "meshes.ring.theta1_deg=90.0"],
        );
        assert!(has(&i, "meshes.ring.r_inner", "> 0"), "{i:?}");
        assert_eq!(i.len(), 1, "{i:?}");
    }

    #[test]
    fn mesh_file_that_is_a_directory_is_reported_as_one() {
        let text = include_str!("../../cases/plate_hole_2d.toml");
        let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("cases/plate_hole_2d.toml");
        let i = match parse_case(text, &file, &["meshes.plate.file=\".\"".to_string()]) {
            Err(SceneError::Invalid { issues, .. }) => issues,
            other => panic!("{other:?}"),
        };
        assert!(has(&i, "meshes.plate.file", "is a directory"), "{i:?}");
        let o = ["meshes.plate.file=\"nope.msh\"".to_string()];
        let e = parse_case(text, &file, &o).unwrap_err().to_string();
        assert!(e.contains("nope.msh not found"), "{e}");
        assert!(parse_case(text, &file, &[]).is_ok());
    }

    #[test]
    fn meshes_too_large_to_run_are_refused_with_the_estimate() {
        let i = issues(
            BLOCK_COMPRESSION_3D,
            &["meshes.block.divisions=[2000, 2000, 2000]"],
        );
        assert!(
            has(&i, "meshes.block.divisions", "2.404e10 unknowns")
                && has(&i, "meshes.block.divisions", "2147483647"),
            "{i:?}"
        );
        // under the index limit, but 1e9 unknowns' matrix needs some 6 TB
        if crate::scene::size::machine_memory_bytes().is_some_and(|m| m < 5e12) {
            let i = issues(
                BLOCK_COMPRESSION_3D,
                &["meshes.block.divisions=[700, 700, 700]"],
            );
            assert!(
                has(&i, "meshes.block.divisions", "estimated memory")
                    && has(&i, "meshes.block.divisions", "more than this machine's"),
                "{i:?}"
            );
        }
        // counts that would overflow usize arithmetic are still a clear error
        let huge = format!("meshes.block.divisions=[{0}, {0}, {0}]", u32::MAX);
        let i = issues(BLOCK_COMPRESSION_3D, &[&huge]);
        assert!(has(&i, "meshes.block.divisions", "too large"), "{i:?}");
        let i = issues(IRONING_2D, &["meshes.cylinder.n_arc=100000000"]);
        assert!(has(&i, "meshes.cylinder.n_arc", "too large"), "{i:?}");
    }

    #[test]
    fn validate_sets_reports_each_missing_set_with_key() {
        let c = parse_case(IRONING_2D, Path::new("c.toml"), &[]).unwrap();
        let all = |_: &str, _: &str, _: SetKind| true;
        assert!(validate_sets(&c, &all).is_ok());
        // Only node sets named *min/top/x* exist; no face sets at all.
        let some = |_: &str, set: &str, kind: SetKind| kind == SetKind::Node && set != "xmax";
        let e = validate_sets(&c, &some).unwrap_err();
        let SceneError::Invalid { issues, .. } = &e else {
            panic!("{e:?}")
        };
        let keys: Vec<&str> = issues.iter().map(|i| i.key.as_str()).collect();
        assert_eq!(
            keys,
            vec![
                "bodies.block.enriched_surface",
                "bodies.cylinder.enriched_surface",
                "ties.0.slave"
            ]
        );
        assert!(
            e.to_string()
                .contains("body `block` has no node set `xmax`"),
            "{e}"
        );
        assert!(e.to_string().contains("c.toml"), "{e}");
    }
}
