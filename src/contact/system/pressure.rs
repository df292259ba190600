//! Post-processing of the contact pressure, normal gap and friction (Sauer 2013): right-hand sides
//! of their L2 projections onto each surface's own interpolation, and the projection itself.
#![allow(clippy::needless_range_loop)]
#![allow(non_snake_case)]

use super::{ContactSystem, Pair};
use crate::contact::formulation::Passes;
use crate::contact::half_pass::QPoint;
use crate::contact::kernel::SlipState;
use crate::contact::pair::Partner;
use crate::contact::projection::basis_values;
use crate::contact::surface::MAX_FACE_NODES;
use crate::fem::quadrature::tensor_rule;

impl ContactSystem {
    /// This rank's right-hand sides of the L2 projections of the contact pressure and the normal gap
    /// (Sauer 2013): per surface, `f_A = int N_A p da` with `p = -t . nu_k` (`nu_k` the surface's own
    /// outward normal: positive in compression, negative in adhesion), and `int N_A g_n da` with
    /// `g_n` capped at the search distance where no partner is within reach. Indexed
    /// `[surface][surface node]` (the order of [`ContactSystem::all_surface_nodes`], the same on
    /// every rank), flattened; sum over ranks before [`ContactSystem::l2_project`].
    pub fn l2_rhs(&self) -> (Vec<f64>, Vec<f64>) {
        let (dim, nt) = (self.dim, self.all_nodes.len());
        let mut fp = vec![0.0; self.surfaces.len() * nt];
        let mut fg = vec![0.0; self.surfaces.len() * nt];
        // one-pass: the master, which integrates no points of its own, also carries the slave
        // points' pressure and gap at their projections (`int N^m_A p da` over the slave's
        // points), so that both surfaces of the pair show the contact zone
        let mut Nm = Vec::new();
        self.each_surface_point(false, |pair, k, e, qp, N, nu| {
            let el = &self.surfaces[k].elements[e];
            let J = (nu[0] * nu[0] + nu[1] * nu[1] + nu[2] * nu[2]).sqrt();
            let p = -el.sign * (0..dim).map(|c| qp.force[c] * nu[c]).sum::<f64>() / J;
            let g = qp
                .gap
                .unwrap_or(pair.def.search_distance)
                .min(pair.def.search_distance);
            for (b, &a) in el.nodes.iter().enumerate() {
                let t = self.node_index(a);
                fp[k * nt + t] += N[b] * p;
                fg[k * nt + t] += N[b] * g * J * qp.w;
            }
            if pair.def.formulation.passes != Passes::OnePass {
                return;
            }
            let master = pair
                .def
                .passes
                .iter()
                .find_map(|(s, partner)| match partner {
                    Partner::Surface(m) if *s == k => Some(*m),
                    _ => None,
                });
            let (Some(km), Some(proj)) = (master, qp.current) else {
                return;
            };
            let mel = &self.surfaces[km].elements[proj.elem as usize];
            basis_values(&mel.basis, &proj.xi, &mut Nm);
            for (b, &a) in mel.nodes.iter().enumerate() {
                let t = self.node_index(a);
                fp[km * nt + t] += Nm[b] * p;
                fg[km * nt + t] += Nm[b] * g * J * qp.w;
            }
        });
        (fp, fg)
    }

    /// Calls `f(pair, surface, element, point, basis values, raw normal)` for every quadrature
    /// point this rank integrates (of the frictional pairs only with `frictional_only`), with the
    /// surface's own basis and raw normal (length: the area factor) at the point's current
    /// position.
    fn each_surface_point(
        &self,
        frictional_only: bool,
        mut f: impl FnMut(&Pair, usize, usize, &QPoint, &[f64], [f64; 3]),
    ) {
        let (dim, m) = (self.dim, self.dim - 1);
        let (mut N, mut dN, mut ddN) = (
            [0.0; MAX_FACE_NODES],
            [0.0; 2 * MAX_FACE_NODES],
            [0.0; 4 * MAX_FACE_NODES],
        );
        for pair in &self.pairs {
            if frictional_only && pair.def.friction.is_none() {
                continue;
            }
            for pass in &pair.passes {
                let k = pass.k;
                for oe in &pass.elems {
                    let e = oe.e as usize;
                    let el = &self.surfaces[k].elements[e];
                    for qp in &pass.points[oe.first..oe.first + oe.n] {
                        el.basis.eval(&qp.xi[..m], &mut N, &mut dN, &mut ddN);
                        let (_, _, nu) =
                            crate::contact::surface::frame(el, dim, self.pos[k].of(e), &qp.xi);
                        f(pair, k, e, qp, &N[..el.basis.n_nodes()], nu);
                    }
                }
            }
        }
    }

