//! Contact (section 2.1 and 3.2 of Corbett & Sauer 2014): two-half-pass contact between enriched or
//! linear surfaces and rigid partners, with the penalty, van der Waals and cohesive laws.
//!
//! - [`basis`]: the face interpolation of a surface element with first and second derivatives.
//! - [`surface`]: contact surfaces as plain data (elements, orientation, adjacency), built from a
//!   body's face set.
//! - [`search`]: bounding boxes in a bin grid (global search).
//! - [`projection`]: closest-point projection (Newton per element, neighbour transfer, edge and
//!   corner projections on faceted surfaces).
//! - [`law`]: pointwise laws, eqs. (5)-(7); [`rigid`]: rigid partners.
//! - [`kernel`]: one quadrature point's residual and consistent tangent.
//! - [`system`]: all pairs on a rank: state, evaluation, resultants (no PETSc, no MPI).
//! - `fault`: an injected projection failure, for tests of the cutback path.

pub mod basis;
mod fault;
pub mod kernel;
pub mod law;
pub mod projection;
pub mod rigid;
pub mod search;
pub mod surface;
pub mod system;

pub use system::{
    Anchor, ContactSystem, Coupling, Friction, Law, PairDef, Partner, PassResult, Settle,
};

#[cfg(test)]
mod tests;
