//! `[[contact]]`: contact pairs of a case. Checked against the model (bodies, face sets, stages)
//! where the pairs are built, `crate::model::contact`.

use crate::scene::element_family::ElementFamily;
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// `[[contact]]`: a contact pair between two surfaces `body.face_set`, or one surface and a rigid
/// partner.
///
/// ```toml
/// [[contact]]
/// surfaces = ["disk.arc", "block.top"]     # two-half-pass between two deformable surfaces
/// law = "penalty"
/// eps_n = 1000.0
///
/// [[contact]]
/// surfaces = ["strip.bottom"]              # against a rigid partner
/// rigid = { shape = "plane", point = [0.0, 0.0], normal = [0.0, 1.0] }
/// law = "van_der_waals"
/// a_h = 1e-19
/// r0 = 0.4
///
/// [[contact]]
/// surfaces = ["block.bottom"]              # Coulomb friction, frictionless in the first stage
/// rigid = { shape = "plane", point = [0.0, 0.0], normal = [0.0, 1.0] }
/// law = "penalty"
/// eps_n = 1000.0
/// mu = 0.3
/// friction_stages = [false, true]
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ContactSpec {
    /// Name used in `history.csv` columns. Default: `contact<index>`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// One or two surfaces, each `body.face_set` (any face set of the body: its enriched surface, or
    /// a face set of linear faces). With one surface, `rigid` gives the partner.
    pub surfaces: Vec<String>,
    /// The rigid partner of a one-surface pair.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rigid: Option<RigidSpec>,
    /// `penalty` (eq. 5), `van_der_waals` (eq. 6) or `cohesive` (eq. 7).
    pub law: LawKind,
    /// A named formulation, `algorithm` and `gap` as one key: `paper` (the paper's: two-half-pass,
    /// pointwise gap, the penalty alone, as the defaults of those keys), `weighted_gap`
    /// (`algorithm = "one_pass"` with `gap = "weighted"`: the slave's control points carry the
    /// pressure of their weighted gap) or `one_pass_pointwise` (`algorithm = "one_pass"` with
    /// `gap = "pointwise"`). `algorithm` or `gap` (with `paper`, `augmented` too) given beside it
    /// must agree with it. Default, for a pair that gives none of `formulation`, `algorithm` and
    /// `gap`: `weighted_gap` for a `penalty` pair of two deformable NURBS-enriched surfaces (both
    /// bodies Q1Np or Q1Np.t); in 2D, `one_pass_pointwise` for a frictionless `penalty` pair of
    /// two deformable faceted surfaces (both bodies Q1C1 or Q1E4); every other pair (adhesion
    /// laws, a rigid partner, faceted surfaces with friction or in 3D, Q1C2 or Q1CH surfaces, an
    /// enriched surface against a faceted one) takes `algorithm` and `gap` at their defaults, the
    /// paper's formulation. The resolved case beside the results names the formulation where a
    /// pair got one (docs/user-guide/contact-settings.md).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub formulation: Option<FormulationName>,
    /// `two_half_pass` (default when the pair gives `gap` or takes no named formulation by
    /// default (see `formulation`): each surface integrated on its own points, traction on its own
    /// body only) or `one_pass` (classic master/slave, the smoother choice in sliding: the first
    /// surface is the slave whose points are integrated, the opposite force goes to the second,
    /// the master, through its shape functions; without friction the slave is integrated over
    /// segments between the master's element boundaries (2D), or with a weighted gap in 3D over
    /// the master elements' images, so a uniform pressure gives the master its consistent forces
    /// on non-matching meshes).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schemars(extend("default" = "two_half_pass"))]
    pub algorithm: Option<Algorithm>,
    /// `penalty`: how the pressure is distributed. `pointwise` (default when the pair gives
    /// `algorithm` or takes no named formulation by default (see `formulation`): eq. 5 at every
    /// quadrature point, the paper's) or `element_mean`: one pressure per surface element, the mean over the
    /// element of the pointwise pressures `eps_n <-g_N>` (weights `w J0`, over its reference
    /// area), applied at every point of the element. On enriched surfaces it removes the
    /// point-to-point pressure oscillation (more contact points than control points) and with it
    /// the penalty dependence of the peak pressure (Hertz, Q1N2: -0.22 % instead of +1.95 % at 8
    /// elements across the contact); it makes Q1C1 worse and steps the force in sliding at the
    /// element scale (docs/user-guide/contact-settings.md). Two-half-pass penalty
    /// contact (deformable or rigid partners, with or without friction: the cone uses the
    /// element's pressure). `weighted`: the gap weighted by each surface control point's basis
    /// function, `g_A = int R_A g_N da / int R_A da` over the surface's own points (current
    /// area), one pressure `p_A = eps_n <-g_A>` per control point, interpolated by the surface
    /// basis, `p = sum_A R_A p_A`, at every point (traction `p n` on the current area). Needs a
    /// non-negative basis (Q1C1, Q1Np, Q1Np.t surfaces; not Q1C2 or Q1CH); two-half-pass (each
    /// surface weighted on its own basis, with or without friction), one-pass (the slave's
    /// control points carry the pressure, the master the opposite traction) or a rigid partner.
    /// `weighted_linear`: the same with the linear parent's corner
    /// functions as weights (one pressure per element corner, a coarser pressure than the
    /// control points of an enriched surface; any surface family). `weighted_mean`: each control
    /// point's pressure is the mean of the points' penalty pressures weighted by its basis
    /// function, `p_A = int R_A eps_n <-g_N> da / int R_A da` (points join one by one, as in
    /// `element_mean`), interpolated by the surface basis; the scope of `weighted`, without
    /// `augmented`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schemars(extend("default" = "pointwise"))]
    pub gap: Option<GapMode>,
    /// `penalty`: augmented Lagrangian enforcement, `{ tol = ..., max = ... }`. After each converged
    /// Newton solve of a load step, every quadrature point's multiplier is updated to its pressure
    /// (Uzawa: `lambda <- <lambda - eps_n g_N>`, the traction being `<lambda - eps_n g_N> n`) and
    /// Newton solves again, until the largest penetration of the pair's points is at most `tol`
    /// (a length, > 0) or `max` (>= 1) rounds were made; a step that is still above `tol` then is
    /// cut back like a failed Newton step. The converged pressure no longer depends on `eps_n`
    /// (which then only sets the convergence speed of the rounds). Multipliers are load-step
    /// history (checkpointed); rounds are counted in `history.csv` (`augmentation_rounds`) and
    /// `summary.json`. Pointwise or weighted gap (the weighted gap: one multiplier per control point);
    /// two-half-pass or one-pass (the slave's points or control points carry the multipliers);
    /// not `element_mean` or `weighted_mean`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub augmented: Option<AugmentedSpec>,
    /// Penalty parameter (> 0; force per length^3 in 3D, per length^2 in 2D): `penalty`, and the
    /// penalty against penetration of `cohesive`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schemars(extend("x-unit" = "force/length^3 (3D), force/length^2 (2D)", "exclusiveMinimum" = 0))]
    pub eps_n: Option<f64>,
    /// Hamaker's constant `A_H` (> 0) of `van_der_waals`, in the case's units of energy.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schemars(extend("x-unit" = "energy", "exclusiveMinimum" = 0))]
    pub a_h: Option<f64>,
    /// Equilibrium spacing `r0` (> 0) of the Lennard-Jones potential, `van_der_waals`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schemars(extend("x-unit" = "length", "exclusiveMinimum" = 0))]
    pub r0: Option<f64>,
    /// Peak traction `T0` (> 0) of `cohesive`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schemars(extend("x-unit" = "traction", "exclusiveMinimum" = 0))]
    pub t0: Option<f64>,
    /// Characteristic opening `g0` (> 0) of `cohesive`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schemars(extend("x-unit" = "length", "exclusiveMinimum" = 0))]
    pub g0: Option<f64>,
    /// `cohesive`: the form of its penalty against penetration, `linear` (default, `t = -eps_n g_n
    /// n` like `penalty`) or `quadratic` (`t = eps_n g_n^2 n`, continuous tangent at `g_n = 0`
    /// where a bonded interface sits; `eps_n` then in force per length^3 in 2D, per length^4 in 3D).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub penetration_penalty: Option<PenaltyForm>,
    /// `cohesive`: the initially debonded part, a box in the reference configuration; quadrature
    /// points inside it carry no cohesive traction (only the penalty against penetration).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub debonded: Option<BoxSpec>,
    /// Any law: the interacting part, a box in the reference configuration. Only the quadrature
    /// points of the pair's surfaces inside it are integrated; the others carry no traction at
    /// all (e.g. adhesion on the left 75 % of a strip, section 4.2). Default: everywhere.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub region: Option<BoxSpec>,
    /// Points farther than this from the partner are not paired (> 0). Default: twice the largest
    /// mean element length of the pair's surfaces.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schemars(extend("x-unit" = "length", "exclusiveMinimum" = 0))]
    pub search_distance: Option<f64>,
    /// Coulomb friction coefficient (> 0) of `penalty`, and of the penalty against penetration of
    /// `cohesive` (Sauer & De Lorenzis 2015: each quadrature point sticks to an anchor on the
    /// partner until its tangential traction reaches `mu` times its normal pressure, then slips).
    /// Default: frictionless. With `algorithm = "one_pass"` the slave's points stick and slip and
    /// the master takes the opposite traction.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schemars(extend("exclusiveMinimum" = 0))]
    pub mu: Option<f64>,
    /// Tangential penalty (> 0, units of `eps_n`) of the stick law `t_T = -eps_t g_T`. Default:
    /// `eps_n` (a `cohesive` pair with the quadratic penetration penalty must give it).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schemars(extend("x-unit" = "units of eps_n", "exclusiveMinimum" = 0))]
    pub eps_t: Option<f64>,
    /// `[n_stages]`: friction on (`true`) or off in each stage, e.g. `[false, true]` to indent
    /// without friction and then slide with it. Default: every stage.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub friction_stages: Vec<bool>,
    /// `[dim]`: point about which `history.csv` reports the moment of the contact forces.
    /// Default: the origin.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schemars(extend("x-unit" = "length"))]
    pub moment_point: Option<Vec<f64>>,
}

