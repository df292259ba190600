//! The contact contribution of one quadrature point of surface `k` (eq. 4 of Corbett & Sauer 2014)
//! and its consistent linearisation with respect to the unknowns of both bodies.
//!
//! With `g = x_k - x_p`, the partner's normal `n` and a law `t(g, n)`, the point adds
//! `r_a = -N_a(xi_k) t J w` to node `a` of its own element (`J` the current or reference area
//! element, `w` the Gauss weight). The tangent needs the variations of `g`, `n` and `J` with respect
//! to every unknown `U` of the element on `k` and of the partner element on `l`:
//! - orthogonal projection (all surface coordinates free): the closest-point condition
//!   `g . a_a = 0` gives `(m_ab - g . a_ab) dxi_b = a_a . (dx_k - N_b dy_b) + g . N_b,a dy_b`, then
//!   `dg = dx_k - N_b dy_b - a_b dxi_b` and `dn = -(n . da_a) a^a` with `da_a = N_b,a dy_b + a_ab dxi_b`
//!   (`a^a = m^ab a_b`); the curvature of the partner enters through `a_ab`.
//! - edge or corner projection of a faceted surface (some coordinates held on the element boundary):
//!   the same condition on the free coordinates only, and the normal along the gap, `n = s g/|g|`,
//!   `dn = s (I - n n) dg / |g|`.
//! - a fixed material pairing (cohesive law): `dg = dx_k - N_b(xi_0) dy_b`, no normal.
//! - a rigid partner: `dg = G dx_k`, `dn = N dx_k` from [`crate::contact::rigid`].
//!
//! One-pass (master/slave) adds the opposite force to the partner (master) element through its
//! shape functions at the projection point, `r_b = +N_b(xi_p) t J w`, whose linearisation also
//! carries `N_b,a dxi_a`.
#![allow(clippy::needless_range_loop)]
#![allow(non_snake_case)]

use crate::contact::law::Traction;
use crate::contact::projection::contract;
use crate::contact::rigid::RigidProjection;
use crate::contact::surface::{raw_normal, SurfaceElement, MAX_FACE_NODES};

/// The quadrature point on surface `k`: its element's basis values there and nodal positions.
pub struct OwnPoint<'a> {
    /// N [n_k]
    pub N: &'a [f64],
    /// dN [n_k][m]
    pub dN: &'a [f64],
    /// Current nodal positions [n_k][dim].
    pub x: &'a [f64],
    /// Gauss weight.
    pub w: f64,
    /// Reference area element `|dX/dxi|` (2D) or `|X_xi x X_eta|` (3D).
    pub J0: f64,
}

/// What the point is paired with.
pub enum PartnerPoint<'a> {
    /// A closest point on a deformable surface element; `free` says which coordinates the
    /// projection left free (all: orthogonal).
    Projected {
        el: &'a SurfaceElement,
        /// Current nodal positions [n_l][dim].
        y: &'a [f64],
        xi: [f64; 2],
        free: [bool; 2],
        /// The closest point of the whole surface, held on its end (the mortar gaps' points
        /// beyond a partner's end): the normal is the gap's own direction `g / |g|`, the gap its
        /// distance, whichever side of the surface's tangent plane the point lies on.
        beyond: bool,
        /// The element's basis at `xi` if known
        /// ([`crate::contact::projection::basis_values`] there): read instead of evaluated.
        basis: Option<&'a [f64]>,
    },
    /// A fixed material point of a deformable surface element (cohesive pairing).
    Material {
        el: &'a SurfaceElement,
        y: &'a [f64],
        xi: [f64; 2],
    },
    /// A rigid partner's closest point.
    Rigid(RigidProjection),
}

/// Which area the law's traction is measured on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Area {
    /// Current area `da` (penalty, eq. 5).
    Current,
    /// Reference area `dA` (van der Waals, cohesive: eqs. 6, 7).
    Reference,
}

