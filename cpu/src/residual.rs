//! Constraint violation per family at the current positions.
//!
//! ```text
//! equality:   max_e |C_e(x)|
//! contact:    max_e max(0, −C_e(x))
//! tether:     max_e max(0, |x1 − x0| − rest)
//! material:   max_e C_e = √(2 W_e)   (+∞ for a refused element; material.rs)
//! ```
//! The maximum is taken per chunk of [`RESIDUAL_GRAIN`] elements and then
//! over the chunks in order: one fixed tree for any thread count.

use crate::dim::{Dim, with_dim};
use crate::parallel::Workers;
use crate::project::Workspace;
use hyperpbd_core::expr::Block;
use hyperpbd_core::kinds::ExpressionKind;
use hyperpbd_core::violation::geometric_violation;
use hyperpbd_core::{Family, FamilyKind, FamilyResidual};
use std::ops::Range;

/// Elements per chunk of the residual.
pub const RESIDUAL_GRAIN: usize = 4096;

/// Evaluates every element of `family` at `x`.
pub fn residual(workers: &Workers, dim: usize, family: &Family, x: &[f64]) -> FamilyResidual {
    let worst = workers
        .map_chunks(family.len(), RESIDUAL_GRAIN, |elements| {
            if family.kind == FamilyKind::Distance {
                with_dim!(dim, distance_violation(family, elements, x))
            } else if let FamilyKind::Expression(kind) = &family.kind {
                expression_violation(kind, dim, family, elements, x)
            } else {
                with_dim!(
                    dim,
                    violation(family, elements, x, &mut Workspace::default())
                )
            }
        })
        .into_iter()
        .fold(0.0, f64::max);
    FamilyResidual {
        label: family.label.clone(),
        max_violation: worst,
    }
}

/// The largest violation of `elements` (any kind, generic path).
fn violation<D: Dim>(
    dim: D,
    family: &Family,
    elements: Range<usize>,
    x: &[f64],
    ws: &mut Workspace,
) -> f64 {
    let dim = dim.n();
    let arity = family.arity;
    let Workspace {
        points,
        grad,
        scratch,
        material,
        ..
    } = ws;
    points.resize(arity * dim, 0.0);
    grad.resize(arity * dim, 0.0);
    let mut worst: f64 = 0.0;
    for e in elements {
        let element = &family.elements[e * arity..(e + 1) * arity];
        for (j, &i) in element.iter().enumerate() {
            let i = i as usize;
            points[j * dim..(j + 1) * dim].copy_from_slice(&x[i * dim..(i + 1) * dim]);
        }
        let kind = &family.kind;
        let geometric = geometric_violation(kind, (e, family.rest[e]), points, dim, grad, scratch);
        let violation = match (geometric, kind) {
            (Some(v), _) => v,
            (None, FamilyKind::HyperplaneContact { normal, .. }) => {
                (family.rest[e] - crate::project::dot(normal, points)).max(0.0)
            }
            // Taken by `mesh_contact::residual` (motion::residual_of): its
            // mesh lives in the plan.
            (None, FamilyKind::MeshContact { .. }) => 0.0,
            // C, or +∞ for a refused element (its Neo-Hookean energy is
            // unbounded as J → 0⁺).
            (None, _) => crate::material::energy_constraint(family, e, points, dim, grad, material)
                .unwrap_or(f64::INFINITY),
        };
        worst = worst.max(violation);
    }
    worst
}

/// The largest violation of expression elements `elements`: C over
/// blocks of elements (`kinds::values`, bit for bit C element by
/// element), each violation formed as the generic path forms it.
fn expression_violation(
    kind: &ExpressionKind,
    dim: usize,
    family: &Family,
    elements: Range<usize>,
    x: &[f64],
) -> f64 {
    let mut worst: f64 = 0.0;
    let mut block = Block::new();
    hyperpbd_core::kinds::values(
        kind,
        dim,
        &family.elements,
        elements,
        x,
        &mut block,
        |e, value| {
            worst = worst.max(kind.violation(value, family.rest[e]));
        },
    );
    worst
}

/// max |(|x_j − x_i|) − rest| over distance elements `elements`: the
/// length formed exactly as `geometry::distance` forms it, without the
/// gradient.
fn distance_violation<D: Dim>(dim: D, family: &Family, elements: Range<usize>, x: &[f64]) -> f64 {
    let n = dim.n();
    let mut worst: f64 = 0.0;
    let ends = family.elements[2 * elements.start..2 * elements.end].chunks_exact(2);
    for (element, &rest) in ends.zip(&family.rest[elements]) {
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
