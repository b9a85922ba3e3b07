//! Greedy constraint coloring, computed once per family at plan time.
//!
//! ```text
//! for each element e in authored order:
//!     color(e) = smallest c such that no dynamic particle of e is already
//!                used by an element of color c
//! ```
//! Fixed particles (inverse mass 0) never move, so they never conflict.
//! Elements of one color touch disjoint dynamic particles, so projecting a
//! color in any order — or all at once on a GPU — gives bit-identical
//! results. The rule depends only on the authored order: deterministic.

/// Colors of `elements` (flat, `arity` indices each). Returns one color per
/// element.
pub fn greedy_colors(elements: &[usize], arity: usize, inverse_mass: &[f64]) -> Vec<u32> {
    let count = elements.len().checked_div(arity).unwrap_or(0);
    let mut colors = Vec::with_capacity(count);
    // used[p * words + w] bit b set: particle p is in color 64 w + b.
    let mut words = 1usize;
    let mut used = vec![0u64; inverse_mass.len()];
    let mut merged: Vec<u64> = Vec::new();
    for element in elements.chunks_exact(arity.max(1)) {
        merged.clear();
        merged.resize(words, 0);
        for &p in element {
            if inverse_mass[p] > 0.0 {
                for (w, m) in merged.iter_mut().enumerate() {
                    *m |= used[p * words + w];
                }
            }
        }
        let color = match merged.iter().position(|&m| m != u64::MAX) {
            Some(w) => w * 64 + merged[w].trailing_ones() as usize,
            None => words * 64,
        };
        if color >= words * 64 {
            // Widen every particle's bitset by one word.
            let wider = words + 1;
            let mut grown = vec![0u64; inverse_mass.len() * wider];
            for p in 0..inverse_mass.len() {
                grown[p * wider..p * wider + words]
                    .copy_from_slice(&used[p * words..(p + 1) * words]);
            }
            used = grown;
            words = wider;
        }
        for &p in element {
            if inverse_mass[p] > 0.0 {
                used[p * words + color / 64] |= 1 << (color % 64);
            }
        }
        colors.push(color as u32);
    }
    colors
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chain_alternates_two_colors() {
        let elements = [0, 1, 1, 2, 2, 3, 3, 4];
        assert_eq!(greedy_colors(&elements, 2, &[1.0; 5]), vec![0, 1, 0, 1]);
    }

    #[test]
    fn fixed_particles_do_not_conflict() {
        // A star around a fixed hub: every spoke can share color 0.
        let elements = [0, 1, 0, 2, 0, 3];
        assert_eq!(
            greedy_colors(&elements, 2, &[0.0, 1.0, 1.0, 1.0]),
            vec![0, 0, 0]
        );
        // The same star around a dynamic hub needs three colors.
        assert_eq!(greedy_colors(&elements, 2, &[1.0; 4]), vec![0, 1, 2]);
    }

    #[test]
    fn more_than_64_colors() {
        let n = 200;
        let elements: Vec<usize> = (1..=n).flat_map(|i| [0, i]).collect();
        let colors = greedy_colors(&elements, 2, &vec![1.0; n + 1]);
        assert_eq!(colors, (0..n as u32).collect::<Vec<_>>());
    }
}
