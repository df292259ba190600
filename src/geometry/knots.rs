//! Open knot vectors (eq. 9 of Corbett & Sauer 2014) and the span search of Piegl & Tiller A2.1.
#![allow(clippy::needless_range_loop)] // index loops mirror the equations
use crate::geometry::{GeometryError, MAX_ORDER};

/// A validated open knot vector of order `p`: finite, non-decreasing, first and last knot repeated
/// exactly `p+1` times, interior multiplicities at most `p`, length `n+p+1` with `n >= p+1`.
#[derive(Debug, Clone, PartialEq)]
pub struct KnotVector {
    p: usize,
    /// [n + p + 1]
    knots: Vec<f64>,
}

impl KnotVector {
    /// Validates `knots` as an open knot vector of order `p`.
    pub fn new(p: usize, knots: Vec<f64>) -> Result<Self, GeometryError> {
        if p == 0 || p > MAX_ORDER {
            return Err(GeometryError::OrderOutOfRange { p, max: MAX_ORDER });
        }
        if let Some((index, &value)) = knots.iter().enumerate().find(|(_, k)| !k.is_finite()) {
            return Err(GeometryError::NonFiniteKnot { index, value });
        }
        let min = 2 * (p + 1);
        if knots.len() < min {
            return Err(GeometryError::TooFewKnots {
                found: knots.len(),
                p,
                min,
            });
        }
        for index in 1..knots.len() {
            if knots[index] < knots[index - 1] {
                return Err(GeometryError::DecreasingKnots {
                    index,
                    prev: knots[index - 1],
                    value: knots[index],
                });
            }
        }
        let (first, last) = (knots[0], knots[knots.len() - 1]);
        if first >= last {
            return Err(GeometryError::EmptyDomain { first, last });
        }
        let kv = KnotVector { p, knots };
        let uniq = kv.unique_with_multiplicity();
        let n_u = uniq.len();
        for (i, &(value, found)) in uniq.iter().enumerate() {
            let end = if i == 0 {
                Some("first")
            } else if i == n_u - 1 {
                Some("last")
            } else {
                None
            };
            match end {
                Some(end) if found != p + 1 => {
                    return Err(GeometryError::NotOpen {
                        end,
                        value,
                        found,
                        expected: p + 1,
                    });
                }
                None if found > p => {
                    return Err(GeometryError::InteriorMultiplicity { value, found, p });
                }
                _ => {}
            }
        }
        Ok(kv)
    }

    /// Open knot vector on `[a, b]` with `n_el` equal knot spans, each interior knot repeated `mult` times.
    pub fn open_uniform(
        p: usize,
        n_el: usize,
        mult: usize,
        a: f64,
        b: f64,
    ) -> Result<Self, GeometryError> {
        if n_el == 0 {
            return Err(GeometryError::BadParameter {
                name: "n_el",
                value: 0.0,
                reason: "must be >= 1",
            });
        }
        let mut knots = vec![a; p + 1];
        for i in 1..n_el {
            let u = a + (b - a) * i as f64 / n_el as f64;
            knots.extend(std::iter::repeat_n(u, mult));
        }
        knots.extend(std::iter::repeat_n(b, p + 1));
        KnotVector::new(p, knots)
    }

    /// Order `p`.
    pub fn degree(&self) -> usize {
        self.p
    }
    /// The knots, [n + p + 1].
    pub fn knots(&self) -> &[f64] {
        &self.knots
    }
    /// Number of basis functions `n`.
    pub fn n_basis(&self) -> usize {
        self.knots.len() - self.p - 1
    }
    /// First parameter value.
    pub fn first(&self) -> f64 {
        self.knots[0]
    }
    /// Last parameter value.
    pub fn last(&self) -> f64 {
        self.knots[self.knots.len() - 1]
    }

    /// Knot span index `i` with `U[i] <= u < U[i+1]` (P&T A2.1); `u` outside the domain is clamped,
    /// and `u = last` belongs to the last non-empty span.
    #[allow(non_snake_case)]
    pub fn find_span(&self, u: f64) -> usize {
        let n = self.n_basis() - 1;
        let U = &self.knots;
        if u >= U[n + 1] {
            return n;
        }
        if u <= U[self.p] {
            // Skip over empty spans is not needed: U[p] < U[p+1] for an open vector.
            return self.p;
        }
        let (mut low, mut high) = (self.p, n + 1);
        let mut mid = (low + high) / 2;
        while u < U[mid] || u >= U[mid + 1] {
            if u < U[mid] {
                high = mid;
            } else {
                low = mid;
            }
            mid = (low + high) / 2;
        }
        mid
    }

