//! Closest-point projection of a point onto a contact surface (section 3.2 of Corbett & Sauer 2014).
//!
//! On one element, the distance `f(xi) = |x - x(xi)|^2 / 2` is minimised over the box
//! `[-1,1]^m` by Newton with the exact Hessian `m_ab - g . x_,ab` (Gauss-Newton `m_ab` where that is
//! not positive definite), clamping to the box; a coordinate that ends on the box boundary with the
//! gradient pushing outward is *bound*. A bound coordinate on a side that has a neighbour moves the
//! search there (the paper's transfer to the neighbouring element); where both elements end on their
//! shared edge, the closest point is that edge or corner of a C0 (faceted) surface, and the caller
//! takes the normal along the gap. A point held on a side of the surface's boundary lies beyond the
//! end of the partner surface and has no partner. A search starts from the last projection of the same point (warm
//! start) or, without one or when the walk fails, from every element whose bounding box holds the
//! point (`crate::contact::search`).
#![allow(clippy::needless_range_loop)]

use crate::contact::basis::FaceBasis;
use crate::contact::search::{Aabb, BinGrid};
use crate::contact::surface::{side_coordinates, side_point, ContactSurface, MAX_FACE_NODES};

/// Current nodal positions of every element of a surface: element `e` has
/// `x[offsets[e]..offsets[e + 1]]` [n_nodes][dim].
#[derive(Debug, Clone, Default)]
pub struct Positions {
    /// [n_el + 1]
    pub offsets: Vec<usize>,
    /// [sum of n_nodes * dim]
    pub x: Vec<f64>,
}

impl Positions {
    /// True when this rank holds the positions of element `e` (its own elements and the ghost
    /// layer; see `crate::contact::system::ghost`).
    pub fn has(&self, e: usize) -> bool {
        self.offsets[e + 1] > self.offsets[e]
    }

    /// Positions of element `e`.
    pub fn of(&self, e: usize) -> &[f64] {
        &self.x[self.offsets[e]..self.offsets[e + 1]]
    }
}

/// The result of a projection onto a surface.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Projection {
    /// Surface element.
    pub elem: u32,
    /// Surface coordinates [m] (second unused in 2D).
    pub xi: [f64; 2],
    /// Coordinates that are free (not held on the element boundary by the constraint). All free:
    /// an orthogonal projection; otherwise an edge or corner projection.
    pub free: [bool; 2],
    /// Distance `|x - x_p|`.
    pub dist: f64,
}

/// A surface coordinate at least this close to `+-1` counts as on the element's boundary when the
/// projection decides which coordinates the boundary holds.
const ON_BOUND: f64 = 1.0 - 1e-12;

/// Newton iterations allowed on one element.
const MAX_NEWTON: usize = 50;
/// Element transfers allowed in one walk.
const MAX_WALK: usize = 64;

/// The basis of a face at one point, as [`project_on_element_from`] and the contact kernel take
/// it: values, first and second derivatives of [`FaceBasis::eval`] one after the other,
/// `[N (n) | dN (n m) | ddN (n m m)]` (layouts of `FaceBasis::eval`), into `out` (resized).
#[allow(non_snake_case)]
pub fn basis_values(basis: &FaceBasis, xi: &[f64; 2], out: &mut Vec<f64>) {
    let (n, m) = (basis.n_nodes(), basis.n_params());
    out.clear();
    out.resize(n * (1 + m + m * m), 0.0);
    let (N, rest) = out.split_at_mut(n);
    let (dN, ddN) = rest.split_at_mut(n * m);
    basis.eval(&xi[..m], N, dN, ddN);
}

/// A face basis stored at the point it was evaluated at (see [`basis_values`]): a projection or
/// the kernel reads it instead of evaluating the same basis at the same point again (the basis
/// depends on the element and the coordinates only, not on the positions).
#[derive(Debug, Clone, Default)]
pub struct BasisAt {
    /// Element and coordinates of the evaluation (`None`: nothing stored).
    pub at: Option<(u32, [f64; 2])>,
    /// [`basis_values`] there.
    pub values: Vec<f64>,
}

