//! Global contact search: axis-aligned bounding boxes of a partner surface's elements sorted into a
//! uniform bin grid, so finding the candidate elements of a point costs O(1) on average and building
//! the grid O(N) (N log N with the sort), instead of testing every element (N^2 over a surface).
#![allow(clippy::needless_range_loop)] // index loops mirror the equations

/// An axis-aligned box in `dim` <= 3 dimensions.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Aabb {
    /// Lower corner [3] (unused components 0).
    pub lo: [f64; 3],
    /// Upper corner [3].
    pub hi: [f64; 3],
}

impl Aabb {
    /// The empty box (grows with [`Aabb::grow`]).
    pub const EMPTY: Aabb = Aabb {
        lo: [f64::INFINITY; 3],
        hi: [f64::NEG_INFINITY; 3],
    };

    /// Extends the box to hold `x` [dim].
    pub fn grow(&mut self, x: &[f64]) {
        for (k, &v) in x.iter().enumerate() {
            self.lo[k] = self.lo[k].min(v);
            self.hi[k] = self.hi[k].max(v);
        }
    }

    /// The box enlarged by `d` on every side of the first `dim` axes.
    pub fn inflated(&self, dim: usize, d: f64) -> Aabb {
        let mut b = *self;
        for k in 0..dim {
            b.lo[k] -= d;
            b.hi[k] += d;
        }
        b
    }

    /// True for a box that holds no point (an element without positions on this rank). A box
    /// grown by points of any dimension has its first axis set.
    pub fn is_empty(&self) -> bool {
        self.lo[0] > self.hi[0]
    }

    /// True when the two boxes overlap on the first `dim` axes.
    pub fn meets(&self, other: &Aabb, dim: usize) -> bool {
        (0..dim).all(|k| self.lo[k] <= other.hi[k] && other.lo[k] <= self.hi[k])
    }

    /// True when `x` [dim] lies in the box.
    pub fn contains(&self, x: &[f64]) -> bool {
        x.iter()
            .enumerate()
            .all(|(k, &v)| v >= self.lo[k] && v <= self.hi[k])
    }
}

/// Element boxes binned on a uniform grid whose cell size is about the mean box size.
#[derive(Debug, Clone, Default)]
pub struct BinGrid {
    dim: usize,
    origin: [f64; 3],
    cell: f64,
    n: [usize; 3],
    /// CSR: elements of bin b are `items[start[b]..start[b + 1]]`. [n_bins + 1]
    start: Vec<usize>,
    items: Vec<u32>,
    boxes: Vec<Aabb>,
    /// The elements' own boxes, before inflation by the search distance (lower bounds of the
    /// distance from a point to an element). Empty: not known.
    raw: Vec<Aabb>,
}

/// Most bins per axis (keeps the grid's memory bounded for extreme aspect ratios).
const MAX_BINS_PER_AXIS: usize = 1024;

impl BinGrid {
    /// Bytes of the grid's arrays (bins, their items, the boxes).
    pub fn heap_bytes(&self) -> usize {
        use std::mem::size_of;
        self.start.len() * size_of::<usize>()
            + self.items.len() * size_of::<u32>()
            + (self.boxes.len() + self.raw.len()) * size_of::<Aabb>()
    }

