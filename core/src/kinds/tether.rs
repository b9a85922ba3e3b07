//! Tether: |x1 − x0| ≤ rest (2 particles), a one-sided distance for
//! long-range attachments: λ ≤ 0, it only ever pulls.
//!
//! ```text
//! C = |x1 − x0| − rest ≤ 0,  ∇C as the distance's
//! violation = max(C, 0)
//! ```

use super::Arity;
use super::relation::Relation;

pub(super) const ARITY: Arity = Arity::Exactly(2);
pub(super) const RELATION: Relation = Relation::AtMost;

pub(super) fn rest_problem(rest: f64) -> Option<&'static str> {
    super::distance::rest_problem(rest)
}

pub(super) fn value(points: &[f64], dim: usize, grad: &mut [f64]) -> f64 {
    super::distance::value(points, dim, grad)
}

pub(super) fn violation(value: f64, rest: f64) -> f64 {
    (value - rest).max(0.0)
}
