//! The case-file layer: a TOML case declares only what its scene needs (meshes, bodies, Dirichlet
//! conditions, periodic ties, load stages, step control, PETSc options, outputs).
//!
//! - [`schema`]: typed serde structs, unknown keys rejected, defaults documented on the fields.
//! - [`element_family`]: `Q1C1`, `Q1E4`, `Q1N<p>[.<t>]`, `Q1C2`, `Q1CH` parsed into [`ElementFamily`].
//! - [`load`]: file -> `toml::Value` -> `--set key.path=value` overrides -> [`Case`] -> [`validate()`].
//! - [`validate`](mod@validate): semantic checks, and [`validate_sets`] for set names once meshes exist.
//! - [`size`]: node, cell and memory estimates of generated meshes, checked before building them.
//! - [`error`]: [`SceneError`], whose messages name the file, the key path and (when known) the line.
//! - [`examples`]: three complete case files, used as test fixtures and as templates.
//! - [`json_schema`]: the JSON Schema of a case file, from the schema's types and doc comments.

pub mod contact_spec;
pub mod element_family;
pub mod error;
pub mod examples;
pub mod json_schema;
mod keypath;
pub mod load;
pub mod schema;
pub mod size;
pub mod validate;

pub use contact_spec::{
    Algorithm, AugmentedSpec, BoxSpec, ContactSpec, FormulationName, GapMode, LawKind, PenaltyForm,
    RigidShapeKind, RigidSpec,
};
pub use element_family::{ElementFamily, ElementFamilyError};
pub use error::{Issue, SceneError};
pub use load::{load_case, parse_case};
pub use schema::*;
pub use validate::{validate, validate_sets, SetKind};
