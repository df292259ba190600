//! The coupling blocks contact adds to the Jacobian's sparsity pattern: those the current
//! projections need, and a band around them reserved for points that slide or approach.

use super::ContactSystem;
use crate::contact::pair::{Anchor, BlockKey, Coupling, Partner};

impl ContactSystem {
    /// The coupling blocks the current projections need (sorted, unique): an element's rows with
    /// the partner elements of its points (under the mortar gap: of the points of every element
    /// sharing a control point with it, and those elements' own columns), cohesive pairings and
    /// friction anchors. Under the one-pass weighted gap the partners of the other elements'
    /// points are [`BlockKey::Reach`] blocks: the own element's rows need their columns, but
    /// only the partners of its own points receive rows from it.
    pub fn couplings(&self) -> Vec<Coupling> {
        let mut out = Vec::new();
        let mut pass_id = 0u32;
        for pair in &self.pairs {
            for pass in &pair.passes {
                let reach = reach_keys(pair, pass);
                for (i, oe) in pass.elems.iter().enumerate() {
                    let sources = pass.coupled_elems(i);
                    if pass.mortar.is_some() {
                        out.extend(
                            sources
                                .iter()
                                .map(|s| (pass_id, oe.e, BlockKey::Own(s.e).encode())),
                        );
                    }
                    if pass.shape.is_some() {
                        out.push((pass_id, oe.e, u32::MAX));
                        continue;
                    }
                    for s in &sources {
                        let key = |l: u32| {
                            if reach && s.e != oe.e {
                                BlockKey::Reach(l).encode()
                            } else {
                                l
                            }
                        };
                        for qp in &pass.points[s.first..s.first + s.n] {
                            // (mortar gaps: a point beyond the partner's end weighs its distance)
                            for p in qp.current.iter().chain(&qp.edge) {
                                out.push((pass_id, oe.e, key(p.elem)));
                            }
                            if let Some((l, _)) = qp.pairing {
                                out.push((pass_id, oe.e, key(l)));
                            }
                            if let Some(Anchor::Surface(l, _)) = qp.committed.anchor {
                                if pair.def.friction.is_some() {
                                    out.push((pass_id, oe.e, key(l)));
                                }
                            }
                        }
                    }
                }
                pass_id += 1;
            }
        }
        out.sort_unstable();
        out.dedup();
        out
    }

    /// The couplings to reserve in the sparsity pattern: for every point with a partner (or a
    /// cohesive pairing), its partner element and the elements within `ring` side-neighbour steps of
    /// it, so that points sliding to a neighbouring element during the next Newton solves still find
    /// their block (`ring = 0`: exactly the current couplings). Rigid partners couple an element
    /// with itself only. Sorted, unique.
    pub fn band_couplings(&mut self, ring: usize) -> Vec<Coupling> {
        let mut out = self.approach_couplings(ring);
        let mut pass_id = 0u32;
        let mut near: Vec<u32> = Vec::new();
        for pair in &self.pairs {
            for pass in &pair.passes {
                let l = match pass.partner {
                    Partner::Surface(l) => Some(l),
                    Partner::Rigid(..) => None,
                };
                let reach = reach_keys(pair, pass);
                for (i, oe) in pass.elems.iter().enumerate() {
                    let sources = pass.coupled_elems(i);
                    if pass.mortar.is_some() {
                        out.extend(
                            sources
                                .iter()
                                .map(|s| (pass_id, oe.e, BlockKey::Own(s.e).encode())),
                        );
                    }
                    let Some(l) = l else {
                        out.push((pass_id, oe.e, u32::MAX));
                        continue;
                    };
                    for (s, q) in sources
                        .iter()
                        .flat_map(|s| (s.first..s.first + s.n).map(move |q| (s.e, q)))
                    {
                        let qp = &pass.points[q];
                        let anchor = match qp.committed.anchor {
                            Some(Anchor::Surface(la, _)) if pair.def.friction.is_some() => Some(la),
                            _ => None,
                        };
                        for le in qp
                            .current
                            .map(|p| p.elem)
                            .into_iter()
                            .chain(qp.edge.map(|p| p.elem))
                            .chain(qp.pairing.map(|p| p.0))
                            .chain(anchor)
                        {
                            near.clear();
                            near.push(le);
                            let mut front = 0;
                            for _ in 0..ring {
                                let end = near.len();
                                for i in front..end {
                                    for nb in self.surfaces[l].elements[near[i] as usize]
                                        .neighbours
                                        .iter()
                                        .flatten()
                                    {
                                        if !near.contains(&nb.0) {
                                            near.push(nb.0);
                                        }
                                    }
                                }
                                front = end;
                            }
                            // (one-pass weighted gap: the own element's points reserve the
                            // partner's rows and columns, and its `Reach` key, so that a
                            // neighbour's point that slides there finds its block too)
                            if !reach {
                                out.extend(near.iter().map(|&f| (pass_id, oe.e, f)));
                                continue;
                            }
                            out.extend(
                                near.iter()
                                    .map(|&f| (pass_id, oe.e, BlockKey::Reach(f).encode())),
                            );
                            if s == oe.e {
                                out.extend(near.iter().map(|&f| (pass_id, oe.e, f)));
                            }
                        }
                    }
                }
                pass_id += 1;
            }
        }
        out.sort_unstable();
        out.dedup();
        out
    }

