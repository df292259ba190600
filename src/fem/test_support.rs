//! Test-only helpers: a reproducible random generator, finite-difference tangents, structured distorted meshes
//! and a tiny dense Newton solver, so element kernels are tested on small meshes without PETSc.

use super::kernel::TlElement;
use super::{hex8, quad4, ElementError};
use crate::material::Material;
use nalgebra::{DMatrix, DVector};

/// Small linear congruential generator giving values in [-1, 1).
pub struct Lcg(pub u64);
impl Lcg {
    pub fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((self.0 >> 11) as f64) / ((1u64 << 53) as f64) * 2.0 - 1.0
    }
}

pub fn max_abs(v: &[f64]) -> f64 {
    v.iter().fold(0.0f64, |m, x| m.max(x.abs()))
}

pub fn max_abs_diff(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter()
        .zip(b)
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()))
}

/// Central-difference tangent `K[i*n + j] = d r_i / d u_j` of a residual function.
pub fn fd_tangent(
    n: usize,
    u: &[f64],
    h: f64,
    mut residual: impl FnMut(&[f64], &mut [f64]) -> Result<(), ElementError>,
) -> Vec<f64> {
    let mut k = vec![0.0; n * n];
    let (mut rp, mut rm) = (vec![0.0; n], vec![0.0; n]);
    for j in 0..n {
        let mut v = u.to_vec();
        v[j] = u[j] + h;
        residual(&v, &mut rp).unwrap();
        v[j] = u[j] - h;
        residual(&v, &mut rm).unwrap();
        for i in 0..n {
            k[i * n + j] = (rp[i] - rm[i]) / (2.0 * h);
        }
    }
    k
}

/// Structured mesh of quads (dim 2) or hexes (dim 3) with nodes in lexicographic order (x fastest).
pub struct Mesh {
    pub dim: usize,
    /// [n_nodes][dim]
    pub coords: Vec<f64>,
    /// [n_elems][4 or 8], in the quad4 / hex8 node order
    pub elems: Vec<Vec<usize>>,
}

impl Mesh {
    pub fn n_nodes(&self) -> usize {
        self.coords.len() / self.dim
    }
    pub fn is_boundary(&self, a: usize) -> bool {
        let x = &self.coords[a * self.dim..(a + 1) * self.dim];
        (0..self.dim).any(|d| {
            let hi = self
                .coords
                .chunks_exact(self.dim)
                .map(|y| y[d])
                .fold(0.0, f64::max);
            x[d].abs() < 1e-12 || (x[d] - hi).abs() < 1e-12
        })
    }
}

/// `nx x ny` quads on `[0,lx] x [0,ly]`; interior nodes moved by up to `distort` times the element size.
pub fn quad_mesh(nx: usize, ny: usize, lx: f64, ly: f64, distort: f64) -> Mesh {
    let mut rng = Lcg(17);
    let (hx, hy) = (lx / nx as f64, ly / ny as f64);
    let mut coords = vec![];
    for j in 0..=ny {
        for i in 0..=nx {
            let interior = i > 0 && i < nx && j > 0 && j < ny;
            let s = if interior { distort } else { 0.0 };
            coords.push(i as f64 * hx + s * hx * rng.next());
            coords.push(j as f64 * hy + s * hy * rng.next());
        }
    }
    let id = |i: usize, j: usize| i + (nx + 1) * j;
    let mut elems = vec![];
    for j in 0..ny {
        for i in 0..nx {
            elems.push(vec![id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)]);
        }
    }
    Mesh {
        dim: 2,
        coords,
        elems,
    }
}

/// `nx x ny x nz` hexes on `[0,l]^3`; interior nodes moved by up to `distort` times the element size.
pub fn hex_mesh(nx: usize, ny: usize, nz: usize, l: f64, distort: f64) -> Mesh {
    let mut rng = Lcg(29);
    let h = [l / nx as f64, l / ny as f64, l / nz as f64];
    let mut coords = vec![];
    for k in 0..=nz {
        for j in 0..=ny {
            for i in 0..=nx {
                let interior = i > 0 && i < nx && j > 0 && j < ny && k > 0 && k < nz;
                let s = if interior { distort } else { 0.0 };
                for (d, idx) in [i, j, k].into_iter().enumerate() {
                    coords.push(idx as f64 * h[d] + s * h[d] * rng.next());
                }
            }
        }
    }
    let id = |i: usize, j: usize, k: usize| i + (nx + 1) * (j + (ny + 1) * k);
    let mut elems = vec![];
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                let mut e = vec![];
                for kk in [k, k + 1] {
                    e.extend([
                        id(i, j, kk),
                        id(i + 1, j, kk),
                        id(i + 1, j + 1, kk),
                        id(i, j + 1, kk),
                    ]);
                }
                elems.push(e);
            }
        }
    }
    Mesh {
        dim: 3,
        coords,
        elems,
    }
}

/// Nodal values of `u = H X`, [n_nodes][dim]; `H`: [dim][dim].
#[allow(non_snake_case)]
pub fn affine(mesh: &Mesh, H: &[f64]) -> Vec<f64> {
    let D = mesh.dim;
    mesh.coords
        .chunks_exact(D)
        .flat_map(|x| (0..D).map(move |i| (0..D).map(|j| H[i * D + j] * x[j]).sum::<f64>()))
        .collect()
}