impl ContactSpec {
    /// `algorithm` and `gap` as they act: a named `formulation` spelled out, else the keys with
    /// their defaults (a contradiction between them is refused where the pair is built).
    pub fn algorithm_and_gap(&self) -> (Algorithm, GapMode) {
        match self.formulation {
            Some(f) => f.algorithm_and_gap(),
            None => (
                self.algorithm.unwrap_or_default(),
                self.gap.unwrap_or_default(),
            ),
        }
    }

    /// The formulation of a pair that names none (neither `formulation` nor `algorithm` nor
    /// `gap`): `weighted_gap` for a penalty pair of two deformable NURBS-enriched surfaces (both
    /// bodies Q1Np or Q1Np.t), and in 2D (`dim`) `one_pass_pointwise` for a frictionless
    /// penalty pair of two deformable faceted surfaces (both bodies Q1C1 or Q1E4), on which every
    /// one-pass weighted gap fails in sliding (ironing mesh 4) and the one-pass pointwise gap over
    /// segments passes the patch test and slides without a rescue (docs/formulations.md). Other
    /// pairs that name none keep the keys' defaults, the paper's formulation, and get `None`: the
    /// adhesion laws (the weighted gap is penalty-only), rigid partners (one pass either way;
    /// there the weighted gap takes fewer Newton iterations but loses the 3D and coarse 2D Hertz
    /// peaks and widens the contact), Q1C2 and Q1CH (bases that go negative or carry slopes),
    /// pairs of an enriched and a faceted surface, and faceted pairs with friction or in 3D (whose
    /// pointwise points are not integrated over segments). A pair that names a formulation or
    /// either key gets `None` too. `family` gives a body's element family by name (`None` for an
    /// unknown body, which the model reports).
    pub fn default_formulation(
        &self,
        dim: usize,
        family: impl Fn(&str) -> Option<ElementFamily>,
    ) -> Option<FormulationName> {
        if self.formulation.is_some() || self.algorithm.is_some() || self.gap.is_some() {
            return None;
        }
        let deformable_pair = self.rigid.is_none() && self.surfaces.len() == 2;
        let all = |f: fn(ElementFamily) -> bool| {
            self.surfaces.iter().all(|s| {
                let body = s.split_once('.').map_or(s.as_str(), |(b, _)| b);
                family(body).is_some_and(f)
            })
        };
        if self.law != LawKind::Penalty || !deformable_pair {
            return None;
        }
        if all(|f| matches!(f, ElementFamily::Q1N { .. })) {
            Some(FormulationName::WeightedGap)
        } else if dim == 2
            && all(|f| matches!(f, ElementFamily::Q1C1 | ElementFamily::Q1E4))
            && self.mu.is_none_or(|mu| mu == 0.0)
        {
            Some(FormulationName::OnePassPointwise)
        } else {
            None
        }
    }