impl BasisAt {
    /// The stored values if they are those of element `e` at exactly `xi` (bit for bit).
    pub fn get(&self, e: u32, xi: &[f64; 2]) -> Option<&[f64]> {
        let (f, yi) = self.at?;
        (f == e && yi[0].to_bits() == xi[0].to_bits() && yi[1].to_bits() == xi[1].to_bits())
            .then_some(&self.values[..])
    }

    /// Stores the basis of element `e` of `s` at `xi`, unless it holds it already.
    pub fn set(&mut self, s: &ContactSurface, e: u32, xi: &[f64; 2]) {
        if self.get(e, xi).is_none() {
            basis_values(&s.elements[e as usize].basis, xi, &mut self.values);
            self.at = Some((e, *xi));
        }
    }
}

/// Point, tangents and second derivatives `(x, x_,i, x_,ij)` of a face with nodal positions `y`
/// [n][dim] from its basis `N` [n], `dN` [n][m], `ddN` [n][m][m].
#[allow(non_snake_case)]
#[allow(clippy::type_complexity)]
pub(crate) fn contract(
    y: &[f64],
    (n, dim, m): (usize, usize, usize),
    N: &[f64],
    dN: &[f64],
    ddN: &[f64],
) -> ([f64; 3], [[f64; 3]; 2], [[[f64; 3]; 2]; 2]) {
    // the two cases with their sizes known to the compiler (the same sums in the same order)
    match (dim, m) {
        (3, 2) => contract_dims(y, (n, 3, 2), N, dN, ddN),
        (2, 1) => contract_dims(y, (n, 2, 1), N, dN, ddN),
        _ => contract_dims(y, (n, dim, m), N, dN, ddN),
    }
}

/// [`contract`]'s sums (inlined, so that constant sizes unroll them).
#[allow(non_snake_case)]
#[allow(clippy::type_complexity)]
#[inline(always)]
fn contract_dims(
    y: &[f64],
    (n, dim, m): (usize, usize, usize),
    N: &[f64],
    dN: &[f64],
    ddN: &[f64],
) -> ([f64; 3], [[f64; 3]; 2], [[[f64; 3]; 2]; 2]) {
    let (y, N, dN, ddN) = (&y[..n * dim], &N[..n], &dN[..n * m], &ddN[..n * m * m]);
    let (mut p, mut a, mut aa) = ([0.0; 3], [[0.0; 3]; 2], [[[0.0; 3]; 2]; 2]);
    for b in 0..n {
        for k in 0..dim {
            let v = y[b * dim + k];
            p[k] += N[b] * v;
            for i in 0..m {
                a[i][k] += dN[b * m + i] * v;
                for j in 0..m {
                    aa[i][j][k] += ddN[b * m * m + i * m + j] * v;
                }
            }
        }
    }
    (p, a, aa)
}

/// Projection onto element `e` from `xi0`, over the box `[-1,1]^m`.
pub fn project_on_element(
    s: &ContactSurface,
    pos: &Positions,
    e: usize,
    x: &[f64; 3],
    xi0: [f64; 2],
) -> Option<Projection> {
    project_on_element_from(s, pos, e, x, xi0, None)
}

