//! The tangle check of an accepted state: is an element's current map `x(xi) = sum_a N_a(xi) x_a`
//! still one-to-one, i.e. `det J = det(dx/dxi) > 0` on the whole element, not only at the
//! quadrature points that the kernel sees?
//!
//! A converged Newton solve only proves `det F > 0` at the Gauss points; an element folded over at
//! a corner (a 500 % compression of a cube ends with the top face below the clamped base) passes
//! that. The load stepping runs this check on every converged state before it accepts it.
//!
//! What each element map guarantees ([`MapCheck`]):
//! - bilinear quad (Q1C1, Q1E4, and a linear cell tied to an enriched surface, through its
//!   virtual corners): `det J` is affine in `(xi, eta)` (the `xi eta` term cancels), so positivity
//!   at the 4 corners is positivity everywhere: exact.
//! - trilinear hex: `det J` is a polynomial of degree 2 in each of `xi, eta, zeta`; its 27
//!   Bernstein coefficients bound it from below, and the 8 corner values are among them. All
//!   coefficients positive proves `det J > 0` everywhere; a corner value `<= 0` is a fold there;
//!   otherwise the patch is subdivided (de Casteljau) down to 1/16 of the element per direction,
//!   and a sub-patch corner `<= 0` is a fold at that point. A patch still undecided at that depth
//!   (the minimum of `det J` within round-off of 0 inside the element) counts as tangled.
//! - enriched cells (Q1Np, Q1Np.t, Q1C2, Q1CH): `det J` at the parent corners and on a grid of
//!   `n + 1` points per surface direction (`n` the surface control points per direction, so
//!   the grid is finer than the control net) on both faces through the thickness (2D: `det J` is
//!   affine in `eta` for these maps, so the faces bound every vertical line; 3D: also the
//!   mid-surface). A necessary condition only: it never reports a valid element, and it finds
//!   any fold at a corner or wider than the grid spacing.
//!
//! Cells whose reference map is itself degenerate somewhere (the collapsed rim cells of
//! `hemisphere_nurbs`, a Gmsh hex positive only at its Gauss points) are checked only where their
//! reference `det J0` is positive, at the grid points: what is reported is always a sign change
//! of `det J` from the reference configuration.
#![allow(non_snake_case)]

use super::{hex8, quad4};

/// Relative size, in units of the element's `h^dim`, below which a reference `det J0` counts as
/// degenerate (such points are not checked; see the module documentation).
const DEGENERATE_TOL: f64 = 1e-10;

/// Halvings per direction of a hex's Bernstein patch before an undecided patch counts as tangled.
const MAX_SUBDIVISION: usize = 4;

/// Where an element's current map folds over: `det J <= 0` at a reference point.
#[derive(Debug, Clone, PartialEq)]
pub struct Tangle {
    /// Parent coordinates of the point, [dim].
    pub xi: Vec<f64>,
    /// The element corner there, when it is one (index in the linear cell's corner order).
    pub corner: Option<usize>,
    /// Reference position of the point, [dim].
    pub X: Vec<f64>,
    /// `det F = det J / det J0` there; for an undecided hex patch, the Bernstein lower bound of
    /// `det J` divided by the reference `det J0` at that point.
    pub det_F: f64,
    /// True when no point with `det J <= 0` was found, only a lower bound (see the module doc).
    pub bound_only: bool,
}

impl std::fmt::Display for Tangle {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let list = |v: &[f64]| {
            v.iter()
                .map(|x| format!("{x}"))
                .collect::<Vec<_>>()
                .join(", ")
        };
        let at = match self.corner {
            Some(k) => format!("corner {k}, xi = ({})", list(&self.xi)),
            None => format!("xi = ({})", list(&self.xi)),
        };
        if self.bound_only {
            write!(
                f,
                "tangled: det F is not shown positive near {at} (reference position ({})): its Bernstein lower bound is {:.3e}",
                list(&self.X),
                self.det_F
            )
        } else {
            write!(
                f,
                "tangled: det F = {:.3e} <= 0 at {at} (reference position ({})): the element is folded over",
                self.det_F,
                list(&self.X)
            )
        }
    }
}

