//! The exhaustive O(n²) reference: every pair i < j, tested in
//! lexicographic order, so the output is already canonical.

use super::{Aabbs, Pair};

/// All pairs (i, j), i < j, whose boxes overlap, in lexicographic order.
pub fn exhaustive_pairs(boxes: &Aabbs) -> Vec<Pair> {
    let n = boxes.len();
    let mut pairs = Vec::new();
    for i in 0..n {
        for j in i + 1..n {
            if boxes.overlap(i, j) {
                pairs.push([i as u32, j as u32]);
            }
        }
    }
    pairs
}
