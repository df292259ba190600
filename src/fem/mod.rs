//! Element kernels for large-deformation solids in the total Lagrangian formulation.
//!
//! Data flow: [`quadrature`] gives Gauss-Legendre rules; a basis ([`quad4`], [`hex8`], or any other family such as
//! the NURBS-enriched elements) tabulates reference derivatives `dN/dxi` at those points; [`kernel::TlElement`]
//! turns them once into `dN/dX` and `w dV` for one element and then evaluates the residual `r = int B^T P dV` and
//! the tangent with the pointwise material of `crate::material`. [`q1e4`] is the enhanced assumed strain quad of
//! Simo & Armero 1992 built on the same kernel, with its 4 internal parameters condensed per element.
//!
//! [`untangle`] checks a converged state's element maps between the quadrature points (folded corners).
//!
//! [`sets`] groups a body's elements on this rank behind the assembly's `ElementSet` trait.
//!
//! Conventions: element dofs are node-major (`dof a*D + i` = node `a`, component `i`); element matrices are
//! `[(n*D)][(n*D)]` row-major; tensors are flat row-major.

pub mod enriched;
mod error;
pub mod hex8;
pub mod kernel;
pub mod q1e4;
pub mod quad4;
pub mod quadrature;
pub mod sets;
pub mod untangle;

#[cfg(test)]
pub(crate) mod test_support;

pub use error::ElementError;
