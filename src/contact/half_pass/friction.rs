//! The friction part of a half-pass (Coulomb, Sauer & De Lorenzis 2015): the committed anchor's
//! current position, its tangent block, and where the point sticks from the next step on. The
//! return mapping itself is in the point kernel ([`crate::contact::kernel`]).
#![allow(clippy::needless_range_loop)]
#![allow(non_snake_case)]

use super::{point_area, HalfPass, PassResult, PointOut, QPoint, Work};
use crate::contact::kernel::{FrictionIn, FrictionOut, OwnPoint, PointResult, SlipState};
use crate::contact::pair::{Anchor, Friction};
use crate::contact::projection::{walk, Absent};
use crate::contact::surface::MAX_FACE_NODES;

/// A point's committed anchor at the current state.
pub(crate) struct AnchorAt {
    pub fin: FrictionIn,
    /// On a deformable partner: the anchor element, its basis values at the anchor and its node
    /// count (for the anchor's tangent block).
    el: Option<(u32, [f64; MAX_FACE_NODES], usize)>,
}

/// The current position of anchor `a` with friction `f` (`None` when the anchor does not fit the
/// partner).
pub(super) fn anchor_at(hp: &HalfPass, f: &Friction, a: Anchor) -> Option<AnchorAt> {
    let (dim, m) = (hp.geo.dim, hp.geo.dim - 1);
    let mut el = None;
    let xa = match (a, hp.l, hp.motion) {
        (Anchor::Surface(la, xia), Some(l), _) => {
            // held by construction: an update requests every anchor element it does not hold,
            // and the assembler refreshes the ghost layer before any evaluation
            if !hp.geo.pos[l].has(la as usize) {
                return None;
            }
            let ela = &hp.geo.surfaces[l].elements[la as usize];
            let ya = hp.geo.pos[l].of(la as usize);
            let (mut Na, mut dNa, mut ddNa) = (
                [0.0; MAX_FACE_NODES],
                [0.0; 2 * MAX_FACE_NODES],
                [0.0; 4 * MAX_FACE_NODES],
            );
            ela.basis.eval(&xia[..m], &mut Na, &mut dNa, &mut ddNa);
            let na = ela.basis.n_nodes();
            let mut xa = [0.0; 3];
            for b in 0..na {
                for c in 0..dim {
                    xa[c] += Na[b] * ya[b * dim + c];
                }
            }
            el = Some((la, Na, na));
            Some(xa)
        }
        (Anchor::Rigid(X), None, Some(mo)) => Some(mo.apply(&X, hp.pair.lambda)),
        _ => None,
    };
    xa.map(|anchor| AnchorAt {
        fin: FrictionIn {
            mu: f.mu,
            eps_t: f.eps_t,
            anchor,
        },
        el,
    })
}

/// The block of the own element's rows and the anchor element's columns, `-N_a w J dt_dxa N_b`
/// (see [`FrictionOut`]), when the point has tangential traction. One-pass (`master`: the
/// point's partner element and its basis at the projection): the master rows carry the opposite,
/// `+N^l_c w J dt_dxa N_b`, a cross block of the partner's rows and the anchor element's columns
/// (the anchor block's own rows are then followed by the anchor element's, zero here).
pub(super) fn anchor_block(
    hp: &HalfPass,
    own: &OwnPoint,
    at: &AnchorAt,
    fo: &FrictionOut,
    master: Option<(u32, &[f64])>,
    work: &mut Work,
) {
    let Some((la, Na, na)) = at.el else {
        return;
    };
    if fo.state == SlipState::None {
        return;
    }
    let dim = hp.geo.dim;
    let nk = own.N.len();
    let nca = (nk + na) * dim;
    let one_pass = hp.pair.formulation.one_pass() && hp.l.is_some();
    let nrows = if one_pass { nca } else { nk * dim };
    let ib = work.block(la, nrows * nca);
    let kb = &mut work.blocks[ib].1;
    let Jw = point_area(dim, own) * own.w;
    for a in 0..nk {
        for i in 0..dim {
            let row = (a * dim + i) * nca;
            for b in 0..na {
                for j in 0..dim {
                    kb[row + (nk + b) * dim + j] -= own.N[a] * Jw * fo.dt_dxa[3 * i + j] * Na[b];
                }
            }
        }
    }
    let Some((le, Nl)) = master else {
        return;
    };
    let nl = Nl.len();
    let ncols = na * dim;
    let ic = super::mortar::cross_slot(work, le, la, nl * dim * ncols);
    let kc = &mut work.cross[ic].2;
    for c in 0..nl {
        for i in 0..dim {
            let row = (c * dim + i) * ncols;
            for b in 0..na {
                for j in 0..dim {
                    kc[row + b * dim + j] += Nl[c] * Jw * fo.dt_dxa[3 * i + j] * Na[b];
                }
            }
        }
    }
}

/// An active frictional contribution: the point's state and tangential output, the pass's
/// stick/slip counts and tangential force, and the anchor this evaluation leads to.
pub(super) fn record(
    hp: &HalfPass,
    own: &OwnPoint,
    qp: &QPoint,
    pr: &PointResult,
    res: &mut PassResult,
    po: &mut PointOut,
) {
    let fo = &pr.friction;
    po.slip = fo.state;
    (po.t_t, po.g_t) = (fo.t_t, fo.g_t);
    res.n_stick += (fo.state == SlipState::Stick) as usize;
    res.n_slip += (fo.state == SlipState::Slip) as usize;
    let Jw = point_area(hp.geo.dim, own) * qp.w;
    for c in 0..3 {
        res.tangential[c] += fo.t_t[c] * Jw;
    }
    // where the point sticks from the next step on
    let xp = [0, 1, 2].map(|c| pr.x[c] - pr.g[c]);
    let target = match fo.state {
        SlipState::Stick => None,
        SlipState::Slip => Some(fo.slip_target),
        SlipState::None => Some(xp),
    };
    po.anchor_trial = match (target, hp.l, hp.shape, hp.motion) {
        (None, ..) => qp.committed.anchor,
        (Some(t), Some(l), ..) => {
            let start = qp.current.map(|p| (p.elem, p.xi));
            let onto = if fo.state == SlipState::Slip {
                match start.map(|w| walk(&hp.geo.surfaces[l], &hp.geo.pos[l], &t, w)) {
                    Some(Ok(p)) => p,
                    Some(Err(Absent(f))) => {
                        po.absent = Some(f);
                        None
                    }
                    None => None,
                }
            } else {
                None
            };
            match onto {
                Some(p) => Some(Anchor::Surface(p.elem, p.xi)),
                None => start.map(|(e, xi)| Anchor::Surface(e, xi)),
            }
        }
        (Some(t), None, Some(shape), Some(mo)) => {
            let on = shape
                .project(&t)
                .map(|rp| [0, 1, 2].map(|c| t[c] - rp.g[c]))
                .unwrap_or(xp);
            Some(Anchor::Rigid(mo.inverse(&on, hp.pair.lambda)))
        }
        _ => None,
    };
}