/// How an element's nodal positions give the corners of its linear cell.
#[derive(Debug, Clone, PartialEq)]
pub enum Corners {
    /// The element's nodes are the corners (quad4 / hex8 order).
    Direct,
    /// A tied cell: corner `k` is `sum_(j, w) w x_j` over `map[k]` (element node `j`, weight `w`).
    Tied(Vec<Vec<(usize, f64)>>),
}

#[derive(Debug, Clone, PartialEq)]
enum Shape {
    /// A bilinear quad (`dim = 2`) or trilinear hex (`dim = 3`) through its corners. `strict`:
    /// the reference is positive everywhere (proven), so the exact tests apply; else only the
    /// grid points of `ref_ok` ([3^dim], lexicographic with xi fastest) are checked.
    Linear {
        corners: Corners,
        strict: bool,
        ref_ok: Vec<bool>,
    },
    /// `det J` at sample points: `xi` [n][dim], `N` [n][n_nodes], `dN` [n][n_nodes][dim],
    /// `det0` [n] the reference determinant (points with a degenerate reference are left out).
    Sampled {
        xi: Vec<f64>,
        N: Vec<f64>,
        dN: Vec<f64>,
        det0: Vec<f64>,
    },
}

/// The tangle check of one element: its reference nodal positions and how its map is checked.
#[derive(Debug, Clone, PartialEq)]
pub struct MapCheck {
    dim: usize,
    /// Reference nodal positions. [n_nodes][dim]
    X: Vec<f64>,
    shape: Shape,
}

fn det(dim: usize, J: &[[f64; 3]; 3]) -> f64 {
    if dim == 2 {
        J[0][0] * J[1][1] - J[0][1] * J[1][0]
    } else {
        J[0][0] * (J[1][1] * J[2][2] - J[1][2] * J[2][1])
            - J[0][1] * (J[1][0] * J[2][2] - J[1][2] * J[2][0])
            + J[0][2] * (J[1][0] * J[2][1] - J[1][1] * J[2][0])
    }
}

/// `det(sum_a x_a (x) dN_a)` for positions `x` [n][dim] and derivatives `dN` [n][dim].
fn det_of(dim: usize, x: &[f64], dN: &[f64]) -> f64 {
    let mut J = [[0.0; 3]; 3];
    for (xa, da) in x.chunks_exact(dim).zip(dN.chunks_exact(dim)) {
        for i in 0..dim {
            for k in 0..dim {
                J[i][k] += xa[i] * da[k];
            }
        }
    }
    det(dim, &J)
}

/// Largest distance between two of the positions `x` [n][dim].
fn diameter(dim: usize, x: &[f64]) -> f64 {
    let p: Vec<&[f64]> = x.chunks_exact(dim).collect();
    let mut h2: f64 = 0.0;
    for (i, a) in p.iter().enumerate() {
        for b in &p[i + 1..] {
            h2 = h2.max(a.iter().zip(*b).map(|(s, t)| (s - t).powi(2)).sum());
        }
    }
    h2.sqrt()
}

/// The 3^dim grid points {-1, 0, 1}^dim, xi fastest. [3^dim][dim]
fn grid3(dim: usize) -> Vec<[f64; 3]> {
    let n = 3usize.pow(dim as u32);
    (0..n)
        .map(|g| {
            let mut p = [0.0; 3];
            for (k, c) in p.iter_mut().enumerate().take(dim) {
                *c = ((g / 3usize.pow(k as u32)) % 3) as f64 - 1.0;
            }
            p
        })
        .collect()
}

/// `det J` of the linear cell with corner positions `x` [2^dim][dim] at `xi`.
fn linear_det(dim: usize, x: &[f64], xi: &[f64; 3]) -> f64 {
    if dim == 2 {
        let d = quad4::shape_derivatives(&[xi[0], xi[1]]);
        det_of(2, x, d.as_flattened())
    } else {
        let d = hex8::shape_derivatives(xi);
        det_of(3, x, d.as_flattened())
    }
}

/// Position `sum_a N_a x_a` of the linear cell with corners `x` at `xi`.
fn linear_point(dim: usize, x: &[f64], xi: &[f64; 3]) -> Vec<f64> {
    let N: Vec<f64> = if dim == 2 {
        quad4::shape_functions(&[xi[0], xi[1]]).to_vec()
    } else {
        hex8::shape_functions(xi).to_vec()
    };
    (0..dim)
        .map(|i| {
            N.iter()
                .zip(x.chunks_exact(dim))
                .map(|(n, p)| n * p[i])
                .sum()
        })
        .collect()
}