    /// The pair's law and formulation in words, as `check` reports it: e.g. `penalty, one-pass,
    /// weighted gap (formulation = "weighted_gap")`, with the augmented Lagrangian and Coulomb
    /// friction where set.
    pub fn describe(&self) -> String {
        let (a, g) = self.algorithm_and_gap();
        let mut out = vec![
            match self.law {
                LawKind::Penalty => "penalty",
                LawKind::VanDerWaals => "van der Waals",
                LawKind::Cohesive => "cohesive",
            }
            .to_string(),
            match a {
                Algorithm::TwoHalfPass => "two-half-pass",
                Algorithm::OnePass => "one-pass",
            }
            .to_string(),
            match g {
                GapMode::Pointwise => "pointwise gap",
                GapMode::ElementMean => "element-mean gap",
                GapMode::Weighted => "weighted gap",
                GapMode::WeightedLinear => "weighted gap (linear weights)",
                GapMode::WeightedMean => "weighted mean pressure",
            }
            .to_string(),
        ];
        if self.augmented.is_some() {
            out.push("augmented Lagrangian".to_string());
        }
        if let Some(mu) = self.mu {
            out.push(format!("Coulomb friction mu = {mu}"));
        }
        let mut s = out.join(", ");
        if let Some(f) = self.formulation {
            s.push_str(&format!(" (formulation = \"{}\")", f.key()));
        }
        s
    }

