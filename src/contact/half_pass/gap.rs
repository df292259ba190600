//! The gap part of a half-pass: where the penalty law's normal gap is taken (`gap`). Pointwise
//! (each point its own gap, the paper's) or `element_mean` (one pressure per own surface element,
//! [`super::element_mean`]) or `weighted` (one pressure per control point of the surface,
//! [`super::mortar`]).
#![allow(clippy::needless_range_loop)]
#![allow(non_snake_case)]

use super::element_mean::{ElementMean, MeanPoint};
use super::mortar::MortarNet;
use super::{block_slot, point_area, HalfPass, OwnElem, QPoint, Work};
use crate::contact::formulation::Pressure;
use crate::contact::kernel::{gap_and_normal, OwnPoint, PointResult, SlipState};
use crate::contact::law::{self, Traction};
use crate::contact::pair::Law;

/// How a half-pass takes the penalty law's normal gap.
pub(crate) enum Gap<'a> {
    /// Each point's own gap.
    Pointwise,
    /// The element's mean pressure, as an equivalent gap (its buffers).
    ElementMean(ElementMean),
    /// The control points' pressures (the pass's control net, with its evaluation state).
    Mortar(&'a mut MortarNet),
}

impl<'a> Gap<'a> {
    /// The gap part of `kind`; the mortar gap uses the pass's control net `net`.
    pub(super) fn new(kind: Pressure, net: Option<&'a mut MortarNet>) -> Gap<'a> {
        match (kind, net) {
            (Pressure::ElementMean, _) => Gap::ElementMean(ElementMean::default()),
            (Pressure::NodalWeights { .. }, Some(net)) => Gap::Mortar(net),
            _ => Gap::Pointwise,
        }
    }

    /// Before the elements of an evaluation (`all`: the pass's own elements, then its halo): the
    /// mortar gap's control-point pressures.
    pub(super) fn begin_pass(&mut self, hp: &HalfPass, all: &[&OwnElem], points: &[QPoint]) {
        if let (Gap::Mortar(net), Law::Penalty { eps_n }) = (self, hp.pair.formulation.law) {
            net.begin(hp, all, points, eps_n);
        }
    }

    /// The pressure the weight nodes give point `j` (of the element's points) of own element
    /// `i`, under the mortar gap.
    pub(super) fn mortar_pressure(&self, i: usize, j: usize) -> Option<f64> {
        match self {
            Gap::Mortar(net) => Some(net.pressure(i, j)),
            _ => None,
        }
    }

    /// In a Jacobian evaluation, after the points of own element `i`: the mortar gap's
    /// control-point terms.
    pub(super) fn end_element(
        &mut self,
        hp: &HalfPass,
        i: usize,
        all: &[&OwnElem],
        points: &[QPoint],
        work: &mut Work,
    ) {
        if let (Gap::Mortar(net), Law::Penalty { eps_n }, true) =
            (self, hp.pair.formulation.law, hp.jacobian)
        {
            net.end_element(hp, i, all, points, eps_n, work);
        }
    }

    /// Before the points of own element `oe` (current nodes `x`): the element's equivalent gap
    /// `-p / eps_n` of its mean pressure, if the mode has one and some point touches.
    pub(super) fn begin_element(
        &mut self,
        hp: &HalfPass,
        oe: &OwnElem,
        points: &[QPoint],
        x: &[f64],
    ) -> Option<f64> {
        let Gap::ElementMean(mean) = self else {
            return None;
        };
        let dim = hp.geo.dim;
        let nk = hp.geo.surfaces[hp.k].elements[oe.e as usize]
            .basis
            .n_nodes();
        let area: f64 = (oe.first..oe.first + oe.n)
            .map(|q| points[q].w * points[q].J0)
            .sum();
        mean.start(nk, area);
        for q in oe.first..oe.first + oe.n {
            let qp = points[q];
            let (bN, _) = oe.basis(q);
            let mut xk = [0.0; 3];
            for a in 0..nk {
                for c in 0..dim {
                    xk[c] += bN[a] * x[a * dim + c];
                }
            }
            let Some((le, pp)) = hp.partner(qp.current, &xk, None) else {
                continue;
            };
            if let Some(pg) = gap_and_normal(dim, &xk, &pp) {
                let (g, n) = (pg.g, pg.n);
                let g_n = g[0] * n[0] + g[1] * n[1] + g[2] * n[2];
                let c = qp.w * qp.J0;
                let p = MeanPoint {
                    q,
                    le,
                    n,
                    nl_vals: pg.basis,
                    nl: pg.n_nodes,
                    c,
                    active: false,
                };
                mean.add(p, &bN[..nk], g_n, hp.touch);
            }
        }
        if mean.finish() {
            Some(mean.g)
        } else {
            None
        }
    }

    /// After the kernel of point `q` (result `pr`) in a Jacobian evaluation: the tangent terms of
    /// the equivalent gap `g_mean` that the kernel, taking the point's own gap, leaves out.
    pub(super) fn correct(
        &self,
        hp: &HalfPass,
        own: &OwnPoint,
        q: usize,
        pr: &PointResult,
        g_mean: Option<f64>,
        work: &mut Work,
    ) {
        let (Gap::ElementMean(mean), Some(gm), Law::Penalty { eps_n }) =
            (self, g_mean, hp.pair.formulation.law)
        else {
            return;
        };
        if gm <= hp.touch {
            let dim = hp.geo.dim;
            let jw = point_area(dim, own) * own.w;
            // d t / d p: the normal, plus the slip direction in slip
            let fo = &pr.friction;
            let d = if fo.state == SlipState::Slip && pr.p_n > 0.0 {
                [0, 1, 2].map(|c| pr.n[c] + fo.t_t[c] / pr.p_n)
            } else {
                pr.n
            };
            let n_used = &mut work.n_used;
            mean.correct(
                dim,
                q,
                own.N,
                jw,
                eps_n,
                d,
                &mut work.blocks,
                &mut |b: &mut super::Blocks, le, len| block_slot(b, n_used, le, len),
            );
        }
    }
}

/// The penalty traction at the point's gap moved along its normal to the element's equivalent
/// gap `gm`.
pub(super) fn mean_penalty(
    eps_n: f64,
    touch: f64,
    gm: f64,
    g: &[f64; 3],
    n: &[f64; 3],
) -> Traction {
    let gn = g[0] * n[0] + g[1] * n[1] + g[2] * n[2];
    let gs = [0, 1, 2].map(|i| g[i] + (gm - gn) * n[i]);
    law::penalty(eps_n, touch, &gs, n)
}