/// The corner whose parent coordinates are `xi`, if any (quad4 / hex8 order).
fn corner_at(dim: usize, xi: &[f64]) -> Option<usize> {
    if dim == 2 {
        quad4::NODES.iter().position(|n| n[..] == xi[..2])
    } else {
        hex8::NODES.iter().position(|n| n[..] == xi[..3])
    }
}

/// Bernstein coefficients (degree 2 per direction, [27], xi fastest) of the triquadratic `det J`
/// of a hex with corners `x` [8][3], from its values on the {-1, 0, 1}^3 grid.
fn hex_bernstein(x: &[f64]) -> [f64; 27] {
    let mut b = [0.0; 27];
    for (g, p) in grid3(3).iter().enumerate() {
        b[g] = linear_det(3, x, p);
    }
    // along each axis: f(0) = b0, f(1) = b2, f(1/2) = (b0 + 2 b1 + b2) / 4
    for axis in 0..3 {
        let s = 3usize.pow(axis);
        for g in 0..27 {
            if (g / s) % 3 == 1 {
                b[g] = 2.0 * b[g] - 0.5 * (b[g - s] + b[g + s]);
            }
        }
    }
    b
}

/// Splits a degree-2 Bernstein patch [27] at the middle of `axis`: (lower half, upper half).
fn split(b: &[f64; 27], axis: u32) -> ([f64; 27], [f64; 27]) {
    let s = 3usize.pow(axis);
    let (mut lo, mut hi) = (*b, *b);
    for g in 0..27 {
        if !(g / s).is_multiple_of(3) {
            continue;
        }
        let (b0, b1, b2) = (b[g], b[g + s], b[g + 2 * s]);
        let mid = 0.25 * (b0 + 2.0 * b1 + b2);
        lo[g + s] = 0.5 * (b0 + b1);
        lo[g + 2 * s] = mid;
        hi[g] = mid;
        hi[g + s] = 0.5 * (b1 + b2);
    }
    (lo, hi)
}

/// What the subdivision of a hex's `det J` found.
enum Verdict {
    Positive,
    /// A point (parent coordinates) where `det J <= 0`, and its value.
    Fold([f64; 3], f64),
    /// Undecided at the depth limit: the patch's lowest coefficient and the point it sits over.
    Undecided([f64; 3], f64),
}

/// Decides the sign of `det J` on the box `lo..hi` of the parent hex from its Bernstein patch `b`.
fn decide(b: &[f64; 27], lo: [f64; 3], hi: [f64; 3], depth: usize) -> Verdict {
    let at = |g: usize| {
        let mut p = [0.0; 3];
        for k in 0..3 {
            let t = ((g / 3usize.pow(k as u32)) % 3) as f64 * 0.5;
            p[k] = lo[k] + t * (hi[k] - lo[k]);
        }
        p
    };
    // corner coefficients are values of det J
    for g in [0, 2, 6, 8, 18, 20, 24, 26] {
        if b[g] <= 0.0 || b[g].is_nan() {
            return Verdict::Fold(at(g), b[g]);
        }
    }
    let (g_min, &min) = b
        .iter()
        .enumerate()
        .min_by(|x, y| x.1.total_cmp(y.1))
        .expect("27 coefficients");
    if min > 0.0 {
        return Verdict::Positive;
    }
    if depth == MAX_SUBDIVISION {
        return Verdict::Undecided(at(g_min), min);
    }
    let mid: [f64; 3] = std::array::from_fn(|k| 0.5 * (lo[k] + hi[k]));
    let mut undecided = None;
    let (b0, b1) = split(b, 0);
    for (bx, (xlo, xhi)) in [(b0, (lo[0], mid[0])), (b1, (mid[0], hi[0]))] {
        let (c0, c1) = split(&bx, 1);
        for (by, (ylo, yhi)) in [(c0, (lo[1], mid[1])), (c1, (mid[1], hi[1]))] {
            let (d0, d1) = split(&by, 2);
            for (bz, (zlo, zhi)) in [(d0, (lo[2], mid[2])), (d1, (mid[2], hi[2]))] {
                match decide(&bz, [xlo, ylo, zlo], [xhi, yhi, zhi], depth + 1) {
                    Verdict::Positive => {}
                    fold @ Verdict::Fold(..) => return fold,
                    u @ Verdict::Undecided(..) => {
                        undecided.get_or_insert(u);
                    }
                }
            }
        }
    }
    undecided.unwrap_or(Verdict::Positive)
}

