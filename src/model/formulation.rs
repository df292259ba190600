//! A `[[contact]]` table's formulation ([`Formulation`]: passes, pressure distribution,
//! enforcement, law), composed once from its keys. Every incompatibility between the keys is
//! collected with its key path, so that `nurbs-contact check` lists them all at once; what needs
//! the model's surfaces (a non-negative basis for the surface weights) is checked where the pair
//! is built, `crate::model::contact`.

use crate::contact::{Augmented, Enforcement, Formulation, Law, Passes, Pressure, WeightBasis};
use crate::scene::{Algorithm, ContactSpec, GapMode, Issue, LawKind, PenaltyForm};

/// The issues of one pair, each keyed `contact.<i>.<key>`.
struct Issues {
    i: usize,
    list: Vec<Issue>,
}

impl Issues {
    fn push(&mut self, key: &str, message: impl Into<String>) {
        self.list.push(Issue {
            key: format!("contact.{}.{key}", self.i),
            line: None,
            message: message.into(),
        });
    }

    /// `v` if given, positive and finite; else an issue at `key`.
    fn positive(&mut self, key: &str, v: Option<f64>, what: &str) -> Option<f64> {
        match v {
            None => {
                self.push(key, format!("missing: {what}"));
                None
            }
            Some(x) if x.is_finite() && x > 0.0 => Some(x),
            Some(x) => {
                self.push(
                    key,
                    format!("{what} must be positive and finite, found {x}"),
                );
                None
            }
        }
    }
}

/// The formulation of pair `i` from its table `spec`, or every incompatibility between its keys
/// (law parameters of another law or missing, a gap mode or enforcement the law or the passes do
/// not support, a law the partner does not support, friction with a law without it).
pub fn formulation(spec: &ContactSpec, i: usize) -> Result<Formulation, Vec<Issue>> {
    let mut v = Issues {
        i,
        list: Vec::new(),
    };
    let law = law(spec, &mut v);
    let penalty = spec.law == LawKind::Penalty;
    let passes = match (spec.rigid.is_some(), spec.algorithm) {
        (true, _) => Passes::Rigid,
        (false, Algorithm::OnePass) => Passes::OnePass,
        (false, Algorithm::TwoHalfPass) => Passes::TwoHalfPass,
    };
    let pressure = match spec.gap {
        GapMode::Pointwise => Pressure::Pointwise,
        GapMode::ElementMean => Pressure::ElementMean,
        GapMode::Mortar => Pressure::NodalWeights {
            basis: WeightBasis::Surface,
            mean: false,
        },
        GapMode::MortarLinear => Pressure::NodalWeights {
            basis: WeightBasis::LinearParent,
            mean: false,
        },
        GapMode::MortarMean => Pressure::NodalWeights {
            basis: WeightBasis::Surface,
            mean: true,
        },
    };
    if pressure != Pressure::Pointwise {
        let name = gap_name(spec.gap);
        if !penalty {
            v.push("gap", format!("`{name}` goes with the `penalty` law only"));
        }
        if pressure == Pressure::ElementMean && passes == Passes::OnePass {
            v.push(
                "gap",
                "`element_mean` is implemented for the two-half-pass algorithm only",
            );
        }
    }
    let enforcement = match spec.augmented {
        None => Enforcement::Penalty,
        Some(a) => {
            if !penalty {
                v.push("augmented", "goes with the `penalty` law only");
            }
            if matches!(spec.gap, GapMode::ElementMean | GapMode::MortarMean) {
                v.push(
                    "augmented",
                    "is implemented for the pointwise gap and `mortar`/`mortar_linear` only (not \
                     `element_mean` or `mortar_mean`: with one multiplier per control point \
                     shifting its points' laws inside the mean, the rounds' answer still depends \
                     on `eps_n` at the edge of the contact zone; use `gap = \"mortar\"` for an \
                     answer free of `eps_n`)",
                );
            }
            if !(a.tol.is_finite() && a.tol > 0.0) {
                v.push(
                    "augmented.tol",
                    format!(
                        "must be a positive length (the largest penetration accepted), got {}",
                        a.tol
                    ),
                );
            }
            if a.max == 0 {
                v.push(
                    "augmented.max",
                    "must be at least 1 (rounds of augmentation per load step)",
                );
            }
            Enforcement::Augmented(Augmented {
                tol: a.tol,
                max: a.max,
            })
        }
    };
    if spec.law == LawKind::Cohesive && spec.rigid.is_some() && spec.surfaces.len() == 1 {
        v.push(
            "law",
            "the cohesive law pairs material points of two deformable surfaces; it needs two \
             surfaces",
        );
    }
    if spec.law == LawKind::VanDerWaals && spec.mu.is_some() {
        v.push(
            "mu",
            "friction goes with the `penalty` law and the `cohesive` law's penalty, not with \
             `van_der_waals`",
        );
    }
    match law {
        Some(law) if v.list.is_empty() => Ok(Formulation {
            passes,
            pressure,
            enforcement,
            law,
        }),
        _ => Err(v.list),
    }
}