/// [`project_on_element`] with the element's basis at the start `xi0` given ([`basis_values`]
/// at `xi0` clamped to the box), which saves its evaluation; the same result.
#[allow(non_snake_case)]
pub fn project_on_element_from(
    s: &ContactSurface,
    pos: &Positions,
    e: usize,
    x: &[f64; 3],
    xi0: [f64; 2],
    start: Option<&[f64]>,
) -> Option<Projection> {
    let el = &s.elements[e];
    let dim = s.dim;
    let m = dim - 1;
    let y = pos.of(e);
    let n = el.basis.n_nodes();
    let (mut N, mut dN, mut ddN) = (
        [0.0; MAX_FACE_NODES],
        [0.0; 2 * MAX_FACE_NODES],
        [0.0; 4 * MAX_FACE_NODES],
    );
    let eval = |xi: &[f64; 2], N: &mut [f64], dN: &mut [f64], ddN: &mut [f64]| {
        el.basis.eval(&xi[..m], N, dN, ddN);
        contract(y, (n, dim, m), N, dN, ddN)
    };
    let scale2 = s.h * s.h;
    let mut xi = xi0;
    for k in 0..m {
        xi[k] = xi[k].clamp(-1.0, 1.0);
    }
    let f_of = |p: &[f64; 3]| 0.5 * (0..dim).map(|k| (x[k] - p[k]).powi(2)).sum::<f64>();
    let mut free = [true; 2];
    // the geometry at `xi`: evaluated once here (from the given basis if there is one), then
    // carried over from the accepted trial point of each line search (the same coordinates, so
    // the same values, without a second evaluation)
    let mut cur = match start {
        Some(b) if b.len() == n * (1 + m + m * m) => {
            contract(y, (n, dim, m), &b[..n], &b[n..n + n * m], &b[n + n * m..])
        }
        _ => eval(&xi, &mut N, &mut dN, &mut ddN),
    };
    for _ in 0..MAX_NEWTON {
        let (p, a, aa) = cur;
        let g = [x[0] - p[0], x[1] - p[1], x[2] - p[2]];
        let f0 = f_of(&p);
        let mut grad = [0.0; 2];
        let mut H = [[0.0; 2]; 2];
        let mut M = [[0.0; 2]; 2];
        for i in 0..m {
            grad[i] = -(0..dim).map(|k| g[k] * a[i][k]).sum::<f64>();
            for j in 0..m {
                M[i][j] = (0..dim).map(|k| a[i][k] * a[j][k]).sum();
                H[i][j] = M[i][j] - (0..dim).map(|k| g[k] * aa[i][j][k]).sum::<f64>();
            }
        }
        // bound coordinates: on the box boundary with the descent direction pointing out
        let tol = 1e-14 * scale2;
        for i in 0..m {
            free[i] = !((xi[i] >= 1.0 && grad[i] < -tol) || (xi[i] <= -1.0 && grad[i] > tol));
        }
        let step = solve_free(&H, &M, &grad, &free, m);
        let Some(step) = step else {
            // all bound: a corner
            let dist = (2.0 * f0).sqrt();
            // a non-finite geometry (a diverged Newton iterate) is a failed projection
            return dist.is_finite().then_some(Projection {
                elem: e as u32,
                xi,
                free,
                dist,
            });
        };
        // backtracking on f keeps far-off starts from oscillating; where the Newton direction,
        // clamped to the box, does not descend (a free coordinate just inside the boundary that
        // the step pushes out), the scaled gradient direction, clamped alike, does
        let gradient_step = [0, 1].map(|i| {
            if i < m && free[i] && M[i][i] > 0.0 {
                -grad[i] / M[i][i]
            } else {
                0.0
            }
        });
        let mut accepted = xi;
        'directions: for step in [step, gradient_step] {
            let len = step[0].abs().max(step[1].abs());
            let damp = if len > 0.5 { 0.5 / len } else { 1.0 };
            let mut t = damp;
            for _ in 0..20 {
                let mut trial = xi;
                for i in 0..m {
                    trial[i] = (xi[i] + t * step[i]).clamp(-1.0, 1.0);
                    // within round-off of the boundary is on it: a step that lands at `1 - ulp`
                    // leaves the coordinate free, and the next Newton step, pushing it out, is clamped
                    // into a direction that need not descend (the line search then finds no decrease
                    // and the projection stalls there, not stationary in the other coordinate)
                    if trial[i].abs() >= ON_BOUND {
                        trial[i] = trial[i].signum();
                    }
                }
                if trial == xi {
                    // clamped to the start (or below round-off): no move in this direction
                    break;
                }
                let geom = eval(&trial, &mut N, &mut dN, &mut ddN);
                if f_of(&geom.0) <= f0 + 1e-15 * scale2 {
                    accepted = trial;
                    cur = geom;
                    break 'directions;
                }
                t *= 0.5;
            }
        }
        let moved = (0..m)
            .map(|i| (accepted[i] - xi[i]).abs())
            .fold(0.0, f64::max);
        xi = accepted;
        if moved < 1e-13 {
            let (p, a, _) = cur;
            let g = [x[0] - p[0], x[1] - p[1], x[2] - p[2]];
            // recompute which coordinates the boundary holds at the final point; one that
            // stalled within round-off of the boundary (`1 - ulp`, where the backtracking finds no
            // decrease) with the distance still falling outwards is on it, not free
            for i in 0..m {
                let gi = -(0..dim).map(|k| g[k] * a[i][k]).sum::<f64>();
                if xi[i] >= ON_BOUND && gi < -tol {
                    xi[i] = 1.0;
                } else if xi[i] <= -ON_BOUND && gi > tol {
                    xi[i] = -1.0;
                }
                free[i] = !((xi[i] >= 1.0 && gi < -tol) || (xi[i] <= -1.0 && gi > tol));
            }
            let dist = (2.0 * f_of(&p)).sqrt();
            return (dist.is_finite() && xi.iter().all(|v| v.is_finite())).then_some(Projection {
                elem: e as u32,
                xi,
                free,
                dist,
            });
        }
    }
    None
}

