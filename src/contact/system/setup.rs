//! Setting up the pairs of a [`ContactSystem`]: the node table, the quadrature points each rank
//! integrates, and the cohesive material pairings of the reference configuration.
#![allow(non_snake_case)]

use super::{ContactSystem, Pair};
use crate::assembly::DofMap;
use crate::contact::formulation::Pressure;
use crate::contact::half_pass::mortar::MortarNet;
use crate::contact::half_pass::{OwnElem, Pass, PassResult, QPoint};
use crate::contact::pair::{Law, PairDef, Partner};
use crate::contact::projection::{basis_values, Positions};
use crate::contact::surface::{raw_normal, ContactSurface, MAX_FACE_NODES};
use crate::fem::quadrature::tensor_rule;
use std::collections::HashMap;

impl ContactSystem {
    /// Sets up the pairs on `surfaces`; this rank integrates the surface elements of the cells
    /// `cell_part` gives it. Cohesive pairings are found here, in the reference configuration,
    /// where every rank still holds every element; then the node table is limited to the elements
    /// this rank holds (`ghost.rs`).
    pub fn new(
        dim: usize,
        surfaces: Vec<ContactSurface>,
        defs: Vec<PairDef>,
        coords: &[f64],
        dofs: &DofMap,
        cell_part: &[u32],
        rank: usize,
    ) -> Result<ContactSystem, String> {
        let mut table: Vec<u32> = surfaces
            .iter()
            .flat_map(|s| s.elements.iter().flat_map(|e| e.nodes.iter().copied()))
            .collect();
        table.sort_unstable();
        table.dedup();
        let X: Vec<f64> = table
            .iter()
            .flat_map(|&a| coords[a as usize * dim..(a as usize + 1) * dim].to_vec())
            .collect();
        let index: HashMap<u32, u32> = table
            .iter()
            .enumerate()
            .map(|(i, &a)| (a, i as u32))
            .collect();
        let slots: Vec<Vec<Vec<u32>>> = surfaces
            .iter()
            .map(|s| {
                s.elements
                    .iter()
                    .map(|e| e.nodes.iter().map(|a| index[a]).collect())
                    .collect()
            })
            .collect();
        let gdofs: Vec<Vec<Vec<i32>>> = surfaces
            .iter()
            .map(|s| {
                s.elements
                    .iter()
                    .map(|e| {
                        e.nodes
                            .iter()
                            .flat_map(|&a| (0..dim).map(move |c| (a, c)))
                            .map(|(a, c)| dofs.global(a, c).map_or(-1, |g| g.0))
                            .collect()
                    })
                    .collect()
            })
            .collect();
        let centres = surfaces
            .iter()
            .map(|s| {
                s.elements
                    .iter()
                    .map(|el| {
                        let mut b = Vec::new();
                        basis_values(&el.basis, &[0.0; 2], &mut b);
                        b
                    })
                    .collect()
            })
            .collect();
        let mut sys = ContactSystem {
            dim,
            pos: vec![Positions::default(); surfaces.len()],
            grids: vec![None; surfaces.len()],
            centres,
            surfaces,
            all_nodes: table.clone(),
            all_X: X.clone(),
            ghost: Default::default(),
            table,
            X,
            slots,
            gdofs,
            pairs: Vec::new(),
            lambda: 0.0,
            cand: Vec::new(),
            work: Default::default(),
            last_update: None,
        };
        sys.work.r_table = vec![0.0; sys.table.len() * dim];
        sys.update_positions(&vec![0.0; sys.X.len()]);
        for def in defs {
            let mut passes = Vec::new();
            for (k, partner) in &def.passes {
                let k = *k;
                let mut points = Vec::new();
                let mut elems = Vec::new();
                let n_el = sys.surfaces[k].elements.len();
                let segments = match partner {
                    Partner::Surface(l) if super::segments::segmented(&def, dim, partner) => {
                        let n_g = sys.surfaces[k]
                            .elements
                            .iter()
                            .map(|el| el.basis.quadrature_counts()[0])
                            .max()
                            .unwrap_or(1);
                        Some(sys.segment_rule(k, *l, n_g, &def.formulation.pressure))
                    }
                    _ => None,
                };
                let per = segments.as_ref().map(|s| s.per_element());
                for e in 0..n_el {
                    if cell_part[sys.surfaces[k].elements[e].cell] as usize == rank {
                        elems.extend(sys.surface_points(&def, k, e, dofs, per, &mut points)?);
                    }
                }
                let (halo, mortar) =
                    if let Pressure::NodalWeights { mean, .. } = def.formulation.pressure {
                        let linear = def.formulation.pressure.linear_parent();
                        let halo = sys.halo(&def, k, linear, &elems, dofs, per, &mut points)?;
                        let all: Vec<&OwnElem> = elems.iter().chain(&halo).collect();
                        let nodes: Vec<Vec<u32>> = all
                            .iter()
                            .map(|o| sys.weight_nodes(k, o.e, linear))
                            .collect();
                        let phi = all
                            .iter()
                            .map(|o| weight_values(dim, o, &points, linear))
                            .collect();
                        let mut net = MortarNet::new(&nodes, phi, &elems, &halo, &points);
                        net.mean = mean;
                        (halo, Some(net))
                    } else {
                        (Vec::new(), None)
                    };
                passes.push(Pass {
                    k,
                    partner: partner.clone(),
                    points,
                    elems,
                    halo,
                    mortar,
                    segments,
                    shape: None,
                    result: PassResult::default(),
                    bases: Vec::new(),
                });
            }
            sys.pairs.push(Pair { def, passes });
        }
        sys.pair_cohesive()?;
        sys.init_ghosts(cell_part, rank);
        Ok(sys)
    }

