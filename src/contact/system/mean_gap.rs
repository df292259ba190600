//! The penalty law on a surface element's mean normal gap (`gap = "element_mean"`).
//!
//! Each own surface element gets one pressure, `p = eps_n <-g_mean>` with
//! `g_mean = sum_j c_j g_N,j / W`, `c_j = w_j J0_j` the reference area weight of its point `j`,
//! `W = sum_j c_j` over the points that have a partner, and every point `k` carries the traction
//! `t_k = p n_k` (its own partner normal). The point kernel evaluates each point with its gap
//! shifted along its normal so that its normal gap is `g_mean`; that gives the residual exactly
//! and the tangent except for the variation of `g_mean`, which the kernel takes as the point's own
//! (`d g_N,k`). Since the gap is along the normal (closest point, or the gap direction at an edge),
//! `d g_N,j = n_j . (N_b(xi_j) du_b - N^l_b(xi_p,j) dy_b)` with no projection terms, and the
//! correction of point `k`'s rows `a` (`coef_ai = N_a(xi_k) J_k w_k eps_n n_k,i`) is
//! - own columns `b`: `coef (A_b - n_k N_b(xi_k))` with `A_b = sum_j c_j n_j N_b(xi_j) / W`;
//! - its partner's columns: `+coef n_k N^l_b(xi_p,k)` (removes the kernel's own-gap term);
//! - each point `j`'s partner columns: `-coef c_j / W n_j N^l_b(xi_p,j)`.
//!
//! With Coulomb friction a slipping point's traction is `p (n_k + mu s_k)` (`mu p s_k` its
//! tangential part), so `n_k` of `coef` becomes `d_k = n_k + t_T,k / p`; a sticking point's
//! tangential traction does not depend on `p`, `d_k = n_k`.
//!
//! All these blocks are couplings of the element with its points' partners, which the sparsity
//! pattern already has.

use super::Blocks;
use crate::contact::surface::MAX_FACE_NODES;

/// A point of the element that has a partner.
pub(super) struct MeanPoint {
    /// Quadrature point index in its pass.
    pub q: usize,
    /// Partner element (`u32::MAX`: rigid).
    pub le: u32,
    /// Partner normal [3].
    pub n: [f64; 3],
    /// Partner basis at the projection [n_l].
    pub nl_vals: [f64; MAX_FACE_NODES],
    /// Partner nodes (0: rigid).
    pub nl: usize,
    /// Reference area weight `w J0`.
    pub c: f64,
}

/// The mean normal gap of one own element and what its linearisation needs.
#[derive(Default)]
pub(super) struct ElementMean {
    /// The mean normal gap.
    pub g: f64,
    /// Total weight `W`.
    pub w: f64,
    /// `A_b` [n_k][3].
    a: Vec<[f64; 3]>,
    points: Vec<MeanPoint>,
}

impl ElementMean {
    /// Starts an element with `nk` own nodes.
    pub fn start(&mut self, nk: usize) {
        self.g = 0.0;
        self.w = 0.0;
        self.a.clear();
        self.a.resize(nk, [0.0; 3]);
        self.points.clear();
    }

    /// Adds point `p` with its own basis values `n_own` [n_k] and normal gap `g_n`.
    pub fn add(&mut self, p: MeanPoint, n_own: &[f64], g_n: f64) {
        self.g += p.c * g_n;
        self.w += p.c;
        for (ab, &nb) in self.a.iter_mut().zip(n_own) {
            for i in 0..3 {
                ab[i] += p.c * p.n[i] * nb;
            }
        }
        self.points.push(p);
    }

    /// Ends the element: false when no point has a partner (no mean).
    pub fn finish(&mut self) -> bool {
        if self.points.is_empty() || self.w <= 0.0 {
            return false;
        }
        self.g /= self.w;
        for ab in &mut self.a {
            for v in ab.iter_mut() {
                *v /= self.w;
            }
        }
        true
    }

    /// The recorded point `q`.
    pub fn point(&self, q: usize) -> Option<&MeanPoint> {
        self.points.iter().find(|p| p.q == q)
    }

    /// Adds the correction of point `q`'s tangent rows (own basis `n_own` [n_k], current area
    /// times weight `jw`, `d` the derivative of its traction with respect to the pressure) to the
    /// element's blocks; `block(le, len)` gives the slot of the block coupling the element with
    /// partner `le` (`len` entries when new).
    #[allow(clippy::too_many_arguments)]
    pub fn correct(
        &self,
        dim: usize,
        q: usize,
        n_own: &[f64],
        jw: f64,
        eps_n: f64,
        d: [f64; 3],
        blocks: &mut Blocks,
        block: &mut dyn FnMut(&mut Blocks, u32, usize) -> usize,
    ) {
        let Some(pk) = self.point(q) else {
            return;
        };
        let nk = n_own.len();
        let n = pk.n;
        let rows = nk * dim;
        // own columns and the point's own partner
        let nck = (nk + pk.nl) * dim;
        let ik = block(blocks, pk.le, rows * nck);
        let kb = &mut blocks[ik].1;
        for a in 0..nk {
            for i in 0..dim {
                let coef = n_own[a] * jw * eps_n * d[i];
                let row = (a * dim + i) * nck;
                for b in 0..nk {
                    for j in 0..dim {
                        kb[row + b * dim + j] += coef * (self.a[b][j] - n[j] * n_own[b]);
                    }
                }
                for b in 0..pk.nl {
                    for j in 0..dim {
                        kb[row + (nk + b) * dim + j] += coef * n[j] * pk.nl_vals[b];
                    }
                }
            }
        }
        // every point's partner through the mean
        for pj in self.points.iter().filter(|p| p.nl > 0) {
            let ncj = (nk + pj.nl) * dim;
            let ij = block(blocks, pj.le, rows * ncj);
            let kb = &mut blocks[ij].1;
            let f = pj.c / self.w;
            for a in 0..nk {
                for i in 0..dim {
                    let coef = n_own[a] * jw * eps_n * d[i] * f;
                    let row = (a * dim + i) * ncj;
                    for b in 0..pj.nl {
                        for j in 0..dim {
                            kb[row + (nk + b) * dim + j] -= coef * pj.n[j] * pj.nl_vals[b];
                        }
                    }
                }
            }
        }
    }
}
