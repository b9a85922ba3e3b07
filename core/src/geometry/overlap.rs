//! The residual of particle–particle contact: the deepest overlap of two
//! balls over the candidate pairs, computed once for both backends.
//!
//! ```text
//! overlap(i, j) = r_i + r_j − |x_j − x_i|        (> 0: the balls interpenetrate)
//! residual      = max(0, max over candidate pairs of overlap(i, j))
//! ```
//! |x_j − x_i|² is summed axis by axis in coordinate order, then one square
//! root: the same arithmetic in the same order on every backend ([`overlap`]
//! is the f32 reference's too, over its lists).

use crate::kinds::ProjectionReal;

/// Deepest overlap max(0, r_i + r_j − |x_j − x_i|) over `pairs` of the
/// balls at `x` (flat, `dim` per particle) with radii `radius`.
pub fn deepest_overlap(dim: usize, radius: &[f64], pairs: &[[u32; 2]], x: &[f64]) -> f64 {
    let mut deepest: f64 = 0.0;
    for &[i, j] in pairs {
        let (i, j) = (i as usize, j as usize);
        deepest = deepest.max(overlap(dim, x, [i, j], radius[i] + radius[j]));
    }
    deepest
}

/// overlap(i, j) = `reach` − |x_j − x_i| (reach = r_i + r_j) in precision `R`.
#[inline]
pub fn overlap<R: ProjectionReal>(dim: usize, x: &[R], [i, j]: [usize; 2], reach: R) -> R {
    let mut len2 = R::constant(0.0);
    for a in 0..dim {
        let d = x[j * dim + a] - x[i * dim + a];
        len2 += d * d;
    }
    reach - len2.sqrt()
}

#[cfg(test)]
mod tests {
    use super::deepest_overlap;

    #[test]
    fn overlap_of_touching_apart_and_interpenetrating_balls() {
        let radius = [0.5, 0.5, 0.25];
        let x = [0.0, 0.0, 1.0, 0.0, 3.0, 0.0];
        // Touching: 0.5 + 0.5 − 1 = 0.
        assert_eq!(deepest_overlap(2, &radius, &[[0, 1]], &x), 0.0);
        // Apart: never below 0.
        assert_eq!(deepest_overlap(2, &radius, &[[1, 2]], &x), 0.0);
        // 0.25 deep.
        let x = [0.0, 0.0, 0.75, 0.0, 3.0, 0.0];
        assert_eq!(deepest_overlap(2, &radius, &[[0, 1], [1, 2]], &x), 0.25);
        assert_eq!(deepest_overlap(2, &radius, &[], &x), 0.0);
    }
}