    /// Bins `boxes` (one per element, already inflated by the search distance). Empty boxes
    /// (elements this rank holds no positions of) are left out: they are no one's candidates.
    pub fn new(dim: usize, boxes: Vec<Aabb>) -> BinGrid {
        let mut all = Aabb::EMPTY;
        let mut mean = 0.0;
        let mut n_boxes = 0usize;
        for b in boxes.iter().filter(|b| !b.is_empty()) {
            n_boxes += 1;
            all.grow(&b.lo[..dim]);
            all.grow(&b.hi[..dim]);
            mean += (0..dim).map(|k| b.hi[k] - b.lo[k]).fold(0.0, f64::max);
        }
        if n_boxes == 0 {
            return BinGrid {
                dim,
                start: vec![0],
                ..Default::default()
            };
        }
        mean /= n_boxes as f64;
        let extent = (0..dim).map(|k| all.hi[k] - all.lo[k]).fold(0.0, f64::max);
        let cell = mean
            .max(extent / MAX_BINS_PER_AXIS as f64)
            .max(f64::MIN_POSITIVE);
        let mut n = [1usize; 3];
        for k in 0..dim {
            n[k] = (((all.hi[k] - all.lo[k]) / cell).floor() as usize + 1).min(MAX_BINS_PER_AXIS);
        }
        let mut g = BinGrid {
            dim,
            origin: all.lo,
            cell,
            n,
            start: Vec::new(),
            items: Vec::new(),
            boxes,
            raw: Vec::new(),
        };
        // counting sort of (bin, element) pairs
        let n_bins = n[0] * n[1] * n[2];
        let mut count = vec![0usize; n_bins + 1];
        let mut pairs = Vec::new();
        for (e, b) in g.boxes.iter().enumerate() {
            if b.is_empty() {
                continue;
            }
            let (lo, hi) = (g.bin_of(&b.lo), g.bin_of(&b.hi));
            for k2 in lo[2]..=hi[2] {
                for k1 in lo[1]..=hi[1] {
                    for k0 in lo[0]..=hi[0] {
                        let bin = k0 + n[0] * (k1 + n[1] * k2);
                        pairs.push((bin, e as u32));
                        count[bin + 1] += 1;
                    }
                }
            }
        }
        for b in 0..n_bins {
            count[b + 1] += count[b];
        }
        let mut fill = count.clone();
        g.items = vec![0; pairs.len()];
        for (bin, e) in pairs {
            g.items[fill[bin]] = e;
            fill[bin] += 1;
        }
        g.start = count;
        g
    }

    fn bin_of(&self, x: &[f64]) -> [usize; 3] {
        let mut b = [0usize; 3];
        for k in 0..self.dim {
            let i = ((x[k] - self.origin[k]) / self.cell).floor();
            b[k] = (i.max(0.0) as usize).min(self.n[k] - 1);
        }
        b
    }

    /// The grid of `boxes` (inflated by the search distance) that also knows each element's own box
    /// `raw` (for [`BinGrid::distance_lower_bound`]).
    pub fn with_raw(dim: usize, boxes: Vec<Aabb>, raw: Vec<Aabb>) -> BinGrid {
        let mut g = BinGrid::new(dim, boxes);
        g.raw = raw;
        g
    }

    /// A lower bound of the distance from `x` [dim] to element `e`: the distance to its own box
    /// (0 without raw boxes).
    pub fn distance_lower_bound(&self, e: u32, x: &[f64]) -> f64 {
        let Some(b) = self.raw.get(e as usize) else {
            return 0.0;
        };
        x.iter()
            .enumerate()
            .map(|(k, &v)| {
                let d = (b.lo[k] - v).max(v - b.hi[k]).max(0.0);
                d * d
            })
            .sum::<f64>()
            .sqrt()
    }

    /// Elements whose box contains `x` [dim], ascending, into `out` (cleared first).
    pub fn candidates(&self, x: &[f64], out: &mut Vec<u32>) {
        out.clear();
        if self.boxes.is_empty() {
            return;
        }
        let b = self.bin_of(x);
        let bin = b[0] + self.n[0] * (b[1] + self.n[1] * b[2]);
        out.extend(
            self.items[self.start[bin]..self.start[bin + 1]]
                .iter()
                .copied()
                .filter(|&e| self.boxes[e as usize].contains(x)),
        );
        out.sort_unstable();
    }

    /// Elements whose binned box meets `b` on the first `dim` axes, ascending, into `out` (cleared
    /// first): those of the bins `b` overlaps (each element is binned in every bin its box
    /// overlaps, so any point the two boxes share lies in a bin of both).
    pub fn meeting(&self, b: &Aabb, out: &mut Vec<u32>) {
        out.clear();
        if self.boxes.is_empty() || b.is_empty() {
            return;
        }
        let (lo, hi) = (self.bin_of(&b.lo), self.bin_of(&b.hi));
        let n = self.n;
        for k2 in lo[2]..=hi[2] {
            for k1 in lo[1]..=hi[1] {
                for k0 in lo[0]..=hi[0] {
                    let bin = k0 + n[0] * (k1 + n[1] * k2);
                    out.extend(
                        self.items[self.start[bin]..self.start[bin + 1]]
                            .iter()
                            .copied()
                            .filter(|&e| self.boxes[e as usize].meets(b, self.dim)),
                    );
                }
            }
        }
        out.sort_unstable();
        out.dedup();
    }

    /// Number of element boxes.
    pub fn len(&self) -> usize {
        self.boxes.len()
    }

