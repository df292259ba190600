//! Cell partitioning with METIS k-way on the face dual graph of the mesh.
use crate::mesh::Mesh;

/// Fixed METIS seed, so that the same mesh always gives the same partition.
const METIS_SEED: metis::Idx = 4242;

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
pub fn partition_cells(mesh: &Mesh, n_parts: usize) -> Result<Vec<u32>, PartitionError> {
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
    let mut part: Vec<metis::Idx> = vec![0; n_cells];
    metis::Graph::new(1, nparts, &xadj, &adjncy)
        .map_err(|e| metis_err(&e))?
        .set_option(metis::option::Seed(METIS_SEED))
        .part_kway(&mut part)
        .map_err(|e| metis_err(&e))?;
    part.into_iter()
        .map(|p| {
            u32::try_from(p).map_err(|_| PartitionError::Metis {
                n_parts,
                msg: format!("part {p} out of range"),
            })
        })
        .collect()
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
        let part = partition_cells(mesh, n_parts).unwrap();
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
        assert_eq!(part, partition_cells(mesh, n_parts).unwrap());
    }

    #[test]
    fn metis_partitions_are_balanced_nonempty_and_cut_little() {
        check(&rectangle([0.0, 0.0], [10.0, 2.0], [40, 8]).unwrap(), 2);
        check(&rectangle([0.0, 0.0], [10.0, 2.0], [40, 8]).unwrap(), 4);
        check(&box3d([0.0; 3], [2.0; 3], [8, 8, 8]).unwrap(), 4);
    }

    #[test]
    fn one_part_is_all_zeros_and_bad_counts_are_errors() {
        let m = rectangle([0.0, 0.0], [1.0, 1.0], [2, 2]).unwrap();
        assert_eq!(partition_cells(&m, 1).unwrap(), vec![0; 4]);
        assert!(matches!(
            partition_cells(&m, 0),
            Err(PartitionError::BadPartCount { .. })
        ));
        assert!(matches!(
            partition_cells(&m, 5),
            Err(PartitionError::BadPartCount { n_parts: 5, .. })
        ));
    }
}