/// Newton step on the free coordinates: `H_ff d = -grad_f`, Gauss-Newton `M` if `H_ff` is not
/// positive definite. `None` when no coordinate is free.
#[allow(non_snake_case)]
fn solve_free(
    H: &[[f64; 2]; 2],
    M: &[[f64; 2]; 2],
    grad: &[f64; 2],
    free: &[bool; 2],
    m: usize,
) -> Option<[f64; 2]> {
    // the free coordinates (no allocation: this runs once per Newton iteration)
    let (mut idx, mut n_free) = ([0usize; 2], 0);
    for i in (0..m).filter(|&i| free[i]) {
        idx[n_free] = i;
        n_free += 1;
    }
    let mut d = [0.0; 2];
    match n_free {
        0 => return None,
        1 => {
            let i = idx[0];
            let h = if H[i][i] > 1e-3 * M[i][i] {
                H[i][i]
            } else {
                M[i][i]
            };
            d[i] = -grad[i] / h;
        }
        _ => {
            let pd = |A: &[[f64; 2]; 2]| {
                let det = A[0][0] * A[1][1] - A[0][1] * A[1][0];
                (A[0][0] > 0.0 && det > 1e-6 * (M[0][0] * M[1][1])).then_some(det)
            };
            let (A, det) = match pd(H) {
                Some(det) => (*H, det),
                None => (*M, M[0][0] * M[1][1] - M[0][1] * M[1][0]),
            };
            if det <= 0.0 {
                return Some([0.0; 2]);
            }
            d[0] = -(A[1][1] * grad[0] - A[0][1] * grad[1]) / det;
            d[1] = -(-A[1][0] * grad[0] + A[0][0] * grad[1]) / det;
        }
    }
    Some(d)
}

/// The sides a bound projection leans on (one per bound coordinate).
fn exit_sides(dim: usize, p: &Projection) -> impl Iterator<Item = usize> + '_ {
    (0..dim - 1).filter(|&i| !p.free[i]).map(move |i| {
        let hi = p.xi[i] >= 1.0;
        match (dim, i, hi) {
            (2, _, false) => 0,
            (2, _, true) => 1,
            (_, 0, true) => 1,
            (_, 0, false) => 3,
            (_, _, false) => 0,
            (_, _, true) => 2,
        }
    })
}

/// True when the projection is held on a side of the surface's boundary (no neighbour there): the
/// point lies beyond the end of the partner surface and has no partner. (Held on a side that has a
/// neighbour, it is an edge or corner projection of a faceted surface.)
pub(crate) fn off_the_edge(s: &ContactSurface, p: &Projection) -> bool {
    exit_sides(s.dim, p).any(|side| s.elements[p.elem as usize].neighbours[side].is_none())
}

/// An element a walk had to enter whose positions this rank does not hold (outside its ghost
/// layer): the walk cannot go on here, and the ghost layer must grow by that element.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Absent(pub u32);

/// Walks from a warm start across neighbours to the closest point. `Ok(None)` if it does not
/// settle; `Err` when it reaches an element whose positions this rank does not hold.
pub fn walk(
    s: &ContactSurface,
    pos: &Positions,
    x: &[f64; 3],
    start: (u32, [f64; 2]),
) -> Result<Option<Projection>, Absent> {
    walk_from(s, pos, x, start, None)
}