    /// The same pair without `formulation` and without `algorithm` and `gap` at their defaults
    /// (cases that differ only in how they spell a formulation compare equal on a restart).
    pub fn canonical(&self) -> ContactSpec {
        let (a, g) = self.algorithm_and_gap();
        ContactSpec {
            formulation: None,
            algorithm: (a != Algorithm::default()).then_some(a),
            gap: (g != GapMode::default()).then_some(g),
            ..self.clone()
        }
    }
}

/// Named formulations (`formulation`), each a value of `algorithm` and `gap`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum FormulationName {
    /// Two-half-pass, pointwise gap, the penalty alone (the paper's).
    Paper,
    /// One-pass with the gap weighted by the slave's control points (`weighted`).
    WeightedGap,
    /// One-pass with the pointwise gap (`algorithm = "one_pass"`, `gap = "pointwise"`); in 2D and
    /// without friction the slave is integrated over segments between the master's element
    /// boundaries.
    OnePassPointwise,
}

impl FormulationName {
    /// Its value of the `formulation` key.
    pub fn key(self) -> &'static str {
        match self {
            FormulationName::Paper => "paper",
            FormulationName::WeightedGap => "weighted_gap",
            FormulationName::OnePassPointwise => "one_pass_pointwise",
        }
    }

    /// Its `algorithm` and `gap`.
    pub fn algorithm_and_gap(self) -> (Algorithm, GapMode) {
        match self {
            FormulationName::Paper => (Algorithm::TwoHalfPass, GapMode::Pointwise),
            FormulationName::WeightedGap => (Algorithm::OnePass, GapMode::Weighted),
            FormulationName::OnePassPointwise => (Algorithm::OnePass, GapMode::Pointwise),
        }
    }
}