    /// This rank's right-hand sides of the L2 projections of friction onto each surface's own
    /// interpolation: `int N_A t_T,c da` per component `c < dim` of the tangential traction on the
    /// surface's body (as [`POINT_RECORD`]'s), then `int N_A chi_stick da` and `int N_A chi_slip da`
    /// with `chi` the indicator of the points that stick / slip (so the projections are the local
    /// fractions of sticking and slipping contact, both 0 out of contact). Indexed
    /// `[surface][block][surface node]` with `dim + 2` blocks per surface, flattened; zero for
    /// frictionless pairs. Sum over ranks before [`ContactSystem::l2_project`].
    pub fn l2_rhs_friction(&self) -> Vec<f64> {
        let (dim, nt) = (self.dim, self.all_nodes.len());
        let nb = dim + 2;
        let mut f = vec![0.0; self.surfaces.len() * nb * nt];
        self.each_surface_point(true, |_, k, e, qp, N, nu| {
            let jw = (nu[0] * nu[0] + nu[1] * nu[1] + nu[2] * nu[2]).sqrt() * qp.w;
            let mut v = [0.0; 5];
            v[..dim].copy_from_slice(&qp.t_t[..dim]);
            v[dim] = (qp.slip == SlipState::Stick) as u8 as f64;
            v[dim + 1] = (qp.slip == SlipState::Slip) as u8 as f64;
            for (b, &a) in self.surfaces[k].elements[e].nodes.iter().enumerate() {
                let t = self.node_index(a);
                for (c, vc) in v[..nb].iter().enumerate() {
                    f[(k * nb + c) * nt + t] += N[b] * vc * jw;
                }
            }
        });
        f
    }

    /// This rank's part of the element mass matrices of the L2 projections: `M_AB = int N_A N_B da`
    /// of every element of every surface in its own interpolation, current configuration (with
    /// `nominal`, reference: `dA`), row-major per element, elements in surface order; filled for the
    /// elements of this rank's cells (the only ones whose positions every rank agrees it holds),
    /// zero elsewhere. Sum over ranks before [`ContactSystem::l2_project`].
    pub fn l2_mass(&self, nominal: bool) -> Vec<f64> {
        let (dim, m) = (self.dim, self.dim - 1);
        let (mut N, mut dN, mut ddN) = (
            [0.0; MAX_FACE_NODES],
            [0.0; 2 * MAX_FACE_NODES],
            [0.0; 4 * MAX_FACE_NODES],
        );
        let mut out = Vec::new();
        let mut Xe = Vec::new();
        for (s, surf) in self.surfaces.iter().enumerate() {
            for (e, el) in surf.elements.iter().enumerate() {
                let n = el.basis.n_nodes();
                let first = out.len();
                out.resize(first + n * n, 0.0);
                if !self.owns_element(s, e) {
                    continue;
                }
                let Me = &mut out[first..];
                let x_e: &[f64] = if nominal {
                    Xe.clear();
                    for &a in &el.nodes {
                        let t = self.node_index(a);
                        Xe.extend_from_slice(&self.all_X[t * dim..(t + 1) * dim]);
                    }
                    &Xe
                } else {
                    self.pos[s].of(e)
                };
                let Ok(rule) = tensor_rule(&el.basis.quadrature_counts()) else {
                    continue;
                };
                for (q, xi) in rule.points.chunks_exact(m).enumerate() {
                    let mut x2 = [0.0; 2];
                    x2[..m].copy_from_slice(xi);
                    el.basis.eval(xi, &mut N, &mut dN, &mut ddN);
                    let (_, _, nu) = crate::contact::surface::frame(el, dim, x_e, &x2);
                    let J = (nu[0] * nu[0] + nu[1] * nu[1] + nu[2] * nu[2]).sqrt();
                    for a in 0..n {
                        for b in 0..n {
                            Me[a * n + b] += N[a] * N[b] * J * rule.weights[q];
                        }
                    }
                }
            }
        }
        out
    }

