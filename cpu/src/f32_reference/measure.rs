//! The simplex measures in f32, as `shaders/measure.wgsl` computes them
//! (the same algorithms as `core/src/geometry`, in the shader's order;
//! det and adj are core's, generic over the precision).
//!
//! ```text
//! det(A)        Gaussian elimination, partial pivoting (first largest
//!               |pivot| wins), product of pivots, sign per row swap
//! adj(A)[j][i]  = (−1)^(i+j) det(A without row i and column j)
//! S = det(EᵀE)/(k!)²,  ∂S/∂E = 2 E adj(EᵀE)/(k!)²    (E: N × k edges)
//! V = det(D)/N!,       ∇_j V = row j−1 of adj(D) / N!
//! ∇_0 = −Σ_j ∇_j
//! ```

// Coordinate loops index several arrays at once, as a kernel does.
#![allow(clippy::needless_range_loop)]

pub use hyperpbd_core::geometry::determinant;

/// k! accumulated in f32 from 1.
fn factorial(k: usize) -> f32 {
    let mut f = 1.0f32;
    for i in 1..=k {
        f *= i as f32;
    }
    f
}

/// adj(A) of the `n`×`n` `a` into `out` (core's `adjugate` in f32).
fn adjugate(a: &[f32], n: usize, out: &mut [f32]) {
    let mut minor = vec![0.0f32; n.saturating_sub(1).pow(2)];
    hyperpbd_core::geometry::adjugate(a, n, out, &mut minor);
}

/// Squared k-measure of the k-simplex `pts` (k + 1 points of `dim`
/// coordinates); its gradient into `grad` (same layout).
pub fn simplex_squared_measure(pts: &[f32], dim: usize, k: usize, grad: &mut [f32]) -> f32 {
    let scale = 1.0 / (factorial(k) * factorial(k));
    let mut edges = vec![0.0f32; dim * k];
    let mut gram = vec![0.0f32; k * k];
    let mut adj = vec![0.0f32; k * k];
    for j in 0..k {
        for a in 0..dim {
            edges[a * k + j] = pts[(j + 1) * dim + a] - pts[a];
        }
    }
    for i in 0..k {
        for j in 0..k {
            let mut s = 0.0f32;
            for a in 0..dim {
                s += edges[a * k + i] * edges[a * k + j];
            }
            gram[i * k + j] = s;
        }
    }
    adjugate(&gram, k, &mut adj);
    let measure = determinant(&mut gram, k) * scale;
    grad[..dim].fill(0.0);
    for j in 0..k {
        for a in 0..dim {
            let mut s = 0.0f32;
            for i in 0..k {
                s += edges[a * k + i] * adj[i * k + j];
            }
            let gj = 2.0 * s * scale;
            grad[(j + 1) * dim + a] = gj;
            grad[a] -= gj;
        }
    }
    measure
}

/// Signed measure det([x1−x0 … xN−x0])/N! of the N + 1 points `pts`.
pub fn oriented_measure(pts: &[f32], n: usize, grad: &mut [f32]) -> f32 {
    let scale = 1.0 / factorial(n);
    let mut edges = vec![0.0f32; n * n];
    let mut adj = vec![0.0f32; n * n];
    for j in 0..n {
        for a in 0..n {
            edges[a * n + j] = pts[(j + 1) * n + a] - pts[a];
        }
    }
    adjugate(&edges, n, &mut adj);
    let measure = determinant(&mut edges, n) * scale;
    grad[..n].fill(0.0);
    for j in 0..n {
        for a in 0..n {
            let gj = adj[j * n + a] * scale;
            grad[(j + 1) * n + a] = gj;
            grad[a] -= gj;
        }
    }
    measure
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unit_simplices() {
        let tri = [0.0, 0.0, 1.0, 0.0, 0.0, 1.0];
        let mut g = [0.0; 6];
        assert_eq!(oriented_measure(&tri, 2, &mut g), 0.5);
        assert_eq!(g, [-0.5, -0.5, 0.5, 0.0, 0.0, 0.5]);
        assert_eq!(simplex_squared_measure(&tri, 2, 2, &mut g), 0.25);
        // Pivot 3 (row swap), factor 1/3 rounds: 2 − (1/3)·4 in f32.
        let mut a = [1.0, 2.0, 3.0, 4.0];
        assert_eq!(determinant(&mut a, 2), -3.0 * (2.0 - (1.0f32 / 3.0) * 4.0));
        // Pivot 4 (row swap), factor 1/2: exact, det = 2.
        let mut b = [2.0, 1.0, 4.0, 3.0];
        assert_eq!(determinant(&mut b, 2), 2.0);
    }
}
