//! Assembly: numbering of unknowns ([`dofmap`]), the element-set interface kernels implement
//! ([`element_set`]), matrix sinks ([`sink`]) and the nonlinear system SNES solves ([`assembler`]).

pub mod assembler;
pub mod coupling;
pub mod dirichlet;
pub mod dofmap;
pub mod element_set;
pub mod sink;
pub mod skew;

pub use assembler::{Assembler, MatrixAssembly, Timers};
pub use coupling::{NodeOffsets, RigidCoupling};
pub use dirichlet::{
    constrained_flags, prescribed_values, ConflictError, DirichletBc, Prescription,
};
pub use dofmap::{DofMap, DofMapError, GlobalDof, LocalDof};
pub use element_set::{ElementFailure, ElementSet};
pub use sink::{CooSink, DenseSink, MatrixSink};
pub use skew::{SkewBc, SkewError, SkewKind, SkewRow, SkewRows};
