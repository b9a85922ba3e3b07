//! Random test boxes for the broadphase: coordinates on a 1/8 grid (exact
//! in f32 and f64, so every precision sees the same boxes), with exact
//! duplicates, boxes that touch a neighbour face to face, zero-width boxes
//! and negative coordinates and zeros.

use super::Lcg;
use hyperpbd_core::broadphase::Aabbs;

/// `n` boxes in R^`dim` from `seed`; `spread` is the side of the region the
/// lower corners fall in (smaller: more overlaps).
pub fn random_boxes(dim: usize, n: usize, spread: f64, seed: u64) -> Aabbs {
    let mut rng = Lcg(seed);
    let grid = |x: f64| (x * 8.0).round() / 8.0;
    let mut min = Vec::with_capacity(n * dim);
    let mut max = Vec::with_capacity(n * dim);
    for i in 0..n {
        let roll = rng.next();
        if i > 0 && roll < -0.8 {
            // An exact duplicate of an earlier box.
            let j = ((rng.next() + 1.0) * 0.5 * i as f64) as usize % i;
            for a in 0..dim {
                min.push(min[j * dim + a]);
                max.push(max[j * dim + a]);
            }
            continue;
        }
        if i > 0 && roll < -0.6 {
            // Touches the previous box: its lower corner on one axis is the
            // previous box's upper corner.
            let touch = ((rng.next() + 1.0) * 0.5 * dim as f64) as usize % dim;
            for a in 0..dim {
                let lo = if a == touch {
                    max[(i - 1) * dim + a]
                } else {
                    min[(i - 1) * dim + a]
                };
                let width = grid((rng.next() + 1.0) * 0.75);
                min.push(lo);
                max.push(lo + width);
            }
            continue;
        }
        let zero_width = roll > 0.9;
        for _ in 0..dim {
            let lo = grid(rng.next() * spread);
            let width = if zero_width {
                0.0
            } else {
                grid((rng.next() + 1.0) * 0.75)
            };
            min.push(lo);
            max.push(lo + width);
        }
    }
    Aabbs::new(dim, min, max)
}