impl MapCheck {
    /// A linear cell (quad4 / hex8 corner order) with reference corner positions `X` [2^dim][dim]
    /// that are the element's nodes.
    pub fn linear(dim: usize, X: &[f64]) -> Self {
        Self::linear_with(dim, X.to_vec(), Corners::Direct)
    }

    /// A linear cell whose corners are the element's nodes `X` [n_nodes][dim] through `corners`.
    pub fn linear_with(dim: usize, X: Vec<f64>, corners: Corners) -> Self {
        let mut check = MapCheck {
            dim,
            X,
            shape: Shape::Linear {
                corners,
                strict: false,
                ref_ok: Vec::new(),
            },
        };
        let x0 = check.corner_positions(&vec![0.0; check.X.len()]);
        let tol = DEGENERATE_TOL * diameter(dim, &x0).powi(dim as i32);
        let ref_ok: Vec<bool> = grid3(dim)
            .iter()
            .map(|p| linear_det(dim, &x0, p) > tol)
            .collect();
        let strict = if dim == 2 {
            // det J is affine: positive corners prove it positive everywhere
            ref_ok.iter().all(|&ok| ok)
        } else {
            let b = hex_bernstein(&x0);
            ref_ok.iter().all(|&ok| ok) && b.iter().all(|&c| c > tol)
        };
        if let Shape::Linear {
            strict: s,
            ref_ok: r,
            ..
        } = &mut check.shape
        {
            *s = strict;
            *r = ref_ok;
        }
        check
    }