/// [`walk`] with the start element's basis at the start coordinates given (`start_basis`,
/// [`basis_values`] there), which saves its evaluation; the same result.
pub fn walk_from(
    s: &ContactSurface,
    pos: &Positions,
    x: &[f64; 3],
    start: (u32, [f64; 2]),
    start_basis: Option<&[f64]>,
) -> Result<Option<Projection>, Absent> {
    let dim = s.dim;
    let (mut e, mut xi) = (start.0 as usize, start.1);
    // the elements entered (on the stack: a walk per point and update)
    let (mut visited, mut n_visited) = ([0usize; MAX_WALK], 0);
    let mut best: Option<Projection> = None;
    let mut given = start_basis;
    for _ in 0..MAX_WALK {
        if !pos.has(e) {
            return Err(Absent(e as u32));
        }
        let Some(p) = project_on_element_from(s, pos, e, x, xi, given.take()) else {
            return Ok(None);
        };
        if best.is_none_or(|b| {
            p.dist < b.dist * (1.0 - 1e-12)
                || p.free_count() > b.free_count() && p.dist <= b.dist * (1.0 + 1e-12)
        }) {
            best = Some(p);
        }
        visited[n_visited] = e;
        n_visited += 1;
        let Some(side) = exit_sides(dim, &p).next() else {
            return Ok(Some(p)); // orthogonal projection inside the element
        };
        if off_the_edge(s, &p) {
            return Ok(None); // beyond the end of the surface: no partner
        }
        match s.elements[e].neighbours[side] {
            Some((f, s2, rev)) if !visited[..n_visited].contains(&(f as usize)) => {
                let (t, _) = side_coordinates(dim, side, &p.xi);
                let t2 = if rev { -t } else { t };
                xi = side_point(dim, s2 as usize, t2, 0.0);
                e = f as usize;
            }
            // both elements hold the point on their shared edge: an edge or corner projection
            _ => return Ok(best.filter(|b| !off_the_edge(s, b))),
        }
    }
    Ok(best.filter(|b| !off_the_edge(s, b)))
}

impl Projection {
    /// Number of free coordinates.
    pub fn free_count(&self) -> usize {
        self.free.iter().filter(|&&f| f).count()
    }
}

/// The global-search grid of a surface at the positions `pos`: each element's own box (NURBS with
/// positive weights and linear faces lie in the convex hull of their nodes; Lagrange and Hermite
/// faces are sampled, with a margin for the surface between the samples, as Hermite tangents are
/// not positions), inflated by the search distance `dist` for binning. Elements whose positions
/// this rank does not hold get empty boxes (no point's candidates).
pub fn surface_grid(s: &ContactSurface, pos: &Positions, dist: f64) -> BinGrid {
    let dim = s.dim;
    let raw: Vec<Aabb> = (0..s.elements.len())
        .map(|e| element_box(s, pos, e))
        .collect();
    let boxes = raw.iter().map(|b| b.inflated(dim, dist)).collect();
    BinGrid::with_raw(dim, boxes, raw)
}

/// The box of element `e` of `s` at the positions `pos` that [`surface_grid`] bins (empty when
/// this rank does not hold the element's positions).
pub fn element_box(s: &ContactSurface, pos: &Positions, e: usize) -> Aabb {
    let dim = s.dim;
    let m = dim - 1;
    let mut b = Aabb::EMPTY;
    if !pos.has(e) {
        return b;
    }
    if matches!(
        s.elements[e].basis,
        FaceBasis::Nurbs(_) | FaceBasis::Line2 | FaceBasis::Quad4
    ) {
        for x in pos.of(e).chunks_exact(dim) {
            b.grow(x);
        }
        return b;
    }
    let k = 4usize;
    let n2 = if m == 2 { k + 1 } else { 1 };
    for j in 0..n2 {
        for i in 0..=k {
            let eta = if m == 2 {
                -1.0 + 2.0 * j as f64 / k as f64
            } else {
                0.0
            };
            let xi = [-1.0 + 2.0 * i as f64 / k as f64, eta];
            let x = crate::contact::surface::frame(&s.elements[e], dim, pos.of(e), &xi).0;
            b.grow(&x[..dim]);
        }
    }
    let size = (0..dim).map(|c| b.hi[c] - b.lo[c]).fold(0.0, f64::max);
    b.inflated(dim, 0.25 * size)
}

/// Newton did not settle on any candidate element of a global search.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ProjectionFailed;