    /// Solves `M x = f` on surface `s` with the consistent mass matrix `M_AB = int N_A N_B da` of its
    /// own interpolation (conjugate gradients, Jacobi-preconditioned, matrix-free over the surface's
    /// elements). `f`: `[surface node]` (the slice of [`ContactSystem::l2_rhs`] for `s`); `mass`:
    /// [`ContactSystem::l2_mass`] summed over ranks (current configuration, or with `nominal` the
    /// reference one: with the pressure's right-hand side (`int N_A p da`) this gives the nominal
    /// pressure, the contact force per reference area, the measure a geometrically linear theory
    /// such as Hertz's predicts; it differs from the current one by the surface stretch). Returns
    /// values per surface node (zero off the surface).
    ///
    /// `ties` (from [`symmetry_ties`], global node ids `(node, representative)`) restrict the
    /// projection to fields whose value at `node` equals that at `representative`: with the ties
    /// of a surface cut by symmetry planes the projection is the whole (mirrored) surface's, whose
    /// field is symmetric. Empty: the projection onto the surface's whole interpolation.
    pub fn l2_project(&self, s: usize, f: &[f64], mass: &[f64], ties: &[(u32, u32)]) -> Vec<f64> {
        let nt = self.all_nodes.len();
        // (tied node, its representative) as surface-node indices
        let tied: Vec<(usize, usize)> = ties
            .iter()
            .map(|&(a, r)| (self.node_index(a), self.node_index(r)))
            .collect();
        let start: usize = self.surfaces[..s]
            .iter()
            .flat_map(|surf| surf.elements.iter().map(|el| el.basis.n_nodes().pow(2)))
            .sum();
        let surf = &self.surfaces[s];
        let mut blocks: Vec<&[f64]> = Vec::with_capacity(surf.elements.len());
        let mut slots: Vec<Vec<usize>> = Vec::with_capacity(surf.elements.len());
        let mut diag = vec![0.0; nt];
        let mut at = start;
        for el in &surf.elements {
            let n = el.basis.n_nodes();
            let Me = &mass[at..at + n * n];
            at += n * n;
            let sl: Vec<usize> = el.nodes.iter().map(|&a| self.node_index(a)).collect();
            for (a, &t) in sl.iter().enumerate() {
                diag[t] += Me[a * n + a].abs();
            }
            blocks.push(Me);
            slots.push(sl);
        }
        // the tied nodes' unknowns are their representatives': `T^T M T` with `T` the expansion
        for &(t, r) in &tied {
            diag[r] += diag[t];
            diag[t] = 0.0;
        }
        let on: Vec<bool> = diag.iter().map(|&d| d > 0.0).collect();
        let mut w = vec![0.0; if tied.is_empty() { 0 } else { nt }];
        let mut apply = |v: &[f64], out: &mut [f64]| {
            out.fill(0.0);
            let v = if tied.is_empty() {
                v
            } else {
                w.copy_from_slice(v);
                for &(t, r) in &tied {
                    w[t] = v[r];
                }
                &w[..]
            };
            for (Me, sl) in blocks.iter().zip(&slots) {
                let n = sl.len();
                for a in 0..n {
                    let mut acc = 0.0;
                    for b in 0..n {
                        acc += Me[a * n + b] * v[sl[b]];
                    }
                    out[sl[a]] += acc;
                }
            }
            for &(t, r) in &tied {
                out[r] += out[t];
                out[t] = 0.0;
            }
        };
        // preconditioned conjugate gradients on the surface's nodes
        let mut x = vec![0.0; nt];
        let mut f_t;
        let f = if tied.is_empty() {
            f
        } else {
            f_t = f.to_vec();
            for &(t, r) in &tied {
                f_t[r] += f_t[t];
                f_t[t] = 0.0;
            }
            &f_t[..]
        };
        let mut r: Vec<f64> = (0..nt).map(|i| if on[i] { f[i] } else { 0.0 }).collect();
        let mut z: Vec<f64> = (0..nt)
            .map(|i| if on[i] { r[i] / diag[i] } else { 0.0 })
            .collect();
        let mut p = z.clone();
        let mut ap = vec![0.0; nt];
        let mut rz: f64 = r.iter().zip(&z).map(|(a, b)| a * b).sum();
        let r0 = r.iter().map(|v| v * v).sum::<f64>().sqrt();
        for _ in 0..10 * nt.max(10) {
            if r.iter().map(|v| v * v).sum::<f64>().sqrt() <= 1e-14 * r0.max(1e-300) {
                break;
            }
            apply(&p, &mut ap);
            let pap: f64 = p.iter().zip(&ap).map(|(a, b)| a * b).sum();
            if pap <= 0.0 {
                break;
            }
            let alpha = rz / pap;
            for i in 0..nt {
                x[i] += alpha * p[i];
                r[i] -= alpha * ap[i];
                z[i] = if on[i] { r[i] / diag[i] } else { 0.0 };
            }
            let rz_new: f64 = r.iter().zip(&z).map(|(a, b)| a * b).sum();
            let beta = rz_new / rz;
            rz = rz_new;
            for i in 0..nt {
                p[i] = z[i] + beta * p[i];
            }
        }
        for &(t, r) in &tied {
            x[t] = x[r];
        }
        x
    }
}

