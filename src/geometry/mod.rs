//! NURBS geometry kernel (Corbett & Sauer 2014, section 2.2; Piegl & Tiller 1997; Borden et al. 2011).
//!
//! How the pieces fit:
//! - [`knots`]: validated open knot vectors (`KnotVector`), span search, unique knots.
//! - [`bspline`]: Cox-de Boor basis and derivatives on a `KnotVector` (eq. 10-11).
//! - [`nurbs`]: rational basis (eq. 12-14), `NurbsCurve` and tensor-product `NurbsSurface` (eq. 15).
//! - [`bezier`]: Bernstein basis on [-1,1], Bezier extraction operators `C_e` per element and the
//!   element basis `R_e = W_e C_e B_e / W` of eq. (16) - what the element kernels consume.
//! - [`refine`]: knot insertion, order elevation, k-refinement and the surface-oriented Q1Np.t
//!   refinement of section 3.3, all on homogeneous control points so geometry is unchanged.
//! - [`conics`]: exact circular arcs, lines, planes and the hollow hemisphere of section 4.4, plus a
//!   builder for refined curves of a family (p, t).
//! - [`fit`]: smooth least-squares B-spline fits of an exact curve/surface (single interior knots),
//!   arc-length parametrisation and point-to-curve/surface distances.
//! - [`table1`]: the element properties of Table 1 measured on a constructed refined curve.
use thiserror::Error;

pub mod bezier;
pub mod bspline;
pub mod conics;
pub mod fit;
pub mod knots;
pub mod nurbs;
pub mod refine;
pub mod table1;

/// Highest polynomial order supported by the stack buffers of the basis routines.
pub const MAX_ORDER: usize = 20;

/// Errors of the geometry kernel; each names the offending value and where it is.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum GeometryError {
    #[error("order p = {p} is out of range 1..={max}")]
    OrderOutOfRange { p: usize, max: usize },
    #[error("knot {index} is not finite ({value})")]
    NonFiniteKnot { index: usize, value: f64 },
    #[error("knot vector decreases at index {index}: {prev} > {value}")]
    DecreasingKnots { index: usize, prev: f64, value: f64 },
    #[error("knot vector has {found} knots, but order {p} needs at least {min}")]
    TooFewKnots { found: usize, p: usize, min: usize },
    #[error(
        "knot vector is not open at its {end} end: first/last knot {value} has multiplicity {found}, expected p+1 = {expected}"
    )]
    NotOpen {
        end: &'static str,
        value: f64,
        found: usize,
        expected: usize,
    },
    #[error(
        "interior knot {value} has multiplicity {found} > p = {p} (basis would be discontinuous)"
    )]
    InteriorMultiplicity { value: f64, found: usize, p: usize },
    #[error("knot vector has zero length parameter domain [{first}, {last}]")]
    EmptyDomain { first: f64, last: f64 },
    #[error("{what}: expected {expected} entries, found {found}")]
    LengthMismatch {
        what: &'static str,
        expected: usize,
        found: usize,
    },
    #[error("weight {index} must be positive and finite, found {value}")]
    BadWeight { index: usize, value: f64 },
    #[error("control point coordinate {index} is not finite ({value})")]
    NonFiniteControlPoint { index: usize, value: f64 },
    #[error("spatial dimension {dim} is not supported (use 2 or 3)")]
    BadDimension { dim: usize },
    #[error("parameter {name} = {value} is invalid: {reason}")]
    BadParameter {
        name: &'static str,
        value: f64,
        reason: &'static str,
    },
    #[error("collocation system for order elevation is singular")]
    SingularCollocation,
}
