//! Error type of the `material` module.
// Field names follow the paper's symbols (`J`, `detJ`); thiserror's generated code inherits this allow.
#![allow(non_snake_case)]

use thiserror::Error;

/// Errors of the material laws; each names the offending value.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum MaterialError {
    #[error("Young's modulus E = {young} must be finite and positive")]
    InvalidYoungsModulus { young: f64 },
    #[error("Poisson's ratio nu = {poisson} must be finite and lie in (-1, 0.5)")]
    InvalidPoissonRatio { poisson: f64 },
    #[error("deformation gradient has non-positive Jacobian J = det F = {J:e}")]
    NonPositiveJacobian { J: f64 },
    #[error("material laws support dimension 2 (plane strain) or 3, got {dim}")]
    UnsupportedDimension { dim: usize },
    #[error("array `{what}` has length {got}, expected {expected} for dimension {dim}")]
    WrongLength {
        what: &'static str,
        dim: usize,
        expected: usize,
        got: usize,
    },
}
