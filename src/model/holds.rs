//! Which parts of a model nothing holds: connected components of the mesh (cells, periodic ties,
//! contact pairs between bodies) that no Dirichlet condition or rigid contact partner reaches, or
//! that the Dirichlet conditions hold against only some rigid motions. Such a problem has a
//! singular tangent: it "converges" at iteration 0 or to an arbitrary rigid shift.

use super::data::Model;
use crate::contact::Partner;
use nalgebra::DMatrix;

/// What [`holds`] found.
#[derive(Debug, Default, Clone)]
pub struct HoldReport {
    /// Components nothing holds, or that only Dirichlet conditions hold and not against every rigid
    /// motion: the tangent is singular.
    pub errors: Vec<String>,
    /// Components held by contact and Dirichlet conditions that alone leave rigid motions free:
    /// contact may hold them, or not.
    pub warnings: Vec<String>,
    /// Bodies named in errors or warnings (the likely free bodies of a singular tangent).
    pub suspects: Vec<String>,
    /// Translations that no Dirichlet condition holds, of bodies (alone, and joined by contact
    /// or ties) that touch a contact pair: whether contact holds them shows only in the tangent,
    /// which load stepping checks ([`crate::solver::TranslationProbe`]).
    pub free_translations: Vec<FreeTranslation>,
}

/// A rigid translation of a set of nodes that no Dirichlet condition holds.
#[derive(Debug, Clone, PartialEq)]
pub struct FreeTranslation {
    /// The set in words, e.g. "body `disk`" or "bodies `a`, `b` together".
    pub what: String,
    /// The translation's axis (0: x, 1: y, 2: z).
    pub axis: usize,
    /// Global nodes whose unknowns are positions (no Hermite tangent pseudo-nodes, no display
    /// nodes), sorted.
    pub nodes: Vec<u32>,
}

struct UnionFind(Vec<u32>);

impl UnionFind {
    fn new(n: usize) -> Self {
        UnionFind((0..n as u32).collect())
    }
    fn find(&mut self, mut a: u32) -> u32 {
        while self.0[a as usize] != a {
            let p = self.0[self.0[a as usize] as usize];
            self.0[a as usize] = p;
            a = p;
        }
        a
    }
    fn union(&mut self, a: u32, b: u32) {
        let (ra, rb) = (self.find(a), self.find(b));
        if ra != rb {
            self.0[ra.max(rb) as usize] = ra.min(rb);
        }
    }
}

#[derive(Default)]
struct Component {
    cells: usize,
    first_cell: usize,
    bodies: Vec<usize>,
    contact: bool,
}

/// Rigid modes of the dimension: 2D `[tx, ty, rz]`, 3D `[tx, ty, tz, rx, ry, rz]`.
fn mode_names(dim: usize) -> &'static [&'static str] {
    if dim == 2 {
        &[
            "translation along x",
            "translation along y",
            "rotation about z",
        ]
    } else {
        &[
            "translation along x",
            "translation along y",
            "translation along z",
            "rotation about x",
            "rotation about y",
            "rotation about z",
        ]
    }
}

/// Values of the rigid modes at point `x` (relative to a centre, scaled) in component `c`.
fn mode_row(dim: usize, x: &[f64], c: usize) -> Vec<f64> {
    if dim == 2 {
        // rotation about z: (-y, x)
        let r = if c == 0 { -x[1] } else { x[0] };
        let mut v = vec![0.0; 3];
        v[c] = 1.0;
        v[2] = r;
        v
    } else {
        let mut v = vec![0.0; 6];
        v[c] = 1.0;
        // rotation about axis a: e_a x x
        for a in 0..3 {
            let mut e = [0.0; 3];
            e[a] = 1.0;
            let cross = [
                e[1] * x[2] - e[2] * x[1],
                e[2] * x[0] - e[0] * x[2],
                e[0] * x[1] - e[1] * x[0],
            ];
            v[3 + a] = cross[c];
        }
        v
    }
}