    /// The quadrature points of element `e` of surface `k` inside the pair's region, appended to
    /// `points`, and the element that holds them (`None`: none inside the region). With `per`
    /// (segmented passes), padded to `per` points by unused slots of weight 0, which the first
    /// update places on the element's segments.
    fn surface_points(
        &self,
        def: &PairDef,
        k: usize,
        e: usize,
        dofs: &DofMap,
        per: Option<usize>,
        points: &mut Vec<QPoint>,
    ) -> Result<Option<OwnElem>, String> {
        let dim = self.dim;
        let el = &self.surfaces[k].elements[e];
        let rule = tensor_rule(&el.basis.quadrature_counts()).map_err(|e| e.to_string())?;
        let first = points.len();
        let m = dim - 1;
        let nk = el.basis.n_nodes();
        let Xe = self.pos[k].of(e);
        let (mut bN, mut bdN) = (Vec::new(), Vec::new());
        let (mut N, mut dN, mut ddN) = (
            [0.0; MAX_FACE_NODES],
            [0.0; 2 * MAX_FACE_NODES],
            [0.0; 4 * MAX_FACE_NODES],
        );
        for (q, xi) in rule.points.chunks_exact(m).enumerate() {
            let mut x2 = [0.0; 2];
            x2[..m].copy_from_slice(xi);
            let (xr, a, _) = crate::contact::surface::frame(el, dim, Xe, &x2);
            if def.region.as_ref().is_some_and(|b| !b.contains(&xr[..dim])) {
                continue;
            }
            el.basis.eval(&x2[..m], &mut N, &mut dN, &mut ddN);
            bN.extend_from_slice(&N[..nk]);
            bdN.extend_from_slice(&dN[..nk * m]);
            let nu = raw_normal(dim, &a);
            let J0 = (nu[0] * nu[0] + nu[1] * nu[1] + nu[2] * nu[2]).sqrt();
            points.push(QPoint {
                xi: x2,
                w: rule.weights[q],
                J0,
                X: xr,
                ..Default::default()
            });
        }
        if points.len() == first {
            return Ok(None); // outside the pair's region
        }
        if let Some(per) = per {
            el.basis.eval(&[0.0; 2][..m], &mut N, &mut dN, &mut ddN);
            while points.len() - first < per {
                bN.extend_from_slice(&N[..nk]);
                bdN.extend_from_slice(&dN[..nk * m]);
                points.push(QPoint::default());
            }
        }
        let local = self.gdofs[k][e]
            .iter()
            .map(|&g| {
                dofs.local(crate::assembly::GlobalDof(g))
                    .map_or(u32::MAX, |l| l.0)
            })
            .collect();
        Ok(Some(OwnElem {
            e: e as u32,
            first,
            n: points.len() - first,
            slots: points.len() - first,
            local,
            N: bN,
            dN: bdN,
        }))
    }

