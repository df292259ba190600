//! Pointwise constitutive laws: a material maps a deformation gradient `F` to the stored energy, the first
//! Piola-Kirchhoff stress `P`, its tangent `A = dP/dF` and the Cauchy stress. It never sees an element; the
//! element kernels in `crate::fem` call it once per quadrature point.
//!
//! - [`neo_hookean`]: compressible Neo-Hookean law of eq. (21) of Corbett & Sauer 2014 (3D and plane strain).

mod error;
pub mod neo_hookean;

pub use error::MaterialError;
pub use neo_hookean::NeoHookean;
