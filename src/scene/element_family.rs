//! Element family names of a body, as written in a case file: `Q1C1`, `Q1E4`, `Q1N<p>` / `Q1N<p>.<t>`,
//! `Q1C2`, `Q1CH` (section 3 of Corbett & Sauer 2014; Q1C2/Q1CH after Sauer 2013).

use serde::{Deserialize, Serialize};
use std::fmt;
use std::str::FromStr;

/// Largest NURBS order accepted in `Q1N<p>`; the paper goes up to Q1N8, beyond that the surface basis
/// has more support than any mesh here can hold.
pub const MAX_NURBS_ORDER: u32 = 16;
const _: () = assert!(MAX_NURBS_ORDER as usize <= crate::geometry::MAX_ORDER);

/// The element family of a body. Enriched families (`Q1N`, `Q1C2`, `Q1CH`) replace the bilinear
/// (trilinear) interpolation on one surface layer of the body by a richer one.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(try_from = "String", into = "String")]
pub enum ElementFamily {
    /// Standard bilinear (2D) / trilinear (3D) Lagrange element.
    Q1C1,
    /// Bilinear element with 4 enhanced assumed strain modes, 2D only.
    Q1E4,
    /// NURBS-enriched contact element of order `p`, with `t` extra knot insertions per surface element
    /// (surface-oriented refinement, section 3.3): `Q1N2` is `{ p: 2, t: 0 }`, `Q1N2.1` is `{ p: 2, t: 1 }`.
    Q1N { p: u32, t: u32 },
    /// Quadratic Lagrange enriched surface element, 2D only.
    Q1C2,
    /// Hermite enriched surface element, 2D only.
    Q1CH,
}

impl ElementFamily {
    /// Whether the family needs an `enriched_surface`.
    pub fn is_enriched(self) -> bool {
        matches!(
            self,
            ElementFamily::Q1N { .. } | ElementFamily::Q1C2 | ElementFamily::Q1CH
        )
    }

    /// Whether the family exists in 3D (Q1E4, Q1C2 and Q1CH are 2D formulations here).
    pub fn supports_3d(self) -> bool {
        matches!(self, ElementFamily::Q1C1 | ElementFamily::Q1N { .. })
    }
}

/// Why an element family name was rejected.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown element family `{name}`: {reason} (expected Q1C1, Q1E4, Q1C2, Q1CH, Q1N<p> or Q1N<p>.<t>, e.g. Q1N2.1)")]
pub struct ElementFamilyError {
    pub name: String,
    pub reason: String,
}

impl FromStr for ElementFamily {
    type Err = ElementFamilyError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let err = |reason: &str| ElementFamilyError {
            name: s.to_string(),
            reason: reason.to_string(),
        };
        match s {
            "Q1C1" => return Ok(ElementFamily::Q1C1),
            "Q1E4" => return Ok(ElementFamily::Q1E4),
            "Q1C2" => return Ok(ElementFamily::Q1C2),
            "Q1CH" => return Ok(ElementFamily::Q1CH),
            _ => {}
        }
        let Some(rest) = s.strip_prefix("Q1N") else {
            return Err(err("not a known family"));
        };
        let (p_str, t_str) = match rest.split_once('.') {
            Some((p, t)) => (p, Some(t)),
            None => (rest, None),
        };
        let parse = |text: &str, what: &str| -> Result<u32, ElementFamilyError> {
            if text.is_empty() || !text.bytes().all(|b| b.is_ascii_digit()) {
                return Err(err(&format!(
                    "{what} `{text}` is not a non-negative integer"
                )));
            }
            text.parse::<u32>()
                .map_err(|_| err(&format!("{what} `{text}` is too large")))
        };
        let p = parse(p_str, "NURBS order p")?;
        if p == 0 || p > MAX_NURBS_ORDER {
            return Err(err(&format!(
                "NURBS order p = {p} must be in 1..={MAX_NURBS_ORDER}"
            )));
        }
        let t = match t_str {
            Some(t) => parse(t, "refinement level t")?,
            None => 0,
        };
        // the refined surface has order p + t, which the basis routines bound
        let max_t = crate::geometry::MAX_ORDER as u32 - p;
        if t > max_t {
            return Err(err(&format!(
                "refinement level t = {t} is out of range 0..={max_t}: the element order p + t \
                 must be at most {}",
                crate::geometry::MAX_ORDER
            )));
        }
        Ok(ElementFamily::Q1N { p, t })
    }
}

