//! Cell partitioning with METIS k-way on the face dual graph of the mesh; with contact, a second
//! balance constraint for the contact quadrature points each cell integrates.
use crate::mesh::Mesh;

/// Fixed METIS seed, so that the same mesh always gives the same partition.
const METIS_SEED: metis::Idx = 4242;

/// Serialises the calls into METIS (see [`partition_cells`]).
static METIS_LOCK: std::sync::Mutex<()> = std::sync::Mutex::new(());

/// Failures of the partitioner.
#[derive(Debug, thiserror::Error)]
pub enum PartitionError {
    #[error("cannot split {n_cells} cells into {n_parts} parts")]
    BadPartCount { n_cells: usize, n_parts: usize },
    #[error("mesh of dimension {0} has no face dual graph")]
    BadDimension(usize),
    #[error("mesh too large for METIS indices: {0}")]
    TooLarge(String),
    #[error("METIS failed for {n_parts} parts: {msg}")]
    Metis { n_parts: usize, msg: String },
}

/// Part (0..n_parts) of every cell, [n_cells], from METIS k-way partitioning of the dual graph
/// whose edges join cells sharing a face (2 nodes in 2D, 4 in 3D), with a fixed seed.
/// `n_parts = 1` returns zeros without calling METIS.
///
/// `contact_points` (empty, or one count per cell) is the number of contact quadrature points a
/// cell's rank integrates. When some are non-zero METIS balances two constraints at once: the
/// cells (bulk work) and the contact points (contact work), so that the ranks owning a contact
/// surface do not carry all of its points (docs/performance/contact.md, "Contact data per rank").
///
/// `facing` (cell pairs `[a, b]`, e.g. [`crate::contact::pair::facing_cells`]) are added to the
/// dual graph as edges of weight 1 beside the shared faces: cells whose contact surfaces face each
/// other across a pair, so that METIS keeps facing pieces on one rank where the balance allows
/// (a two-body scene has no shared face between its bodies, and without them a split along the
/// contact interface cuts nothing). Empty: the face dual graph alone, as before.
pub fn partition_cells(
    mesh: &Mesh,
    n_parts: usize,
    contact_points: &[u32],
    facing: &[[u32; 2]],
) -> Result<Vec<u32>, PartitionError> {
    let n_cells = mesh.n_cells();
    if n_parts == 0 || n_parts > n_cells {
        return Err(PartitionError::BadPartCount { n_cells, n_parts });
    }
    if n_parts == 1 {
        return Ok(vec![0; n_cells]);
    }
    let shared = match mesh.dim {
        2 => 2,
        3 => 4,
        d => return Err(PartitionError::BadDimension(d)),
    };
    let (xadj, adjncy) = mesh.dual_graph(shared);
    if let Some(&[a, b]) = facing
        .iter()
        .find(|&&[a, b]| a as usize >= n_cells || b as usize >= n_cells)
    {
        return Err(PartitionError::Metis {
            n_parts,
            msg: format!("facing cells [{a}, {b}] out of {n_cells} cells"),
        });
    }
    let (xadj, adjncy, adjwgt) = with_facing_edges(xadj, adjncy, facing);
    let too_large = |what: &str| PartitionError::TooLarge(what.to_string());
    let xadj: Vec<metis::Idx> = xadj
        .into_iter()
        .map(metis::Idx::try_from)
        .collect::<Result<_, _>>()
        .map_err(|_| too_large("xadj"))?;
    let adjncy: Vec<metis::Idx> = adjncy
        .into_iter()
        .map(metis::Idx::try_from)
        .collect::<Result<_, _>>()
        .map_err(|_| too_large("adjncy"))?;
    let nparts = metis::Idx::try_from(n_parts).map_err(|_| too_large("n_parts"))?;
    let metis_err = |e: &dyn std::fmt::Display| PartitionError::Metis {
        n_parts,
        msg: e.to_string(),
    };
    if !contact_points.is_empty() && contact_points.len() != n_cells {
        return Err(PartitionError::Metis {
            n_parts,
            msg: format!(
                "{} contact point counts for {n_cells} cells",
                contact_points.len()
            ),
        });
    }
    let weighted = contact_points.iter().any(|&c| c > 0);
    let vwgt: Vec<metis::Idx> = if weighted {
        contact_points
            .iter()
            .flat_map(|&c| [1, c as metis::Idx])
            .collect()
    } else {
        Vec::new()
    };
    let mut part: Vec<metis::Idx> = vec![0; n_cells];
    let graph = metis::Graph::new(if weighted { 2 } else { 1 }, nparts, &xadj, &adjncy)
        .map_err(|e| metis_err(&e))?;
    let graph = if weighted {
        graph.set_vwgt(&vwgt)
    } else {
        graph
    };
    let adjwgt: Vec<metis::Idx> = adjwgt
        .into_iter()
        .map(metis::Idx::try_from)
        .collect::<Result<_, _>>()
        .map_err(|_| too_large("adjwgt"))?;
    let graph = if facing.is_empty() {
        graph
    } else {
        graph.set_adjwgt(&adjwgt)
    };
    {
        // METIS keeps its random generator in a process-wide static (GKlib), so two partitions
        // computed at once in one process (threads: the test harness) interleave their draws and
        // a seeded call is no longer reproducible: one call at a time
        let _one_at_a_time = METIS_LOCK.lock().unwrap_or_else(|e| e.into_inner());
        graph
            .set_option(metis::option::Seed(METIS_SEED))
            .part_kway(&mut part)
            .map_err(|e| metis_err(&e))?;
    }
    part.into_iter()
        .map(|p| {
            u32::try_from(p).map_err(|_| PartitionError::Metis {
                n_parts,
                msg: format!("part {p} out of range"),
            })
        })
        .collect()
}

