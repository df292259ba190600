//! Parallel helpers: METIS partitioning of the cells' dual graph ([`partition`]).

pub mod partition;

pub use partition::{edge_cut, facing_cut, partition_cells, PartitionError};