    /// The mortar gap's weight nodes of element `e` of surface `k` (global ids): its control
    /// points, or with `linear` its linear parent's corners.
    fn weight_nodes(&self, k: usize, e: u32, linear: bool) -> Vec<u32> {
        let el = &self.surfaces[k].elements[e as usize];
        if linear {
            el.corners.clone()
        } else {
            el.nodes.clone()
        }
    }

    /// The mortar gap's halo of `elems` on surface `k`: the elements of other ranks that share a
    /// weight node with them, with their points appended to `points` (in element order; `per` as
    /// [`ContactSystem::surface_points`]).
    #[allow(clippy::too_many_arguments)]
    fn halo(
        &self,
        def: &PairDef,
        k: usize,
        linear: bool,
        elems: &[OwnElem],
        dofs: &DofMap,
        per: Option<usize>,
        points: &mut Vec<QPoint>,
    ) -> Result<Vec<OwnElem>, String> {
        let own: std::collections::HashSet<u32> = elems.iter().map(|o| o.e).collect();
        let cps: std::collections::HashSet<u32> = elems
            .iter()
            .flat_map(|o| self.weight_nodes(k, o.e, linear))
            .collect();
        let mut halo = Vec::new();
        for e in 0..self.surfaces[k].elements.len() as u32 {
            if own.contains(&e)
                || !self
                    .weight_nodes(k, e, linear)
                    .iter()
                    .any(|t| cps.contains(t))
            {
                continue;
            }
            halo.extend(self.surface_points(def, k, e as usize, dofs, per, points)?);
        }
        Ok(halo)
    }

    /// Material point pairing of cohesive pairs, in the reference configuration (positions are
    /// still the reference ones).
    fn pair_cohesive(&mut self) -> Result<(), String> {
        let cohesive = |d: &PairDef| matches!(d.formulation.law, Law::Cohesive { .. });
        // the partners' grids before any search, in pass order: the first pass that meets a
        // surface sizes its grid with its pair's search distance
        for pair in 0..self.pairs.len() {
            if !cohesive(&self.pairs[pair].def) {
                continue;
            }
            let dist = self.pairs[pair].def.search_distance;
            for pass in 0..self.pairs[pair].passes.len() {
                if let Partner::Surface(l) = self.pairs[pair].passes[pass].partner {
                    self.ensure_grid(l, dist);
                }
            }
        }
        self.for_each_partner_point(cohesive, |sys, pt| {
            let def = &sys.pairs[pt.pair].def;
            let dist = def.search_distance;
            if let Some(b) = &def.debonded {
                if b.contains(&pt.x[..sys.dim]) {
                    return Ok(());
                }
            }
            let p = sys.search_partner(pt.l, &pt.x, dist).ok().flatten();
            if let Some(p) = p.filter(|p| p.dist <= dist) {
                sys.pairs[pt.pair].passes[pt.pass].points[pt.q].pairing = Some((p.elem, p.xi));
            }
            Ok(())
        })
    }
}

/// The mortar gap's weight functions at the points of `oe` [n_points][n_weight_nodes]: the
/// element's surface basis, or with `linear` its linear parent's corner functions (2D corners at
/// xi = -1, +1; 3D bilinear, corners (-1,-1), (1,-1), (1,1), (-1,1), as `SurfaceElement::corners`).
fn weight_values(dim: usize, oe: &OwnElem, points: &[QPoint], linear: bool) -> Vec<f64> {
    if !linear {
        return oe.N.clone();
    }
    let mut out = Vec::new();
    for q in &points[oe.first..oe.first + oe.n] {
        let [x, y] = q.xi;
        if dim == 2 {
            out.extend([0.5 * (1.0 - x), 0.5 * (1.0 + x)]);
        } else {
            out.extend([
                0.25 * (1.0 - x) * (1.0 - y),
                0.25 * (1.0 + x) * (1.0 - y),
                0.25 * (1.0 + x) * (1.0 + y),
                0.25 * (1.0 - x) * (1.0 + y),
            ]);
        }
    }
    out
}