/// Global search: every element whose (inflated) box holds `x`, each projected from its centre; the
/// closest wins, an orthogonal projection over an edge projection at equal distance. `Ok(None)`:
/// no partner (no candidate, or the closest point lies beyond the end of the surface); `Err` only
/// when there were candidates and the projection failed on every one of them.
pub fn global_search(
    s: &ContactSurface,
    pos: &Positions,
    grid: &BinGrid,
    x: &[f64; 3],
    scratch: &mut Vec<u32>,
) -> Result<Option<Projection>, ProjectionFailed> {
    search(s, pos, grid, x, scratch, None, false)
}

/// [`global_search`] with every element's basis at its centre given (`centres[e]`:
/// [`basis_values`] at `xi = 0`, where each candidate's projection starts), which saves those
/// evaluations, and that skips a candidate whose nodes' hull lies beyond the best point found
/// ([`hull_distance_bound`]); the same result.
pub fn global_search_from(
    s: &ContactSurface,
    pos: &Positions,
    grid: &BinGrid,
    x: &[f64; 3],
    scratch: &mut Vec<u32>,
    centres: Option<&[Vec<f64>]>,
) -> Result<Option<Projection>, ProjectionFailed> {
    search(s, pos, grid, x, scratch, centres, true)
}

/// A lower bound of the distance from `x` to element `e` of `s` (0 where none is known): the
/// element lies in the convex hull of its nodes (linear faces) or of its Bezier points (NURBS with
/// positive weights, [`bezier_points`]; the control points where those do not apply), so no
/// point of it is nearer than those points' least extent along any unit direction from `x`. The
/// directions are those from `x` to the iterates of Frank-Wolfe's minimisation of the distance
/// over the hull, starting at the points' centroid; the largest extent is returned (it tends to
/// the distance to the hull as the iterations go on). The Bezier points of a NURBS element lie
/// around the element itself, its control points around its neighbours as well: a point near the
/// element's edge is then no longer within the neighbour's bound.
#[cfg(test)]
pub(crate) fn hull_distance_bound(
    s: &ContactSurface,
    pos: &Positions,
    e: usize,
    x: &[f64; 3],
) -> f64 {
    hull_distance_bound_to(s, pos, e, x, f64::INFINITY)
}

/// Frank-Wolfe iterations of [`hull_distance_bound`].
const HULL_ITERATIONS: usize = 8;

/// [`hull_distance_bound`], returned as soon as it exceeds `enough`.
pub(crate) fn hull_distance_bound_to(
    s: &ContactSurface,
    pos: &Positions,
    e: usize,
    x: &[f64; 3],
    enough: f64,
) -> f64 {
    let dim = s.dim;
    let nodes = pos.of(e);
    let mut bezier = [0.0; 3 * MAX_FACE_NODES];
    let y = match &s.elements[e].basis {
        FaceBasis::Line2 | FaceBasis::Quad4 => nodes,
        FaceBasis::Nurbs(d) => match bezier_points(d, dim, nodes, None, &mut bezier) {
            Some(n) => &bezier[..n * dim],
            None => nodes,
        },
        _ => return 0.0,
    };
    hull_bound_of(y, dim, x, enough)
}

/// The Frank-Wolfe bound of [`hull_distance_bound`] for the points `y` [n][dim]: a lower bound of
/// the distance from `x` to their convex hull (0 without points), returned as soon as it exceeds
/// `enough`.
fn hull_bound_of(y: &[f64], dim: usize, x: &[f64; 3], enough: f64) -> f64 {
    let n = y.len() / dim;
    if n == 0 {
        return 0.0;
    }
    // z: a point of the hull relative to x, first the nodes' centroid
    let mut z = [0.0; 3];
    for node in y.chunks_exact(dim) {
        for k in 0..dim {
            z[k] += node[k];
        }
    }
    for k in 0..dim {
        z[k] = z[k] / n as f64 - x[k];
    }
    let mut bound = 0.0f64;
    for _ in 0..HULL_ITERATIONS {
        let l = (0..dim).map(|k| z[k] * z[k]).sum::<f64>().sqrt();
        if l.is_nan() || l <= 0.0 {
            break;
        }
        // the node of least extent along z (Frank-Wolfe's vertex); the extent bounds the distance
        let (mut least, mut at) = (f64::INFINITY, 0);
        for (i, node) in y.chunks_exact(dim).enumerate() {
            let t = (0..dim).map(|k| (node[k] - x[k]) * z[k]).sum::<f64>();
            if t < least {
                (least, at) = (t, i);
            }
        }
        bound = bound.max(least / l);
        if bound > enough {
            break;
        }
        // exact line search of |z|^2 from z towards that node
        let v = &y[at * dim..at * dim + dim];
        let mut dz = [0.0; 3];
        for k in 0..dim {
            dz[k] = v[k] - x[k] - z[k];
        }
        let dd = (0..dim).map(|k| dz[k] * dz[k]).sum::<f64>();
        if dd.is_nan() || dd <= 0.0 {
            break;
        }
        let g = (-(0..dim).map(|k| z[k] * dz[k]).sum::<f64>() / dd).clamp(0.0, 1.0);
        if g <= 0.0 {
            break; // z is the hull's closest point: the bound is its distance
        }
        for k in 0..dim {
            z[k] += g * dz[k];
        }
    }
    bound.max(0.0)
}

