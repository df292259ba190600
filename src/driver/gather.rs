//! Gathers onto rank 0: the one variable-count gather and its uses (error messages, rows).

use super::Error;
use mpi::datatype::PartitionMut;
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;

/// The distinct error messages of all ranks, on rank 0 (empty elsewhere), each prefixed with the
/// ranks that hold it when they differ between ranks.
///
/// Collective.
pub(super) fn gather_errors(world: &SimpleCommunicator, result: &Result<(), Error>) -> Vec<String> {
    let text = match result {
        Err(e) if !matches!(e, Error::OtherRank) => e.to_string(),
        _ => String::new(),
    };
    // A leading tag byte keeps every contribution non-empty: Open MPI rejects a Gatherv whose
    // buffers are all empty (MPI_ERR_ARG), which is the all-ranks-succeeded case.
    let mut bytes = vec![u8::from(!text.is_empty())];
    bytes.extend(text.into_bytes());
    let Some((buf, lens, displs)) = gather_varcount(world, &bytes[..]) else {
        return Vec::new();
    };
    let size = world.size() as usize;
    let mut distinct: Vec<(String, Vec<usize>)> = Vec::new();
    for r in 0..size {
        let (a, b) = (displs[r] as usize + 1, (displs[r] + lens[r]) as usize);
        if buf[a - 1] == 0 {
            continue;
        }
        let m = String::from_utf8_lossy(&buf[a..b]).into_owned();
        match distinct.iter_mut().find(|(t, _)| *t == m) {
            Some((_, ranks)) => ranks.push(r),
            None => distinct.push((m, vec![r])),
        }
    }
    if distinct.len() <= 1 {
        return distinct.into_iter().map(|(m, _)| m).collect();
    }
    distinct
        .into_iter()
        .map(|(m, ranks)| format!("[rank {ranks:?}] {m}"))
        .collect()
}

/// The rows of every rank concatenated on rank 0 (empty elsewhere). Collective.
pub(super) fn gather_rows(comm: &SimpleCommunicator, rows: &[f64]) -> Vec<f64> {
    match gather_varcount(comm, rows) {
        Some((buf, _, _)) => buf,
        None => Vec::new(),
    }
}

/// The MPI gatherv onto rank 0: on rank 0, the contributions of all ranks concatenated in rank
/// order, with each rank's length and offset in it; `None` on the other ranks.
///
/// Collective.
pub(super) fn gather_varcount<T>(
    comm: &SimpleCommunicator,
    data: &[T],
) -> Option<(Vec<T>, Vec<i32>, Vec<i32>)>
where
    T: Equivalence + Default + Clone,
{
    let root = comm.process_at_rank(0);
    let len = data.len() as i32;
    if comm.rank() != 0 {
        root.gather_into(&len);
        root.gather_varcount_into(data);
        return None;
    }
    let mut lens = vec![0i32; comm.size() as usize];
    root.gather_into_root(&len, &mut lens[..]);
    let displs: Vec<i32> = lens
        .iter()
        .scan(0, |acc, &l| {
            let d = *acc;
            *acc += l;
            Some(d)
        })
        .collect();
    let mut buf = vec![T::default(); lens.iter().sum::<i32>() as usize];
    {
        let mut part = PartitionMut::new(&mut buf[..], &lens[..], &displs[..]);
        root.gather_varcount_into_root(data, &mut part);
    }
    Some((buf, lens, displs))
}

/// What every rank holds for contact and receives per evaluation (summary.json `contact_data`),
/// or `None` without a contact system.
///
/// Collective.
pub(super) fn contact_data(
    world: &SimpleCommunicator,
    asm: &crate::assembly::Assembler,
) -> Option<crate::io::ContactDataStats> {
    let sys = asm.coupling_set::<crate::contact::ContactSystem>()?;
    let f = sys.footprint();
    let (received, gathers, refreshes) = asm.coupling_traffic().unwrap_or((0, 0, 0));
    // the mean over the run's gathers (the node list changes with each refresh)
    let mine = [
        f.table_nodes as u64,
        f.surface_bytes as u64,
        f.point_bytes as u64,
        (8 * received / gathers.max(1)) as u64,
        f.ghost_elements as u64,
        refreshes as u64,
    ];
    const N: usize = 6;
    let mut all = vec![0u64; N * world.size() as usize];
    world.all_gather_into(&mine[..], &mut all[..]);
    let column = |k: usize| all.chunks_exact(N).map(|r| r[k]).collect::<Vec<u64>>();
    let mut evaluations = gathers as u64;
    world.process_at_rank(0).broadcast_into(&mut evaluations);
    Some(crate::io::ContactDataStats {
        table_nodes: column(0),
        surface_bytes: column(1),
        point_bytes: column(2),
        received_bytes_per_evaluation: column(3),
        ghost_elements: column(4),
        refreshes: column(5),
        evaluations,
    })
}

/// Every rank's own assembly timers, in rank order (collective).
pub(super) fn rank_times(
    world: &SimpleCommunicator,
    t: &crate::assembly::Timers,
) -> crate::io::RankTimes {
    let mine = [
        t.residual,
        t.jacobian,
        t.pattern,
        t.contact,
        t.contact_update,
        t.contact_evaluate,
        t.contact_refresh,
    ];
    const N: usize = 7;
    let mut all = vec![0.0f64; N * world.size() as usize];
    world.all_gather_into(&mine[..], &mut all[..]);
    let column = |k: usize| all.chunks_exact(N).map(|r| r[k]).collect::<Vec<f64>>();
    crate::io::RankTimes {
        residual: column(0),
        jacobian: column(1),
        pattern: column(2),
        contact: column(3),
        contact_update: column(4),
        contact_evaluate: column(5),
        contact_refresh: column(6),
    }
}
