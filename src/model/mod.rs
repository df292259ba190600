//! The model: what a case declares, built into meshes, bodies, global node numbering, Dirichlet
//! conditions, periodic ties and element sets — and nothing the case does not declare.
//!
//! Every rank builds the same model (meshes are generated or read on every rank; they are small next
//! to the matrix), then assembles only the cells METIS gives it.

mod build;

pub use build::{Body, Model, ModelError};
