//! Oriented full-dimensional measure: C = det([x1−x0 … xN−x0])/N! − rest
//! (N + 1 particles); an equality that keeps a simplex from inverting
//! (geometry/oriented_measure.rs has ∇C).
//!
//! ```text
//! rest ≠ 0, and an authored simplex above the degeneracy floor
//!   |V| > DEGENERATE_VOLUME_RATIO · (longest edge)^N / N!
//! violation = |C|
//! ```

use super::Arity;
use crate::geometry::{DEGENERATE_VOLUME_RATIO, Scratch, factorial, oriented_measure};

pub(super) const ARITY: Arity = Arity::Full;

pub(super) fn rest_problem(rest: f64) -> Option<&'static str> {
    (rest == 0.0).then_some("an oriented rest measure of zero has no orientation to preserve")
}

/// The degeneracy check of an authored simplex (`points`, its signed
/// volume `value`).
pub(super) fn authored_problem(points: &[f64], dim: usize, value: f64) -> Option<String> {
    let mut longest: f64 = 0.0;
    for a in points.chunks_exact(dim) {
        for b in points.chunks_exact(dim) {
            longest = longest.max(distance(a, b));
        }
    }
    let floor = DEGENERATE_VOLUME_RATIO * longest.powi(dim as i32) / factorial(dim);
    (value.abs() <= floor).then(|| {
        format!(
            "the authored simplex has signed volume {value:e}, not above the degeneracy floor \
             {floor:e}"
        )
    })
}

fn distance(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y) * (x - y))
        .sum::<f64>()
        .sqrt()
}

pub(super) fn value(points: &[f64], dim: usize, grad: &mut [f64], scratch: &mut Scratch) -> f64 {
    oriented_measure(points, dim, grad, scratch)
}

pub(super) fn violation(value: f64, rest: f64) -> f64 {
    (value - rest).abs()
}