/// `augmented = { tol = ..., max = ... }` of a `[[contact]]` pair.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct AugmentedSpec {
    /// Largest penetration accepted (a length, > 0).
    #[schemars(extend("x-unit" = "length", "exclusiveMinimum" = 0))]
    pub tol: f64,
    /// Most augmentation rounds per load step (>= 1).
    #[schemars(range(min = 1))]
    pub max: usize,
}

/// Where the penalty law's normal gap is taken (`gap`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum GapMode {
    /// At every quadrature point (eq. 5).
    #[default]
    Pointwise,
    /// The mean over each surface element's points.
    ElementMean,
    /// Weighted by each surface control point's basis function.
    Weighted,
    /// Weighted by the linear parent's corner functions.
    WeightedLinear,
    /// The points' penalty pressures weighted by each surface control point's basis function.
    WeightedMean,
}

/// Contact algorithms.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Algorithm {
    #[default]
    TwoHalfPass,
    OnePass,
}

/// Forms of the cohesive law's penalty against penetration.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum PenaltyForm {
    Linear,
    Quadratic,
}

/// Contact laws.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum LawKind {
    Penalty,
    VanDerWaals,
    Cohesive,
}

/// An axis-aligned box `{ min = [...], max = [...] }`, `[dim]` each.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct BoxSpec {
    /// `[dim]`: lower corner.
    #[schemars(extend("x-unit" = "length"))]
    pub min: Vec<f64>,
    /// `[dim]`: upper corner.
    #[schemars(extend("x-unit" = "length"))]
    pub max: Vec<f64>,
}

/// A rigid contact partner and its motion. Normals point out of the rigid body.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct RigidSpec {
    /// `plane` (a line in 2D; `point`, `normal`), `circle` (2D) / `sphere` (3D) (`center`,
    /// `radius`, `inside`), `cylinder` (3D; `center`, `axis`, `radius`, `inside`).
    pub shape: RigidShapeKind,
    /// `[dim]`: a point of the plane.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schemars(extend("x-unit" = "length"))]
    pub point: Option<Vec<f64>>,
    /// `[dim]`: the plane's normal, towards the deformable body (need not be normalised).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub normal: Option<Vec<f64>>,
    /// `[dim]`: centre of the circle/sphere, a point on the cylinder's axis.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schemars(extend("x-unit" = "length"))]
    pub center: Option<Vec<f64>>,
    /// Radius (> 0).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schemars(extend("x-unit" = "length", "exclusiveMinimum" = 0))]
    pub radius: Option<f64>,
    /// Cylinder axis (3D).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub axis: Option<[f64; 3]>,
    /// The deformable body is inside the circle/sphere/cylinder (a cavity). Default: false.
    #[serde(default)]
    pub inside: bool,
    /// `[n_stages][dim]`: translation reached at the end of each stage (linear in a stage).
    /// Default: none.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    #[schemars(extend("x-unit" = "length"))]
    pub translation: Vec<Vec<f64>>,
    /// `[n_stages]`: rotation angle in degrees reached at the end of each stage, about
    /// `rotation_axis` (3D; 2D rotates in the plane) through `rotation_center`. Default: none.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    #[schemars(extend("x-unit" = "degrees"))]
    pub rotation_deg: Vec<f64>,
    /// `[dim]`: centre of the rotation. Default: the origin.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schemars(extend("x-unit" = "length"))]
    pub rotation_center: Option<Vec<f64>>,
    /// Rotation axis (3D). Default: `[0, 0, 1]`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rotation_axis: Option<[f64; 3]>,
}

