//! A contact pair's formulation as one value, composed once when the pair is built from its
//! `[[contact]]` table (`crate::model::formulation::formulation`) and read by the contact pass
//! instead of separate flags. Four orthogonal parts:
//!
//! - [`Passes`]: which surfaces are integrated and where the forces go. `TwoHalfPass` (the
//!   paper's: each of two deformable surfaces integrated on its own points against the other,
//!   traction on its own body only), `OnePass` (master/slave: the first surface's points, the
//!   opposite force on the second through its shape functions) or `Rigid` (one surface against a
//!   rigid partner: one half-pass, whatever `algorithm` says).
//! - [`Pressure`]: how the penalty pressure is distributed over the points. `Pointwise` (eq. 5 at
//!   every point), `ElementMean` (one pressure per surface element) or `NodalWeights` (one
//!   pressure per weight node, interpolated back to the points: the weights are the surface's
//!   own basis or the linear parent's corner functions, and what is weighted is the points' gap
//!   or, with `mean`, their penalty pressures).
//! - [`Enforcement`]: plain penalty, or augmented Lagrangian rounds (`Augmented`) after each
//!   converged solve.
//! - the [`Law`] with its parameters (penalty, van der Waals, cohesive).
//!
//! Friction, the `region` and the rigid partner's shape stay beside it in the pair's
//! [`PairDef`](crate::contact::PairDef): they do not change which code path a point takes.
//!
//! The combinations a case can build (the others are refused, each with its key, all at once):
//!
//! | passes | pressure | enforcement | law |
//! | --- | --- | --- | --- |
//! | any | `Pointwise` | `Penalty` | any |
//! | any | `Pointwise` | `Augmented` | penalty |
//! | `TwoHalfPass`, `Rigid` | `ElementMean` | `Penalty` | penalty |
//! | any | `NodalWeights { mean: false, .. }` | `Penalty` or `Augmented` | penalty |
//! | any | `NodalWeights { basis: Surface, mean: true }` | `Penalty` | penalty |
//!
//! `NodalWeights { basis: LinearParent, mean: true }` has no key and is never built. The
//! surface basis as weights also needs a non-negative basis (Q1C1, Q1Np, Q1Np.t surfaces), a
//! fact of the model checked where the surfaces exist. The cohesive law pairs material points of
//! two deformable surfaces (not `Rigid`); friction goes with the penalty law and the cohesive
//! law's penalty.
//!
//! The parts are kept apart as Tribol's coupling schemes keep theirs (contact method, model and
//! enforcement method as separate enumerations, each checked against the others when the scheme
//! is validated, every failing part reported), rather than as one enumeration of named variants
//! (MOOSE's `formulation` parameter of its contact action, which chooses the constraint and user
//! objects as a whole). Named presets (`formulation = "paper"`, `"weighted_gap"`) are spelled
//! out into these parts.

use crate::contact::pair::{Augmented, Law};

/// Which surfaces a pair integrates, and where their forces go.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Passes {
    /// Two deformable surfaces, each integrated on its own points against the other; the
    /// traction acts on the integrated surface's body only.
    TwoHalfPass,
    /// Master/slave: the first (slave) surface's points are integrated, the opposite force goes
    /// to the second (master) through its shape functions.
    OnePass,
    /// One deformable surface against a rigid partner.
    Rigid,
}

/// Which functions weight the nodal pressure of [`Pressure::NodalWeights`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WeightBasis {
    /// The surface's own basis (its control points; non-negative bases only).
    Surface,
    /// The linear parent's corner functions (one weight node per element corner).
    LinearParent,
}

/// How the penalty pressure is distributed over a surface's points.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum Pressure {
    /// Eq. (5) at every quadrature point (the paper's).
    #[default]
    Pointwise,
    /// One pressure per surface element, the mean over its points.
    ElementMean,
    /// One pressure per weight node, interpolated by the weights back to the points. `mean:
    /// false` weights the points' gaps, `g_A = int R_A g_n da / int R_A da`, `p_A = eps_n
    /// <-g_A>`; `mean: true` weights their penalty pressures, `p_A = int R_A eps_n <-g_n> da /
    /// int R_A da`.
    NodalWeights { basis: WeightBasis, mean: bool },
}

impl Pressure {
    /// One pressure per weight node (the surface's control points or the linear parent's
    /// corners).
    pub fn is_nodal(&self) -> bool {
        matches!(self, Pressure::NodalWeights { .. })
    }

    /// Nodal weights by the linear parent's corner functions.
    pub fn linear_parent(&self) -> bool {
        matches!(
            self,
            Pressure::NodalWeights {
                basis: WeightBasis::LinearParent,
                ..
            }
        )
    }
}

/// How the penalty law is enforced.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Enforcement {
    /// The penalty alone: the pressure depends on `eps_n`.
    Penalty,
    /// Augmented Lagrangian (Uzawa) rounds after each converged solve.
    Augmented(Augmented),
}

/// A pair's formulation: passes, pressure distribution, enforcement and law.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Formulation {
    pub passes: Passes,
    pub pressure: Pressure,
    pub enforcement: Enforcement,
    pub law: Law,
}

impl Formulation {
    /// Master/slave: the single half-pass also applies the opposite force to the master.
    pub fn one_pass(&self) -> bool {
        self.passes == Passes::OnePass
    }

    /// The augmented Lagrangian settings, if enforced so.
    pub fn augmented(&self) -> Option<Augmented> {
        match self.enforcement {
            Enforcement::Augmented(a) => Some(a),
            Enforcement::Penalty => None,
        }
    }
}