/// Coulomb friction at a point (Sauer & De Lorenzis 2015): the current position of the point's
/// anchor on the partner (held fixed within a load step) and the parameters. The trial tangential
/// traction is `-eps_t g_T` with `g_T = (I - n n)(x_k - x_a)`; beyond `mu p_N` (`p_N = t_N . n`,
/// the law's normal pressure) the point slips and the traction is returned onto the cone,
/// `t_T = mu p_N s`, `s = -g_T / |g_T|`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrictionIn {
    pub mu: f64,
    pub eps_t: f64,
    /// Current position of the anchor [3].
    pub anchor: [f64; 3],
}

/// Stick or slip of a frictional point.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum SlipState {
    /// No tangential traction (no normal pressure, or no friction).
    #[default]
    None,
    Stick,
    Slip,
}

/// What friction computed at a point.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct FrictionOut {
    pub state: SlipState,
    /// Tangential traction `t_T` [3] (included in the point's traction).
    pub t_t: [f64; 3],
    /// `d t_T,i / d x_a,j` [3][3] row-major: the derivative with respect to the anchor's position
    /// (the caller chains it with the anchor element's shape functions).
    pub dt_dxa: [f64; 9],
    /// Slip: where the anchor moves, `x_a + g_T - g_T'` with `g_T'` the elastic part of the
    /// tangential gap that the returned traction corresponds to (`t_T = -eps_t g_T'`); not on the
    /// partner surface when it is curved (the caller projects it).
    pub slip_target: [f64; 3],
    /// Tangential gap to the anchor, `g_T = (I - n n)(x_k - x_a)` (trial) [3].
    pub g_t: [f64; 3],
}

/// What a point computed, for forces, moments and output.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct PointResult {
    /// Gap vector [3].
    pub g: [f64; 3],
    /// Normal used [3] (zero for a material pairing).
    pub n: [f64; 3],
    /// Current position of the point [3].
    pub x: [f64; 3],
    /// Force on body k from this point, `t J w` [3].
    pub force: [f64; 3],
    /// True when the traction is not zero.
    pub active: bool,
    /// Friction at the point (state `None` without friction).
    pub friction: FrictionOut,
    /// Normal pressure of the law's traction, `t_N . n`.
    pub p_n: f64,
}

/// Reusable buffers (nothing allocates per quadrature point once they have grown).
#[derive(Default)]
pub struct Scratch {
    dg: Vec<[f64; 3]>,
    dn: Vec<[f64; 3]>,
    dJ: Vec<f64>,
    dxi: Vec<[f64; 2]>,
    dtt: Vec<[f64; 3]>,
    /// Variation of the traction times area `d(t J)` per traction component and column [dim][nc]
    /// (the same for every row node, which only scales it).
    dtJ: Vec<f64>,
}

