//! Unsigned squared simplex measure: C = det(EᵀE)/(k!)² − rest for a
//! k-simplex (k + 1 particles, 1 ≤ k ≤ N), E = [x1−x0 … xk−x0]; an
//! equality (geometry/simplex_measure.rs has ∇C).
//!
//! ```text
//! violation = |C|
//! ```

use super::Arity;
use crate::FamilyKind;
use crate::geometry::{Scratch, simplex_squared_measure};

pub(super) const ARITY: Arity = Arity::Simplex;

pub(super) fn rest_problem(rest: f64) -> Option<&'static str> {
    (rest < 0.0).then_some("a squared measure must be >= 0")
}

pub(super) fn value(points: &[f64], dim: usize, grad: &mut [f64], scratch: &mut Scratch) -> f64 {
    simplex_squared_measure(points, dim, grad, scratch)
}

pub(super) fn family_kind(arity: usize) -> FamilyKind {
    FamilyKind::SimplexMeasure { k: arity - 1 }
}

pub(super) fn violation(value: f64, rest: f64) -> f64 {
    (value - rest).abs()
}
