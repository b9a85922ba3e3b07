//! The negative curvature of a measure spring E = C²/(2α), C = V(x) −
//! rest, over a segment of positions (the parent module's D_i):
//!
//! ```text
//! ∇²E = (1/α) ∇C ∇Cᵀ + (C/α) ∇²V  ⪰  −(sup|C| / α) sup‖∇²V‖ I      (the first part is PSD)
//! sup|C| over the segment ≤ max(|C(a)|, |C(b)|) + sup‖∇V‖ |a_e − b_e| / 2   (nearer end)
//! L = the largest edge x_v − x_0 of the element at either end (a norm is convex on a segment)
//! oriented V = det D / N!, D = [x_1 − x_0 … x_N − x_0]:
//!   d²det[U, W] = Σ_{b≠d} det(D; col b ← U_b, col d ← W_d) ≤ N L^{N−2} ‖U‖_F ‖W‖_F  (Hadamard)
//!   ‖∇det‖ = ‖cof D‖_F ≤ N L^{N−1};   x → D has norm √(N + 1)
//!   ‖∇²V‖ ≤ (N + 1) N L^{N−2} / N!,   ‖∇V‖ ≤ √(N + 1) N L^{N−1} / N!
//! simplex measure V = det(EᵀE)/(k!)² (squared measure), k = 1: V = |e|²: ‖∇²V‖ = 4, ‖∇V‖ ≤ 2√2 L
//!   k = 2: 4V = |a|²|b|² − (a·b)²; along (u, w): (4V)'' ≤ 12 L² (|u|² + |w|²), (4V)' ≤ 4√2 L³ |(u, w)|
//!   x → (a, b) has norm √3:  ‖∇²V‖ ≤ 9 L²,  ‖∇V‖ ≤ √6 L³
//! ```
//! Other orders (k ≥ 3 simplex measures) state no bound; V itself is
//! core's `kinds::value`.

use hyperpbd_core::ConstraintKind;
use hyperpbd_core::geometry::Scratch;
use hyperpbd_core::kinds;

/// V at `points` by core's `kinds::value` (the golden definition).
fn value(oriented: bool, points: &[f64], dim: usize) -> f64 {
    let kind = if oriented {
        ConstraintKind::OrientedMeasure
    } else {
        ConstraintKind::SimplexMeasure
    };
    let mut grad = vec![0.0; points.len()];
    kinds::value(kind, points, dim, &mut grad, &mut Scratch::new())
}

/// The largest edge |x_v − x_0| of the element at `points`.
fn largest_edge(points: &[f64], dim: usize) -> f64 {
    (1..points.len() / dim)
        .map(|v| {
            (0..dim)
                .map(|a| (points[v * dim + a] - points[a]).powi(2))
                .sum::<f64>()
                .sqrt()
        })
        .fold(0.0, f64::max)
}

/// c_e = sup|C| sup‖∇²V‖ / α over the segment between the element's
/// points `a` and `b` (arity × N each), or `None` where no bound is
/// derived.
pub fn measure_curvature(
    oriented: bool,
    compliance: f64,
    rest: f64,
    a: &[f64],
    b: &[f64],
    dim: usize,
) -> Option<f64> {
    let k = a.len() / dim - 1;
    let l = largest_edge(a, dim).max(largest_edge(b, dim));
    let (hessian, slope) = if oriented && dim == 1 {
        (0.0, 1.0)
    } else if oriented {
        let n = dim as f64;
        let factorial: f64 = (1..=dim).map(|v| v as f64).product();
        (
            (n + 1.0) * n * l.powi(dim as i32 - 2) / factorial,
            (n + 1.0).sqrt() * n * l.powi(dim as i32 - 1) / factorial,
        )
    } else {
        match k {
            1 => (4.0, 2.0 * 2f64.sqrt() * l),
            2 => (9.0 * l * l, 6f64.sqrt() * l.powi(3)),
            _ => return None,
        }
    };
    let moved = a
        .iter()
        .zip(b)
        .map(|(p, q)| (p - q) * (p - q))
        .sum::<f64>()
        .sqrt();
    let c = (value(oriented, a, dim) - rest)
        .abs()
        .max((value(oriented, b, dim) - rest).abs())
        + 0.5 * slope * moved;
    Some(c * hessian / compliance)
}

#[cfg(test)]
mod tests {
    use super::value;

    /// The bounds above are derived for V = det(EᵀE)/(k!)²: core's value
    /// is that (k = 1: |e|², k = 2: (|a|²|b|² − (a·b)²)/4).
    #[test]
    fn simplex_measure_is_the_squared_measure_the_bounds_assume() {
        let segment = [0.1, 0.2, 0.3, 1.1, -0.4, 0.8];
        let e: Vec<f64> = (0..3).map(|k| segment[3 + k] - segment[k]).collect();
        let squared: f64 = e.iter().map(|v| v * v).sum();
        assert!((value(false, &segment, 3) - squared).abs() <= 1e-14);
        let triangle = [0.0, 0.0, 0.0, 1.0, 0.2, 0.1, 0.3, 0.9, -0.2];
        let (a, b) = (&triangle[3..6], &triangle[6..9]);
        let dot = |u: &[f64], w: &[f64]| u.iter().zip(w).map(|(p, q)| p * q).sum::<f64>();
        let expected = (dot(a, a) * dot(b, b) - dot(a, b).powi(2)) / 4.0;
        assert!((value(false, &triangle, 3) - expected).abs() <= 1e-14);
        let tetra = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];
        assert!((value(true, &tetra, 3) - 1.0 / 6.0).abs() <= 1e-15);
    }
}
