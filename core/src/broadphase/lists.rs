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
    let (mut offsets, mut entries) = (Vec::new(), Vec::new());
    contact_lists_into(pairs, particles, &mut offsets, &mut entries);
    (offsets, entries)
}

/// [`contact_lists`] into `offsets` and `entries`, reusing their memory.
pub fn contact_lists_into(
    pairs: &[Pair],
    particles: usize,
    offsets: &mut Vec<u32>,
    entries: &mut Vec<u32>,
) {
    offsets.clear();
    offsets.resize(particles + 1, 0);
    for &[i, j] in pairs {
        offsets[i as usize + 1] += 1;
        offsets[j as usize + 1] += 1;
    }
    for k in 0..particles {
        offsets[k + 1] += offsets[k];
    }
    entries.clear();
    entries.resize(2 * pairs.len(), 0);
    // fill[k]: the next free entry of particle k (offsets[k] to start).
    let mut fill = offsets[..particles].to_vec();
    for (e, &[i, j]) in pairs.iter().enumerate() {
        for (side, k) in [(0u32, i), (1, j)] {
            let at = &mut fill[k as usize];
            entries[*at as usize] = 2 * e as u32 + side;
            *at += 1;
        }
    }
}