    /// A map checked at sample points: `xi` [n][dim] parent coordinates, `shape(xi, N, dN)` the
    /// element's basis, `X` [n_nodes][dim] its reference nodal positions.
    pub fn sampled(
        dim: usize,
        X: Vec<f64>,
        xi: &[f64],
        shape: impl Fn(&[f64], &mut [f64], &mut [f64]),
    ) -> Self {
        let n = X.len() / dim;
        let tol = DEGENERATE_TOL * diameter(dim, &X).powi(dim as i32);
        let (mut N, mut dN) = (vec![0.0; n], vec![0.0; n * dim]);
        let (mut keep_xi, mut keep_N, mut keep_dN, mut det0) =
            (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        for p in xi.chunks_exact(dim) {
            shape(p, &mut N, &mut dN);
            let d0 = det_of(dim, &X, &dN);
            if d0 > tol {
                keep_xi.extend_from_slice(p);
                keep_N.extend_from_slice(&N);
                keep_dN.extend_from_slice(&dN);
                det0.push(d0);
            }
        }
        MapCheck {
            dim,
            X,
            shape: Shape::Sampled {
                xi: keep_xi,
                N: keep_N,
                dN: keep_dN,
                det0,
            },
        }
    }

    /// The sample points of an enriched cell: the parent corners and a grid of `n[k] + 1` points
    /// along each surface direction `k` ([dim - 1] counts), on the faces through the thickness
    /// (and in 3D the mid-surface). [n_points][dim]
    pub fn enriched_points(dim: usize, n: &[usize]) -> Vec<f64> {
        let line =
            |m: usize| -> Vec<f64> { (0..=m).map(|i| -1.0 + 2.0 * i as f64 / m as f64).collect() };
        let mut out = Vec::new();
        if dim == 2 {
            for eta in [-1.0, 1.0] {
                for xi in line(n[0].max(1)) {
                    out.extend([xi, eta]);
                }
            }
        } else {
            for zeta in [-1.0, 0.0, 1.0] {
                for eta in line(n[1].max(1)) {
                    for xi in line(n[0].max(1)) {
                        out.extend([xi, eta, zeta]);
                    }
                }
            }
        }
        out
    }

    /// The current corner positions of a linear shape for element displacements `u` [n][dim].
    fn corner_positions(&self, u: &[f64]) -> Vec<f64> {
        let d = self.dim;
        let x: Vec<f64> = self.X.iter().zip(u).map(|(X, u)| X + u).collect();
        match &self.shape {
            Shape::Linear {
                corners: Corners::Tied(map),
                ..
            } => map
                .iter()
                .flat_map(|row| {
                    (0..d).map(|i| row.iter().map(|&(j, w)| w * x[j * d + i]).sum::<f64>())
                })
                .collect(),
            _ => x,
        }
    }

    /// Checks the map at element displacements `u` [n_nodes][dim]: the first fold found, if any.
    pub fn check(&self, u: &[f64]) -> Result<(), Tangle> {
        let d = self.dim;
        match &self.shape {
            Shape::Linear { strict, ref_ok, .. } => {
                let x = self.corner_positions(u);
                let x0 = self.corner_positions(&vec![0.0; u.len()]);
                let fold = |p: [f64; 3], det: f64, bound_only: bool| Tangle {
                    xi: p[..d].to_vec(),
                    corner: corner_at(d, &p),
                    X: linear_point(d, &x0, &p),
                    det_F: det / linear_det(d, &x0, &p),
                    bound_only,
                };
                if d == 3 && *strict {
                    return match decide(&hex_bernstein(&x), [-1.0; 3], [1.0; 3], 0) {
                        Verdict::Positive => Ok(()),
                        Verdict::Fold(p, v) => Err(fold(p, v, false)),
                        Verdict::Undecided(p, v) => Err(fold(p, v, true)),
                    };
                }
                // a quad's affine det J is decided by its corners; a cell with a degenerate
                // reference somewhere is checked at the grid points where its reference is not
                for (p, _) in grid3(d)
                    .iter()
                    .zip(ref_ok)
                    .filter(|(p, ok)| **ok && (d == 3 || corner_at(2, &p[..]).is_some()))
                {
                    let v = linear_det(d, &x, p);
                    if v.is_nan() || v <= 0.0 {
                        return Err(fold(*p, v, false));
                    }
                }
                Ok(())
            }
            Shape::Sampled { xi, N, dN, det0 } => {
                let n = self.X.len() / d;
                let x: Vec<f64> = self.X.iter().zip(u).map(|(X, u)| X + u).collect();
                for (k, p) in xi.chunks_exact(d).enumerate() {
                    let v = det_of(d, &x, &dN[k * n * d..(k + 1) * n * d]);
                    if v.is_nan() || v <= 0.0 {
                        let Nk = &N[k * n..(k + 1) * n];
                        let X = (0..d)
                            .map(|i| (0..n).map(|a| Nk[a] * self.X[a * d + i]).sum())
                            .collect();
                        let is_corner = p.iter().all(|c| c.abs() == 1.0);
                        return Err(Tangle {
                            xi: p.to_vec(),
                            corner: is_corner.then(|| corner_at(d, p)).flatten(),
                            X,
                            det_F: v / det0[k],
                            bound_only: false,
                        });
                    }
                }
                Ok(())
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fem::enriched::{q1np_2d, EnrichedElementData};
    use crate::fem::quadrature::tensor_rule;

    /// `det J` at every point of a tensor Gauss rule with `n` points per direction.
    fn gauss_dets(dim: usize, x: &[f64], n: usize) -> Vec<f64> {
        let rule = tensor_rule(&vec![n; dim]).unwrap();
        rule.points
            .chunks_exact(dim)
            .map(|p| {
                let mut q = [0.0; 3];
                q[..dim].copy_from_slice(p);
                linear_det(dim, x, &q)
            })
            .collect()
    }

    fn unit_hex() -> Vec<f64> {
        hex8::NODES
            .iter()
            .flat_map(|n| n.map(|c| 0.5 * (c + 1.0)))
            .collect()
    }

    #[test]
    fn quad_folded_at_a_corner_but_positive_at_every_gauss_point_is_tangled() {
        let X = [0.0, 0.0, 1.0, 0.0, 1.0, 1.0, 0.0, 1.0];
        let check = MapCheck::linear(2, &X);
        assert_eq!(check.check(&[0.0; 8]), Ok(()));
        // corner 2 pulled inwards past the diagonal 1-3: a dart, re-entrant at corner 2, where
        // the affine det J is negative, while it is still positive at the 2x2 Gauss points
        let x = [0.0, 0.0, 1.0, 0.0, 0.45, 0.45, 0.0, 1.0];
        assert!(gauss_dets(2, &x, 2).iter().all(|&d| d > 0.0));
        let u: Vec<f64> = x.iter().zip(&X).map(|(x, X)| x - X).collect();
        let t = check.check(&u).unwrap_err();
        assert_eq!(t.corner, Some(2));
        assert_eq!(t.xi, vec![1.0, 1.0]);
        assert!(t.det_F < 0.0 && !t.bound_only, "{t}");
        assert!(t.to_string().contains("corner 2"), "{t}");
        // a convex but strongly distorted quad is not tangled
        let y = [0.0, 0.0, 1.0, 0.0, 0.55, 0.55, 0.0, 1.0];
        let v: Vec<f64> = y.iter().zip(&X).map(|(y, X)| y - X).collect();
        assert_eq!(check.check(&v), Ok(()));
    }

    #[test]
    fn hex_folded_at_a_corner_but_positive_at_every_gauss_point_is_tangled() {
        let X = unit_hex();
        let check = MapCheck::linear(3, &X);
        assert_eq!(check.check(&[0.0; 24]), Ok(()));
        // the top corner 6 pushed in to (0.55, 0.55, 0.55), past the plane of its neighbours: the
        // Gauss points stay positive
        let mut x = X.clone();
        x[6 * 3..6 * 3 + 3].copy_from_slice(&[0.55; 3]);
        assert!(gauss_dets(3, &x, 2).iter().all(|&d| d > 0.0));
        let u: Vec<f64> = x.iter().zip(&X).map(|(x, X)| x - X).collect();
        let t = check.check(&u).unwrap_err();
        assert_eq!(t.corner, Some(6), "{t}");
        assert!(t.det_F < 0.0 && !t.bound_only);
        assert_eq!(t.X, vec![1.0, 1.0, 1.0]);
    }

    #[test]
    fn hex_with_positive_corners_and_gauss_points_but_a_fold_between_is_found_by_subdivision() {
        // found by a random search over perturbed unit cubes: det J > 0 at the 8 corners, the 8
        // Gauss points and the centre, < 0 on the edge xi = -1, eta = 1 near zeta = -0.2
        let x = [
            [0.11, 0.42, -0.27],
            [1.44, 0.34, 0.33],
            [0.9, 1.6, 0.35],
            [0.09, 0.54, 0.09],
            [-0.58, 0.48, 0.8],
            [0.84, 0.06, 1.16],
            [1.1, 0.98, 1.16],
            [0.42, 0.94, 1.0],
        ]
        .as_flattened()
        .to_vec();
        assert!(hex8::NODES.iter().all(|n| linear_det(3, &x, n) > 0.0));
        assert!(gauss_dets(3, &x, 2).iter().all(|&d| d > 0.0));
        assert!(linear_det(3, &x, &[-1.0, 1.0, -0.2]) < 0.0);
        let X = unit_hex();
        let u: Vec<f64> = x.iter().zip(&X).map(|(x, X)| x - X).collect();
        let t = MapCheck::linear(3, &X).check(&u).unwrap_err();
        assert!(t.corner.is_none() && t.det_F <= 0.0 && !t.bound_only, "{t}");
        // the point found is a real fold: det J there is what the message says
        let mut p = [0.0; 3];
        p.copy_from_slice(&t.xi);
        assert!(linear_det(3, &x, &p) <= 0.0);
        // a moderately sheared and twisted hex is valid everywhere
        let mut y = X.clone();
        for a in 4..8 {
            y[3 * a] += 0.4;
            y[3 * a + 1] += 0.1 * a as f64;
        }
        let v: Vec<f64> = y.iter().zip(&X).map(|(y, X)| y - X).collect();
        assert_eq!(MapCheck::linear(3, &X).check(&v), Ok(()));
    }

    #[test]
    fn bernstein_coefficients_reproduce_det_j_and_bound_it() {
        let mut x = unit_hex();
        x[6 * 3 + 2] = 1.7;
        x[3] = 1.3;
        x[4 * 3 + 1] = -0.2;
        let b = hex_bernstein(&x);
        let bern = |i: usize, t: f64| match i {
            0 => (1.0 - t) * (1.0 - t),
            1 => 2.0 * t * (1.0 - t),
            _ => t * t,
        };
        let min = b.iter().copied().fold(f64::INFINITY, f64::min);
        for p in [[0.3, -0.7, 0.1], [-1.0, 0.25, 0.9], [0.8, 0.8, -0.4]] {
            let t: Vec<f64> = p.iter().map(|c| 0.5 * (c + 1.0)).collect();
            let mut v = 0.0;
            for (g, bg) in b.iter().enumerate() {
                v += bg * bern(g % 3, t[0]) * bern((g / 3) % 3, t[1]) * bern(g / 9, t[2]);
            }
            let exact = linear_det(3, &x, &p);
            assert!((v - exact).abs() < 1e-12, "{v} {exact}");
            assert!(exact >= min);
        }
        // subdivision keeps the polynomial: the lower half's corner at the middle is f(0, ., .)
        let (lo, _) = split(&b, 0);
        let mid = linear_det(3, &x, &[0.0, -1.0, -1.0]);
        assert!((lo[2] - mid).abs() < 1e-12);
    }

    #[test]
    fn tied_corners_follow_their_control_points() {
        // a quad whose corner 2 is the mean of two element nodes (4 and 5)
        let X = vec![0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.8, 1.0, 1.2, 1.0];
        let map = vec![
            vec![(0, 1.0)],
            vec![(1, 1.0)],
            vec![(4, 0.5), (5, 0.5)],
            vec![(3, 1.0)],
        ];
        let check = MapCheck::linear_with(2, X.clone(), Corners::Tied(map));
        assert_eq!(check.check(&[0.0; 12]), Ok(()));
        // both control points of corner 2 moved so that it sits at (0.45, 0.45): a dart
        let mut u = vec![0.0; 12];
        u[8..12].copy_from_slice(&[-0.55; 4]);
        let t = check.check(&u).unwrap_err();
        assert_eq!(t.corner, Some(2), "{t}");
    }

    #[test]
    fn degenerate_reference_corners_are_not_checked() {
        // corner 2 collinear with its neighbours in the reference: det J0 = 0 there
        let X = [0.0, 0.0, 1.0, 0.0, 0.5, 0.5, 0.0, 1.0];
        let check = MapCheck::linear(2, &X);
        assert_eq!(check.check(&[0.0; 8]), Ok(()));
        // pushing corner 3 through makes corner 3 tangled, which is reported
        let mut u = [0.0; 8];
        u[6] = 1.5;
        u[7] = -1.5;
        assert!(check.check(&u).is_err());
    }

    #[test]
    fn enriched_cell_whose_surface_doubles_back_near_a_corner_is_tangled() {
        // Q1N2 on a straight bottom edge [0, 2] x {0}, top nodes (2, 1), (0, 1)
        let el = EnrichedElementData::new_2d(
            2,
            vec![1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
            vec![1.0; 3],
            vec![0, 1, 2],
        )
        .unwrap();
        let X = vec![0.0, 0.0, 1.0, 0.0, 2.0, 0.0, 2.0, 1.0, 0.0, 1.0];
        let pts = MapCheck::enriched_points(2, &[3]);
        let check = MapCheck::sampled(2, X.clone(), &pts, |p, N, dN| {
            q1np_2d(&el, p[0], p[1], N, dN)
        });
        assert_eq!(check.check(&[0.0; 10]), Ok(()));
        // the middle control point moved along the surface to x = 2.2: the surface runs back
        // for xi > 0.83 (dx/dxi < 0 next to corner 1), beyond the last Gauss point 0.775
        let mut u = vec![0.0; 10];
        u[2] = 1.2;
        let (mut N, mut dN) = ([0.0; 5], [0.0; 10]);
        let x: Vec<f64> = X.iter().zip(&u).map(|(X, u)| X + u).collect();
        let rule = tensor_rule(&[3, 2]).unwrap();
        for p in rule.points.chunks_exact(2) {
            q1np_2d(&el, p[0], p[1], &mut N, &mut dN);
            assert!(det_of(2, &x, &dN) > 0.0, "Gauss point {p:?}");
        }
        let t = check.check(&u).unwrap_err();
        assert_eq!((t.corner, t.xi.clone()), (Some(1), vec![1.0, -1.0]), "{t}");
        assert!(t.det_F < 0.0);
        assert_eq!(t.X, vec![2.0, 0.0]);
    }
}
