//! The one walk over the points a rank integrates in passes against a surface partner, and the
//! global search on the partner: the projection of every point (`ContactSystem::update`) and the
//! cohesive pairings of the reference configuration (`setup.rs`) both go through it.

use super::ContactSystem;
use crate::contact::pair::{PairDef, Partner};
use crate::contact::projection::{off_the_edge, side_distance_bound, Projection, ProjectionFailed};

/// A point of a pass against a surface partner, as [`ContactSystem::for_each_partner_point`]
/// hands it out.
#[derive(Debug, Clone, Copy)]
pub(super) struct PartnerPoint {
    /// The pair.
    pub(super) pair: usize,
    /// Its pass.
    pub(super) pass: usize,
    /// The point's index in the pass.
    pub(super) q: usize,
    /// The integrated surface.
    pub(super) k: usize,
    /// Its element that holds the point.
    pub(super) e: usize,
    /// The partner surface.
    pub(super) l: usize,
    /// Current position of the point.
    pub(super) x: [f64; 3],
}

impl ContactSystem {
    /// Calls `f` on every point this rank integrates in a pass against a surface partner, of the
    /// pairs `select` takes, and on the points of the passes' halos (the mortar gap's): pair by
    /// pair, pass by pass, own element by own element, then halo element by halo element, in
    /// point order, with the point's current position. `f` may change anything but the passes' points
    /// and elements lists (it sets the points' projections); its first error ends the walk.
    pub(super) fn for_each_partner_point(
        &mut self,
        select: impl Fn(&PairDef) -> bool,
        mut f: impl FnMut(&mut Self, PartnerPoint) -> Result<(), String>,
    ) -> Result<(), String> {
        for pair in 0..self.pairs.len() {
            if !select(&self.pairs[pair].def) {
                continue;
            }
            for pass in 0..self.pairs[pair].passes.len() {
                let Partner::Surface(l) = self.pairs[pair].passes[pass].partner else {
                    continue;
                };
                let k = self.pairs[pair].passes[pass].k;
                let n_own = self.pairs[pair].passes[pass].elems.len();
                let n_halo = self.pairs[pair].passes[pass].halo.len();
                for oe in 0..n_own + n_halo {
                    let ps = &self.pairs[pair].passes[pass];
                    let o = ps.elems.get(oe).unwrap_or_else(|| &ps.halo[oe - n_own]);
                    let (e, first, n) = (o.e as usize, o.first, o.n);
                    for q in first..first + n {
                        let ps = &self.pairs[pair].passes[pass];
                        let o = ps.elems.get(oe).unwrap_or_else(|| &ps.halo[oe - n_own]);
                        let x = o.position(q, self.pos[k].of(e), self.dim);
                        let pt = PartnerPoint {
                            pair,
                            pass,
                            q,
                            k,
                            e,
                            l,
                            x,
                        };
                        f(self, pt)?;
                    }
                }
            }
        }
        Ok(())
    }

    /// The closest point to `x` on surface `l` by the global search in its bin grid, built for
    /// the search distance `dist` if the surface has none at its current positions.
    pub(super) fn search_partner(
        &mut self,
        l: usize,
        x: &[f64; 3],
        dist: f64,
    ) -> Result<Option<Projection>, ProjectionFailed> {
        // the closest point of the whole surface decides: beyond its end, no partner
        let best = self.closest_partner(l, x, dist, None)?;
        Ok(best.filter(|b| !off_the_edge(&self.surfaces[l], b)))
    }

    /// Whether the closest point of surface `l` to `x` may lie beyond the surface's end when
    /// `seed` (a point of the surface within the search distance `dist`, not beyond its end) is
    /// known: false when no candidate of the global search ([`Self::closest_partner`]) has a side
    /// without a neighbour within the seed's distance (with a margin far above the search's
    /// tolerances). The search's closest point is then the seed or a point inside the surface, and
    /// `closest_partner(l, x, dist, Some(seed))` need not run to tell that it is not beyond the end.
    pub(super) fn end_may_be_closest(
        &mut self,
        l: usize,
        x: &[f64; 3],
        dist: f64,
        seed: &Projection,
    ) -> bool {
        self.ensure_grid(l, dist);
        let grid = self.grids[l].as_ref().expect("built above");
        let s = &self.surfaces[l];
        grid.candidates(&x[..s.dim], &mut self.cand);
        let enough = seed.dist * (1.0 + 1e-8) + 1e-10 * s.h;
        self.cand.iter().any(|&e| {
            let el = &s.elements[e as usize];
            (0..el.neighbours.len()).any(|side| {
                el.neighbours[side].is_none()
                    && side_distance_bound(s, &self.pos[l], e as usize, side, x, enough) <= enough
            })
        })
    }

    /// The closest point of surface `l` to `x` (beyond the surface's end too), from `seed`:
    /// [`crate::contact::projection::global_closest_from`].
    pub(super) fn closest_partner(
        &mut self,
        l: usize,
        x: &[f64; 3],
        dist: f64,
        seed: Option<Projection>,
    ) -> Result<Option<Projection>, ProjectionFailed> {
        self.ensure_grid(l, dist);
        let grid = self.grids[l].as_ref().expect("built above");
        let centres = self.centres.get(l).map(|c| &c[..]);
        crate::contact::projection::global_closest_from(
            &self.surfaces[l],
            &self.pos[l],
            grid,
            x,
            &mut self.cand,
            centres,
            seed,
        )
    }
}