/// The held unit direction of every node under a skew condition that carries unknowns (a radial
/// condition's node on its axis holds none), once per condition.
fn skew_directions(model: &Model, has_unknowns: &impl Fn(u32) -> bool) -> Vec<(u32, [f64; 3])> {
    let dim = model.dim;
    let mut out = Vec::new();
    for sk in &model.skews {
        for &n in sk.nodes.iter().filter(|&&n| has_unknowns(n)) {
            let x = &model.coords[n as usize * dim..(n as usize + 1) * dim];
            if let Some(t) = sk.direction(x) {
                out.push((n, t));
            }
        }
    }
    out
}

/// Analyses the model: `has_unknowns(node)` says whether a node carries unknowns (display nodes of
/// enriched surfaces do not).
pub fn holds(model: &Model, has_unknowns: impl Fn(u32) -> bool) -> HoldReport {
    let dim = model.dim;
    let n_nodes = model.n_nodes();
    let mut uf = UnionFind::new(n_nodes);
    let n_cells = model.cell_offsets.len().saturating_sub(1);
    for c in 0..n_cells {
        let nodes = &model.cell_nodes[model.cell_offsets[c]..model.cell_offsets[c + 1]];
        for w in nodes.windows(2) {
            uf.union(w[0], w[1]);
        }
    }
    for &(s, m) in &model.ties {
        uf.union(s, m);
    }
    // Before contact joins them: parts that only contact with another body holds are free until
    // the contact closes (a singular tangent at the first step).
    let mut alone = UnionFind(uf.0.clone());
    let surface_nodes = |k: usize| -> Vec<u32> {
        model.contact_surfaces[k]
            .elements
            .iter()
            .flat_map(|e| e.nodes.iter().copied())
            .collect()
    };
    let mut rigid_held: Vec<u32> = Vec::new();
    let mut contact_nodes: Vec<u32> = Vec::new();
    for pair in &model.contact_pairs {
        for (k, partner) in &pair.passes {
            let mine = surface_nodes(*k);
            contact_nodes.extend(&mine);
            match partner {
                Partner::Surface(j) => {
                    let theirs = surface_nodes(*j);
                    if let (Some(&a), Some(&b)) = (mine.first(), theirs.first()) {
                        uf.union(a, b);
                    }
                }
                Partner::Rigid(..) => rigid_held.extend(&mine),
            }
        }
    }
    // components, keyed by root
    let mut comps: std::collections::BTreeMap<u32, Component> = Default::default();
    for c in 0..n_cells {
        let first = model.cell_nodes[model.cell_offsets[c]];
        let comp = comps.entry(uf.find(first)).or_insert_with(|| Component {
            first_cell: c,
            ..Default::default()
        });
        comp.cells += 1;
        let b = model.cell_body[c] as usize;
        if !comp.bodies.contains(&b) {
            comp.bodies.push(b);
        }
    }
    for n in rigid_held.iter().chain(&contact_nodes) {
        if let Some(comp) = comps.get_mut(&uf.find(*n)) {
            comp.contact = true;
        }
    }
    let rigid_roots: std::collections::BTreeSet<u32> =
        rigid_held.iter().map(|&n| uf.find(n)).collect();
    // held directions of each component: Dirichlet components and skew conditions' directions
    let mut constrained: std::collections::BTreeMap<u32, Vec<(u32, [f64; 3])>> = Default::default();
    for bc in &model.bcs {
        for &n in &bc.nodes {
            if !has_unknowns(n) {
                continue;
            }
            let root = uf.find(n);
            let list = constrained.entry(root).or_default();
            for &c in &bc.components {
                let mut e = [0.0; 3];
                e[c] = 1.0;
                list.push((n, e));
            }
        }
    }
    for (n, t) in skew_directions(model, &has_unknowns) {
        constrained.entry(uf.find(n)).or_default().push((n, t));
    }
    let n_modes = if dim == 2 { 3 } else { 6 };
    let mut report = HoldReport::default();
    for (root, comp) in &comps {
        let list = constrained.get(root).map(Vec::as_slice).unwrap_or(&[]);
        let bodies: Vec<String> = comp
            .bodies
            .iter()
            .map(|&b| format!("`{}`", model.bodies[b].name))
            .collect();
        let n_body_cells: usize = comp
            .bodies
            .iter()
            .map(|&b| model.bodies[b].mesh.n_cells())
            .sum();
        let what = if comp.cells == n_body_cells && bodies.len() == 1 {
            format!("body {}", bodies[0])
        } else if comp.cells == n_body_cells {
            format!("bodies {} (joined by contact or ties)", bodies.join(", "))
        } else {
            let b = comp.bodies[0];
            format!(
                "a part of body {} ({} of its {} cells, from cell {})",
                bodies.join(", "),
                comp.cells,
                n_body_cells,
                comp.first_cell - model.bodies[b].cell_offset
            )
        };
        let suspects = comp.bodies.iter().map(|&b| model.bodies[b].name.clone());
        if list.is_empty() && !comp.contact {
            report.errors.push(format!(
                "{what} is held by no Dirichlet condition, tie or contact pair: it can move freely"
            ));
            report.suspects.extend(suspects);
            continue;
        }
        if rigid_roots.contains(root) && list.is_empty() {
            continue;
        }
        // centre and scale of the constrained nodes, for a well-conditioned Gram matrix
        let mut centre = vec![0.0; dim];
        let (mut lo, mut hi) = (vec![f64::MAX; dim], vec![f64::MIN; dim]);
        for (n, _) in list {
            for d in 0..dim {
                let x = model.coords[*n as usize * dim + d];
                centre[d] += x / list.len() as f64;
                lo[d] = lo[d].min(x);
                hi[d] = hi[d].max(x);
            }
        }
        let scale = (0..dim)
            .map(|d| hi[d] - lo[d])
            .fold(0.0, f64::max)
            .max(1e-300);
        let mut gram = DMatrix::<f64>::zeros(n_modes, n_modes);
        let mut x = [0.0; 3];
        for (n, t) in list {
            for d in 0..dim {
                x[d] = (model.coords[*n as usize * dim + d] - centre[d]) / scale;
            }
            let mut row = vec![0.0; n_modes];
            for c in (0..dim).filter(|&c| t[c] != 0.0) {
                for (r, m) in row.iter_mut().zip(mode_row(dim, &x[..dim], c)) {
                    *r += t[c] * m;
                }
            }
            for i in 0..n_modes {
                for j in 0..n_modes {
                    gram[(i, j)] += row[i] * row[j];
                }
            }
        }
        let eig = gram.symmetric_eigen();
        let largest = eig.eigenvalues.iter().cloned().fold(0.0, f64::max);
        let mut free = Vec::new();
        for (k, &l) in eig.eigenvalues.iter().enumerate() {
            if l <= 1e-10 * largest.max(1.0) {
                let v = eig.eigenvectors.column(k);
                let (i, _) = v.iter().enumerate().fold((0, 0.0), |(bi, bv), (i, x)| {
                    if x.abs() > bv {
                        (i, x.abs())
                    } else {
                        (bi, bv)
                    }
                });
                free.push(mode_names(dim)[i]);
            }
        }
        if free.is_empty() {
            continue;
        }
        free.sort();
        free.dedup();
        let text = format!(
            "{what} is held by Dirichlet conditions against only some rigid motions: free {}",
            free.join(", ")
        );
        if comp.contact {
            report
                .warnings
                .push(format!("{text} (unless contact holds it)"));
        } else {
            report.errors.push(text);
        }
        report.suspects.extend(suspects);
    }
    let mut held_alone: std::collections::BTreeSet<u32> =
        rigid_held.iter().map(|&n| alone.find(n)).collect();
    for (n, _) in skew_directions(model, &has_unknowns) {
        held_alone.insert(alone.find(n));
    }
    for bc in &model.bcs {
        for &n in bc.nodes.iter().filter(|&&n| has_unknowns(n)) {
            held_alone.insert(alone.find(n));
        }
    }
    let mut warned: std::collections::BTreeSet<u32> = Default::default();
    for c in 0..n_cells {
        let root = alone.find(model.cell_nodes[model.cell_offsets[c]]);
        if held_alone.contains(&root) || !warned.insert(root) {
            continue;
        }
        let body = &model.bodies[model.cell_body[c] as usize].name;
        report.warnings.push(format!(
            "body `{body}` (from cell {}) is held only through a contact pair with another body: it is free until the contact closes",
            c - model.bodies[model.cell_body[c] as usize].cell_offset
        ));
        report.suspects.push(body.clone());
    }
    report.suspects.sort();
    report.suspects.dedup();
    report.free_translations = free_translations(model, &has_unknowns, &mut alone, &mut uf);
    report
}

