//! Constraint violation of the geometric and material families
//! (cpu/src/residual.rs's arithmetic, here once for every backend that
//! reports residuals from a state it reads back).
//!
//! ```text
//! distance, simplex / oriented measure:  |C| = |value − rest|
//! tether:                                max(0, |x1 − x0| − rest)
//! material (StVK, Neo-Hookean):          C = √(2W) (material::energy_constraint),
//!                                        +∞ for an element the law refuses
//! family residual:                       max over its elements (exact in any order)
//! collisions (ball barriers):            max(0, max over pairs (r_i + r_j − |x_j − x_i|)),
//!                                        pairs: every pair whose boxes x ± r overlap
//!                                        (any overlapping pair has overlapping boxes)
//! ```
//! Contact families have their own violation (the backend's contact
//! normals) and are not handled here.

use crate::broadphase::{Aabbs, grid_pairs};
use crate::geometry::{
    Scratch, deepest_overlap, distance, oriented_measure, simplex_squared_measure,
};
use crate::material::{MaterialScratch, energy_constraint};
use crate::{Family, FamilyKind, FamilyResidual, Plan, kinds};

/// The violation of element `e` (colour-ordered slot) of a geometric
/// family at `points` (its members' coordinates, arity × `dim`); `None`
/// for contact and material kinds. `grad` (arity × `dim`) is scratch.
pub fn geometric_violation(
    kind: &FamilyKind,
    (e, rest): (usize, f64),
    points: &[f64],
    dim: usize,
    grad: &mut [f64],
    scratch: &mut Scratch,
) -> Option<f64> {
    let value = match kind {
        FamilyKind::Distance | FamilyKind::Tether => distance(points, dim, grad),
        FamilyKind::SimplexMeasure { .. } => simplex_squared_measure(points, dim, grad, scratch),
        FamilyKind::OrientedMeasure => oriented_measure(points, dim, grad, scratch),
        FamilyKind::Expression(expression) => expression.value_at(e, points, &mut scratch.columns),
        FamilyKind::HyperplaneContact { .. }
        | FamilyKind::MeshContact { .. }
        | FamilyKind::Material { .. } => return None,
    };
    kinds::violation(kind, value, rest)
}

/// The residual of every geometric and material family of `families` at
/// `x` (`dim` coordinates per particle), in family order; contact families
/// are left out.
pub fn family_residuals(families: &[Family], dim: usize, x: &[f64]) -> Vec<FamilyResidual> {
    let mut scratch = Scratch::default();
    let mut material = MaterialScratch::new();
    let mut out = Vec::new();
    for family in families {
        if family.kind.is_inequality() {
            continue;
        }
        let arity = family.arity;
        let mut points = vec![0.0; arity * dim];
        let mut grad = vec![0.0; arity * dim];
        let mut worst: f64 = 0.0;
        for e in 0..family.len() {
            for (j, &i) in family.elements[e * arity..(e + 1) * arity]
                .iter()
                .enumerate()
            {
                let i = i as usize;
                points[j * dim..(j + 1) * dim].copy_from_slice(&x[i * dim..(i + 1) * dim]);
            }
            let v = match family.kind.material_element(e, &points, dim) {
                Some(element) => {
                    energy_constraint(element, &mut grad, &mut material).unwrap_or(f64::INFINITY)
                }
                None => {
                    let rest = family.rest[e];
                    geometric_violation(
                        &family.kind,
                        (e, rest),
                        &points,
                        dim,
                        &mut grad,
                        &mut scratch,
                    )
                    .unwrap_or(0.0)
                }
            };
            worst = worst.max(v);
        }
        out.push(FamilyResidual {
            label: family.label.clone(),
            max_violation: worst,
        });
    }
    out
}

/// The "collisions" residual of a plan whose balls are barrier terms (the
/// coupled implicit step): the deepest overlap of any two balls at `x`
/// (0 when none overlaps), over the pairs of the broadphase on the static
/// boxes x ± r, pairs of two fixed particles left out.
pub fn ball_overlap_residual(plan: &Plan, x: &[f64]) -> FamilyResidual {
    let boxes = Aabbs::particles(plan.dim, x, &plan.radius, 0.0);
    let w = &plan.inverse_mass;
    let mut pairs = grid_pairs(&boxes);
    pairs.retain(|&[i, j]| w[i as usize] + w[j as usize] > 0.0);
    FamilyResidual {
        label: "collisions".into(),
        max_violation: deepest_overlap(plan.dim, &plan.radius, &pairs, x),
    }
}