    /// True without boxes.
    pub fn is_empty(&self) -> bool {
        self.boxes.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Deterministic pseudo-random numbers in [0, 1).
    fn lcg(state: &mut u64) -> f64 {
        *state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (*state >> 11) as f64 / (1u64 << 53) as f64
    }

    /// A box in [0, 10.8]^dim of sides up to 0.8, inflated by 0.05.
    fn random_box(dim: usize, s: &mut u64) -> Aabb {
        let mut b = Aabb::EMPTY;
        let c: Vec<f64> = (0..dim).map(|_| 10.0 * lcg(s)).collect();
        b.grow(&c);
        let c2: Vec<f64> = c.iter().map(|v| v + 0.8 * lcg(s)).collect();
        b.grow(&c2);
        b.inflated(dim, 0.05)
    }

    #[test]
    fn bin_grid_finds_exactly_the_boxes_that_contain_a_point() {
        let mut s = 7u64;
        for dim in [2, 3] {
            let boxes: Vec<Aabb> = (0..300).map(|_| random_box(dim, &mut s)).collect();
            let grid = BinGrid::new(dim, boxes.clone());
            let mut out = Vec::new();
            for _ in 0..2000 {
                let x: Vec<f64> = (0..dim).map(|_| 11.0 * lcg(&mut s) - 0.5).collect();
                grid.candidates(&x, &mut out);
                let brute: Vec<u32> = (0..boxes.len() as u32)
                    .filter(|&e| boxes[e as usize].contains(&x))
                    .collect();
                assert_eq!(out, brute, "dim {dim} x {x:?}");
            }
        }
    }

    #[test]
    fn elements_without_positions_are_no_candidates_and_leave_the_others_theirs() {
        // the ghost layer: a rank bins empty boxes for the elements it does not hold
        let mut s = 11u64;
        for dim in [2, 3] {
            let boxes: Vec<Aabb> = (0..200)
                .map(|i| {
                    if i % 3 == 0 {
                        Aabb::EMPTY.inflated(dim, 0.05)
                    } else {
                        random_box(dim, &mut s)
                    }
                })
                .collect();
            assert!(boxes
                .iter()
                .enumerate()
                .all(|(i, b)| b.is_empty() == (i % 3 == 0)));
            let grid = BinGrid::new(dim, boxes.clone());
            let mut out = Vec::new();
            let mut found = 0;
            for _ in 0..2000 {
                let x: Vec<f64> = (0..dim).map(|_| 11.0 * lcg(&mut s) - 0.5).collect();
                grid.candidates(&x, &mut out);
                let brute: Vec<u32> = (0..boxes.len() as u32)
                    .filter(|&e| e % 3 != 0 && boxes[e as usize].contains(&x))
                    .collect();
                assert_eq!(out, brute, "dim {dim} x {x:?}");
                found += out.len();
            }
            assert!(found > 0, "dim {dim}: some point has candidates");
        }
    }

    #[test]
    fn bin_grid_finds_exactly_the_boxes_that_meet_a_box() {
        let mut s = 5u64;
        for dim in [2, 3] {
            let boxes: Vec<Aabb> = (0..300).map(|_| random_box(dim, &mut s)).collect();
            let grid = BinGrid::new(dim, boxes.clone());
            let mut out = Vec::new();
            let (mut found, mut missed) = (0, 0);
            for i in 0..500 {
                // boxes from a point to several bins wide, some beyond the grid
                let mut b = Aabb::EMPTY;
                let c: Vec<f64> = (0..dim).map(|_| 13.0 * lcg(&mut s) - 1.5).collect();
                b.grow(&c);
                let w = if i % 5 == 0 { 0.0 } else { 3.0 * lcg(&mut s) };
                b.grow(&c.iter().map(|v| v + w).collect::<Vec<_>>());
                grid.meeting(&b, &mut out);
                let brute: Vec<u32> = (0..boxes.len() as u32)
                    .filter(|&e| boxes[e as usize].meets(&b, dim))
                    .collect();
                assert_eq!(out, brute, "dim {dim} box {b:?}");
                found += out.len();
                missed += boxes.len() - out.len();
            }
            assert!(
                found > 0 && missed > 0,
                "dim {dim}: {found} found, {missed} not"
            );
        }
    }

    #[test]
    fn empty_grid_has_no_candidates() {
        let g = BinGrid::new(2, Vec::new());
        let mut out = vec![1];
        g.candidates(&[0.0, 0.0], &mut out);
        assert!(out.is_empty());
    }
}