/// The translations no Dirichlet condition holds, of each body part alone and of each set of parts
/// that contact or ties join, among those that touch a contact pair (see
/// [`HoldReport::free_translations`]). A skew condition holds the translations along the axes its
/// direction has a component on (so a free axis never carries a skew condition's dependent
/// unknown).
fn free_translations(
    model: &Model,
    has_unknowns: &impl Fn(u32) -> bool,
    alone: &mut UnionFind,
    joint: &mut UnionFind,
) -> Vec<FreeTranslation> {
    let dim = model.dim;
    let n_nodes = model.n_nodes();
    if model.contact_pairs.is_empty() {
        return Vec::new();
    }
    // position unknowns: not a Hermite tangent pseudo-node, not a display node, in some cell
    let mut position = vec![false; n_nodes];
    for c in 0..model.cell_offsets.len().saturating_sub(1) {
        for &n in &model.cell_nodes[model.cell_offsets[c]..model.cell_offsets[c + 1]] {
            position[n as usize] = has_unknowns(n);
        }
    }
    for b in &model.bodies {
        if let Some(e) = &b.enrichment {
            for &p in &e.pseudo_nodes {
                position[(p + b.node_offset) as usize] = false;
            }
        }
    }
    let mut contact_node = vec![false; n_nodes];
    for s in &model.contact_surfaces {
        for e in &s.elements {
            for &n in &e.nodes {
                contact_node[n as usize] = true;
            }
        }
    }
    let mut out: Vec<FreeTranslation> = Vec::new();
    for uf in [alone, joint] {
        let mut groups: std::collections::BTreeMap<u32, Vec<u32>> = Default::default();
        for n in 0..n_nodes as u32 {
            if position[n as usize] {
                groups.entry(uf.find(n)).or_default().push(n);
            }
        }
        let mut held: std::collections::BTreeMap<u32, [bool; 3]> = Default::default();
        for bc in &model.bcs {
            for &n in bc.nodes.iter().filter(|&&n| has_unknowns(n)) {
                let h = held.entry(uf.find(n)).or_default();
                for &c in &bc.components {
                    h[c] = true;
                }
            }
        }
        for (n, t) in skew_directions(model, has_unknowns) {
            let h = held.entry(uf.find(n)).or_default();
            for c in 0..dim {
                h[c] |= t[c] != 0.0;
            }
        }
        for (root, nodes) in groups {
            if !nodes.iter().any(|&n| contact_node[n as usize]) {
                continue;
            }
            if out.iter().any(|t| t.nodes == nodes) {
                continue;
            }
            let mut bodies: Vec<String> = Vec::new();
            for b in &model.bodies {
                let range = b.node_offset..b.node_offset + b.n_nodes() as u32;
                if nodes.iter().any(|n| range.contains(n)) {
                    bodies.push(format!("`{}`", b.name));
                }
            }
            let what = match bodies.len() {
                1 => format!("body {}", bodies[0]),
                _ => format!("bodies {} together", bodies.join(", ")),
            };
            let h = held.get(&root).copied().unwrap_or_default();
            for axis in (0..dim).filter(|&a| !h[a]) {
                out.push(FreeTranslation {
                    what: what.clone(),
                    axis,
                    nodes: nodes.clone(),
                });
            }
        }
    }
    out
}
