//! Error type of the `fem` module.
// Field names follow the paper's symbols (`J`, `detJ`); thiserror's generated code inherits this allow.
#![allow(non_snake_case)]

use crate::material::MaterialError;
use thiserror::Error;

/// Errors of the element kernels; each names the element-local quadrature point or the offending value.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ElementError {
    #[error("non-positive reference Jacobian det(dX/dxi) = {detJ:e} at quadrature point {qp}")]
    NonPositiveReferenceJacobian { qp: usize, detJ: f64 },
    #[error("inverted element: J = det F = {J:e} at quadrature point {qp}")]
    Inverted { qp: usize, J: f64 },
    #[error("material failure at quadrature point {qp}: {source}")]
    Material { qp: usize, source: MaterialError },
    #[error("element kernels support dimension 2 or 3, got {dim}")]
    UnsupportedDimension { dim: usize },
    #[error("array `{what}` has length {got}, expected {expected}")]
    WrongLength {
        what: &'static str,
        expected: usize,
        got: usize,
    },
    #[error("Gauss-Legendre rule needs at least 1 point per direction, got {n}")]
    InvalidPointCount { n: usize },
    #[error("Gauss-Legendre Newton iteration did not converge for n = {n}")]
    QuadratureNotConverged { n: usize },
    #[error("enhanced-strain tangent K_aa is singular")]
    SingularEnhancedTangent,
    #[error("enhanced-strain parameters did not converge in {iterations} iterations: |R_alpha| = {residual:e} > {tolerance:e}")]
    EnhancedNotConverged {
        iterations: usize,
        residual: f64,
        tolerance: f64,
    },
}

impl ElementError {
    /// Attach the quadrature point to a material error; an inverted `F` becomes [`ElementError::Inverted`].
    pub(crate) fn from_material(qp: usize, e: MaterialError) -> Self {
        match e {
            MaterialError::NonPositiveJacobian { J } => ElementError::Inverted { qp, J },
            source => ElementError::Material { qp, source },
        }
    }
}