    /// With `ring >= 1`, the couplings of points that have no partner yet but lie within the search
    /// distance of a partner element's box: the elements they may reach during the next solves
    /// (a contact zone that grows, as under an indenter, then needs no pattern rebuild).
    fn approach_couplings(&mut self, ring: usize) -> Vec<Coupling> {
        let mut out = Vec::new();
        if ring == 0 {
            return out;
        }
        let mut pass_id = 0u32;
        for pi in 0..self.pairs.len() {
            let dist = self.pairs[pi].def.search_distance;
            for qi in 0..self.pairs[pi].passes.len() {
                let (k, partner) = {
                    let p = &self.pairs[pi].passes[qi];
                    (p.k, p.partner.clone())
                };
                if let Partner::Surface(l) = partner {
                    // (own element, element holding the point, its coordinates)
                    let waiting: Vec<(u32, u32, [f64; 2])> = {
                        let pass = &self.pairs[pi].passes[qi];
                        let mut w = Vec::new();
                        for (i, oe) in pass.elems.iter().enumerate() {
                            for s in pass.coupled_elems(i) {
                                w.extend(
                                    (s.first..s.first + s.n)
                                        .filter(|&q| {
                                            let p = &pass.points[q];
                                            p.current.is_none() && p.w > 0.0
                                        })
                                        .map(|q| (oe.e, s.e, pass.points[q].xi)),
                                );
                            }
                        }
                        w
                    };
                    if !waiting.is_empty() {
                        self.ensure_grid(l, dist);
                    }
                    for (e, es, xi) in waiting {
                        let x = self.point_position(k, es as usize, &xi);
                        let grid = self.grids[l].as_ref().expect("built above");
                        grid.candidates(&x[..self.dim], &mut self.cand);
                        out.extend(self.cand.iter().map(|&f| (pass_id, e, f)));
                    }
                }
                pass_id += 1;
            }
        }
        out
    }

    /// Why coupling `c` (pass, surface element, block key) names no coupling of this system: a
    /// pass, an element of its surface or a partner element beyond the model's. Every coupling
    /// this system produces passes; a pattern read from a checkpoint is checked with it.
    pub fn check_block(&self, c: &Coupling) -> Result<(), String> {
        let (pass, k_e, l_e) = *c;
        let n_pass = self.pairs.iter().map(|p| p.passes.len()).sum::<usize>();
        if pass as usize >= n_pass {
            return Err(format!(
                "pass {pass}: the contact pairs have {n_pass} passes"
            ));
        }
        let (k, partner, _) = self.pass_surfaces(pass as usize);
        let n_k = self.surfaces[k].elements.len();
        let beyond = |e: u32, s: usize, n: usize| {
            format!("pass {pass}: element {e} of surface {s}, which has {n} elements")
        };
        if k_e as usize >= n_k {
            return Err(beyond(k_e, k, n_k));
        }
        match (BlockKey::decode(l_e), partner) {
            (BlockKey::Own(e2), _) if e2 as usize >= n_k => Err(beyond(e2, k, n_k)),
            (BlockKey::Partner(e2) | BlockKey::Reach(e2), Some(l))
                if e2 as usize >= self.surfaces[l].elements.len() =>
            {
                Err(beyond(e2, l, self.surfaces[l].elements.len()))
            }
            _ => Ok(()),
        }
    }

    /// Rows (own element, constrained rows dropped by the caller) and columns of a coupling block:
    /// those of the own element and its partner element (one-pass: the partner's rows too, but
    /// not under a `Reach` key), or (mortar gap) of another element of the own surface.
    pub fn block_dofs(&self, c: &Coupling) -> (Vec<i32>, Vec<i32>) {
        let (pass, k_e, l_e) = *c;
        let (k, partner, one_pass) = self.pass_surfaces(pass as usize);
        let own = &self.gdofs[k][k_e as usize][..];
        let key = BlockKey::decode(l_e);
        if let BlockKey::Own(e2) = key {
            return (own.to_vec(), self.gdofs[k][e2 as usize].clone());
        }
        let mut cols = own.to_vec();
        if let (Some(l), Some(l_e)) = (partner, key.partner()) {
            cols.extend_from_slice(&self.gdofs[l][l_e as usize]);
        }
        let rows = if one_pass && matches!(key, BlockKey::Partner(_)) {
            cols.clone()
        } else {
            own.to_vec()
        };
        (rows, cols)
    }

    /// The global unknowns of both sides of this rank's couplings now ([`Self::couplings`]:
    /// each surface element with a point on or near its partner, and that partner element),
    /// sorted and without repeats: the contact interface of the iterative route's interface
    /// correction.
    pub fn interface_dofs(&self) -> Vec<i32> {
        let mut out = Vec::new();
        for c in self.couplings() {
            let (_, cols) = self.block_dofs(&c);
            out.extend(cols.into_iter().filter(|&d| d >= 0));
        }
        out.sort_unstable();
        out.dedup();
        out
    }

    fn pass_surfaces(&self, pass: usize) -> (usize, Option<usize>, bool) {
        let mut i = 0;
        for pair in &self.pairs {
            for p in &pair.passes {
                if i == pass {
                    let l = match p.partner {
                        Partner::Surface(l) => Some(l),
                        Partner::Rigid(..) => None,
                    };
                    return (p.k, l, pair.def.formulation.one_pass() && l.is_some());
                }
                i += 1;
            }
        }
        unreachable!("pass index out of range")
    }
}

/// Whether a pass keys the partner elements of its elements' neighbours' points as
/// [`BlockKey::Reach`] blocks (the one-pass weighted gaps against another surface).
fn reach_keys(pair: &super::Pair, pass: &crate::contact::half_pass::Pass) -> bool {
    pass.mortar.is_some()
        && pair.def.formulation.one_pass()
        && matches!(pass.partner, Partner::Surface(_))
}
