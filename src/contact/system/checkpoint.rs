//! The committed per-point state of the contact system as plain rows, for checkpoints: each
//! quadrature point is keyed by its pair, half-pass, surface element and index inside the element,
//! which do not depend on the partition, so a checkpoint written on N ranks restarts on M.
//! Mortar-gap passes add one row per control point of their own elements, keyed by (pair, pass,
//! -1, global node), with the augmented Lagrangian multiplier in the last value (a control point
//! shared by ranks has a row from each, equal to round-off).

use super::{Anchor, ContactSystem};
use crate::contact::half_pass::PointState;

/// Values per point row: key (pair, pass, element, point), warm start (tag, element, xi),
/// friction anchor (tag, 3 values), cohesive pairing (tag, element, xi), augmented Lagrangian
/// multiplier.
pub const ROW: usize = 17;

fn opt2(v: Option<(u32, [f64; 2])>) -> [f64; 4] {
    match v {
        Some((e, xi)) => [1.0, e as f64, xi[0], xi[1]],
        None => [0.0; 4],
    }
}

fn get2(r: &[f64]) -> Option<(u32, [f64; 2])> {
    (r[0] != 0.0).then(|| (r[1] as u32, [r[2], r[3]]))
}

impl ContactSystem {
    /// The committed state of every point this rank integrates, [`ROW`] values per point: every
    /// slot of a segmented element, placed or not (a restart gives a 3D segmented element as many
    /// slots again and places the points again, each slot's projection its warm start).
    pub fn export_points(&self) -> Vec<f64> {
        let mut out = Vec::new();
        for (pi, pair) in self.pairs.iter().enumerate() {
            for (qi, pass) in pair.passes.iter().enumerate() {
                for el in &pass.elems {
                    for j in 0..el.slots {
                        let q = &pass.points[el.first + j];
                        out.extend_from_slice(&[pi as f64, qi as f64, el.e as f64, j as f64]);
                        out.extend_from_slice(&opt2(q.committed.projection));
                        out.extend_from_slice(&match q.committed.anchor {
                            None => [0.0; 4],
                            Some(Anchor::Surface(e, xi)) => [1.0, e as f64, xi[0], xi[1]],
                            Some(Anchor::Rigid(x)) => [2.0, x[0], x[1], x[2]],
                        });
                        out.extend_from_slice(&opt2(q.pairing));
                        out.push(q.committed.lambda);
                    }
                }
                if let Some(net) = &pass.mortar {
                    for a in (0..net.node.len()).filter(|&a| net.is_own(a)) {
                        let node = net.node[a];
                        let mut row = [0.0; ROW];
                        row[..4].copy_from_slice(&[pi as f64, qi as f64, -1.0, node as f64]);
                        row[ROW - 1] = net.lambda_committed[a];
                        out.extend_from_slice(&row);
                    }
                }
            }
        }
        out
    }

    /// True when this rank integrates surface element `e` in half-pass `pass` (numbered over all
    /// pairs' passes, as in [`crate::contact::Coupling`]).
    pub fn integrates(&self, pass: u32, e: u32) -> bool {
        self.pairs
            .iter()
            .flat_map(|p| &p.passes)
            .nth(pass as usize)
            .is_some_and(|p| p.elems.binary_search_by_key(&e, |o| o.e).is_ok())
    }

    /// Sets the committed and trial state of this rank's points from the rows of all ranks
    /// ([`export_points`](Self::export_points) of each, in any order). Every point of this rank
    /// must have a row.
    pub fn import_points(&mut self, rows: &[f64]) -> Result<(), String> {
        let key = |r: &[f64]| (r[0] as usize, r[1] as usize, r[2] as u32, r[3] as usize);
        let index: std::collections::HashMap<_, usize> = rows
            .chunks_exact(ROW)
            .enumerate()
            .filter(|(_, r)| r[2] >= 0.0)
            .map(|(i, r)| (key(r), i))
            .collect();
        // mortar control points: (pair, pass, global node) -> multiplier
        let cps: std::collections::HashMap<_, f64> = rows
            .chunks_exact(ROW)
            .filter(|r| r[2] < 0.0)
            .map(|r| ((r[0] as usize, r[1] as usize, r[3] as u32), r[ROW - 1]))
            .collect();
        self.last_update = None;
        // 3D segments: an element whose placements had grown it gets its rows' room again
        let mut grown: std::collections::HashMap<(usize, usize, u32), usize> =
            std::collections::HashMap::new();
        for &(pi, qi, e, j) in index.keys() {
            let n = grown.entry((pi, qi, e)).or_insert(0);
            *n = (*n).max(j + 1);
        }
        for (pi, pair) in self.pairs.iter_mut().enumerate() {
            for (qi, pass) in pair.passes.iter_mut().enumerate() {
                let Some(most) = pass
                    .segments
                    .as_ref()
                    .filter(|s| s.three_d())
                    .map(|s| s.most_points())
                else {
                    continue;
                };
                let mut need = Vec::new();
                for (i, el) in pass.elems.iter().enumerate() {
                    let Some(&n) = grown.get(&(pi, qi, el.e)) else {
                        continue;
                    };
                    if n > most {
                        return Err(format!(
                            "contact pair {pi}, pass {qi}, surface element {}: state for point {} (its segments hold at most {most})",
                            el.e,
                            n - 1
                        ));
                    }
                    need.push((i, n));
                }
                super::segments::reserve(pass, &need);
            }
        }
        for (pi, pair) in self.pairs.iter_mut().enumerate() {
            for (qi, pass) in pair.passes.iter_mut().enumerate() {
                for el in &pass.elems {
                    for j in 0..el.slots {
                        let Some(&i) = index.get(&(pi, qi, el.e, j)) else {
                            return Err(format!(
                                "no state for contact pair {pi}, pass {qi}, surface element {}, point {j}",
                                el.e
                            ));
                        };
                        let r = &rows[i * ROW..(i + 1) * ROW];
                        let q = &mut pass.points[el.first + j];
                        q.committed = PointState {
                            projection: get2(&r[4..8]),
                            anchor: match r[8] as u32 {
                                1 => Some(Anchor::Surface(r[9] as u32, [r[10], r[11]])),
                                2 => Some(Anchor::Rigid([r[9], r[10], r[11]])),
                                _ => None,
                            },
                            lambda: r[16],
                        };
                        q.trial = q.committed;
                        q.pairing = get2(&r[12..16]);
                    }
                }
                if let Some(net) = &mut pass.mortar {
                    for a in 0..net.node.len() {
                        let node = net.node[a];
                        let l = cps.get(&(pi, qi, node)).copied();
                        if l.is_none() && net.is_own(a) {
                            return Err(format!(
                                "no multiplier for contact pair {pi}, pass {qi}, control point (node) {node}"
                            ));
                        }
                        net.lambda_committed[a] = l.unwrap_or(0.0);
                        net.lambda[a] = l.unwrap_or(0.0);
                    }
                }
            }
        }
        Ok(())
    }
}
