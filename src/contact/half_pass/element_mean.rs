//! The penalty pressure averaged over each surface element (`gap = "element_mean"`).
//!
//! Each own surface element gets one pressure, the mean of the pointwise penalty pressures over
//! the element: `p = eps_n sum_{j active} c_j (-g_N,j) / W`, `c_j = w_j J0_j` the reference area
//! weight of point `j`, `W = sum_j c_j` over all points of the element (its reference area), and
//! "active" the points with `g_N,j <= touch` (the pointwise law's active set). Every point `k`
//! of the element then carries `t_k = p n_k` (its own partner normal). Points enter and leave the
//! mean one by one, so the pressure grows continuously as an element comes into contact.
//!
//! The point kernel evaluates each point with its gap shifted along its normal to the element's
//! equivalent gap `g_e = -p / eps_n`; that gives the residual exactly and the tangent except for
//! the variation of `g_e`, which the kernel takes as the point's own (`d g_N,k`). Since the gap is
//! along the normal (closest point, or the gap direction at an edge),
//! `d g_N,j = n_j . (N_b(xi_j) du_b - N^l_b(xi_p,j) dy_b)` with no projection terms, and the
//! correction of point `k`'s rows `a` (`coef_ai = N_a(xi_k) J_k w_k eps_n n_k,i`) is
//! - own columns `b`: `coef (A_b - n_k N_b(xi_k))` with `A_b = sum_{j active} c_j n_j N_b(xi_j) / W`;
//! - its partner's columns: `+coef n_k N^l_b(xi_p,k)` (removes the kernel's own-gap term);
//! - each active point `j`'s partner columns: `-coef c_j / W n_j N^l_b(xi_p,j)`.
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
pub(crate) struct MeanPoint {
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
    /// In the pointwise active set (set by [`ElementMean::add`]).
    pub active: bool,
}

/// The mean normal gap of one own element and what its linearisation needs.
#[derive(Default)]
pub(crate) struct ElementMean {
    /// The equivalent gap `g_e = -p / eps_n`.
    pub g: f64,
    /// Total weight `W` (the element's reference area).
    pub w: f64,
    /// `A_b` [n_k][3].
    a: Vec<[f64; 3]>,
    points: Vec<MeanPoint>,
}

impl ElementMean {
    /// Starts an element with `nk` own nodes and reference area `area` (the sum of its points'
    /// `w J0`).
    pub fn start(&mut self, nk: usize, area: f64) {
        self.g = 0.0;
        self.w = area;
        self.a.clear();
        self.a.resize(nk, [0.0; 3]);
        self.points.clear();
    }

    /// Adds point `p` (with a partner) with its own basis values `n_own` [n_k] and normal gap
    /// `g_n`; it joins the mean when `g_n <= touch`.
    pub fn add(&mut self, mut p: MeanPoint, n_own: &[f64], g_n: f64, touch: f64) {
        p.active = g_n <= touch;
        if p.active {
            self.g += p.c * g_n;
            for (ab, &nb) in self.a.iter_mut().zip(n_own) {
                for i in 0..3 {
                    ab[i] += p.c * p.n[i] * nb;
                }
            }
        }
        self.points.push(p);
    }

    /// Ends the element: false when none of its points is active (no pressure; the pointwise
    /// law, inactive at every point, applies).
    pub fn finish(&mut self) -> bool {
        if !self.points.iter().any(|p| p.active) || self.w <= 0.0 {
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
        for pj in self.points.iter().filter(|p| p.nl > 0 && p.active) {
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