/// The ties that make the L2 projection on surface `surf` the whole surface's where symmetry
/// planes cut it: `(node, representative)` pairs of global node ids. The planes are
/// [`symmetry_planes`]'s; one counts for the surface only where the surface lies on one side of it
/// (a line support through the body's middle is no symmetry plane); an element edge lies
/// on it when the row of the element's control points along that edge does. The whole surface
/// continues a NURBS face (degree >= 2 across the edge) smoothly into its mirror image, so a
/// symmetric field on it has zero slope across the plane: the next row of control values equals
/// the row on the plane. Rows are tied to rows per element; the ties of two planes meeting at a
/// corner are merged, each node tied to one representative. Only NURBS faces get ties (a C^0
/// face's mirror image is continuous without one). `coords`: reference coordinates of the global
/// nodes [n][dim].
pub fn symmetry_ties(
    surf: &crate::contact::surface::ContactSurface,
    planes: &[([f64; 3], f64)],
    coords: &[f64],
    dim: usize,
) -> Vec<(u32, u32)> {
    use crate::contact::basis::FaceBasis;
    use std::collections::BTreeMap;
    let extent = coords
        .iter()
        .fold(0.0f64, |m, &x| m.max(x.abs()))
        .max(1e-300);
    let on_plane = |a: u32, (n, c): &([f64; 3], f64)| {
        let x = &coords[a as usize * dim..(a as usize + 1) * dim];
        ((0..dim).map(|i| x[i] * n[i]).sum::<f64>() - c).abs() <= 1e-9 * extent
    };
    // the planes the whole surface lies on one side of
    let side = |a: u32, (n, c): &([f64; 3], f64)| {
        let x = &coords[a as usize * dim..(a as usize + 1) * dim];
        let d = (0..dim).map(|i| x[i] * n[i]).sum::<f64>() - c;
        if d.abs() <= 1e-9 * extent {
            0
        } else if d > 0.0 {
            1
        } else {
            -1
        }
    };
    let planes: Vec<([f64; 3], f64)> = planes
        .iter()
        .filter(|pl| {
            let sides = surf
                .elements
                .iter()
                .flat_map(|el| el.nodes.iter())
                .map(|&a| side(a, pl));
            let (mut above, mut below) = (false, false);
            for s in sides {
                above |= s > 0;
                below |= s < 0;
            }
            !(above && below)
        })
        .copied()
        .collect();
    let planes = &planes[..];
    // union-find over global node ids
    let mut parent: BTreeMap<u32, u32> = BTreeMap::new();
    fn find(parent: &mut BTreeMap<u32, u32>, a: u32) -> u32 {
        let mut r = a;
        while let Some(&p) = parent.get(&r) {
            if p == r {
                break;
            }
            r = p;
        }
        parent.insert(a, r);
        r
    }
    for el in &surf.elements {
        let FaceBasis::Nurbs(d) = &el.basis else {
            continue;
        };
        let (nu, nv) = (d.p + 1, d.q + 1);
        let node = |i: usize, j: usize| el.nodes[j * nu + i];
        // (rows along the edge: the row on the plane and the next one) per edge of the face
        let mut edges: Vec<(Vec<u32>, Vec<u32>)> = Vec::new();
        if d.p >= 2 {
            for (i0, i1) in [(0, 1), (d.p, d.p - 1)] {
                edges.push((
                    (0..nv).map(|j| node(i0, j)).collect(),
                    (0..nv).map(|j| node(i1, j)).collect(),
                ));
            }
        }
        if d.q >= 2 {
            for (j0, j1) in [(0, 1), (d.q, d.q - 1)] {
                edges.push((
                    (0..nu).map(|i| node(i, j0)).collect(),
                    (0..nu).map(|i| node(i, j1)).collect(),
                ));
            }
        }
        for (row, next) in &edges {
            let cut = planes.iter().any(|pl| {
                row.iter().all(|&a| on_plane(a, pl)) && next.iter().all(|&a| !on_plane(a, pl))
            });
            if !cut {
                continue;
            }
            for (&a, &b) in row.iter().zip(next) {
                let (ra, rb) = (find(&mut parent, a), find(&mut parent, b));
                if ra != rb {
                    let (lo, hi) = (ra.min(rb), ra.max(rb));
                    parent.insert(hi, lo);
                    parent.insert(lo, lo);
                }
            }
        }
    }
    let nodes: Vec<u32> = parent.keys().copied().collect();
    nodes
        .into_iter()
        .filter_map(|a| {
            let r = find(&mut parent, a);
            (r != a).then_some((a, r))
        })
        .collect()
}

