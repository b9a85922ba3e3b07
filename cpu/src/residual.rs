//! Constraint violation per family at the current positions.
//!
//! ```text
//! equality:   max_e |C_e(x)|
//! contact:    max_e max(0, −C_e(x))
//! tether:     max_e max(0, |x1 − x0| − rest)
//! ```

use crate::dim::{Dim, with_dim};
use crate::project::Workspace;
use hyperpbd_core::geometry::{distance, oriented_measure, simplex_squared_measure};
use hyperpbd_core::{Family, FamilyKind, FamilyResidual};

/// Evaluates every element of `family` at `x`.
pub fn residual(dim: usize, family: &Family, x: &[f64], ws: &mut Workspace) -> FamilyResidual {
    if family.kind == FamilyKind::Distance {
        return FamilyResidual {
            label: family.label.clone(),
            max_violation: with_dim!(dim, distance_violation(family, x)),
        };
    }
    let arity = family.arity;
    let Workspace {
        points,
        grad,
        scratch,
    } = ws;
    points.resize(arity * dim, 0.0);
    grad.resize(arity * dim, 0.0);
    let mut worst: f64 = 0.0;
    for e in 0..family.len() {
        let element = &family.elements[e * arity..(e + 1) * arity];
        for (j, &i) in element.iter().enumerate() {
            let i = i as usize;
            points[j * dim..(j + 1) * dim].copy_from_slice(&x[i * dim..(i + 1) * dim]);
        }
        let violation = match &family.kind {
            FamilyKind::Distance => (distance(points, dim, grad) - family.rest[e]).abs(),
            FamilyKind::Tether => (distance(points, dim, grad) - family.rest[e]).max(0.0),
            FamilyKind::SimplexMeasure { .. } => {
                (simplex_squared_measure(points, dim, grad, scratch) - family.rest[e]).abs()
            }
            FamilyKind::OrientedMeasure => {
                (oriented_measure(points, dim, grad, scratch) - family.rest[e]).abs()
            }
            FamilyKind::HyperplaneContact { normal, .. } => {
                (family.rest[e] - crate::project::dot(normal, points)).max(0.0)
            }
        };
        worst = worst.max(violation);
    }
    FamilyResidual {
        label: family.label.clone(),
        max_violation: worst,
    }
}

/// max |(|x_j − x_i|) − rest| over a distance family: the length formed
/// exactly as `geometry::distance` forms it, without the gradient.
fn distance_violation<D: Dim>(dim: D, family: &Family, x: &[f64]) -> f64 {
    let n = dim.n();
    let mut worst: f64 = 0.0;
    for (element, &rest) in family.elements.chunks_exact(2).zip(&family.rest) {
        let (i, j) = (element[0] as usize, element[1] as usize);
        let (xi, xj) = (&x[i * n..i * n + n], &x[j * n..j * n + n]);
        let mut d2 = 0.0;
        for a in 0..n {
            let e = xj[a] - xi[a];
            d2 += e * e;
        }
        worst = worst.max((d2.sqrt() - rest).abs());
    }
    worst
}
