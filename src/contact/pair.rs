//! A contact pair as declared and resolved against the model: its law, friction, partners of its
//! half-passes, and the coupling blocks it adds to the Jacobian. Plain data, shared by the
//! half-pass ([`crate::contact::half_pass`]) and the system ([`crate::contact::system`]).

use crate::contact::formulation::Formulation;
use crate::contact::law::{self, Traction};
use crate::contact::rigid::{RigidMotion, RigidShape};
use crate::contact::search::Aabb;

/// A contact law with its parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Law {
    /// Eq. (5): penalty `eps_n` on the current surface.
    Penalty { eps_n: f64 },
    /// Eq. (6): van der Waals adhesion (reference traction).
    VanDerWaals { a_h: f64, r0: f64 },
    /// Eq. (7): exponential cohesive zone with material point pairing, plus a penalty `eps_n`
    /// against penetration.
    Cohesive {
        t0: f64,
        g0: f64,
        eps_n: f64,
        /// The penalty against penetration is quadratic in the penetration (else linear).
        quadratic: bool,
    },
}

/// Coulomb friction of a pair (Sauer & De Lorenzis 2015, unbiased two-half-pass): every quadrature
/// point keeps an anchor on the partner where it sticks; see [`crate::contact::kernel::FrictionIn`].
#[derive(Debug, Clone, PartialEq)]
pub struct Friction {
    /// Friction coefficient (> 0).
    pub mu: f64,
    /// Tangential penalty (> 0).
    pub eps_t: f64,
    /// Per load stage: friction on (empty: every stage). A frictionless stage moves each anchor
    /// with its point, so friction starts from the state the stage leaves.
    pub stages: Vec<bool>,
}

impl Friction {
    /// True when friction acts at load `lambda` (stage `s` runs over `(s, s + 1]`).
    pub fn on_at(&self, lambda: f64) -> bool {
        if self.stages.is_empty() {
            return true;
        }
        let s = ((lambda - 1e-9).ceil() - 1.0).max(0.0) as usize;
        self.stages[s.min(self.stages.len() - 1)]
    }
}

/// Where a frictional point sticks: a material point of the partner (deformable: element and
/// surface coordinates; rigid: its position in the rigid body's reference configuration).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Anchor {
    Surface(u32, [f64; 2]),
    Rigid([f64; 3]),
}

/// The partner of a half-pass.
#[derive(Debug, Clone, PartialEq)]
pub enum Partner {
    /// Another contact surface (index into the system's surfaces).
    Surface(usize),
    /// A rigid shape and its motion.
    Rigid(RigidShape, RigidMotion),
}

/// A declared contact pair, resolved against the model.
#[derive(Debug, Clone, PartialEq)]
pub struct PairDef {
    /// Name (history columns).
    pub name: String,
    /// Passes, pressure distribution, enforcement and law ([`Formulation`]).
    pub formulation: Formulation,
    /// Half-passes: (integrated surface, partner). Two-half-pass: both ways; one-pass and rigid:
    /// one.
    pub passes: Vec<(usize, Partner)>,
    /// Points farther than this from the partner are not paired.
    pub search_distance: f64,
    /// Moments of the contact forces are taken about this point [3].
    pub moment_point: [f64; 3],
    /// Reference-configuration box whose points carry no cohesive traction (initially debonded).
    pub debonded: Option<Aabb>,
    /// Reference-configuration box outside which the pair's quadrature points are not integrated.
    pub region: Option<Aabb>,
    /// Coulomb friction (penalty law, and the cohesive law's penalty against penetration).
    pub friction: Option<Friction>,
}

/// Augmented Lagrangian (Uzawa) enforcement of a penalty pair: after each converged solve every
/// point's multiplier becomes its pressure, until the largest penetration is at most `tol`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Augmented {
    /// Largest penetration accepted (a length).
    pub tol: f64,
    /// Most rounds per load step.
    pub max: usize,
}

/// One coupling block of the Jacobian, contact's [`Block`](crate::assembly::Block): rows of
/// element `k_e` of the pass's surface, and the columns its third key names ([`BlockKey`]), as
/// `(pass, k_e, key)`.
pub type Coupling = crate::assembly::Block;