/// The symmetry planes of a model: (unit normal, offset `n . x`) of every `sliding` condition
/// whose nodes lie on one plane, and of every roller written as one displacement component held
/// at zero in every stage (`fixed`, or `displacement` with zero values) whose nodes lie on one
/// plane normal to that component's axis; in both cases the nodes must cover a face of the plane
/// (not one point, nor in 3D one line: those are supports against rigid motion). For
/// [`symmetry_ties`]. A plane stated twice is listed once. `coords`: reference coordinates
/// [n][dim].
pub fn symmetry_planes(
    skews: &[crate::assembly::skew::SkewBc],
    bcs: &[crate::assembly::dirichlet::DirichletBc],
    coords: &[f64],
    dim: usize,
) -> Vec<([f64; 3], f64)> {
    use crate::assembly::dirichlet::Prescription;
    use crate::assembly::skew::SkewKind;
    let extent = coords
        .iter()
        .fold(0.0f64, |m, &x| m.max(x.abs()))
        .max(1e-300);
    let x = |a: u32| {
        let mut p = [0.0; 3];
        p[..dim].copy_from_slice(&coords[a as usize * dim..(a as usize + 1) * dim]);
        p
    };
    let sub = |a: [f64; 3], b: [f64; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    let norm = |a: [f64; 3]| (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
    // whether `nodes` cover a face of the plane, not a point or (3D) a line of it: a support
    // that holds a point or a line is no symmetry plane
    let spans_face = |nodes: &[u32]| {
        let Some(&first) = nodes.first() else {
            return false;
        };
        let p0 = x(first);
        let Some(p1) = nodes
            .iter()
            .map(|&a| x(a))
            .max_by(|a, b| norm(sub(*a, p0)).total_cmp(&norm(sub(*b, p0))))
        else {
            return false;
        };
        let e = sub(p1, p0);
        if norm(e) <= 1e-9 * extent {
            return false;
        }
        dim == 2
            || nodes.iter().any(|&a| {
                let d = sub(x(a), p0);
                let c = [
                    d[1] * e[2] - d[2] * e[1],
                    d[2] * e[0] - d[0] * e[2],
                    d[0] * e[1] - d[1] * e[0],
                ];
                norm(c) > 1e-9 * extent * norm(e)
            })
    };
    // the plane with `normal` through every node of `nodes`, if they lie on one and cover a face
    let plane_of = |normal: [f64; 3], nodes: &[u32]| {
        let offset = |a: u32| (0..dim).map(|i| x(a)[i] * normal[i]).sum::<f64>();
        let c = offset(*nodes.first()?);
        (nodes
            .iter()
            .all(|&a| (offset(a) - c).abs() <= 1e-9 * extent)
            && spans_face(nodes))
        .then_some((normal, c))
    };
    let sliding = skews.iter().filter_map(|sk| match &sk.kind {
        SkewKind::Sliding { normal } => plane_of(*normal, &sk.nodes),
        _ => None,
    });
    let rollers = bcs.iter().filter_map(|bc| {
        let &[c] = bc.components.as_slice() else {
            return None;
        };
        let zero = match &bc.kind {
            Prescription::Fixed => true,
            Prescription::Displacement(v) => v.iter().flatten().all(|&x| x == 0.0),
            Prescription::Rotation { .. } => false,
        };
        let mut normal = [0.0; 3];
        normal[c] = 1.0;
        zero.then(|| plane_of(normal, &bc.nodes)).flatten()
    });
    let mut out: Vec<([f64; 3], f64)> = Vec::new();
    for (n, c) in sliding.chain(rollers) {
        let same = |(m, d): &([f64; 3], f64)| {
            (0..3).all(|i| (m[i] - n[i]).abs() <= 1e-12) && (d - c).abs() <= 1e-9 * extent
        };
        if !out.iter().any(same) {
            out.push((n, c));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Model;
    use std::path::Path;

    /// The model of shipped case `file` with `sets`.
    fn shipped(file: &str, sets: &[&str]) -> Model {
        let path = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("cases")
            .join(file);
        let sets: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
        let case = crate::scene::load_case(&path, &sets).expect("case");
        Model::build(&case).expect("model")
    }

    /// The quarter sphere of `cases/hertz_3d.toml` (Q1N2 patch, `sliding` rollers on x = 0 and
    /// y = 0): both planes are found, every group of tied control points holds one on a plane and
    /// neighbours of it only, and at the corner the rows of both planes are merged into one group.
    #[test]
    fn a_quarter_spheres_patch_is_tied_across_its_two_symmetry_planes() {
        let model = shipped(
            "hertz_3d.toml",
            &[
                "bodies.ball.element=\"Q1N2\"",
                "meshes.ball.divisions=[4,4,3]",
            ],
        );
        let dim = model.dim;
        let planes = symmetry_planes(&model.skews, &model.bcs, &model.coords, dim);
        assert_eq!(planes.len(), 2, "{planes:?}");
        let surf = &model.contact_surfaces[0];
        let ties = symmetry_ties(surf, &planes, &model.coords, dim);
        assert!(!ties.is_empty());
        let x = |a: u32| &model.coords[a as usize * dim..(a as usize + 1) * dim];
        let on = |a: u32, (n, c): &([f64; 3], f64)| {
            ((0..dim).map(|i| x(a)[i] * n[i]).sum::<f64>() - c).abs() < 1e-9
        };
        let h = surf.h;
        // groups of control points with one value: each holds a point on a plane, and its points
        // are neighbours in the patch
        let mut groups: std::collections::BTreeMap<u32, Vec<u32>> = Default::default();
        for &(a, r) in &ties {
            assert!(
                ties.iter().all(|&(b, _)| b != r),
                "representative {r} is itself tied"
            );
            groups.entry(r).or_insert_with(|| vec![r]).push(a);
        }
        for (r, g) in &groups {
            assert!(
                g.iter().any(|&a| planes.iter().any(|p| on(a, p))),
                "group of {r} off the planes: {g:?}"
            );
            for &a in g {
                let d: f64 = (0..dim)
                    .map(|i| (x(a)[i] - x(*r)[i]).powi(2))
                    .sum::<f64>()
                    .sqrt();
                assert!(d < 1.5 * h, "{a} tied to {r} at {d} (element size {h})");
            }
        }
        // the corner point of both planes shares its value with its neighbours on both sides
        let corner: Vec<&Vec<u32>> = groups
            .values()
            .filter(|g| g.iter().any(|&a| planes.iter().all(|p| on(a, p))))
            .collect();
        assert_eq!(corner.len(), 1, "{corner:?}");
        assert!(corner[0].len() >= 4, "corner group {:?}", corner[0]);
    }

    /// The same quarter sphere with its rollers written as `fixed` components (x on x = 0, y on
    /// y = 0) instead of `sliding` conditions: the same two planes and the same ties; a `fixed`
    /// condition on two components or off a plane is not one.
    #[test]
    fn rollers_written_as_fixed_components_are_the_same_symmetry_planes() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("cases/hertz_3d.toml");
        let text = std::fs::read_to_string(&path).expect("case");
        let sets = vec![
            "bodies.ball.element=\"Q1N2\"".to_string(),
            "meshes.ball.divisions=[4,4,3]".to_string(),
        ];
        let build = |text: &str, name: &str| {
            let dir = std::env::temp_dir().join(format!(
                "nurbs-contact-rollers-{}-{name}",
                std::process::id()
            ));
            std::fs::create_dir_all(&dir).expect("scratch dir");
            let file = dir.join("case.toml");
            std::fs::write(&file, text).expect("write case");
            let case = crate::scene::load_case(&file, &sets).expect("case");
            let model = Model::build(&case).expect("model");
            std::fs::remove_dir_all(&dir).ok();
            model
        };
        let roller = |set: &str, c: &str| {
            format!(
                "[[bcs]]\nbody = \"ball\"\nset = \"{set}\"\nkind = \"fixed\"\ncomponents = [{c}]\n"
            )
        };
        let replace = |rollers: &str| {
            let start = text
                .find("[[bcs]]\nbody = \"ball\"\nset = \"xmin\"")
                .expect("xmin rollers");
            let end = text.find("[[contact]]").expect("contact table");
            format!("{}{rollers}\n{}", &text[..start], &text[end..])
        };
        let ties_and_planes = |m: &Model| {
            let planes = symmetry_planes(&m.skews, &m.bcs, &m.coords, m.dim);
            let ties = symmetry_ties(&m.contact_surfaces[0], &planes, &m.coords, m.dim);
            (planes, ties)
        };
        let sliding = ties_and_planes(&build(&text, "sliding"));
        let fixed = build(
            &replace(&format!(
                "{}\n{}",
                roller("xmin", "\"x\""),
                roller("ymin", "\"y\"")
            )),
            "fixed",
        );
        assert!(fixed.skews.is_empty());
        let fixed = ties_and_planes(&fixed);
        assert_eq!(fixed.0.len(), 2, "{:?}", fixed.0);
        for (n, c) in &sliding.0 {
            assert!(
                fixed.0.iter().any(|(m, d)| m == n && (d - c).abs() < 1e-12),
                "plane {n:?} {c} of the sliding rollers missing: {:?}",
                fixed.0
            );
        }
        assert_eq!(sliding.1, fixed.1, "the ties differ");
        // x and y held together on x = 0 is a clamp, not a symmetry plane
        let clamped = build(&replace(&roller("xmin", "\"x\", \"y\"")), "clamped");
        assert!(ties_and_planes(&clamped).0.is_empty());
        // the 3D contact patch test holds lines of nodes in x and y against rigid motion: no
        // planes of those, and no ties on its surfaces
        let m = shipped(
            "contact_patch_3d.toml",
            &[
                "bodies.lower.element=\"Q1N2\"",
                "bodies.upper.element=\"Q1N2\"",
            ],
        );
        let planes = symmetry_planes(&m.skews, &m.bcs, &m.coords, m.dim);
        assert!(
            planes.iter().all(|(n, _)| n[2] == 1.0),
            "only the base's z planes: {planes:?}"
        );
        for surf in &m.contact_surfaces {
            assert!(symmetry_ties(surf, &planes, &m.coords, m.dim).is_empty());
        }
    }
}
