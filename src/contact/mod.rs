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
//! - [`formulation`]: a pair's formulation as one value composed at set-up: passes, pressure
//!   distribution, enforcement, law.
//! - [`pair`]: a declared pair as plain data: formulation, friction, partners, coupling blocks.
//! - [`half_pass`]: one pass over a surface's own points (gather -> partner -> law -> kernel ->
//!   scatter), with the gap mode and friction as parts.
//! - [`system`]: all pairs on a rank: state, evaluation, resultants (no PETSc, no MPI).
//! - `fault`: an injected projection failure, for tests of the cutback path.

pub mod basis;
mod fault;
pub mod formulation;
pub mod half_pass;
pub mod kernel;
pub mod law;
pub mod pair;
pub mod projection;
pub mod rigid;
pub mod search;
pub mod surface;
pub mod system;

pub use formulation::{Enforcement, Formulation, Passes, Pressure, WeightBasis};
pub use half_pass::PassResult;
pub use pair::{Anchor, Augmented, Coupling, Friction, Law, PairDef, Partner};
pub use system::ContactSystem;

#[cfg(test)]
mod tests;