/// What a coupling block's columns are: those of the own element and partner element `l`
/// (one-pass: its rows too), the same columns under the own element's rows only (`Reach`: the
/// one-pass weighted gap's partner elements of points of the own element's neighbours, whose
/// rows the own element's residual does not reach), those of the own element against a rigid
/// partner, or (weighted gaps) those of element `e` of the integrated surface itself. Encoded
/// into the block's third `u32` only here: partner elements as themselves, `Reach` with bit 30
/// set, the rigid partner as `u32::MAX`, own-surface elements with the top bit set.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum BlockKey {
    Partner(u32),
    Reach(u32),
    Rigid,
    Own(u32),
}

const OWN_BIT: u32 = 1 << 31;
const REACH_BIT: u32 = 1 << 30;

impl BlockKey {
    /// The block's third `u32`.
    pub(crate) fn encode(self) -> u32 {
        match self {
            BlockKey::Partner(l) => {
                debug_assert!(l < REACH_BIT, "partner element {l} beyond the key's range");
                l
            }
            BlockKey::Reach(l) => {
                debug_assert!(l < REACH_BIT, "partner element {l} beyond the key's range");
                l | REACH_BIT
            }
            BlockKey::Rigid => u32::MAX,
            BlockKey::Own(e) => {
                // (`OWN_BIT - 1` would be the rigid partner's `u32::MAX`)
                debug_assert!(e < OWN_BIT - 1, "own element {e} beyond the key's range");
                e | OWN_BIT
            }
        }
    }

    /// The key a block's third `u32` encodes.
    pub(crate) fn decode(key: u32) -> BlockKey {
        if key == u32::MAX {
            BlockKey::Rigid
        } else if key & OWN_BIT != 0 {
            BlockKey::Own(key & !OWN_BIT)
        } else if key & REACH_BIT != 0 {
            BlockKey::Reach(key & !REACH_BIT)
        } else {
            BlockKey::Partner(key)
        }
    }

    /// The partner element whose columns the block holds (`Partner` and `Reach`).
    pub(crate) fn partner(self) -> Option<u32> {
        match self {
            BlockKey::Partner(l) | BlockKey::Reach(l) => Some(l),
            BlockKey::Rigid | BlockKey::Own(_) => None,
        }
    }
}

/// The COO slot of a coupling block in the current pattern (`None`: not in it).
pub use crate::assembly::SlotOf;

/// The traction of a pair's law at a point with gap `g` and normal `n` [3].
/// `touch`: gaps below it count as touching (round-off tolerance of the penalty's active set).
pub(crate) fn law_traction(law: &Law, touch: f64, g: &[f64; 3], n: &[f64; 3]) -> Traction {
    match *law {
        Law::Penalty { eps_n } => law::penalty(eps_n, touch, g, n),
        Law::VanDerWaals { a_h, r0 } => law::van_der_waals(a_h, r0, g, n),
        Law::Cohesive {
            eps_n,
            quadratic: false,
            ..
        } => law::penalty(eps_n, touch, g, n),
        Law::Cohesive {
            eps_n,
            quadratic: true,
            ..
        } => law::penalty_quadratic(eps_n, g, n),
    }
}

/// Relative round-off tolerance of "touching", in units of the surface's element length.
pub(crate) const TOUCH: f64 = 1e-12;

/// Pairs of bulk cells `[a, b]` (`a < b`, sorted, no repeats) whose contact surface elements face
/// each other across a pair between two deformable surfaces in the reference configuration
/// `coords` [n_global_nodes][dim]: a control point of one element lies within the pair's search
/// distance of the other's control-point box. The partitioner adds them to the dual graph, so
/// that METIS keeps facing surface pieces on one rank where it can (each such cut edge is a
/// partner element a rank must gather; docs/performance/contact.md, "Contact data per rank").
/// Rigid partners add none.
pub fn facing_cells(
    surfaces: &[crate::contact::surface::ContactSurface],
    pairs: &[PairDef],
    coords: &[f64],
    dim: usize,
) -> Vec<[u32; 2]> {
    use crate::contact::search::BinGrid;
    use crate::contact::surface::reference_positions;
    let mut edges = Vec::new();
    let mut cand = Vec::new();
    for def in pairs {
        for (k, partner) in &def.passes {
            let Partner::Surface(l) = partner else {
                continue;
            };
            let (own, other) = (&surfaces[*k], &surfaces[*l]);
            let boxes: Vec<Aabb> = other
                .elements
                .iter()
                .map(|el| {
                    let mut b = Aabb::EMPTY;
                    for x in reference_positions(coords, dim, &el.nodes).chunks(dim) {
                        b.grow(x);
                    }
                    b.inflated(dim, def.search_distance)
                })
                .collect();
            let grid = BinGrid::new(dim, boxes);
            let mut mine = Vec::new();
            for el in &own.elements {
                let a = el.cell as u32;
                mine.clear();
                for x in reference_positions(coords, dim, &el.nodes).chunks(dim) {
                    grid.candidates(x, &mut cand);
                    mine.extend(
                        cand.iter()
                            .map(|&e| other.elements[e as usize].cell as u32)
                            .filter(|&c| c != a)
                            .map(|c| [a.min(c), a.max(c)]),
                    );
                }
                // one element's points share their partners
                mine.sort_unstable();
                mine.dedup();
                edges.extend_from_slice(&mine);
            }
        }
    }
    edges.sort_unstable();
    edges.dedup();
    edges
}

