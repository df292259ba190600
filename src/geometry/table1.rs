//! Table 1 of Corbett & Sauer 2014 (section 3.3), measured on a constructed refined curve: a straight
//! line of `n_el` equal elements, built as a linear NURBS and refined to family Q1Np.t.
#![allow(clippy::needless_range_loop)] // index loops mirror the equations
use crate::geometry::conics::{line_segment, refined_curve};
use crate::geometry::nurbs::NurbsCurve;
use crate::geometry::GeometryError;

/// Element properties of one Table 1 row.
#[derive(Debug, Clone, PartialEq)]
pub struct Table1Row {
    /// surface continuity `C^k` across element boundaries: `k = order - max interior multiplicity`
    pub continuity: usize,
    /// DOF of one 2D enriched element, `2 (n_s^e + 2)`
    pub dof_per_element: usize,
    /// surface nodes (control points) per element, `n_s^e`
    pub n_s_e: usize,
    /// distance between the outermost control points of an interior element, in element lengths
    pub node_span: f64,
    /// basis functions whose support lies within one element (counted for an interior element)
    pub n_ex: usize,
    /// maximum number of elements in the support of one basis function
    pub n_max: usize,
}

/// Measures the Table 1 quantities on `curve`, taking element `e` as the representative element.
/// `l_e`: the element length used to express the node span.
#[allow(non_snake_case)]
pub fn measure(curve: &NurbsCurve, e: usize, l_e: f64) -> Result<Table1Row, GeometryError> {
    let kv = &curve.knots;
    let q = kv.degree();
    let spans = kv.element_spans();
    let &span = spans.get(e).ok_or(GeometryError::BadParameter {
        name: "element",
        value: e as f64,
        reason: "no such element in the curve",
    })?;
    let U = kv.knots();
    // number of non-empty knot spans covered by the support [U[i], U[i+q+1]] of function i
    let support = |i: usize| (i..=i + q).filter(|&k| U[k] < U[k + 1]).count();
    let n_max = (0..kv.n_basis()).map(support).max().unwrap_or(0);
    let first = span - q;
    let n_ex = (first..=span).filter(|&i| support(i) == 1).count();
    let (a, b) = (curve.ctrl_point(first), curve.ctrl_point(span));
    let dist = ((0..3).map(|c| (b[c] - a[c]).powi(2)).sum::<f64>()).sqrt();
    let n_s_e = q + 1;
    Ok(Table1Row {
        continuity: kv.min_interior_continuity(),
        dof_per_element: 2 * (n_s_e + 2),
        n_s_e,
        node_span: dist / l_e,
        n_ex,
        n_max,
    })
}

/// Table 1 row of family Q1Np.t, computed on a straight line of `n_el` unit elements refined by
/// [`refined_curve`]; the representative element is the middle one, so `n_el` should be large
/// enough (>= 2 (p+t) + 1) for it to be unaffected by the open ends.
pub fn table1_row(p: usize, t: usize, n_el: usize) -> Result<Table1Row, GeometryError> {
    let line = line_segment(&[0.0, 0.0], &[n_el as f64, 0.0])?;
    let curve = refined_curve(&line, p, t, n_el)?;
    measure(&curve, n_el / 2, 1.0)
}

/// One published row: `(p, t, C^k, DOF, n_s^e, node span, n_ex, n_max)`.
pub type PublishedRow = (usize, usize, usize, usize, usize, f64, usize, usize);

/// Table 1 of Corbett & Sauer 2014 as published, the reference the tests compare against:
/// `(p, t, continuity C^k, DOF per element, n_s^e, node span in L_e, n_ex, n_max)`.
pub const TABLE1_PAPER: [PublishedRow; 9] = [
    (2, 0, 1, 10, 3, 2.0, 0, 3),
    (3, 0, 2, 12, 4, 3.0, 0, 4),
    (4, 0, 3, 14, 5, 4.0, 0, 5),
    (2, 1, 1, 12, 4, 5.0 / 3.0, 0, 2),
    (2, 2, 1, 14, 5, 1.5, 1, 2),
    (2, 3, 1, 16, 6, 1.4, 2, 2),
    (3, 1, 2, 14, 5, 2.0, 0, 3),
    (3, 2, 2, 16, 6, 1.8, 0, 2),
    (3, 3, 2, 18, 7, 5.0 / 3.0, 1, 2),
];

#[cfg(test)]
#[allow(non_snake_case)]
mod tests {
    use super::*;

    #[test]
    fn table1_of_the_paper_is_reproduced_from_refined_curves() {
        for (p, t, ck, dof, ns, span, nex, nmax) in TABLE1_PAPER {
            let r = table1_row(p, t, 15).unwrap();
            assert_eq!(r.continuity, ck, "Q1N{p}.{t}");
            assert_eq!(r.dof_per_element, dof, "Q1N{p}.{t}");
            assert_eq!(r.n_s_e, ns, "Q1N{p}.{t}");
            assert!(
                (r.node_span - span).abs() < 1e-12,
                "Q1N{p}.{t}: {} vs {span}",
                r.node_span
            );
            assert_eq!(r.n_ex, nex, "Q1N{p}.{t}");
            assert_eq!(r.n_max, nmax, "Q1N{p}.{t}");
        }
    }

    #[test]
    fn node_span_tends_to_one_for_many_elevations() {
        // section 3.3: node span -> 1 as t -> infinity. For t >= p-2 the outermost Greville points of
        // an element sit (p-1)/(p+t) outside it, so node span = 1 + 2 (p-1)/(p+t).
        for p in 2..=3 {
            for t in p - 2..=8 {
                let span = table1_row(p, t, 21).unwrap().node_span;
                let expected = 1.0 + 2.0 * (p as f64 - 1.0) / (p + t) as f64;
                assert!(
                    (span - expected).abs() < 1e-12,
                    "p={p} t={t}: {span} vs {expected}"
                );
            }
        }
    }
}