/// The dual graph `(xadj, adjncy)` with the `facing` cell pairs added as edges both ways, and the
/// edge weights: 1 per shared face plus 1 per facing pair (a pair that also shares a face, as in
/// self-contact, weighs 2). Without `facing` the graph is returned as it is, weights empty.
fn with_facing_edges(
    xadj: Vec<usize>,
    adjncy: Vec<u32>,
    facing: &[[u32; 2]],
) -> (Vec<usize>, Vec<u32>, Vec<u32>) {
    if facing.is_empty() {
        return (xadj, adjncy, Vec::new());
    }
    let n = xadj.len() - 1;
    let mut lists: Vec<Vec<(u32, u32)>> = (0..n)
        .map(|c| {
            adjncy[xadj[c]..xadj[c + 1]]
                .iter()
                .map(|&o| (o, 1))
                .collect()
        })
        .collect();
    for &[a, b] in facing {
        if a != b {
            lists[a as usize].push((b, 1));
            lists[b as usize].push((a, 1));
        }
    }
    let (mut x, mut adj, mut w) = (vec![0], Vec::new(), Vec::new());
    for mut l in lists {
        l.sort_unstable();
        let start = adj.len();
        for (o, wt) in l {
            match adj.len().checked_sub(1) {
                Some(last) if last >= start && adj[last] == o => w[last] += wt,
                _ => {
                    adj.push(o);
                    w.push(wt);
                }
            }
        }
        x.push(adj.len());
    }
    (x, adj, w)
}

/// Number of `facing` cell pairs that lie in different parts.
pub fn facing_cut(facing: &[[u32; 2]], part: &[u32]) -> usize {
    facing
        .iter()
        .filter(|&&[a, b]| part[a as usize] != part[b as usize])
        .count()
}