fn dot(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn cross(a: &[f64; 3], b: &[f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// Partner geometry at `xi`: basis, point, tangents, second derivatives.
struct PartnerGeom {
    N: [f64; MAX_FACE_NODES],
    dN: [f64; 2 * MAX_FACE_NODES],
    p: [f64; 3],
    a: [[f64; 3]; 2],
    aa: [[[f64; 3]; 2]; 2],
    n: usize,
}

/// `known`: the basis at `xi` ([`crate::contact::projection::basis_values`]), read instead of
/// evaluated when given.
fn partner_geom(
    el: &SurfaceElement,
    dim: usize,
    y: &[f64],
    xi: &[f64; 2],
    known: Option<&[f64]>,
) -> PartnerGeom {
    let m = dim - 1;
    let mut g = PartnerGeom {
        N: [0.0; MAX_FACE_NODES],
        dN: [0.0; 2 * MAX_FACE_NODES],
        p: [0.0; 3],
        a: [[0.0; 3]; 2],
        aa: [[[0.0; 3]; 2]; 2],
        n: el.basis.n_nodes(),
    };
    let n = g.n;
    let mut buf = [0.0; 4 * MAX_FACE_NODES];
    let ddN: &[f64] = match known {
        Some(b) if b.len() == n * (1 + m + m * m) => {
            g.N[..n].copy_from_slice(&b[..n]);
            g.dN[..n * m].copy_from_slice(&b[n..n + n * m]);
            &b[n + n * m..]
        }
        _ => {
            el.basis.eval(&xi[..m], &mut g.N, &mut g.dN, &mut buf);
            &buf
        }
    };
    (g.p, g.a, g.aa) = contract(y, (n, dim, m), &g.N, &g.dN, ddN);
    g
}

/// A point's gap and normal towards its partner, with the partner's basis at the projection.
pub struct PartnerGap {
    /// Gap vector [3].
    pub g: [f64; 3],
    /// Normal [3].
    pub n: [f64; 3],
    /// Partner element basis at the projection [n_nodes] (nothing for a rigid partner).
    pub basis: [f64; MAX_FACE_NODES],
    /// Partner element nodes (0: rigid).
    pub n_nodes: usize,
}

/// The gap vector and the normal of a point at `xk` [3] paired with a projected or rigid partner
/// (as [`contact_point_pass`] takes them), and the partner element's basis at the projection.
/// `None` for a material pairing.
pub fn gap_and_normal(dim: usize, xk: &[f64; 3], partner: &PartnerPoint) -> Option<PartnerGap> {
    let m = dim - 1;
    match partner {
        PartnerPoint::Rigid(rp) => Some(PartnerGap {
            g: rp.g,
            n: rp.n,
            basis: [0.0; MAX_FACE_NODES],
            n_nodes: 0,
        }),
        PartnerPoint::Material { .. } => None,
        PartnerPoint::Projected {
            el,
            y,
            xi,
            free,
            basis,
            beyond,
        } => {
            let ge = partner_geom(el, dim, y, xi, *basis);
            let g = [0, 1, 2].map(|k| xk[k] - ge.p[k]);
            let (n, _) = projected_normal(dim, &ge, el.sign, &g, &free[..m], *beyond);
            Some(PartnerGap {
                g,
                n,
                basis: ge.N,
                n_nodes: ge.n,
            })
        }
    }
}

/// The normal at a projection onto a deformable partner: the partner surface's (signed) normal
/// where the projection is orthogonal (every coordinate `free`, or a zero gap), else the normal
/// along the gap (an edge or corner of a faceted partner), signed to the surface's side unless
/// the point lies `beyond` the surface's end (then `g / |g|`). Returns it and whether it is
/// orthogonal.
fn projected_normal(
    dim: usize,
    ge: &PartnerGeom,
    sign: f64,
    g: &[f64; 3],
    free: &[bool],
    beyond: bool,
) -> ([f64; 3], bool) {
    let nr = raw_normal(dim, &ge.a);
    let l = dot(&nr, &nr).sqrt();
    let ns = nr.map(|c| sign * c / l);
    let gl = dot(g, g).sqrt();
    if free.iter().all(|&f| f) || gl == 0.0 {
        (ns, true)
    } else if beyond {
        (g.map(|c| c / gl), false)
    } else {
        let sgn = if dot(g, &ns) >= 0.0 { 1.0 } else { -1.0 };
        (g.map(|c| sgn * c / gl), false)
    }
}

/// The inputs of one point's evaluation.
pub struct PointIn<'a> {
    pub dim: usize,
    pub own: &'a OwnPoint<'a>,
    pub partner: &'a PartnerPoint<'a>,
    /// `law(g, n)`: the traction.
    pub law: &'a dyn Fn(&[f64; 3], &[f64; 3]) -> Traction,
    /// Coulomb friction on top of the law's traction (the anchor's own unknowns are not among the
    /// columns: their block is `-N_a w J dt_dxa N_b(xi_a)`, see [`FrictionOut`]).
    pub friction: Option<&'a FrictionIn>,
    /// The area the law's traction is measured on.
    pub area: Area,
    /// One-pass: the partner element's rows follow the own rows in `r` [(n_k + n_l) * dim] and
    /// `K` [(n_k + n_l) * dim][n_cols] (no effect for a rigid partner).
    pub one_pass: bool,
}

/// Evaluates one point: adds its residual to `r` [n_k*dim] and, if given, its tangent to `K`
/// [n_k*dim][n_cols] row-major, `n_cols = (n_k + n_l) * dim` (own unknowns first, then the partner
/// element's; `n_l = 0` for a rigid partner); see [`PointIn`] for one-pass rows and friction.
pub fn contact_point_pass(
    input: &PointIn,
    r: &mut [f64],
    K: Option<&mut [f64]>,
    s: &mut Scratch,
) -> PointResult {
    let PointIn {
        dim,
        own,
        partner,
        law,
        friction,
        area,
        one_pass,
    } = *input;
    let m = dim - 1;
    let nk = own.N.len();
    // own point, tangents and area element
    let mut xk = [0.0; 3];
    let mut ak = [[0.0; 3]; 2];
    for a in 0..nk {
        for k in 0..dim {
            xk[k] += own.N[a] * own.x[a * dim + k];
            for i in 0..m {
                ak[i][k] += own.dN[a * m + i] * own.x[a * dim + k];
            }
        }
    }
    let nu_raw = raw_normal(dim, &ak);
    let Jc = dot(&nu_raw, &nu_raw).sqrt();
    let J = match area {
        Area::Current => Jc,
        Area::Reference => own.J0,
    };

    // gap and normal
    let (geom, el_sign) = match partner {
        PartnerPoint::Projected {
            el, y, xi, basis, ..
        } => (Some(partner_geom(el, dim, y, xi, *basis)), el.sign),
        PartnerPoint::Material { el, y, xi } => (Some(partner_geom(el, dim, y, xi, None)), el.sign),
        PartnerPoint::Rigid(_) => (None, 1.0),
    };
    let nl = geom.as_ref().map_or(0, |g| g.n);
    let (g, n, orthogonal) = match (partner, &geom) {
        (PartnerPoint::Rigid(rp), _) => (rp.g, rp.n, true),
        (PartnerPoint::Material { .. }, Some(ge)) => {
            ([0, 1, 2].map(|k| xk[k] - ge.p[k]), [0.0; 3], true)
        }
        (PartnerPoint::Projected { free, beyond, .. }, Some(ge)) => {
            let g = [0, 1, 2].map(|k| xk[k] - ge.p[k]);
            let (n, orthogonal) = projected_normal(dim, ge, el_sign, &g, &free[..m], *beyond);
            (g, n, orthogonal)
        }
        _ => unreachable!("a deformable partner always has its geometry"),
    };
    let tr = law(&g, &n);
    // friction on top of the law's normal traction
    let mut fr = FrictionOut::default();
    let p_n = dot(&tr.t, &n);
    let mut fric = None;
    if let Some(f) = friction.filter(|_| p_n > 0.0 && !tr.is_zero()) {
        let (out, state) = friction_return(f, &xk, &n, p_n);
        fr = out;
        fric = Some(state);
    }
    let t_tot = [0, 1, 2].map(|k| tr.t[k] + fr.t_t[k]);
    let mut out = PointResult {
        g,
        n,
        x: xk,
        force: t_tot.map(|c| c * J * own.w),
        active: !tr.is_zero(),
        friction: fr,
        p_n,
    };
    // `active` means "contributes to the residual or the tangent"; resultants count only points
    // that carry traction (a touching point with zero traction contributes stiffness only)
    if !out.active {
        return out;
    }
    for a in 0..nk {
        for i in 0..dim {
            r[a * dim + i] -= own.N[a] * t_tot[i] * J * own.w;
        }
    }
    let master = one_pass && nl > 0;
    if master {
        let ge = geom.as_ref().expect("a deformable partner");
        for b in 0..nl {
            for i in 0..dim {
                r[(nk + b) * dim + i] += ge.N[b] * t_tot[i] * J * own.w;
            }
        }
    }
    let Some(K) = K else {
        return out;
    };

    // variations per column
    let nc = (nk + nl) * dim;
    s.dg.clear();
    s.dg.resize(nc, [0.0; 3]);
    s.dn.clear();
    s.dn.resize(nc, [0.0; 3]);
    s.dJ.clear();
    s.dJ.resize(nc, 0.0);
    s.dxi.clear();
    s.dxi.resize(nc, [0.0; 2]);
    // area element of the current configuration
    if area == Area::Current {
        area_variation(dim, own, &ak, &nu_raw, Jc, s);
    }
    gap_variations(dim, own, partner, geom.as_ref(), (&g, &n, orthogonal), s);
    // variation of the tangential traction per column (the anchor held fixed)
    s.dtt.clear();
    s.dtt.resize(nc, [0.0; 3]);
    if let Some(state) = fric {
        friction_variations(dim, own, &tr, (&n, p_n), &fr, state, s);
    }
    // d(t J) per component and column, once: every row node only scales it
    s.dtJ.clear();
    s.dtJ.resize(dim * nc, 0.0);
    for i in 0..dim {
        for c in 0..nc {
            let mut v = s.dtt[c][i];
            for j in 0..dim {
                v += tr.dt_dg[3 * i + j] * s.dg[c][j] + tr.dt_dn[3 * i + j] * s.dn[c][j];
            }
            s.dtJ[i * nc + c] = v * J + t_tot[i] * s.dJ[c];
        }
    }
    for a in 0..nk {
        for i in 0..dim {
            let row = (a * dim + i) * nc;
            let f = -own.N[a] * own.w;
            for (k, &d) in K[row..row + nc]
                .iter_mut()
                .zip(&s.dtJ[i * nc..(i + 1) * nc])
            {
                *k += f * d;
            }
        }
    }
    if master {
        // rows of the master element: +N_b(xi_p) t J w, with xi_p moving
        let ge = geom.as_ref().expect("a deformable partner");
        for b in 0..nl {
            for i in 0..dim {
                let row = ((nk + b) * dim + i) * nc;
                for c in 0..nc {
                    let dNb: f64 = (0..m).map(|al| ge.dN[b * m + al] * s.dxi[c][al]).sum();
                    K[row + c] += own.w * (ge.N[b] * s.dtJ[i * nc + c] + dNb * t_tot[i] * J);
                }
            }
        }
    }
    out.active = true;
    out
}

/// What the friction variations need of the return mapping: the friction, `d = x_k - x_a`,
/// `n . d`, the trial tangential gap `g_T` and its length.
type FrictionState<'a> = (&'a FrictionIn, [f64; 3], f64, [f64; 3], f64);

/// The return mapping of Coulomb friction at own point `xk` [3] with normal `n` [3] and normal
/// pressure `p_n > 0`: stick within the cone, else slip onto it.
fn friction_return<'a>(
    f: &'a FrictionIn,
    xk: &[f64; 3],
    n: &[f64; 3],
    p_n: f64,
) -> (FrictionOut, FrictionState<'a>) {
    let mut fr = FrictionOut::default();
    let d = [0, 1, 2].map(|k| xk[k] - f.anchor[k]);
    let nd = dot(n, &d);
    let gt = [0, 1, 2].map(|k| d[k] - n[k] * nd);
    let gl = dot(&gt, &gt).sqrt();
    fr.g_t = gt;
    // On the cone (within round-off; where a point that slipped in the last step starts the
    // next one), the slip branch: the traction is the same on both, and its tangent is the
    // one that holds while the point keeps sliding.
    if f.eps_t * gl < f.mu * p_n * (1.0 - 1e-8) {
        fr.state = SlipState::Stick;
        fr.t_t = gt.map(|c| -f.eps_t * c);
        for i in 0..3 {
            for j in 0..3 {
                // d g_T / d x_a = -(I - n n)
                let pij = if i == j { 1.0 } else { 0.0 } - n[i] * n[j];
                fr.dt_dxa[3 * i + j] = f.eps_t * pij;
            }
        }
    } else {
        fr.state = SlipState::Slip;
        let sv = gt.map(|c| -c / gl);
        fr.t_t = sv.map(|c| f.mu * p_n * c);
        let ratio = f.mu * p_n / (f.eps_t * gl);
        fr.slip_target = [0, 1, 2].map(|k| f.anchor[k] + gt[k] * (1.0 - ratio));
        // d s / d x_a = (I - s s)(I - n n) / |g_T|
        for i in 0..3 {
            for j in 0..3 {
                let mut v = 0.0;
                for k in 0..3 {
                    let ss = if i == k { 1.0 } else { 0.0 } - sv[i] * sv[k];
                    let pkj = if k == j { 1.0 } else { 0.0 } - n[k] * n[j];
                    v += ss * pkj;
                }
                fr.dt_dxa[3 * i + j] = f.mu * p_n * v / gl;
            }
        }
    }
    (fr, (f, d, nd, gt, gl))
}

