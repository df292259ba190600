//! A `[[contact]]` table's formulation ([`Formulation`]: passes, pressure distribution,
//! enforcement, law), composed once from its keys. Every incompatibility between the keys is
//! collected with its key path, so that `nurbs-contact check` lists them all at once; what needs
//! the model's surfaces (a non-negative basis for the surface weights) is checked where the pair
//! is built, `crate::model::contact`.

use crate::contact::{Augmented, Enforcement, Formulation, Law, Passes, Pressure, WeightBasis};
use crate::scene::{Algorithm, ContactSpec, FormulationName, GapMode, Issue, LawKind, PenaltyForm};

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
/// (a named `formulation` against `algorithm`, `gap` or `augmented`, law parameters of another
/// law or missing, a gap mode or enforcement the law or the passes do not support, a law the
/// partner does not support, friction with a law without it).
pub fn formulation(spec: &ContactSpec, i: usize) -> Result<Formulation, Vec<Issue>> {
    let mut v = Issues {
        i,
        list: Vec::new(),
    };
    named(spec, &mut v);
    let (algorithm, gap) = spec.algorithm_and_gap();
    // the key that chose the gap
    let gap_key = if spec.formulation.is_some() && spec.gap.is_none() {
        "formulation"
    } else {
        "gap"
    };
    let law = law(spec, &mut v);
    let penalty = spec.law == LawKind::Penalty;
    let passes = match (spec.rigid.is_some(), algorithm) {
        (true, _) => Passes::Rigid,
        (false, Algorithm::OnePass) => Passes::OnePass,
        (false, Algorithm::TwoHalfPass) => Passes::TwoHalfPass,
    };
    let pressure = match gap {
        GapMode::Pointwise => Pressure::Pointwise,
        GapMode::ElementMean => Pressure::ElementMean,
        GapMode::Weighted => Pressure::NodalWeights {
            basis: WeightBasis::Surface,
            mean: false,
        },
        GapMode::WeightedLinear => Pressure::NodalWeights {
            basis: WeightBasis::LinearParent,
            mean: false,
        },
        GapMode::WeightedMean => Pressure::NodalWeights {
            basis: WeightBasis::Surface,
            mean: true,
        },
    };
    if pressure != Pressure::Pointwise {
        let name = gap_name(gap);
        if !penalty {
            v.push(
                gap_key,
                format!("`{name}` goes with the `penalty` law only"),
            );
        }
        if pressure == Pressure::ElementMean && passes == Passes::OnePass {
            v.push(
                gap_key,
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
            if matches!(gap, GapMode::ElementMean | GapMode::WeightedMean) {
                v.push(
                    "augmented",
                    "is implemented for the pointwise gap and `weighted`/`weighted_linear` only (not \
                     `element_mean` or `weighted_mean`: with one multiplier per control point \
                     shifting its points' laws inside the mean, the rounds' answer still depends \
                     on `eps_n` at the edge of the contact zone; use `gap = \"weighted\"` for an \
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

/// A named `formulation` against the keys it sets: `algorithm` and `gap` given beside it must
/// agree with it, and `paper` enforces by the penalty alone (no `augmented`).
fn named(spec: &ContactSpec, v: &mut Issues) {
    let Some(name) = spec.formulation else {
        return;
    };
    let (algorithm, gap) = name.algorithm_and_gap();
    let this = name.key();
    let i = v.i;
    if let Some(a) = spec.algorithm.filter(|&a| a != algorithm) {
        v.push(
            "formulation",
            format!(
                "`{this}` is `algorithm = \"{}\"`, which contradicts `contact.{i}.algorithm = \
                 \"{}\"` (give one of the two keys)",
                algorithm_name(algorithm),
                algorithm_name(a)
            ),
        );
    }
    if let Some(g) = spec.gap.filter(|&g| g != gap) {
        v.push(
            "formulation",
            format!(
                "`{this}` is `gap = \"{}\"`, which contradicts `contact.{i}.gap = \"{}\"` (give \
                 one of the two keys)",
                gap_name(gap),
                gap_name(g)
            ),
        );
    }
    if name == FormulationName::Paper && spec.augmented.is_some() {
        v.push(
            "formulation",
            format!(
                "`paper` enforces contact by the penalty alone, which contradicts \
                 `contact.{i}.augmented` (drop one of the two keys)"
            ),
        );
    }
}

/// The key value of an algorithm.
fn algorithm_name(a: Algorithm) -> &'static str {
    match a {
        Algorithm::TwoHalfPass => "two_half_pass",
        Algorithm::OnePass => "one_pass",
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
        GapMode::Weighted => "weighted",
        GapMode::WeightedLinear => "weighted_linear",
        GapMode::WeightedMean => "weighted_mean",
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
                 gap = \"weighted_linear\"\naugmented = { tol = 1e-6, max = 4 }",
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
            &spec("law = \"penalty\"\neps_n = 1.0\ngap = \"weighted_mean\""),
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

    #[test]
    fn each_named_formulation_equals_its_spelled_out_keys() {
        for law in [
            "law = \"penalty\"\neps_n = 10.0",
            "law = \"van_der_waals\"\na_h = 1.0\nr0 = 0.1",
        ] {
            let named = formulation(&spec(&format!("{law}\nformulation = \"paper\"")), 0);
            let keys = formulation(
                &spec(&format!(
                    "{law}\nalgorithm = \"two_half_pass\"\ngap = \"pointwise\""
                )),
                0,
            );
            assert_eq!(named.unwrap(), keys.clone().unwrap());
            assert_eq!(keys, formulation(&spec(law), 0));
        }
        let law = "law = \"penalty\"\neps_n = 10.0\naugmented = { tol = 1e-6, max = 3 }";
        let named = formulation(&spec(&format!("{law}\nformulation = \"weighted_gap\"")), 0);
        let keys = formulation(
            &spec(&format!(
                "{law}\nalgorithm = \"one_pass\"\ngap = \"weighted\""
            )),
            0,
        );
        assert_eq!(named.clone().unwrap(), keys.unwrap());
        assert_eq!(named.unwrap().passes, Passes::OnePass);
        // the keys that agree with the name may be given beside it
        let both = "formulation = \"weighted_gap\"\nalgorithm = \"one_pass\"\ngap = \"weighted\"";
        assert!(formulation(&spec(&format!("{law}\n{both}")), 0).is_ok());
        // and a restart sees one formulation however it is spelled
        let a = spec(&format!("{law}\nformulation = \"weighted_gap\""));
        let b = spec(&format!(
            "{law}\nalgorithm = \"one_pass\"\ngap = \"weighted\""
        ));
        assert_eq!(a.canonical(), b.canonical());
        let p = spec("law = \"penalty\"\neps_n = 1.0\nformulation = \"paper\"");
        let d = spec("law = \"penalty\"\neps_n = 1.0\nalgorithm = \"two_half_pass\"");
        assert_eq!(p.canonical(), d.canonical());
        assert_ne!(a.canonical(), d.canonical());
    }

    #[test]
    fn a_name_contradicted_by_a_key_is_refused_with_both_keys() {
        let law = "law = \"penalty\"\neps_n = 10.0";
        for (extra, other) in [
            (
                "formulation = \"paper\"\nalgorithm = \"one_pass\"",
                "contact.2.algorithm",
            ),
            (
                "formulation = \"paper\"\ngap = \"weighted\"",
                "contact.2.gap",
            ),
            (
                "formulation = \"paper\"\naugmented = { tol = 1e-6, max = 3 }",
                "contact.2.augmented",
            ),
            (
                "formulation = \"weighted_gap\"\nalgorithm = \"two_half_pass\"",
                "contact.2.algorithm",
            ),
            (
                "formulation = \"weighted_gap\"\ngap = \"pointwise\"",
                "contact.2.gap",
            ),
        ] {
            let e = formulation(&spec(&format!("{law}\n{extra}")), 2).unwrap_err();
            assert_eq!(keys(&e), ["contact.2.formulation"], "{extra}");
            assert!(e[0].message.contains(other), "{extra}: {}", e[0].message);
        }
        // both contradictions at once, and the law's issue at the key that chose the gap
        let e = formulation(
            &spec(
                "law = \"cohesive\"\nt0 = 1.0\ng0 = 1.0\neps_n = 1.0\n\
                 formulation = \"weighted_gap\"\nalgorithm = \"two_half_pass\"\n\
                 gap = \"weighted_mean\"",
            ),
            0,
        )
        .unwrap_err();
        assert_eq!(keys(&e).len(), 3, "{e:?}");
        let e = formulation(
            &spec("law = \"cohesive\"\nt0 = 1.0\ng0 = 1.0\neps_n = 1.0\nformulation = \"weighted_gap\""),
            0,
        )
        .unwrap_err();
        assert_eq!(keys(&e), ["contact.0.formulation"]);
        assert!(e[0]
            .message
            .contains("`weighted` goes with the `penalty` law only"));
    }
}