/// Number of dual-graph edges (shared faces) whose two cells lie in different parts.
pub fn edge_cut(mesh: &Mesh, part: &[u32]) -> usize {
    let shared = if mesh.dim == 3 { 4 } else { 2 };
    let (xadj, adjncy) = mesh.dual_graph(shared);
    let mut cut = 0;
    for c in 0..mesh.n_cells() {
        cut += adjncy[xadj[c]..xadj[c + 1]]
            .iter()
            .filter(|&&o| (o as usize) > c && part[o as usize] != part[c])
            .count();
    }
    cut
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::box3d::box3d;
    use crate::mesh::rectangle::rectangle;

    /// Deterministic pseudo-random balanced assignment (LCG shuffle), for comparison.
    fn random_partition(n_cells: usize, n_parts: usize) -> Vec<u32> {
        let mut part: Vec<u32> = (0..n_cells).map(|c| (c % n_parts) as u32).collect();
        let mut state: u64 = 12345;
        for i in (1..n_cells).rev() {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let j = (state >> 33) as usize % (i + 1);
            part.swap(i, j);
        }
        part
    }

    fn check(mesh: &Mesh, n_parts: usize) {
        let part = partition_cells(mesh, n_parts, &[], &[]).unwrap();
        let mut sizes = vec![0usize; n_parts];
        for &p in &part {
            sizes[p as usize] += 1;
        }
        let ideal = mesh.n_cells() as f64 / n_parts as f64;
        assert!(sizes.iter().all(|&s| s > 0), "empty part: {sizes:?}");
        assert!(
            sizes.iter().all(|&s| (s as f64) < 1.1 * ideal + 1.0),
            "unbalanced: {sizes:?}"
        );
        let cut = edge_cut(mesh, &part);
        let random_cut = edge_cut(mesh, &random_partition(mesh.n_cells(), n_parts));
        assert!(4 * cut < random_cut, "cut {cut} vs random {random_cut}");
        // deterministic
        assert_eq!(part, partition_cells(mesh, n_parts, &[], &[]).unwrap());
    }

    #[test]
    fn metis_partitions_are_balanced_nonempty_and_cut_little() {
        check(&rectangle([0.0, 0.0], [10.0, 2.0], [40, 8]).unwrap(), 2);
        check(&rectangle([0.0, 0.0], [10.0, 2.0], [40, 8]).unwrap(), 4);
        check(&box3d([0.0; 3], [2.0; 3], [8, 8, 8]).unwrap(), 4);
    }

    /// Contact points on the cells of the last four columns of a 40 x 8 strip: the bulk-only
    /// partition cuts the strip in the middle and gives one part every point; the two-constraint
    /// partition splits the points too, and still cuts little.
    #[test]
    fn contact_points_are_balanced_as_a_second_constraint() {
        let mesh = rectangle([0.0, 0.0], [10.0, 2.0], [40, 8]).unwrap();
        let points: Vec<u32> = (0..mesh.n_cells())
            .map(|c| {
                let x = mesh.cell(c).iter().map(|&a| mesh.node(a)[0]).sum::<f64>() / 4.0;
                if x > 9.0 {
                    4
                } else {
                    0
                }
            })
            .collect();
        let per_part = |part: &[u32], w: &dyn Fn(usize) -> u32| {
            let mut t = [0u32; 2];
            for (c, &p) in part.iter().enumerate() {
                t[p as usize] += w(c);
            }
            t
        };
        let total: u32 = points.iter().sum();
        assert_eq!(total, 4 * 32);
        let bulk_only = partition_cells(&mesh, 2, &[], &[]).unwrap();
        let t = per_part(&bulk_only, &|c| points[c]);
        assert!(t.contains(&0), "bulk-only split the points: {t:?}");
        let both = partition_cells(&mesh, 2, &points, &[]).unwrap();
        let t = per_part(&both, &|c| points[c]);
        assert!(
            t.iter().all(|&n| (n as f64) <= 0.55 * total as f64),
            "points unbalanced: {t:?}"
        );
        let cells = per_part(&both, &|_| 1);
        assert!(
            cells.iter().all(|&n| (n as f64) <= 0.55 * 320.0),
            "cells unbalanced: {cells:?}"
        );
        let random_cut = edge_cut(&mesh, &random_partition(mesh.n_cells(), 2));
        assert!(4 * edge_cut(&mesh, &both) < random_cut);
        assert_eq!(both, partition_cells(&mesh, 2, &points, &[]).unwrap());
        assert!(partition_cells(&mesh, 2, &points[1..], &[]).is_err());
    }

    /// Two strips stacked without a shared face (two bodies touching along y = 0), each cell of
    /// the lower one's top row facing the upper one's bottom-row cells it overlaps, both rows
    /// carrying contact points. Without the facing edges METIS is free to split along the
    /// interface (no face is cut there), so that every facing pair is cut; with them the split
    /// runs across the strips and cuts few.
    #[test]
    fn facing_contact_cells_are_kept_together() {
        let lower = rectangle([0.0, -1.0], [16.0, 1.0], [64, 4]).unwrap();
        let upper = rectangle([0.0, 0.0], [16.0, 1.0], [48, 4]).unwrap();
        let mut mesh = Mesh::new(2);
        mesh.coords = lower.coords.clone();
        mesh.coords.extend_from_slice(&upper.coords);
        let off = lower.n_nodes() as u32;
        for c in 0..lower.n_cells() {
            mesh.push_cell(lower.cell_kind[c], lower.cell(c));
        }
        for c in 0..upper.n_cells() {
            let nodes: Vec<u32> = upper.cell(c).iter().map(|&a| a + off).collect();
            mesh.push_cell(upper.cell_kind[c], &nodes);
        }
        let span = |c: usize| {
            let ys: Vec<f64> = mesh.cell(c).iter().map(|&a| mesh.node(a)[1]).collect();
            let xs: Vec<f64> = mesh.cell(c).iter().map(|&a| mesh.node(a)[0]).collect();
            let (lo, hi) = (
                xs.iter().cloned().fold(f64::MAX, f64::min),
                xs.iter().cloned().fold(f64::MIN, f64::max),
            );
            let top = ys.iter().any(|&y| y.abs() < 1e-12);
            (lo, hi, top)
        };
        let n_lower = lower.n_cells();
        let spans: Vec<_> = (0..mesh.n_cells()).map(span).collect();
        let points: Vec<u32> = spans.iter().map(|s| if s.2 { 3 } else { 0 }).collect();
        let mut facing = Vec::new();
        for (a, &(alo, ahi, at)) in spans[..n_lower].iter().enumerate() {
            for (b, &(blo, bhi, bt)) in spans.iter().enumerate().skip(n_lower) {
                if at && bt && alo < bhi && blo < ahi {
                    facing.push([a as u32, b as u32]);
                }
            }
        }
        assert_eq!(points.iter().filter(|&&p| p > 0).count(), 64 + 48);
        let apart = partition_cells(&mesh, 2, &points, &[]).unwrap();
        let joined = partition_cells(&mesh, 2, &points, &facing).unwrap();
        let (cut_apart, cut_joined) = (facing_cut(&facing, &apart), facing_cut(&facing, &joined));
        assert!(
            cut_joined * 10 < facing.len() && cut_joined * 4 < cut_apart.max(1),
            "facing pairs cut: {cut_joined} joined, {cut_apart} apart, of {}",
            facing.len()
        );
        for part in [&apart, &joined] {
            let mut cells = [0usize; 2];
            part.iter().for_each(|&p| cells[p as usize] += 1);
            assert!(
                cells
                    .iter()
                    .all(|&n| n as f64 <= 0.55 * mesh.n_cells() as f64),
                "{cells:?}"
            );
        }
        assert_eq!(joined, partition_cells(&mesh, 2, &points, &facing).unwrap());
        assert!(partition_cells(&mesh, 2, &points, &[[0, 10_000]]).is_err());
        // the graph with facing edges: symmetric, weights 1 per face and per facing pair
        let (x0, a0) = mesh.dual_graph(2);
        let (x, adj, w) = with_facing_edges(x0.clone(), a0.clone(), &facing);
        assert_eq!(adj.len(), a0.len() + 2 * facing.len());
        assert_eq!(w.iter().map(|&w| w as usize).sum::<usize>(), adj.len());
        for c in 0..mesh.n_cells() {
            for &o in &adj[x[c]..x[c + 1]] {
                assert!(adj[x[o as usize]..x[o as usize + 1]].contains(&(c as u32)));
            }
        }
        // a pair that also shares a face weighs 2
        let (_, a1, w1) = with_facing_edges(x0, a0.clone(), &[[0, a0[0]]]);
        assert_eq!(a1.len(), a0.len());
        assert_eq!(w1[0], 2);
    }

    #[test]
    fn one_part_is_all_zeros_and_bad_counts_are_errors() {
        let m = rectangle([0.0, 0.0], [1.0, 1.0], [2, 2]).unwrap();
        assert_eq!(partition_cells(&m, 1, &[], &[]).unwrap(), vec![0; 4]);
        assert!(matches!(
            partition_cells(&m, 0, &[], &[]),
            Err(PartitionError::BadPartCount { .. })
        ));
        assert!(matches!(
            partition_cells(&m, 5, &[], &[]),
            Err(PartitionError::BadPartCount { n_parts: 5, .. })
        ));
    }
}