/// The variations of the gap `dg`, normal `dn`, partner coordinates `dxi` per column into `s` (the
/// area element's `dJ` is set by the caller), for the point's partner: rigid, material pairing or
/// closest point (`g`, `n` and whether the normal is the surface's, `orthogonal`).
fn gap_variations(
    dim: usize,
    own: &OwnPoint,
    partner: &PartnerPoint,
    geom: Option<&PartnerGeom>,
    (g, n, orthogonal): (&[f64; 3], &[f64; 3], bool),
    s: &mut Scratch,
) {
    let m = dim - 1;
    let nk = own.N.len();
    let nl = geom.map_or(0, |g| g.n);
    let nc = (nk + nl) * dim;
    match (partner, geom) {
        (PartnerPoint::Rigid(rp), _) => {
            for a in 0..nk {
                for i in 0..dim {
                    let c = a * dim + i;
                    for j in 0..3 {
                        s.dg[c][j] = rp.dg_dx[3 * j + i] * own.N[a];
                        s.dn[c][j] = rp.dn_dx[3 * j + i] * own.N[a];
                    }
                }
            }
        }
        (PartnerPoint::Material { .. }, Some(ge)) => {
            for a in 0..nk {
                for i in 0..dim {
                    s.dg[a * dim + i][i] = own.N[a];
                }
            }
            for b in 0..nl {
                for i in 0..dim {
                    s.dg[(nk + b) * dim + i][i] = -ge.N[b];
                }
            }
        }
        (PartnerPoint::Projected { free, .. }, Some(ge)) => {
            let (mut fr_buf, mut n_fr) = ([0usize; 2], 0);
            for i in (0..m).filter(|&i| free[i]) {
                fr_buf[n_fr] = i;
                n_fr += 1;
            }
            let fr = &fr_buf[..n_fr];
            // A_ff = m_ff - g . a_ff on the free coordinates
            let mut A = [[0.0; 2]; 2];
            for (p, &i) in fr.iter().enumerate() {
                for (q, &j) in fr.iter().enumerate() {
                    A[p][q] = dot(&ge.a[i], &ge.a[j]) - dot(g, &ge.aa[i][j]);
                }
            }
            let det = if fr.len() == 2 {
                A[0][0] * A[1][1] - A[0][1] * A[1][0]
            } else {
                A[0][0]
            };
            // metric and contravariant tangents (orthogonal normal variation)
            let mut M = [[0.0; 2]; 2];
            for i in 0..m {
                for j in 0..m {
                    M[i][j] = dot(&ge.a[i], &ge.a[j]);
                }
            }
            let mut acon = [[0.0; 3]; 2];
            if m == 1 {
                acon[0] = ge.a[0].map(|c| c / M[0][0]);
            } else {
                let dm = M[0][0] * M[1][1] - M[0][1] * M[1][0];
                let mi = [[M[1][1] / dm, -M[0][1] / dm], [-M[1][0] / dm, M[0][0] / dm]];
                for i in 0..2 {
                    for k in 0..3 {
                        acon[i][k] = mi[i][0] * ge.a[0][k] + mi[i][1] * ge.a[1][k];
                    }
                }
            }
            let gl = dot(g, g).sqrt();
            for c in 0..nc {
                let (node, i) = (c / dim, c % dim);
                // dx_k - dx_p(xi fixed), and da_alpha(xi fixed)
                let mut dd = [0.0; 3];
                let mut da = [[0.0; 3]; 2];
                if node < nk {
                    dd[i] = own.N[node];
                } else {
                    let b = node - nk;
                    dd[i] = -ge.N[b];
                    for al in 0..m {
                        da[al][i] = ge.dN[b * m + al];
                    }
                }
                let mut rhs = [0.0; 2];
                for (p, &al) in fr.iter().enumerate() {
                    rhs[p] = dot(&ge.a[al], &dd) + dot(g, &da[al]);
                }
                let mut dxi = [0.0; 2];
                if fr.len() == 1 {
                    dxi[fr[0]] = rhs[0] / det;
                } else if fr.len() == 2 {
                    dxi[0] = (A[1][1] * rhs[0] - A[0][1] * rhs[1]) / det;
                    dxi[1] = (-A[1][0] * rhs[0] + A[0][0] * rhs[1]) / det;
                }
                s.dxi[c] = dxi;
                let mut dg = dd;
                for &be in fr {
                    for k in 0..3 {
                        dg[k] -= ge.a[be][k] * dxi[be];
                    }
                }
                s.dg[c] = dg;
                if orthogonal {
                    let mut dn = [0.0; 3];
                    for al in 0..m {
                        let mut dal = da[al];
                        for &be in fr {
                            for k in 0..3 {
                                dal[k] += ge.aa[al][be][k] * dxi[be];
                            }
                        }
                        let nd = dot(n, &dal);
                        for k in 0..3 {
                            dn[k] -= nd * acon[al][k];
                        }
                    }
                    s.dn[c] = dn;
                } else {
                    // n = s g/|g| with s = sign(g . n)
                    let sg = if dot(g, n) >= 0.0 { 1.0 } else { -1.0 };
                    let ndg = dot(n, &dg);
                    s.dn[c] = [0, 1, 2].map(|k| sg * (dg[k] - n[k] * ndg) / gl);
                }
            }
        }
        _ => unreachable!(),
    }
}

