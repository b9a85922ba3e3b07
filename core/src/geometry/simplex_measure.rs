//! Unsigned squared measure of a k-simplex embedded in R^N.
//!
//! ```text
//! E = [x1 − x0 … xk − x0]          (N × k)
//! G = EᵀE                           (k × k Gram matrix)
//! S = det(G) / (k!)²                (squared k-measure; length^(2k))
//! ∂S/∂E = 2 E adj(G) / (k!)²        (column j−1 is ∇_j S, j = 1..k)
//! ∇_0 S = −Σ_j ∇_j S
//! ```
//! The adjugate keeps ∇S finite at a singular Gram matrix; a collapsed
//! simplex whose first derivative vanishes gets ∇S = 0 (no response).
//! One code for both precisions: the golden path runs it in f64, the f32
//! reference in f32 (`measure.wgsl`'s order: k! from 1 factor by factor,
//! adj(G) before det(G), the scatter j, a ascending).

use super::{
    Scratch, adjugate, determinant, edge_matrix, factorial_in, gram, scatter_edge_gradient,
};
use crate::kinds::ProjectionReal;

/// S for the k-simplex `points` (k + 1 points of length `dim`).
pub fn simplex_squared_measure<R: ProjectionReal>(
    points: &[R],
    dim: usize,
    grad: &mut [R],
    scratch: &mut Scratch<R>,
) -> R {
    let k = points.len() / dim - 1;
    let one = R::constant(1.0);
    let scale = one / (factorial_in::<R>(k) * factorial_in::<R>(k));
    let Scratch {
        edges,
        gram: gram_matrix,
        adj,
        minor,
        ..
    } = scratch;
    let zero = R::constant(0.0);
    edges.resize(dim * k, zero);
    gram_matrix.resize(k * k, zero);
    adj.resize(k * k, zero);
    minor.resize(k * k, zero);
    edge_matrix(points, dim, k, edges);
    gram(edges, dim, k, gram_matrix);
    adjugate(gram_matrix, k, adj, minor);
    let measure = determinant(gram_matrix, k) * scale;
    let two = R::constant(2.0);
    scatter_edge_gradient(grad, dim, k, |j, a| {
        let mut s = zero;
        for i in 0..k {
            s += edges[a * k + i] * adj[i * k + j];
        }
        two * s * scale
    });
    measure
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn triangle_in_3d_has_area_squared() {
        let pts = [0.0, 0.0, 0.0, 2.0, 0.0, 0.0, 0.0, 3.0, 0.0];
        let mut g = [0.0; 9];
        let s = simplex_squared_measure(&pts, 3, &mut g, &mut Scratch::new());
        approx::assert_relative_eq!(s, 9.0, epsilon = 1e-12); // area 3
        let sum: f64 = (0..3).map(|a| g[a] + g[3 + a] + g[6 + a]).sum();
        approx::assert_abs_diff_eq!(sum, 0.0, epsilon = 1e-12);
    }

    #[test]
    fn gradient_matches_finite_differences() {
        let pts = [
            0.1, 0.2, -0.3, 0.4, 1.2, 0.1, 0.3, -0.2, 0.05, 0.9, 0.4, 0.7,
        ];
        let dim = 4;
        let mut g = [0.0; 12];
        let mut scratch = Scratch::new();
        simplex_squared_measure(&pts, dim, &mut g, &mut scratch);
        let eps = 1e-6;
        for i in 0..pts.len() {
            let mut p = pts;
            p[i] += eps;
            let up = simplex_squared_measure(&p, dim, &mut [0.0; 12], &mut scratch);
            p[i] -= 2.0 * eps;
            let down = simplex_squared_measure(&p, dim, &mut [0.0; 12], &mut scratch);
            approx::assert_abs_diff_eq!((up - down) / (2.0 * eps), g[i], epsilon = 1e-7);
        }
    }
}