/// The law with its parameters; `None` with issues when a parameter is missing or out of range,
/// and an issue for every parameter of another law.
fn law(spec: &ContactSpec, v: &mut Issues) -> Option<Law> {
    let used: &[&str] = match spec.law {
        LawKind::Penalty => &["eps_n"],
        LawKind::VanDerWaals => &["a_h", "r0"],
        LawKind::Cohesive => &["t0", "g0", "eps_n", "debonded", "penetration_penalty"],
    };
    let given = [
        ("eps_n", spec.eps_n.is_some()),
        ("a_h", spec.a_h.is_some()),
        ("r0", spec.r0.is_some()),
        ("t0", spec.t0.is_some()),
        ("g0", spec.g0.is_some()),
        ("debonded", spec.debonded.is_some()),
        ("penetration_penalty", spec.penetration_penalty.is_some()),
    ];
    for (k, g) in given {
        if g && !used.contains(&k) {
            v.push(
                k,
                format!(
                    "not a parameter of law `{}` (its parameters: {})",
                    law_name(spec.law),
                    used.join(", ")
                ),
            );
        }
    }
    match spec.law {
        LawKind::Penalty => Some(Law::Penalty {
            eps_n: v.positive("eps_n", spec.eps_n, "the penalty parameter")?,
        }),
        LawKind::VanDerWaals => {
            let a_h = v.positive("a_h", spec.a_h, "Hamaker's constant");
            let r0 = v.positive("r0", spec.r0, "the equilibrium spacing");
            Some(Law::VanDerWaals { a_h: a_h?, r0: r0? })
        }
        LawKind::Cohesive => {
            let t0 = v.positive("t0", spec.t0, "the peak traction");
            let g0 = v.positive("g0", spec.g0, "the characteristic opening");
            let eps_n = v.positive("eps_n", spec.eps_n, "the penalty parameter");
            Some(Law::Cohesive {
                t0: t0?,
                g0: g0?,
                eps_n: eps_n?,
                quadratic: spec.penetration_penalty == Some(PenaltyForm::Quadratic),
            })
        }
    }
}

/// The key value of a law.
pub(crate) fn law_name(l: LawKind) -> &'static str {
    match l {
        LawKind::Penalty => "penalty",
        LawKind::VanDerWaals => "van_der_waals",
        LawKind::Cohesive => "cohesive",
    }
}

/// The key value of a gap mode.
pub(crate) fn gap_name(g: GapMode) -> &'static str {
    match g {
        GapMode::Pointwise => "pointwise",
        GapMode::ElementMean => "element_mean",
        GapMode::Mortar => "mortar",
        GapMode::MortarLinear => "mortar_linear",
        GapMode::MortarMean => "mortar_mean",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec(extra: &str) -> ContactSpec {
        toml::from_str(&format!("surfaces = [\"a.top\", \"b.bottom\"]\n{extra}")).unwrap()
    }

    fn keys(e: &[Issue]) -> Vec<&str> {
        e.iter().map(|i| i.key.as_str()).collect()
    }

    #[test]
    fn every_incompatibility_of_a_pair_is_reported_with_its_key() {
        let s = spec(
            "law = \"van_der_waals\"\na_h = 1e-3\nr0 = 0.1\neps_n = 5.0\ngap = \"element_mean\"\n\
             augmented = { tol = 0.0, max = 0 }\nmu = 0.3\nalgorithm = \"one_pass\"",
        );
        let e = formulation(&s, 3).unwrap_err();
        assert_eq!(
            keys(&e),
            [
                "contact.3.eps_n",
                "contact.3.gap",
                "contact.3.gap",
                "contact.3.augmented",
                "contact.3.augmented",
                "contact.3.augmented.tol",
                "contact.3.augmented.max",
                "contact.3.mu",
            ]
        );
        assert!(e[1]
            .message
            .contains("`element_mean` goes with the `penalty` law only"));
        assert!(e[2].message.contains("two-half-pass algorithm only"));
        // missing parameters of several laws, each by its key
        let e = formulation(&spec("law = \"cohesive\"\ng0 = 0.0"), 0).unwrap_err();
        assert_eq!(
            keys(&e),
            ["contact.0.t0", "contact.0.g0", "contact.0.eps_n"]
        );
        assert!(e[1]
            .message
            .contains("must be positive and finite, found 0"));
    }

    #[test]
    fn the_keys_compose_the_parts() {
        let f = formulation(&spec("law = \"penalty\"\neps_n = 10.0"), 0).unwrap();
        assert_eq!(
            f,
            Formulation {
                passes: Passes::TwoHalfPass,
                pressure: Pressure::Pointwise,
                enforcement: Enforcement::Penalty,
                law: Law::Penalty { eps_n: 10.0 },
            }
        );
        let f = formulation(
            &spec(
                "law = \"penalty\"\neps_n = 10.0\nalgorithm = \"one_pass\"\n\
                 gap = \"mortar_linear\"\naugmented = { tol = 1e-6, max = 4 }",
            ),
            0,
        )
        .unwrap();
        assert_eq!(f.passes, Passes::OnePass);
        assert!(f.one_pass());
        assert_eq!(
            f.pressure,
            Pressure::NodalWeights {
                basis: WeightBasis::LinearParent,
                mean: false
            }
        );
        assert_eq!(f.augmented(), Some(Augmented { tol: 1e-6, max: 4 }));
        let f = formulation(
            &spec("law = \"penalty\"\neps_n = 1.0\ngap = \"mortar_mean\""),
            0,
        );
        assert_eq!(
            f.unwrap().pressure,
            Pressure::NodalWeights {
                basis: WeightBasis::Surface,
                mean: true
            }
        );
        // a rigid partner is one half-pass, whatever `algorithm` says (no master)
        let rigid: ContactSpec = toml::from_str(
            "surfaces = [\"a.top\"]\nrigid = { shape = \"plane\" }\nlaw = \"penalty\"\n\
             eps_n = 1.0\nalgorithm = \"one_pass\"\ngap = \"element_mean\"",
        )
        .unwrap();
        let f = formulation(&rigid, 0).unwrap();
        assert_eq!((f.passes, f.one_pass()), (Passes::Rigid, false));
        assert_eq!(f.pressure, Pressure::ElementMean);
    }
}
