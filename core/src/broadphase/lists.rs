//! Each particle's contact list, from the canonical pair list (CSR):
//!
//! ```text
//! entries[offsets[k]..offsets[k + 1]] = 2 e + side for every pair e = (i, j)
//!                                       with k = i (side 0) or k = j (side 1),
//!                                       in pair order
//! ```
//! One rule for both backends: a particle sums its contacts in this order.

use super::Pair;

/// (offsets, entries) of `pairs` over `particles` particles.
pub fn contact_lists(pairs: &[Pair], particles: usize) -> (Vec<u32>, Vec<u32>) {
    let mut offsets = vec![0u32; particles + 1];
    for &[i, j] in pairs {
        offsets[i as usize + 1] += 1;
        offsets[j as usize + 1] += 1;
    }
    for k in 0..particles {
        offsets[k + 1] += offsets[k];
    }
    let mut fill = offsets.clone();
    let mut entries = vec![0u32; 2 * pairs.len()];
    for (e, &[i, j]) in pairs.iter().enumerate() {
        for (side, k) in [(0u32, i), (1, j)] {
            let at = &mut fill[k as usize];
            entries[*at as usize] = 2 * e as u32 + side;
            *at += 1;
        }
    }
    (offsets, entries)
}