/// The partitioner's contact weight per cell [n_cells] (`[solver] partition = "contact"`): the
/// contact points (`points`, [`points_per_cell`]) of the cells whose contact surface faces a
/// partner (`facing`, [`facing_cells`]), 0 for the others. The contact work of a point with a
/// partner in reach (a warm-started projection every evaluation, and its traction and blocks once
/// active) is many times that of a point with none (a bin lookup that finds no candidate), so
/// balancing all points let one rank take every facing piece and the other the far ones: on the
/// 1e5 scale scene one rank did 74 % of the projections' time and 82 % of the contact blocks'
/// (docs/user-guide/parallel-and-clusters.md, "How a run is split").
/// When no cell faces a partner (rigid partners only, or surfaces farther apart than the search
/// distance), every point counts.
pub fn facing_points(points: &[u32], facing: &[[u32; 2]]) -> Vec<u32> {
    let mut faces = vec![false; points.len()];
    for &[a, b] in facing {
        for c in [a, b] {
            if let Some(f) = faces.get_mut(c as usize) {
                *f = true;
            }
        }
    }
    let w: Vec<u32> = points
        .iter()
        .zip(&faces)
        .map(|(&p, &f)| if f { p } else { 0 })
        .collect();
    if w.iter().any(|&p| p > 0) {
        w
    } else {
        points.to_vec()
    }
}

/// The contact quadrature points each cell's rank integrates [n_cells]: the points of every
/// half-pass's surface elements, counted on the element's bulk cell (the partitioner's second
/// balance constraint). A pair's `region` is not applied: a weight, not a count of active points.
pub fn points_per_cell(
    surfaces: &[crate::contact::surface::ContactSurface],
    pairs: &[PairDef],
    n_cells: usize,
) -> Vec<u32> {
    let mut count = vec![0u32; n_cells];
    for def in pairs {
        for (k, _) in &def.passes {
            for el in &surfaces[*k].elements {
                let n: usize = el.basis.quadrature_counts().iter().product();
                count[el.cell] += n as u32;
            }
        }
    }
    count
}

#[cfg(test)]
mod tests {
    use super::facing_points;

    #[test]
    fn facing_points_keep_the_points_of_facing_cells_only() {
        // cells 0..5 with contact points 9, 9, 0, 4, 9; cells 0 and 3 face each other
        let points = [9, 9, 0, 4, 9];
        assert_eq!(facing_points(&points, &[[0, 3]]), vec![9, 0, 0, 4, 0]);
        // a facing pair whose cells carry no points (a cell out of range is ignored)
        assert_eq!(facing_points(&points, &[[2, 7]]), points.to_vec());
        // nothing faces (rigid partners, or surfaces beyond the search distance): every point
        assert_eq!(facing_points(&points, &[]), points.to_vec());
    }
}

#[cfg(test)]
mod block_key_tests {
    use super::BlockKey;

    #[test]
    fn block_keys_round_trip_and_stay_apart() {
        for k in [
            BlockKey::Partner(0),
            BlockKey::Partner((1 << 30) - 1),
            BlockKey::Reach(0),
            BlockKey::Reach((1 << 30) - 1),
            BlockKey::Rigid,
            BlockKey::Own(0),
            BlockKey::Own(17),
            BlockKey::Own((1 << 31) - 2),
        ] {
            assert_eq!(BlockKey::decode(k.encode()), k);
        }
        assert_ne!(BlockKey::Own(5).encode(), BlockKey::Partner(5).encode());
        assert_ne!(BlockKey::Reach(5).encode(), BlockKey::Partner(5).encode());
        assert_ne!(BlockKey::Reach(5).encode(), BlockKey::Own(5).encode());
        assert_ne!(
            BlockKey::Own((1 << 31) - 2).encode(),
            BlockKey::Rigid.encode()
        );
    }
}
