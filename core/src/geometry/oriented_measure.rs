//! Signed full-dimensional measure of an N-simplex in R^N.
//!
//! ```text
//! D = [x1 − x0 … xN − x0]           (N × N, column j−1 = x_j − x_0)
//! V = det(D) / N!
//! ∂det/∂D[a][j] = adj(D)[j][a]      so ∇_j V = row j−1 of adj(D) / N!
//! ∇_0 V = −Σ_j ∇_j V
//! ```
//! Reflection or an odd vertex permutation flips the sign of V.
//! One code for both precisions (the golden path in f64, the f32 reference
//! in f32 in `measure.wgsl`'s order: adj(D) before det(D)).

use super::{Scratch, adjugate, determinant, edge_matrix, factorial_in, scatter_edge_gradient};
use crate::kinds::ProjectionReal;

/// V for the N + 1 points `points` in R^`dim` (N = dim).
pub fn oriented_measure<R: ProjectionReal>(
    points: &[R],
    dim: usize,
    grad: &mut [R],
    scratch: &mut Scratch<R>,
) -> R {
    let n = dim;
    let scale = R::constant(1.0) / factorial_in::<R>(n);
    let Scratch {
        edges, adj, minor, ..
    } = scratch;
    let zero = R::constant(0.0);
    edges.resize(n * n, zero);
    adj.resize(n * n, zero);
    minor.resize(n * n, zero);
    edge_matrix(points, n, n, edges);
    adjugate(edges, n, adj, minor);
    minor.copy_from_slice(&edges[..n * n]);
    let measure = determinant(minor, n) * scale;
    scatter_edge_gradient(grad, n, n, |j, a| adj[j * n + a] * scale);
    measure
}

/// V alone: the value [`oriented_measure`] returns, bit for bit (the same
/// determinant of the same edge matrix), without the gradient's adjugate.
pub fn oriented_volume(points: &[f64], dim: usize, scratch: &mut Scratch) -> f64 {
    let n = dim;
    let scale = 1.0 / factorial_in::<f64>(n);
    let minor = &mut scratch.minor;
    minor.resize(n * n, 0.0);
    edge_matrix(points, n, n, minor);
    determinant(minor, n) * scale
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unit_simplices_and_orientation() {
        let mut s = Scratch::new();
        let tri = [0.0, 0.0, 1.0, 0.0, 0.0, 1.0];
        approx::assert_relative_eq!(oriented_measure(&tri, 2, &mut [0.0; 6], &mut s), 0.5);
        let flipped = [0.0, 0.0, 0.0, 1.0, 1.0, 0.0];
        approx::assert_relative_eq!(oriented_measure(&flipped, 2, &mut [0.0; 6], &mut s), -0.5);
        let seg = [2.0, 5.0];
        approx::assert_relative_eq!(oriented_measure(&seg, 1, &mut [0.0; 2], &mut s), 3.0);
    }

    #[test]
    fn f32_unit_simplices_in_the_shaders_order() {
        let mut s = Scratch::<f32>::default();
        let tri = [0.0f32, 0.0, 1.0, 0.0, 0.0, 1.0];
        let mut g = [0.0f32; 6];
        assert_eq!(oriented_measure(&tri, 2, &mut g, &mut s), 0.5);
        assert_eq!(g, [-0.5, -0.5, 0.5, 0.0, 0.0, 0.5]);
        let squared = crate::geometry::simplex_squared_measure(&tri, 2, &mut g, &mut s);
        assert_eq!(squared, 0.25);
        // Pivot 3 (row swap), factor 1/3 rounds: 2 − (1/3)·4 in f32.
        let mut a = [1.0f32, 2.0, 3.0, 4.0];
        let expected = -3.0 * (2.0 - (1.0f32 / 3.0) * 4.0);
        assert_eq!(crate::geometry::determinant(&mut a, 2), expected);
    }

    #[test]
    fn the_volume_alone_is_the_measure_bit_for_bit() {
        let mut s = Scratch::new();
        let pts = [
            0.1, 0.0, 0.2, -0.1, 1.1, 0.1, 0.0, 0.2, 0.0, 0.9, 0.1, 0.0, 0.2, 0.1, 1.2, 0.1, -0.1,
            0.0, 0.3, 0.8,
        ];
        let with_gradient = oriented_measure(&pts, 4, &mut [0.0; 20], &mut s);
        assert_eq!(
            oriented_volume(&pts, 4, &mut s).to_bits(),
            with_gradient.to_bits()
        );
        let tri = [0.3, -0.2, 1.7, 0.1, 0.2, 0.9];
        let with_gradient = oriented_measure(&tri, 2, &mut [0.0; 6], &mut s);
        assert_eq!(
            oriented_volume(&tri, 2, &mut s).to_bits(),
            with_gradient.to_bits()
        );
    }

    #[test]
    fn gradient_matches_finite_differences_in_4d() {
        let pts = [
            0.1, 0.0, 0.2, -0.1, 1.1, 0.1, 0.0, 0.2, 0.0, 0.9, 0.1, 0.0, 0.2, 0.1, 1.2, 0.1, -0.1,
            0.0, 0.3, 0.8,
        ];
        let mut g = [0.0; 20];
        let mut s = Scratch::new();
        oriented_measure(&pts, 4, &mut g, &mut s);
        let eps = 1e-6;
        for i in 0..pts.len() {
            let mut p = pts;
            p[i] += eps;
            let up = oriented_measure(&p, 4, &mut [0.0; 20], &mut s);
            p[i] -= 2.0 * eps;
            let down = oriented_measure(&p, 4, &mut [0.0; 20], &mut s);
            approx::assert_abs_diff_eq!((up - down) / (2.0 * eps), g[i], epsilon = 1e-8);
        }
    }
}
