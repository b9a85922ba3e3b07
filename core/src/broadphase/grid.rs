//! Uniform-grid broadphase: the same pairs as the sweep, found per box.
//!
//! ```text
//! grid axes   the (up to) 3 axes along which the box corners spread most
//! cell size   s_a = E_a (1 + 2^−20), E_a = the largest box extent along a
//!             (enlarged, never below, when there would be > 4n cells)
//! cell of v   q_a(v) = min(⌊(v − lo_a) / s_a⌋, c_a − 1), 0 below lo_a  (monotone)
//! store       box j in the cell of its lower corner q(min_j)   (counting sort:
//!             within a cell in index order)
//! query i     every box j > i stored in cells q_a(min_i) − 1 ..= q_a(max_i)
//!             on each grid axis with overlap(i, j); sorted by j
//! pairs       query 0, query 1, …  concatenated: canonical order
//! ```
//! Why every overlapping pair is found, once: overlap gives min_j ≤ max_i,
//! so q(min_j) ≤ q(max_i); and min_i ≤ max_j ≤ min_j + E, so
//! min_i − min_j < s_a by a margin of 2^−20 s_a, far above the rounding of
//! (v − lo)/s (relative 2^−52 of at most 4n cells), hence
//! q(min_j) ≥ q(min_i) − 1. Each box sits in one cell and a query visits
//! each cell once. The overlap test is [`Aabbs::overlap`] on the f64
//! coordinates, so the list equals [`super::exhaustive_pairs`].
//!
//! On a dense cube of n boxes one query meets a few dozen boxes, where the
//! one-axis sweep meets a slab of n^(2/3). Boxes with a non-finite
//! coordinate, or a grid too coarse to help (more than 16 boxes per cell
//! on average: one huge box), go to [`super::sweep_pairs`] instead.

use super::{Aabbs, Pair};

/// Grid axes at most (the overlap test covers the others).
const MAX_GRID_AXES: usize = 3;

/// Boxes per cell on average above which the sweep is used instead.
const MAX_OCCUPANCY: usize = 16;

/// A uniform grid over some boxes, built once per broadphase.
#[derive(Debug, Clone)]
pub struct BoxGrid<'a> {
    boxes: &'a Aabbs,
    /// Grid axes, and per axis: origin, cell size, cell count.
    axes: Vec<GridAxis>,
    /// Boxes of cell c are `entries[starts[c]..starts[c + 1]]`.
    starts: Vec<u32>,
    entries: Vec<u32>,
}

#[derive(Debug, Clone, Copy)]
struct GridAxis {
    axis: usize,
    origin: f64,
    size: f64,
    cells: usize,
    /// Linear-index stride of this axis.
    stride: usize,
}

impl GridAxis {
    /// q(v): the cell along this axis (`as` truncates, which is ⌊t⌋ for
    /// t > 0, saturating; without the call `floor` is on x86-64).
    fn cell(&self, v: f64) -> usize {
        let t = (v - self.origin) / self.size;
        if t > 0.0 {
            (t as usize).min(self.cells - 1)
        } else {
            0
        }
    }
}

impl<'a> BoxGrid<'a> {
    /// The grid over `boxes`, or `None` when they call for the sweep
    /// (non-finite coordinates, or a grid too coarse to help).
    pub fn new(boxes: &'a Aabbs) -> Option<Self> {
        let (d, n) = (boxes.dim, boxes.len());
        if n == 0 || d == 0 || !boxes.min.iter().chain(&boxes.max).all(|v| v.is_finite()) {
            return None;
        }
        // Per axis: lowest lower corner, spread of lower corners, largest extent.
        let mut stats: Vec<(usize, f64, f64, f64)> = (0..d)
            .map(|a| {
                let (mut lo, mut hi, mut extent) = (f64::INFINITY, f64::NEG_INFINITY, 0.0f64);
                for i in 0..n {
                    let (min, max) = (boxes.min[i * d + a], boxes.max[i * d + a]);
                    lo = lo.min(min);
                    hi = hi.max(min);
                    extent = extent.max(max - min);
                }
                (a, lo, hi - lo, extent)
            })
            .collect();
        // Widest spread first; ties by axis index.
        stats.sort_by(|x, y| y.2.total_cmp(&x.2).then(x.0.cmp(&y.0)));
        stats.truncate(MAX_GRID_AXES);
        let limit = (4 * n).max(64) as f64;
        let per_axis = libm::pow(limit, 1.0 / stats.len() as f64);
        let mut axes = Vec::with_capacity(stats.len());
        let mut total = 1usize;
        for &(axis, origin, spread, extent) in &stats {
            let size = (extent * (1.0 + 1.0 / 1_048_576.0)).max(spread / per_axis);
            let cells = if size > 0.0 && size.is_finite() {
                ((spread / size).floor() as usize)
                    .saturating_add(1)
                    .min(1 << 20)
            } else {
                1
            };
            let size = if size > 0.0 && size.is_finite() {
                size
            } else {
                1.0
            };
            axes.push(GridAxis {
                axis,
                origin,
                size,
                cells,
                stride: total,
            });
            total = total.saturating_mul(cells);
        }
        if total > 8 * n + 64 || n / total > MAX_OCCUPANCY {
            return None;
        }
        let cell_of = |i: usize| -> usize {
            axes.iter()
                .map(|g| g.cell(boxes.min[i * d + g.axis]) * g.stride)
                .sum()
        };
        let cells: Vec<u32> = (0..n).map(|i| cell_of(i) as u32).collect();
        let mut starts = vec![0u32; total + 1];
        for &c in &cells {
            starts[c as usize + 1] += 1;
        }
        for c in 0..total {
            starts[c + 1] += starts[c];
        }
        let mut fill = starts.clone();
        let mut entries = vec![0u32; n];
        for (i, &c) in cells.iter().enumerate() {
            let at = &mut fill[c as usize];
            entries[*at as usize] = i as u32;
            *at += 1;
        }
        Some(BoxGrid {
            boxes,
            axes,
            starts,
            entries,
        })
    }

