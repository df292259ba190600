//! Quasi-static solution: load stepping over the stages of a case, Newton (PETSc SNES) per step, and
//! automatic cutback when a step diverges or meets a domain error.

pub mod judge;
pub mod linear;
pub mod load_stepping;
mod settle;

pub use load_stepping::{
    run_load_steps, run_load_steps_from, translation_resistance, AfterStep, LoadPosition,
    PredictorState, SolverError, StepControl, StepEvent, StepRecord, StepSizer, TranslationProbe,
    FREE_TRANSLATION_TOL,
};