    /// Distinct knot values with their multiplicities, in increasing order.
    pub fn unique_with_multiplicity(&self) -> Vec<(f64, usize)> {
        let mut out: Vec<(f64, usize)> = Vec::new();
        for &k in &self.knots {
            match out.last_mut() {
                Some((v, m)) if *v == k => *m += 1,
                _ => out.push((k, 1)),
            }
        }
        out
    }

    /// Multiplicity of the value `u` in the knot vector (0 if absent).
    pub fn multiplicity(&self, u: f64) -> usize {
        self.knots.iter().filter(|&&k| k == u).count()
    }

    /// Span indices `i` of the non-empty knot spans `[U[i], U[i+1])`, one per element, in order.
    pub fn element_spans(&self) -> Vec<usize> {
        (self.p..self.n_basis())
            .filter(|&i| self.knots[i] < self.knots[i + 1])
            .collect()
    }

    /// Number of elements (non-empty knot spans).
    pub fn n_elements(&self) -> usize {
        self.unique_with_multiplicity().len() - 1
    }

    /// Lowest continuity `C^k` over interior knots, `k = p - max interior multiplicity`
    /// (`p` itself, i.e. C^inf within a single element, if there are no interior knots).
    pub fn min_interior_continuity(&self) -> usize {
        let u = self.unique_with_multiplicity();
        let max_m = u[1..u.len() - 1].iter().map(|&(_, m)| m).max().unwrap_or(0);
        self.p - max_m
    }
}

#[cfg(test)]
#[allow(non_snake_case)]
mod tests {
    use super::*;

    #[test]
    fn bad_knot_vectors_give_the_right_error() {
        assert!(matches!(
            KnotVector::new(0, vec![0., 1.]),
            Err(GeometryError::OrderOutOfRange { .. })
        ));
        assert!(matches!(
            KnotVector::new(2, vec![0., 0., 0., f64::NAN, 1., 1., 1.]),
            Err(GeometryError::NonFiniteKnot { index: 3, .. })
        ));
        assert!(matches!(
            KnotVector::new(2, vec![0., 0., 0., 1., 1.]),
            Err(GeometryError::TooFewKnots {
                found: 5,
                p: 2,
                min: 6
            })
        ));
        assert!(matches!(
            KnotVector::new(2, vec![0., 0., 0., 0.7, 0.5, 1., 1., 1.]),
            Err(GeometryError::DecreasingKnots { index: 4, .. })
        ));
        assert!(matches!(
            KnotVector::new(2, vec![0., 0., 0.5, 1., 1., 1.]),
            Err(GeometryError::NotOpen {
                end: "first",
                found: 2,
                expected: 3,
                ..
            })
        ));
        assert!(matches!(
            KnotVector::new(2, vec![0., 0., 0., 0.5, 1., 1.]),
            Err(GeometryError::NotOpen {
                end: "last",
                found: 2,
                ..
            })
        ));
        assert!(matches!(
            KnotVector::new(2, vec![0., 0., 0., 0.5, 0.5, 0.5, 1., 1., 1.]),
            Err(GeometryError::InteriorMultiplicity { found: 3, p: 2, .. })
        ));
        assert!(matches!(
            KnotVector::new(1, vec![1., 1., 1., 1.]),
            Err(GeometryError::EmptyDomain { .. })
        ));
    }

    #[test]
    fn find_span_brackets_parameter() {
        let kv = KnotVector::new(2, vec![0., 0., 0., 0.25, 0.5, 0.5, 1., 1., 1.]).unwrap();
        for k in 0..=100 {
            let u = k as f64 / 100.0;
            let i = kv.find_span(u);
            let U = kv.knots();
            assert!(
                U[i] <= u && (u < U[i + 1] || (u == 1.0 && U[i + 1] == 1.0)),
                "u={u} i={i}"
            );
            assert!(U[i] < U[i + 1]);
        }
        assert_eq!(
            kv.unique_with_multiplicity(),
            vec![(0., 3), (0.25, 1), (0.5, 2), (1., 3)]
        );
        assert_eq!(kv.element_spans(), vec![2, 3, 5]);
        assert_eq!(kv.min_interior_continuity(), 0);
    }
}