/// The variation of the tangential traction per column into `s.dtt` (the anchor held fixed),
/// from the gap and normal variations.
fn friction_variations(
    dim: usize,
    own: &OwnPoint,
    tr: &Traction,
    (n, p_n): (&[f64; 3], f64),
    fr: &FrictionOut,
    (f, d, nd, gt, gl): FrictionState,
    s: &mut Scratch,
) {
    let nk = own.N.len();
    let nc = s.dg.len();
    for c in 0..nc {
        let (node, i) = (c / dim, c % dim);
        let (dg, dn) = (&s.dg[c], &s.dn[c]);
        // d x_k for this column (the partner's nodes move x_k not at all)
        let mut dd = [0.0; 3];
        if node < nk {
            dd[i] = own.N[node];
        }
        // d g_T = (I - n n) dd - (n . d) dn - n (d . dn)
        let ndd = dot(n, &dd);
        let ddn = dot(&d, dn);
        let dgt = [0, 1, 2].map(|k| dd[k] - n[k] * ndd - nd * dn[k] - n[k] * ddn);
        s.dtt[c] = match fr.state {
            SlipState::Stick => dgt.map(|v| -f.eps_t * v),
            _ => {
                // p_N = t_N . n: d p_N = n . (dt/dg dg + dt/dn dn) + t_N . dn
                let mut dp = dot(&tr.t, dn);
                for i2 in 0..3 {
                    let mut v = 0.0;
                    for j in 0..3 {
                        v += tr.dt_dg[3 * i2 + j] * dg[j] + tr.dt_dn[3 * i2 + j] * dn[j];
                    }
                    dp += n[i2] * v;
                }
                let sv = gt.map(|c| -c / gl);
                let sdg = dot(&sv, &dgt);
                [0, 1, 2].map(|k| f.mu * sv[k] * dp - f.mu * p_n * (dgt[k] - sv[k] * sdg) / gl)
            }
        };
    }
}

/// The variation of the current area element `Jc` per own column into `s.dJ` (tangents `ak`, raw
/// normal `nu_raw`).
fn area_variation(
    dim: usize,
    own: &OwnPoint,
    ak: &[[f64; 3]; 2],
    nu_raw: &[f64; 3],
    Jc: f64,
    s: &mut Scratch,
) {
    let m = dim - 1;
    let nk = own.N.len();
    let nu = nu_raw.map(|c| c / Jc);
    let (c1, c2) = if dim == 2 {
        (ak[0].map(|c| c / Jc), [0.0; 3])
    } else {
        (cross(&ak[1], &nu), cross(&nu, &ak[0]))
    };
    for a in 0..nk {
        for i in 0..dim {
            let mut v = own.dN[a * m] * c1[i];
            if dim == 3 {
                v += own.dN[a * m + 1] * c2[i];
            }
            s.dJ[a * dim + i] = v;
        }
    }
}
