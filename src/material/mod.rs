//! Pointwise constitutive laws: a material maps a deformation gradient `F` to the stored energy, the first
//! Piola-Kirchhoff stress `P`, its tangent `A = dP/dF` and the Cauchy stress. It never sees an element; the
//! element kernels in `crate::fem` call it once per quadrature point.
//!
//! - [`neo_hookean`]: compressible Neo-Hookean law of eq. (21) of Corbett & Sauer 2014 (3D and plane strain).
//! - [`linear_elastic`]: small-strain (geometrically linear) Hooke law, for validation against classical
//!   solutions (3D and plane strain).
//!
//! [`Material`] is the law of one body: an enum over the laws with the same methods, dispatched by `match`.

mod error;
pub mod linear_elastic;
pub mod neo_hookean;
#[cfg(test)]
mod test_support;

pub use error::MaterialError;
pub use linear_elastic::LinearElastic;
pub use neo_hookean::NeoHookean;

/// The constitutive law of a body, as the element kernels see it. Tensor layouts are those of [`neo_hookean`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Material {
    NeoHookean(NeoHookean),
    LinearElastic(LinearElastic),
}

impl From<NeoHookean> for Material {
    fn from(m: NeoHookean) -> Self {
        Material::NeoHookean(m)
    }
}

impl From<LinearElastic> for Material {
    fn from(m: LinearElastic) -> Self {
        Material::LinearElastic(m)
    }
}

#[allow(non_snake_case)]
impl Material {
    /// True for a finite-strain law, which needs `det F > 0` everywhere (an inverted element is
    /// an error). A small-strain law (`linear_elastic`) answers in the reference configuration and
    /// accepts any `F`, so its displaced mesh may overlap itself without the answer being wrong.
    pub fn finite_strain(&self) -> bool {
        matches!(self, Material::NeoHookean(_))
    }

    /// Shear modulus `mu` (a Lame parameter of every law).
    pub fn mu(&self) -> f64 {
        match self {
            Material::NeoHookean(m) => m.mu,
            Material::LinearElastic(m) => m.mu,
        }
    }

    /// Lame's first parameter `lambda` (`Lambda` of eq. 21 for Neo-Hookean).
    pub fn lambda(&self) -> f64 {
        match self {
            Material::NeoHookean(m) => m.lambda,
            Material::LinearElastic(m) => m.lambda,
        }
    }

    /// Stored energy per reference volume `W(F)`; `F`: `[dim][dim]`.
    pub fn energy(&self, dim: usize, F: &[f64]) -> Result<f64, MaterialError> {
        match self {
            Material::NeoHookean(m) => m.energy(dim, F),
            Material::LinearElastic(m) => m.energy(dim, F),
        }
    }

    /// Cauchy stress, always 3x3 row-major (plane strain includes `sigma_33`).
    pub fn cauchy(&self, dim: usize, F: &[f64], sigma: &mut [f64; 9]) -> Result<(), MaterialError> {
        match self {
            Material::NeoHookean(m) => m.cauchy(dim, F, sigma),
            Material::LinearElastic(m) => m.cauchy(dim, F, sigma),
        }
    }
}

/// The stress of a law: each law implements the specialised [`ConstitutiveLaw::pk1_impl`]; the checked
/// entry points [`ConstitutiveLaw::pk1`] and [`ConstitutiveLaw::pk1_tangent`] (sizes validated, dimension
/// dispatched) are shared.
#[allow(non_snake_case)]
pub trait ConstitutiveLaw {
    /// Unchecked `P` (and `A` when given) for dimension `D`; the slices have exactly the sizes of `D`.
    fn pk1_impl<const D: usize>(
        &self,
        F: &[f64],
        P: &mut [f64],
        A: Option<&mut [f64]>,
    ) -> Result<(), MaterialError>;

    /// First Piola-Kirchhoff stress `P(F)`; `F`, `P`: `[dim][dim]`.
    fn pk1(&self, dim: usize, F: &[f64], P: &mut [f64]) -> Result<(), MaterialError> {
        NeoHookean::check(dim, "F", F.len(), 2)?;
        NeoHookean::check(dim, "P", P.len(), 2)?;
        if dim == 2 {
            self.pk1_impl::<2>(F, P, None)
        } else {
            self.pk1_impl::<3>(F, P, None)
        }
    }

    /// `P(F)` and its tangent `A_iJkL = dP_iJ/dF_kL`; `F`, `P`: `[dim][dim]`, `A`: `[dim][dim][dim][dim]`.
    fn pk1_tangent(
        &self,
        dim: usize,
        F: &[f64],
        P: &mut [f64],
        A: &mut [f64],
    ) -> Result<(), MaterialError> {
        NeoHookean::check(dim, "F", F.len(), 2)?;
        NeoHookean::check(dim, "P", P.len(), 2)?;
        NeoHookean::check(dim, "A", A.len(), 4)?;
        if dim == 2 {
            self.pk1_impl::<2>(F, P, Some(A))
        } else {
            self.pk1_impl::<3>(F, P, Some(A))
        }
    }
}

#[allow(non_snake_case)]
impl ConstitutiveLaw for Material {
    #[inline(always)]
    fn pk1_impl<const D: usize>(
        &self,
        F: &[f64],
        P: &mut [f64],
        A: Option<&mut [f64]>,
    ) -> Result<(), MaterialError> {
        match self {
            Material::NeoHookean(m) => m.pk1_impl::<D>(F, P, A),
            Material::LinearElastic(m) => m.pk1_impl::<D>(F, P, A),
        }
    }
}

#[cfg(test)]
#[allow(non_snake_case)]
mod tests {
    use super::*;

    /// Every method of [`Material`] returns what its law returns.
    #[test]
    fn material_dispatches_to_its_law() {
        let F = [1.1, 0.2, -0.1, 0.95];
        let nh = NeoHookean::from_young_poisson(3.0, 0.3).unwrap();
        let le = LinearElastic::from_young_poisson(3.0, 0.3).unwrap();
        let mut results = Vec::new();
        for m in [Material::from(nh), Material::from(le)] {
            assert_eq!((m.mu(), m.lambda()), (nh.mu, nh.lambda));
            let (mut P, mut Pt, mut A, mut s) = ([0.0; 4], [0.0; 4], [0.0; 16], [0.0; 9]);
            m.pk1(2, &F, &mut P).unwrap();
            m.pk1_tangent(2, &F, &mut Pt, &mut A).unwrap();
            m.cauchy(2, &F, &mut s).unwrap();
            assert_eq!(P, Pt);
            results.push((m.energy(2, &F).unwrap(), P, A, s));
        }
        let (mut P, mut A, mut s) = ([0.0; 4], [0.0; 16], [0.0; 9]);
        nh.pk1_tangent(2, &F, &mut P, &mut A).unwrap();
        nh.cauchy(2, &F, &mut s).unwrap();
        assert_eq!(results[0], (nh.energy(2, &F).unwrap(), P, A, s));
        le.pk1_tangent(2, &F, &mut P, &mut A).unwrap();
        le.cauchy(2, &F, &mut s).unwrap();
        assert_eq!(results[1], (le.energy(2, &F).unwrap(), P, A, s));
        assert!(
            results[0].1 != results[1].1,
            "the laws differ away from F = I"
        );
    }
}