    /// Number of boxes.
    pub fn len(&self) -> usize {
        self.boxes.len()
    }

    /// True without boxes.
    pub fn is_empty(&self) -> bool {
        self.boxes.is_empty()
    }

    /// Appends the pairs (i, j), j > i, of box `i` to `pairs`, by j.
    pub fn pairs_of(&self, i: usize, pairs: &mut Vec<Pair>) {
        let d = self.boxes.dim;
        let first = pairs.len();
        // Cell ranges along each grid axis; the first axis is contiguous
        // in the linear index, so each combination of the others is one run.
        let mut low = [0usize; MAX_GRID_AXES];
        let mut high = [0usize; MAX_GRID_AXES];
        for (k, g) in self.axes.iter().enumerate() {
            low[k] = g.cell(self.boxes.min[i * d + g.axis]).saturating_sub(1);
            high[k] = g.cell(self.boxes.max[i * d + g.axis]);
        }
        let g = self.axes.len();
        let mut at = low;
        loop {
            let base: usize = (1..g).map(|k| at[k] * self.axes[k].stride).sum();
            let run = self.starts[base + low[0]] as usize..self.starts[base + high[0] + 1] as usize;
            for &j in &self.entries[run] {
                if j as usize > i && self.boxes.overlap(i, j as usize) {
                    pairs.push([i as u32, j]);
                }
            }
            // Next combination of the other axes.
            let mut k = 1;
            while k < g {
                if at[k] < high[k] {
                    at[k] += 1;
                    break;
                }
                at[k] = low[k];
                k += 1;
            }
            if k >= g {
                break;
            }
        }
        pairs[first..].sort_unstable();
    }
}

/// All overlapping pairs (i < j) in canonical order: the grid, or the
/// sweep where the grid does not apply. Equal to
/// [`super::exhaustive_pairs`].
pub fn grid_pairs(boxes: &Aabbs) -> Vec<Pair> {
    match BoxGrid::new(boxes) {
        Some(grid) => {
            let mut pairs = Vec::new();
            for i in 0..grid.len() {
                grid.pairs_of(i, &mut pairs);
            }
            pairs
        }
        None => super::sweep_pairs(boxes, super::sweep_axis(boxes)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::broadphase::exhaustive_pairs;

    /// A deterministic jittered cloud of boxes of mixed sizes.
    fn cloud(dim: usize, n: usize, seed: u64, spread: f64) -> Aabbs {
        let mut state = seed;
        let mut next = || {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let (mut min, mut max) = (Vec::new(), Vec::new());
        for _ in 0..n {
            let r = 0.05 + 0.2 * next();
            for _ in 0..dim {
                let c = spread * next();
                min.push(c - r);
                max.push(c + r);
            }
        }
        Aabbs::new(dim, min, max)
    }

    #[test]
    fn grid_pairs_equal_the_exhaustive_reference() {
        for dim in 1..=5 {
            for (n, spread) in [
                (0, 1.0),
                (1, 1.0),
                (2, 0.1),
                (300, 3.0),
                (500, 1.0),
                (400, 30.0),
            ] {
                let boxes = cloud(dim, n, 7 + n as u64, spread);
                assert_eq!(
                    grid_pairs(&boxes),
                    exhaustive_pairs(&boxes),
                    "dim {dim}, {n} boxes over {spread}"
                );
            }
        }
    }

    #[test]
    fn touching_and_degenerate_boxes() {
        // Point boxes on a lattice (extent 0), touching boxes, one huge box.
        let points = Aabbs::new(
            2,
            vec![0.0, 0.0, 1.0, 0.0, 1.0, 0.0],
            vec![0.0, 0.0, 1.0, 0.0, 1.0, 0.0],
        );
        assert_eq!(grid_pairs(&points), vec![[1, 2]]);
        let touching = Aabbs::new(1, vec![0.0, 1.0, 2.0], vec![1.0, 2.0, 3.0]);
        assert_eq!(grid_pairs(&touching), vec![[0, 1], [1, 2]]);
        let mut huge = cloud(3, 200, 3, 5.0);
        huge.min[..3].copy_from_slice(&[-1e3; 3]);
        huge.max[..3].copy_from_slice(&[1e3; 3]);
        assert_eq!(grid_pairs(&huge), exhaustive_pairs(&huge));
        let mut nan = cloud(2, 50, 5, 1.0);
        nan.min[7] = f64::NAN;
        assert_eq!(grid_pairs(&nan), exhaustive_pairs(&nan));
    }
}