/// The Bezier points of a NURBS face with control points `nodes` [n][dim] into `out`, their
/// number returned: `Q_b = sum_a C_ab w_a P_a / W_b` with `W_b = sum_a C_ab w_a` (`C` the
/// extraction operator, `N_a = sum_b C_ab B_b`), so that `x(xi) = sum_b B_b W_b Q_b / sum_b B_b
/// W_b`, a convex combination of the `Q_b` where every `W_b > 0` (the Bernstein polynomials are
/// non-negative on the element). Points with `W_b = 0` carry no weight and are left out. The
/// element lies in their hull, a tighter one than its control points' (each `Q_b` is a convex
/// combination of the control points where `C >= 0`). With `side`, only the points of that side
/// (the numbering of [`crate::contact::surface::side_coordinates`]): the only Bernstein polynomials
/// that do not vanish there are theirs, so the side lies in their hull. `None` where some `W_b < 0`
/// or the sizes do not fit.
fn bezier_points(
    d: &crate::fem::enriched::EnrichedElementData,
    dim: usize,
    nodes: &[f64],
    side: Option<usize>,
    out: &mut [f64],
) -> Option<usize> {
    let n = d.weights.len();
    let (wu, wv) = (d.p + 1, d.q + 1);
    if n == 0
        || n != wu * wv
        || nodes.len() != n * dim
        || d.extraction.len() != n * n
        || n * dim > out.len()
    {
        return None;
    }
    let mut used = 0;
    for b in 0..n {
        let (r, t) = (b % wu, b / wu);
        let on_side = match (dim, side) {
            (_, None) => true,
            (2, Some(0)) => r == 0,
            (2, Some(_)) => r == d.p,
            (_, Some(0)) => t == 0,
            (_, Some(1)) => r == d.p,
            (_, Some(2)) => t == d.q,
            (_, Some(_)) => r == 0,
        };
        if !on_side {
            continue;
        }
        let (mut wb, mut q) = (0.0, [0.0; 3]);
        for a in 0..n {
            let c = d.extraction[a * n + b] * d.weights[a];
            wb += c;
            for k in 0..dim {
                q[k] += c * nodes[a * dim + k];
            }
        }
        if wb < 0.0 || !wb.is_finite() {
            return None;
        }
        if wb == 0.0 {
            continue;
        }
        for k in 0..dim {
            out[used * dim + k] = q[k] / wb;
        }
        used += 1;
    }
    (used > 0).then_some(used)
}

/// A lower bound of the distance from `x` to side `side` of element `e` of `s` (the numbering of
/// [`crate::contact::surface::side_coordinates`]), 0 where none is known: the Frank-Wolfe bound of
/// [`hull_distance_bound`] for the side's nodes (linear faces) or Bezier points (NURBS), returned
/// as soon as it exceeds `enough`. A projection held on that side lies no nearer.
pub(crate) fn side_distance_bound(
    s: &ContactSurface,
    pos: &Positions,
    e: usize,
    side: usize,
    x: &[f64; 3],
    enough: f64,
) -> f64 {
    let dim = s.dim;
    if !pos.has(e) {
        return 0.0;
    }
    let nodes = pos.of(e);
    let mut y = [0.0; 3 * MAX_FACE_NODES];
    let n = match &s.elements[e].basis {
        FaceBasis::Line2 => {
            let a = if side == 0 { 0 } else { 1 };
            y[..dim].copy_from_slice(&nodes[a * dim..(a + 1) * dim]);
            1
        }
        FaceBasis::Quad4 => {
            for (j, a) in [side % 4, (side + 1) % 4].into_iter().enumerate() {
                y[j * dim..(j + 1) * dim].copy_from_slice(&nodes[a * dim..(a + 1) * dim]);
            }
            2
        }
        FaceBasis::Nurbs(d) => match bezier_points(d, dim, nodes, Some(side), &mut y) {
            Some(n) => n,
            None => return 0.0,
        },
        _ => return 0.0,
    };
    hull_bound_of(&y[..n * dim], dim, x, enough)
}