/// Rigid shapes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum RigidShapeKind {
    Plane,
    Circle,
    Sphere,
    Cylinder,
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec(extra: &str, surfaces: &str) -> ContactSpec {
        toml::from_str(&format!("surfaces = {surfaces}\n{extra}")).unwrap()
    }

    #[test]
    fn a_pair_describes_its_law_and_formulation_in_words() {
        let al = "law = \"penalty\"\neps_n = 10.0\naugmented = { tol = 1e-6, max = 9 }\nmu = 0.2";
        let mut s = spec(al, "[\"a.s\", \"b.t\"]");
        assert_eq!(
            s.describe(),
            "penalty, two-half-pass, pointwise gap, augmented Lagrangian, Coulomb friction mu = 0.2"
        );
        s.formulation = Some(FormulationName::WeightedGap);
        assert_eq!(
            s.describe(),
            "penalty, one-pass, weighted gap, augmented Lagrangian, Coulomb friction mu = 0.2 \
             (formulation = \"weighted_gap\")"
        );
    }

    #[test]
    fn a_penalty_pair_naming_no_formulation_gets_the_weighted_gap_if_enriched_and_one_pass_if_faceted(
    ) {
        let family = |b: &str| match b {
            "n2" => Some(ElementFamily::Q1N { p: 2, t: 0 }),
            "n21" => Some(ElementFamily::Q1N { p: 2, t: 1 }),
            "c1" => Some(ElementFamily::Q1C1),
            "e4" => Some(ElementFamily::Q1E4),
            "c2" => Some(ElementFamily::Q1C2),
            _ => None,
        };
        let penalty = "law = \"penalty\"\neps_n = 10.0";
        let both = "[\"n2.s\", \"n21.t\"]";
        assert_eq!(
            spec(penalty, both).default_formulation(2, family),
            Some(FormulationName::WeightedGap)
        );
        // augmented and friction keep the default
        let al = format!("{penalty}\naugmented = {{ tol = 1e-6, max = 9 }}\nmu = 0.2");
        assert_eq!(
            spec(&al, both).default_formulation(2, family),
            Some(FormulationName::WeightedGap)
        );
        // two faceted surfaces without friction: the one-pass pointwise gap
        let faceted = "[\"c1.s\", \"e4.t\"]";
        assert_eq!(
            spec(penalty, faceted).default_formulation(2, family),
            Some(FormulationName::OnePassPointwise)
        );
        assert_eq!(
            spec(&format!("{penalty}\nmu = 0.0"), faceted).default_formulation(2, family),
            Some(FormulationName::OnePassPointwise)
        );
        // a pair that names a formulation or either key, another law, a rigid partner, a faceted
        // surface with friction or beside an enriched one, a Lagrange / Hermite surface, or an
        // unknown body keeps the keys' defaults
        assert_eq!(spec(penalty, faceted).default_formulation(3, family), None);
        for (extra, surfaces) in [
            (format!("{penalty}\nmu = 0.2"), faceted),
            (format!("{penalty}\nformulation = \"paper\""), faceted),
            ("law = \"van_der_waals\"\na_h = 1.0\nr0 = 0.1".to_string(), faceted),
            (format!("{penalty}\nformulation = \"paper\""), both),
            (format!("{penalty}\nalgorithm = \"two_half_pass\""), both),
            (format!("{penalty}\ngap = \"pointwise\""), both),
            ("law = \"van_der_waals\"\na_h = 1.0\nr0 = 0.1".to_string(), both),
            (penalty.to_string(), "[\"n2.s\", \"c1.t\"]"),
            (penalty.to_string(), "[\"c2.s\", \"n2.t\"]"),
            (penalty.to_string(), "[\"n2.s\", \"nobody.t\"]"),
            (
                format!("{penalty}\nrigid = {{ shape = \"plane\", point = [0.0, 0.0], normal = [0.0, 1.0] }}"),
                "[\"n2.s\"]",
            ),
        ] {
            assert_eq!(
                spec(&extra, surfaces).default_formulation(2, family),
                None,
                "{extra} {surfaces}"
            );
        }
    }
}