impl fmt::Display for ElementFamily {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ElementFamily::Q1C1 => f.write_str("Q1C1"),
            ElementFamily::Q1E4 => f.write_str("Q1E4"),
            ElementFamily::Q1C2 => f.write_str("Q1C2"),
            ElementFamily::Q1CH => f.write_str("Q1CH"),
            ElementFamily::Q1N { p, t: 0 } => write!(f, "Q1N{p}"),
            ElementFamily::Q1N { p, t } => write!(f, "Q1N{p}.{t}"),
        }
    }
}

impl TryFrom<String> for ElementFamily {
    type Error = ElementFamilyError;
    fn try_from(s: String) -> Result<Self, Self::Error> {
        s.parse()
    }
}

impl From<ElementFamily> for String {
    fn from(f: ElementFamily) -> String {
        f.to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn element_family_parses_every_paper_name() {
        assert_eq!("Q1C1".parse(), Ok(ElementFamily::Q1C1));
        assert_eq!("Q1E4".parse(), Ok(ElementFamily::Q1E4));
        assert_eq!("Q1C2".parse(), Ok(ElementFamily::Q1C2));
        assert_eq!("Q1CH".parse(), Ok(ElementFamily::Q1CH));
        assert_eq!("Q1N2".parse(), Ok(ElementFamily::Q1N { p: 2, t: 0 }));
        assert_eq!("Q1N2.1".parse(), Ok(ElementFamily::Q1N { p: 2, t: 1 }));
        assert_eq!("Q1N8".parse(), Ok(ElementFamily::Q1N { p: 8, t: 0 }));
        assert_eq!("Q1N3.1".parse(), Ok(ElementFamily::Q1N { p: 3, t: 1 }));
        assert_eq!("Q1N2.18".parse(), Ok(ElementFamily::Q1N { p: 2, t: 18 }));
    }

    #[test]
    fn element_family_display_round_trips() {
        for name in ["Q1C1", "Q1E4", "Q1C2", "Q1CH", "Q1N2", "Q1N2.2", "Q1N4"] {
            let f: ElementFamily = name.parse().unwrap();
            assert_eq!(f.to_string(), name);
        }
    }

    #[test]
    fn element_family_rejects_bad_names_with_reason() {
        for (name, why) in [
            ("Q1N0", "must be in 1..="),
            ("Q1X", "not a known family"),
            ("Q1N", "not a non-negative integer"),
            ("Q1N2.", "refinement level"),
            ("Q1N2.x", "refinement level"),
            ("Q1N-1", "not a non-negative integer"),
            (
                "Q1N2.1000",
                "refinement level t = 1000 is out of range 0..=18",
            ),
            ("Q1N16.5", "refinement level t = 5 is out of range 0..=4"),
            ("q1c1", "not a known family"),
        ] {
            let e = name.parse::<ElementFamily>().unwrap_err();
            let shown = e.to_string();
            assert!(shown.contains(name), "{shown}");
            assert!(shown.contains(why), "{name}: {shown}");
        }
    }

    #[test]
    fn enriched_families_are_q1n_q1c2_q1ch() {
        assert!(!ElementFamily::Q1C1.is_enriched());
        assert!(!ElementFamily::Q1E4.is_enriched());
        assert!(ElementFamily::Q1N { p: 2, t: 1 }.is_enriched());
        assert!(ElementFamily::Q1C2.is_enriched());
        assert!(ElementFamily::Q1CH.is_enriched());
        assert!(!ElementFamily::Q1E4.supports_3d());
        assert!(ElementFamily::Q1N { p: 2, t: 0 }.supports_3d());
    }
}