/// [`global_search_from`] that keeps the closest point when it lies beyond the end of the surface
/// (an edge or corner projection with [`off_the_edge`]), and that starts from `seed` (a point of
/// the surface already known, as a walk's) as its best point: candidates farther than it are
/// skipped, and it is the answer unless a candidate holds a closer one (with a seed there is
/// always an answer).
pub fn global_closest_from(
    s: &ContactSurface,
    pos: &Positions,
    grid: &BinGrid,
    x: &[f64; 3],
    scratch: &mut Vec<u32>,
    centres: Option<&[Vec<f64>]>,
    seed: Option<Projection>,
) -> Result<Option<Projection>, ProjectionFailed> {
    closest(s, pos, grid, x, scratch, centres, true, seed)
}

/// The global search; `hull`: skip candidates by [`hull_distance_bound`].
fn search(
    s: &ContactSurface,
    pos: &Positions,
    grid: &BinGrid,
    x: &[f64; 3],
    scratch: &mut Vec<u32>,
    centres: Option<&[Vec<f64>]>,
    hull: bool,
) -> Result<Option<Projection>, ProjectionFailed> {
    let best = closest(s, pos, grid, x, scratch, centres, hull, None)?;
    // the closest point of the whole surface decides: beyond its end, no partner
    Ok(best.filter(|b| !off_the_edge(s, b)))
}

/// The closest point of the surface among the candidates (beyond its end too), from `seed`.
#[allow(clippy::too_many_arguments)]
fn closest(
    s: &ContactSurface,
    pos: &Positions,
    grid: &BinGrid,
    x: &[f64; 3],
    scratch: &mut Vec<u32>,
    centres: Option<&[Vec<f64>]>,
    hull: bool,
    seed: Option<Projection>,
) -> Result<Option<Projection>, ProjectionFailed> {
    grid.candidates(&x[..s.dim], scratch);
    // nearest boxes first: once an element's box is farther than the best point found, so are the
    // rest (branch and bound), which skips most Newton projections of a global search
    let mut order: Vec<(f64, u32)> = scratch
        .iter()
        .map(|&e| (grid.distance_lower_bound(e, &x[..s.dim]), e))
        .collect();
    order.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut best: Option<Projection> = seed;
    let mut tried = 0;
    for &(lb, e) in &order {
        if best.is_some_and(|b| lb > b.dist * (1.0 + 1e-10) + 1e-14 * s.h) {
            break;
        }
        // a candidate whose hull is clearly beyond the best point cannot hold a better one (the
        // margin, far above round-off, keeps every candidate that could tie with it)
        if hull
            && best.is_some_and(|b| {
                let enough = b.dist * (1.0 + 1e-8) + 1e-10 * s.h;
                hull_distance_bound_to(s, pos, e as usize, x, enough) > enough
            })
        {
            continue;
        }
        tried += 1;
        let centre = centres.and_then(|c| c.get(e as usize)).map(|c| &c[..]);
        if let Some(p) = project_on_element_from(s, pos, e as usize, x, [0.0; 2], centre) {
            let better = match best {
                None => true,
                Some(b) => {
                    p.dist < b.dist * (1.0 - 1e-10) - 1e-14 * s.h
                        || (p.dist <= b.dist * (1.0 + 1e-10) + 1e-14 * s.h
                            && p.free_count() > b.free_count())
                }
            };
            if better {
                best = Some(p);
            }
        }
    }
    if best.is_none() && tried > 0 {
        return Err(ProjectionFailed);
    }
    Ok(best)
}
