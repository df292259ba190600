//! The model: what a case declares, built into meshes, bodies, global node numbering, Dirichlet
//! conditions, periodic ties and element sets — and nothing the case does not declare.
//!
//! Enriched families ([`enrich`]) add an enriched layer to a body: new nodes after its mesh nodes,
//! enriched node lists for the cells of its contact surface, remapped node sets.
//!
//! Every rank builds the same model (meshes are generated or read on every rank; they are small next
//! to the matrix), then assembles only the cells METIS gives it.

mod build;
pub mod contact;
mod contact_checks;
mod data;
pub mod enrich;
#[cfg(test)]
mod enrich_tests;
mod error;
pub mod formulation;
mod holds;
pub mod memory;
mod sampling;

pub use build::{enriched_tl_element, tied_tl_element};
pub use data::{Body, Model};
pub use enrich::{EnrichError, EnrichedCell, Enrichment, ExactSurface, TiedCell};
pub use error::ModelError;
pub use holds::{holds, FreeTranslation, HoldReport};
pub use sampling::{apply_display, SampledGrid};
