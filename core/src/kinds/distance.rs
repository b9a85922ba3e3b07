//! Distance: C = |x1 − x0| − rest (2 particles), an equality.
//!
//! ```text
//! ∇_1 C = n = (x1 − x0)/|x1 − x0|,  ∇_0 C = −n     (0 where x1 = x0: no response)
//! violation = |C|
//! ```

use super::Arity;

pub(super) const ARITY: Arity = Arity::Exactly(2);

pub(super) fn rest_problem(rest: f64) -> Option<&'static str> {
    (rest < 0.0).then_some("a rest length must be >= 0")
}

pub(super) fn value(points: &[f64], dim: usize, grad: &mut [f64]) -> f64 {
    crate::geometry::distance(points, dim, grad)
}

pub(super) fn violation(value: f64, rest: f64) -> f64 {
    (value - rest).abs()
}
