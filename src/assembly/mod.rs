//! Assembly: numbering of unknowns ([`dofmap`]), the element-set interface kernels implement
//! ([`element_set`]), the coupling-set interface contact implements ([`coupling_set`]), matrix
//! sinks ([`sink`]), conditions ([`dirichlet`], [`skew`], [`rigid_coupling`]) and the nonlinear
//! system SNES solves ([`assembler`]). Nothing here knows what an element or a coupling set
//! computes: assembly imports nothing from `crate::contact`, `crate::fem` or `crate::model`.

pub mod assembler;
pub mod coupling_set;
pub mod dirichlet;
pub mod dofmap;
pub mod element_set;
pub mod rigid_coupling;
pub mod sink;
pub mod skew;

pub use assembler::{Assembler, MatrixAssembly, Timers};
pub use coupling_set::{Augment, Block, CouplingSet, SlotOf};
pub use dirichlet::{
    constrained_flags, prescribed_values, ConflictError, DirichletBc, Prescription,
};
pub use dofmap::{DofMap, DofMapError, GlobalDof, LocalDof};
pub use element_set::{ElementFailure, ElementSet};
pub use rigid_coupling::{NodeOffsets, RigidCoupling};
pub use sink::{BlockScatter, CellMap, CooSink, CouplingRuns, DenseSink, MatrixSink, DROPPED};
pub use skew::{SkewBc, SkewError, SkewKind, SkewRow, SkewRows};