/// All dofs of nodes on the bounding box of the mesh.
pub fn boundary_dofs(mesh: &Mesh) -> Vec<usize> {
    (0..mesh.n_nodes())
        .filter(|&a| mesh.is_boundary(a))
        .flat_map(|a| (0..mesh.dim).map(move |d| a * mesh.dim + d))
        .collect()
}

#[allow(non_snake_case)]
pub fn element_coords(mesh: &Mesh, e: usize) -> Vec<f64> {
    gather(mesh, e, &mesh.coords)
}

/// Element values of a nodal field, [n_nodes_e][dim].
#[allow(non_snake_case)]
pub fn gather(mesh: &Mesh, e: usize, u: &[f64]) -> Vec<f64> {
    let D = mesh.dim;
    mesh.elems[e]
        .iter()
        .flat_map(|&a| u[a * D..(a + 1) * D].iter().copied())
        .collect()
}

/// Add an element residual and tangent into global ones.
#[allow(non_snake_case)]
pub fn scatter(
    mesh: &Mesh,
    e: usize,
    r_e: &[f64],
    k_e: &[f64],
    r: &mut [f64],
    k: &mut DMatrix<f64>,
) {
    let D = mesh.dim;
    let dofs: Vec<usize> = mesh.elems[e]
        .iter()
        .flat_map(|&a| (0..D).map(move |d| a * D + d))
        .collect();
    let nd = dofs.len();
    for (p, &gp) in dofs.iter().enumerate() {
        r[gp] += r_e[p];
        for (q, &gq) in dofs.iter().enumerate() {
            k[(gp, gq)] += k_e[p * nd + q];
        }
    }
}

/// Plain bilinear / trilinear elements of a mesh with 2 Gauss points per direction.
pub fn tl_elements(mesh: &Mesh) -> Vec<TlElement> {
    (0..mesh.elems.len())
        .map(|e| {
            let x = element_coords(mesh, e);
            if mesh.dim == 2 {
                quad4::tl_element(&x, 2).unwrap()
            } else {
                hex8::tl_element(&x, 2).unwrap()
            }
        })
        .collect()
}

/// Global internal force and tangent of a mesh of [`TlElement`]s.
pub fn assemble(
    mesh: &Mesh,
    els: &[TlElement],
    mat: &Material,
    u: &[f64],
    r: &mut [f64],
    k: &mut DMatrix<f64>,
) -> Result<(), ElementError> {
    for (e, el) in els.iter().enumerate() {
        let nd = el.n_dofs();
        let (mut r_e, mut k_e) = (vec![0.0; nd], vec![0.0; nd * nd]);
        el.residual_tangent(mat, &gather(mesh, e, u), &mut r_e, Some(&mut k_e))?;
        scatter(mesh, e, &r_e, &k_e, r, k);
    }
    Ok(())
}

/// Newton's method on `f_int(u) = f_ext` with Dirichlet values `fixed` (dof, value); `assemble` fills the
/// (zeroed) internal force and tangent. Returns the number of iterations.
pub fn newton_solve(
    fixed: &[(usize, f64)],
    f_ext: &[f64],
    u: &mut [f64],
    mut assemble: impl FnMut(&[f64], &mut [f64], &mut DMatrix<f64>) -> Result<(), ElementError>,
) -> Result<usize, String> {
    let n = u.len();
    let mut is_fixed = vec![false; n];
    for &(d, v) in fixed {
        is_fixed[d] = true;
        u[d] = v;
    }
    let free: Vec<usize> = (0..n).filter(|&d| !is_fixed[d]).collect();
    let mut r = vec![0.0; n];
    let mut k = DMatrix::zeros(n, n);
    let mut r0 = None;
    let mut prev_norm = f64::INFINITY;
    for it in 0..40 {
        r.fill(0.0);
        k.fill(0.0);
        assemble(u, &mut r, &mut k).map_err(|e| e.to_string())?;
        let rf = DVector::from_iterator(free.len(), free.iter().map(|&d| r[d] - f_ext[d]));
        let norm = rf.norm();
        let scale = *r0.get_or_insert(norm.max(max_abs(&r)).max(1e-30));
        // converged, or stalled at rounding level after a large decrease (quadratic convergence would still
        // divide the norm by far more than 10)
        let stalled = norm <= 1e-6 * scale && norm > 0.1 * prev_norm;
        if norm <= 1e-14 * scale || stalled || free.is_empty() {
            return Ok(it);
        }
        prev_norm = norm;
        let kf = DMatrix::from_fn(free.len(), free.len(), |p, q| k[(free[p], free[q])]);
        let du = kf.lu().solve(&(-rf)).ok_or("singular tangent")?;
        for (p, &d) in free.iter().enumerate() {
            u[d] += du[p];
        }
        if du.amax() <= 1e-13 * max_abs(u).max(1e-300) {
            return Ok(it + 1);
        }
    }
    Err("Newton did not converge in 40 iterations".into())
}

/// Lateral stretch `lt` with zero lateral Cauchy stress for axial stretch `la`:
/// `Lambda ln J + mu (lt^2 - 1) = 0`, `J = la lt^(D-1)`.
#[allow(non_snake_case)]
pub fn lateral_stretch(m: &Material, D: usize, la: f64) -> f64 {
    let mut lt: f64 = 1.0;
    for _ in 0..50 {
        let J = la * lt.powi(D as i32 - 1);
        let g = m.lambda() * J.ln() + m.mu() * (lt * lt - 1.0);
        let dg = m.lambda() * (D as f64 - 1.0) / lt + 2.0 * m.mu() * lt;
        lt -= g / dg;
    }
    lt
}
