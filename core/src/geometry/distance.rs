//! Distance between two points.
//!
//! ```text
//! d = |x1 − x0|        ∇_1 d = (x1 − x0)·(1/d),   ∇_0 d = −∇_1 d
//! |∇_0 d|² = |∇_1 d|² = 1 exactly (projections use 1, not the rounded sum)
//! d = 0: no direction exists, so ∇d = 0 (no response)
//! ```

/// |x1 − x0| with gradients; `points` = [x0, x1], `grad` the same layout.
pub fn distance(points: &[f64], dim: usize, grad: &mut [f64]) -> f64 {
    let (x0, x1) = points.split_at(dim);
    let mut d2 = 0.0;
    for a in 0..dim {
        let e = x1[a] - x0[a];
        d2 += e * e;
    }
    let d = d2.sqrt();
    if d > 0.0 {
        let inv = 1.0 / d;
        for a in 0..dim {
            let n = (x1[a] - x0[a]) * inv;
            grad[a] = -n;
            grad[dim + a] = n;
        }
    } else {
        grad[..2 * dim].fill(0.0);
    }
    d
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn distance_and_unit_gradient() {
        let mut g = [0.0; 4];
        let d = distance(&[0.0, 0.0, 3.0, 4.0], 2, &mut g);
        assert_eq!(d, 5.0);
        for (a, b) in g.iter().zip([-0.6, -0.8, 0.6, 0.8]) {
            approx::assert_abs_diff_eq!(*a, b, epsilon = 1e-15);
        }
    }

    #[test]
    fn coincident_points_have_no_direction() {
        let mut g = [9.0; 6];
        assert_eq!(distance(&[1.0, 2.0, 3.0, 1.0, 2.0, 3.0], 3, &mut g), 0.0);
        assert_eq!(g, [0.0; 6]);
    }
}
