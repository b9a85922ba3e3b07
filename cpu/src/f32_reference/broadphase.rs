//! The GPU's broadphase in f32 (`shaders/grid.wgsl`): every particle's
//! contact list from the f32 swept boxes.
//!
//! ```text
//! box i   lo = below(min(p_i, x_i) − pad_i),  hi = above(max(p_i, x_i) + pad_i)
//!         (f32 operations; below/above: one f32 step outward, always;
//!         pad = r + margin rounded up to f32 on the host)
//! list i  every j ≠ i with lo_i ≤ hi_j and lo_j ≤ hi_i on every axis
//!         (closed intervals), w_i + w_j ≠ 0, ascending
//! ```
//! The device finds the overlapping boxes on a hashed grid and sorts each
//! list; the grid only decides which boxes are tested, never which pairs
//! come out (grid.wgsl's proof), so the lists are the exhaustive test's.
//! Here a sort and sweep on one axis finds the same pairs: boxes in order
//! of lo on that axis, box t after box s is tested while lo_t ≤ hi_s.

use super::Particles;

/// below_f32 of grid.wgsl: the f32 just below f (0 → −2⁻¹²⁶).
fn below(f: f32) -> f32 {
    let bits = f.to_bits();
    if f > 0.0 {
        f32::from_bits(bits - 1)
    } else if f == 0.0 {
        -f32::MIN_POSITIVE
    } else {
        f32::from_bits(bits + 1)
    }
}

/// outward_up of grid.wgsl: −below(−f).
fn above(f: f32) -> f32 {
    -below(-f)
}

/// The f32 swept boxes (lower, upper corners; `dim` per box) of every
/// particle from `s.p` to `s.x`, padded by `pad`.
fn boxes(s: &Particles, pad: &[f32]) -> (Vec<f32>, Vec<f32>) {
    let n = s.dim;
    let mut lo = vec![0.0f32; s.x.len()];
    let mut hi = vec![0.0f32; s.x.len()];
    for (i, &pad) in pad.iter().enumerate() {
        for a in 0..n {
            let (start, end) = (s.p[i * n + a], s.x[i * n + a]);
            lo[i * n + a] = below(start.min(end) - pad);
            hi[i * n + a] = above(start.max(end) + pad);
        }
    }
    (lo, hi)
}

/// Every particle's contact list (ascending partners) into `lists`.
pub fn lists(s: &Particles, pad: &[f32], lists: &mut Vec<Vec<u32>>) {
    let n = s.dim;
    let count = pad.len();
    let (lo, hi) = boxes(s, pad);
    lists.resize_with(count, Vec::new);
    for list in lists.iter_mut() {
        list.clear();
    }
    // The axis of the widest spread of lower corners (any axis is exact).
    let spread = |a: usize| {
        let values = (0..count).map(|i| lo[i * n + a]);
        let (min, max) = values.fold((f32::MAX, f32::MIN), |(l, h), v| (l.min(v), h.max(v)));
        max - min
    };
    let axis = (0..n)
        .max_by(|&a, &b| spread(a).total_cmp(&spread(b)))
        .unwrap_or(0);
    let mut order: Vec<usize> = (0..count).collect();
    order.sort_by(|&i, &j| lo[i * n + axis].total_cmp(&lo[j * n + axis]));
    let overlap = |i: usize, j: usize| {
        (0..n).all(|a| lo[i * n + a] <= hi[j * n + a] && lo[j * n + a] <= hi[i * n + a])
    };
    for (at, &i) in order.iter().enumerate() {
        for &j in &order[at + 1..] {
            if lo[j * n + axis] > hi[i * n + axis] {
                break;
            }
            // Pairs of two fixed particles are left out (W = 0).
            if overlap(i, j) && s.w[i] + s.w[j] != 0.0 {
                lists[i].push(j as u32);
                lists[j].push(i as u32);
            }
        }
    }
    for list in lists.iter_mut() {
        list.sort_unstable();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn particles(dim: usize, x: Vec<f32>, w: Vec<f32>) -> Particles {
        Particles {
            dim,
            p: x.clone(),
            x,
            v: Vec::new(),
            force: Vec::new(),
            w,
            gravity_scale: Vec::new(),
        }
    }

    /// The sweep's lists are the exhaustive test's on the same boxes.
    #[test]
    fn sweep_lists_are_the_exhaustive_ones() {
        let (dim, count) = (3, 200);
        let mut seed = 12345u32;
        let mut next = || {
            seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (seed >> 8) as f32 / (1u32 << 24) as f32
        };
        let x: Vec<f32> = (0..count * dim).map(|_| next()).collect();
        let w: Vec<f32> = (0..count)
            .map(|i| if i % 7 == 0 { 0.0 } else { 1.0 })
            .collect();
        let pad: Vec<f32> = (0..count).map(|_| 0.15 * next()).collect();
        let s = particles(dim, x, w);
        let mut found = Vec::new();
        lists(&s, &pad, &mut found);
        let (lo, hi) = boxes(&s, &pad);
        let mut pairs = 0;
        for i in 0..count {
            let expected: Vec<u32> = (0..count)
                .filter(|&j| {
                    j != i
                        && s.w[i] + s.w[j] != 0.0
                        && (0..dim).all(|a| {
                            lo[i * dim + a] <= hi[j * dim + a] && lo[j * dim + a] <= hi[i * dim + a]
                        })
                })
                .map(|j| j as u32)
                .collect();
            pairs += expected.len();
            assert_eq!(found[i], expected, "particle {i}");
        }
        assert!(pairs > count, "the case must have pairs ({pairs})");
    }

    /// Two boxes whose f32 corners meet only after the outward steps are
    /// listed (as on the device), and two fixed particles are not.
    #[test]
    fn outward_rounding_decides_a_grazing_pair() {
        let gap = f32::from_bits(1.0f32.to_bits() + 1);
        let s = particles(1, vec![0.0, gap, 5.0, 5.5], vec![1.0, 1.0, 0.0, 0.0]);
        let mut found = Vec::new();
        lists(&s, &[0.5, 0.5, 1.0, 1.0], &mut found);
        assert_eq!(found, vec![vec![1], vec![0], vec![], vec![]]);
    }

    #[test]
    fn outward_steps() {
        assert_eq!(below(1.0), f32::from_bits(1.0f32.to_bits() - 1));
        assert_eq!(above(1.0), f32::from_bits(1.0f32.to_bits() + 1));
        assert_eq!(below(0.0), -f32::MIN_POSITIVE);
        assert_eq!(above(0.0), f32::MIN_POSITIVE);
        assert_eq!(below(-1.0), f32::from_bits((-1.0f32).to_bits() + 1));
    }
}
