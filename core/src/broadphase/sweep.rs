//! Sort-and-sweep along one axis.
//!
//! ```text
//! key_k   = sortable(key_down(min_k[axis]))              (see keys.rs)
//! order   = boxes sorted by (key, index)                  (stable: ties by index)
//! for each position s, box i = order[s]:
//!   for t = s+1, s+2, … while key(order[t]) ≤ sortable(key_up(max_i[axis])):
//!     j = order[t];  if overlap(i, j): emit (min(i, j), max(i, j))
//! sort the emitted pairs lexicographically
//! ```
//! Every overlapping pair is emitted exactly once: at the box that comes
//! first in `order` (a later box t overlapping i has min_t ≤ max_i, so the
//! scan from i reaches it). The final sort makes the list canonical, equal
//! to [`super::exhaustive_pairs`]. The GPU sweep runs the same rule: a
//! stable radix sort of the same keys, a count / scan / emit of the same
//! scan, and a radix sort of the pairs.

use super::keys::{key_down, key_up, sortable_bits};
use super::{Aabbs, Pair};

/// The sweep axis: the one along which the box centers spread most
/// (the first such axis on ties; axis 0 without boxes). Computed with
/// min/max only, so it is exact and order-independent.
pub fn sweep_axis(boxes: &Aabbs) -> usize {
    let d = boxes.dim;
    let mut best = (0, f64::NEG_INFINITY);
    for a in 0..d {
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for i in 0..boxes.len() {
            let c = 0.5 * boxes.min[i * d + a] + 0.5 * boxes.max[i * d + a];
            lo = lo.min(c);
            hi = hi.max(c);
        }
        let spread = hi - lo;
        if spread > best.1 {
            best = (a, spread);
        }
    }
    best.0
}

/// All overlapping pairs by sort-and-sweep along `axis`, canonical order.
pub fn sweep_pairs(boxes: &Aabbs, axis: usize) -> Vec<Pair> {
    let d = boxes.dim;
    let n = boxes.len();
    let mut order: Vec<(u32, u32)> = (0..n)
        .map(|i| (sortable_bits(key_down(boxes.min[i * d + axis])), i as u32))
        .collect();
    order.sort_unstable();
    let mut pairs = Vec::new();
    for (s, &(_, i)) in order.iter().enumerate() {
        let up = sortable_bits(key_up(boxes.max[i as usize * d + axis]));
        for &(key, j) in &order[s + 1..] {
            if key > up {
                break;
            }
            if boxes.overlap(i as usize, j as usize) {
                pairs.push([i.min(j), i.max(j)]);
            }
        }
    }
    pairs.sort_unstable();
    pairs
}
