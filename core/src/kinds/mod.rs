//! Constraint kinds, one home each: what a kind's elements are (arity),
//! which rest values it takes, how it is checked, its value C with ∇C, its
//! relation and its violation. Validation, the plan, residuals and the
//! implicit springs ask here; the backends' tuned kernels implement the
//! same value (their differential tests hold them to it).
//!
//! ```text
//! kind               arity          rest (omitted: C at the authored positions)   relation  violation   home
//! distance           2              ≥ 0                                           C = 0     |C|         distance.rs
//! tether             2              ≥ 0                                           C ≤ 0     max(C, 0)   tether.rs
//! simplex_measure    k+1, 1 ≤ k ≤ N ≥ 0                                           C = 0     |C|         simplex_measure.rs
//! oriented_measure   N+1            ≠ 0; authored simplex not degenerate          C = 0     |C|         oriented_measure.rs
//! stvk, neo_hookean  k+1, 1 ≤ k ≤ N 0 (the rest shape lives in the plan's frames)  C = 0     √(2W)       material.rs
//! hyperplane contact 1 (obstacle)   offset + radius                               C ≥ 0     by the backend's normals  hyperplane_contact.rs
//! mesh contact       1 (obstacle)   radius (C = dist(x, mesh) − radius)           C ≥ 0     by the backend's normals  mesh_contact.rs
//! expression         any, per family any                                          relation  by relation expression.rs
//! bending (cosine)   4, N ≥ 3       in [−1, 1]                                    C = 0     |C|         bending.rs (an expression)
//! bending (quadratic) 4, N ≥ 3      ≥ 0; omitted: 0 (flat)                        C = 0     |C|         bending.rs (an expression
//!                                                                                                      with per-element weights)
//! ```
//! Adding a kind: one file here, a variant of [`ConstraintKind`] (and of
//! [`FamilyKind`] if it compiles to its own), one line in each function
//! below; every match over kinds in the crates is exhaustive, so the
//! compiler names every place left (the backends' kernels, the shared
//! codes of `gpu/src/codes.rs`).

mod bending;
pub mod contact_friction;
mod distance;
mod expression;
mod expression_projection;
#[cfg(test)]
mod expression_tests;
pub mod hyperplane_contact;
mod material;
mod mesh_bounds;
pub mod mesh_candidates;
pub mod mesh_contact;
mod oriented_measure;
pub mod particle_contact;
pub mod primal_element;
mod real;
mod relation;
mod simplex_measure;
mod tether;

pub use bending::{BendingModel, quadratic_weights};
pub use expression::ExpressionKind;
pub use expression_projection::{Colour, Positions, ProjectionScratch, project, values};
pub use real::ProjectionReal;
pub use relation::Relation;

use crate::expr::ParamValue;
use crate::geometry::Scratch;
use crate::material::Material;
use crate::{ConstraintFamily, ConstraintKind, FamilyKind, SceneError};

/// How many particles an element of a kind has.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Arity {
    /// Exactly this many.
    Exactly(usize),
    /// N + 1: a full-dimensional simplex of R^N.
    Full,
    /// Any length ≥ 1, the same for the whole family (expressions).
    Family,
    /// A k-simplex: k + 1 particles with 1 ≤ k ≤ N, the same k for the
    /// whole family.
    Simplex,
}

/// The arity of `kind`.
pub fn arity(kind: ConstraintKind) -> Arity {
    match kind {
        ConstraintKind::Distance => distance::ARITY,
        ConstraintKind::Tether => tether::ARITY,
        ConstraintKind::SimplexMeasure => simplex_measure::ARITY,
        ConstraintKind::OrientedMeasure => oriented_measure::ARITY,
        ConstraintKind::Stvk | ConstraintKind::NeoHookean => material::ARITY,
        ConstraintKind::Expression => Arity::Family,
        ConstraintKind::Bending => bending::ARITY,
    }
}

/// Why an authored rest value `rest` (finite) is refused by `family`'s
/// kind, if it is. Material kinds take no rest values (their validation
/// refuses the key).
pub fn rest_problem(family: &ConstraintFamily, rest: f64) -> Option<&'static str> {
    match family.kind {
        ConstraintKind::Distance => distance::rest_problem(rest),
        ConstraintKind::Tether => tether::rest_problem(rest),
        ConstraintKind::SimplexMeasure => simplex_measure::rest_problem(rest),
        ConstraintKind::OrientedMeasure => oriented_measure::rest_problem(rest),
        ConstraintKind::Bending => bending::rest_problem(family.model.unwrap_or_default(), rest),
        ConstraintKind::Stvk | ConstraintKind::NeoHookean | ConstraintKind::Expression => None,
    }
}

/// Why `kind` cannot live in R^`dim`, if it cannot.
pub fn dimension_problem(kind: ConstraintKind, dim: usize) -> Option<String> {
    match kind {
        ConstraintKind::Bending => (dim < bending::MIN_DIM).then(|| {
            format!(
                "a fold between two triangles needs dim >= {} (the scene has {dim})",
                bending::MIN_DIM
            )
        }),
        ConstraintKind::Distance
        | ConstraintKind::Tether
        | ConstraintKind::SimplexMeasure
        | ConstraintKind::OrientedMeasure
        | ConstraintKind::Stvk
        | ConstraintKind::NeoHookean
        | ConstraintKind::Expression => None,
    }
}

/// The compiled expression of constraint family `f` when its kind is
/// defined by one — a user's `value`, or a built-in kind written as an
/// expression (bending) — for elements of `arity` particles in
/// R^`dim`; `None` for the kinds with kernels of their own. `position(i)`
/// is particle i's authored position (the per-element constants of
/// quadratic bending are computed from them; the family's indices must
/// be in range).
pub fn expression_of<'p>(
    f: usize,
    family: &ConstraintFamily,
    arity: usize,
    dim: usize,
    position: impl Fn(usize) -> &'p [f64],
) -> Result<Option<ExpressionKind>, SceneError> {
    Ok(match family.kind {
        ConstraintKind::Expression => {
            let path = format!("constraints[{f}].value");
            let source = family
                .value
                .as_deref()
                .ok_or_else(|| SceneError::MissingField {
                    path: path.clone(),
                    kind: "expression",
                })?;
            let params = expression_params(f, family)?;
            let relation = family.relation.unwrap_or(Relation::Equal);
            let compiled = ExpressionKind::new("expression", source, &params, relation, arity, dim);
            Some(compiled.map_err(|source| SceneError::Expression {
                path,
                source: Box::new(source),
            })?)
        }
        ConstraintKind::Bending => Some(bending_of(f, family, arity, dim, position)?),
        ConstraintKind::Distance
        | ConstraintKind::Tether
        | ConstraintKind::SimplexMeasure
        | ConstraintKind::OrientedMeasure
        | ConstraintKind::Stvk
        | ConstraintKind::NeoHookean => None,
    })
}

/// The bending family `f` of `family.model` (the quadratic weights from
/// the authored positions `position`).
fn bending_of<'p>(
    f: usize,
    family: &ConstraintFamily,
    arity: usize,
    dim: usize,
    position: impl Fn(usize) -> &'p [f64],
) -> Result<ExpressionKind, SceneError> {
    let compiled = match family.model.unwrap_or_default() {
        BendingModel::Cosine => {
            ExpressionKind::new("bending", bending::COSINE, &[], Relation::Equal, arity, dim)
        }
        BendingModel::Quadratic => {
            let mut weights = Vec::with_capacity(3 * family.elements.len());
            let mut points = Vec::with_capacity(4 * dim);
            for (e, element) in family.elements.iter().enumerate() {
                points.clear();
                for &i in element {
                    points.extend_from_slice(position(i));
                }
                let k = bending::quadratic_weights(&points, dim).map_err(|why| {
                    SceneError::DegenerateRest {
                        path: format!("constraints[{f}].elements[{e}]"),
                        why: why.into(),
                    }
                })?;
                weights.extend_from_slice(&k);
            }
            let kind = ExpressionKind::with_constants(
                "bending",
                bending::QUADRATIC,
                &[],
                &bending::QUADRATIC_CONSTANTS,
                weights,
                Relation::Equal,
                arity,
                dim,
            );
            kind.map(|mut kind| {
                kind.fixed_rest = Some(0.0);
                kind
            })
        }
    };
    compiled.map_err(|source| SceneError::Expression {
        path: format!("constraints[{f}].type"),
        source: Box::new(source),
    })
}

/// Why the authored element at `points` (its particles' positions, arity ×
/// `dim`), whose value is `value`, cannot be an element of `kind` with
/// its rest value taken from it, if it cannot.
pub fn authored_problem(
    kind: ConstraintKind,
    points: &[f64],
    dim: usize,
    value: f64,
) -> Option<String> {
    match kind {
        ConstraintKind::OrientedMeasure => oriented_measure::authored_problem(points, dim, value),
        ConstraintKind::Distance
        | ConstraintKind::Tether
        | ConstraintKind::SimplexMeasure
        | ConstraintKind::Stvk
        | ConstraintKind::NeoHookean
        | ConstraintKind::Expression
        | ConstraintKind::Bending => None,
    }
}

/// The value of `kind` at `points` (arity × `dim`, gathered), with ∇C
/// written into `grad` (the layout of `points`): the rest value an element
/// takes from its authored geometry. A material kind's value here is 0,
/// the minimum of its energy constraint C = √(2W) (its rest shape lives in
/// the plan's rest frames), with ∇C = 0. Expression families are valued
/// by their compiled tape ([`ExpressionKind::value_at`]); validation and
/// the plan take that path, and the implicit path refuses them.
pub fn value(
    kind: ConstraintKind,
    points: &[f64],
    dim: usize,
    grad: &mut [f64],
    scratch: &mut Scratch,
) -> f64 {
    match kind {
        ConstraintKind::Distance => distance::value(points, dim, grad),
        ConstraintKind::Tether => tether::value(points, dim, grad),
        ConstraintKind::SimplexMeasure => simplex_measure::value(points, dim, grad, scratch),
        ConstraintKind::OrientedMeasure => oriented_measure::value(points, dim, grad, scratch),
        ConstraintKind::Stvk | ConstraintKind::NeoHookean => material::rest_value(grad),
        ConstraintKind::Expression | ConstraintKind::Bending => {
            unreachable!("an expression's value needs its compiled tape (ExpressionKind::value_at)")
        }
    }
}

/// The compiled kind of an authored family of `kind` whose elements have
/// `arity` particles (`material`: its law and Lamé parameters, for the
/// material kinds; `expression`: the compiled expression).
pub fn family_kind(
    kind: ConstraintKind,
    arity: usize,
    material: Option<Material>,
    expression: Option<ExpressionKind>,
) -> FamilyKind {
    match (kind, material) {
        (ConstraintKind::Expression | ConstraintKind::Bending, _) => match expression {
            Some(expression) => FamilyKind::Expression(std::sync::Arc::new(expression)),
            None => unreachable!("the plan compiles every expression family"),
        },
        (ConstraintKind::Stvk | ConstraintKind::NeoHookean, Some(material)) => {
            material::family_kind(material, arity)
        }
        (ConstraintKind::Distance, _) => FamilyKind::Distance,
        (ConstraintKind::Tether, _) => FamilyKind::Tether,
        (ConstraintKind::SimplexMeasure, _) => simplex_measure::family_kind(arity),
        (ConstraintKind::OrientedMeasure, _) => FamilyKind::OrientedMeasure,
        (ConstraintKind::Stvk | ConstraintKind::NeoHookean, None) => {
            unreachable!("material_plan compiles a material for every material family")
        }
    }
}

/// The relation of a compiled kind.
pub fn relation(kind: &FamilyKind) -> Relation {
    match kind {
        FamilyKind::Distance | FamilyKind::SimplexMeasure { .. } | FamilyKind::OrientedMeasure => {
            Relation::Equal
        }
        FamilyKind::Tether => tether::RELATION,
        FamilyKind::Material { .. } => material::RELATION,
        FamilyKind::HyperplaneContact { .. } => hyperplane_contact::RELATION,
        FamilyKind::MeshContact { .. } => mesh_contact::RELATION,
        FamilyKind::Expression(expression) => expression.relation,
    }
}

/// The violation of one element of a geometric kind whose value is
/// `value` and rest value `rest`; `None` for contact and material kinds
/// (the backend's contact normals and the law measure those).
pub fn violation(kind: &FamilyKind, value: f64, rest: f64) -> Option<f64> {
    match kind {
        FamilyKind::Distance => Some(distance::violation(value, rest)),
        FamilyKind::Tether => Some(tether::violation(value, rest)),
        FamilyKind::SimplexMeasure { .. } => Some(simplex_measure::violation(value, rest)),
        FamilyKind::OrientedMeasure => Some(oriented_measure::violation(value, rest)),
        FamilyKind::Expression(expression) => Some(expression.violation(value, rest)),
        FamilyKind::HyperplaneContact { .. }
        | FamilyKind::MeshContact { .. }
        | FamilyKind::Material { .. } => None,
    }
}

/// The params of family `f` in authored order: a number or an array of
/// numbers each (the compiler checks a vector's length against N).
fn expression_params(
    f: usize,
    family: &ConstraintFamily,
) -> Result<Vec<(String, ParamValue)>, SceneError> {
    let mut out = Vec::new();
    for (name, value) in family.params.iter().flatten() {
        let path = format!("constraints[{f}].params.{name}");
        let number = |v: &serde_json::Value, path: String| match v.as_f64() {
            Some(x) if x.is_finite() => Ok(x),
            Some(x) => Err(SceneError::NonFinite { path, value: x }),
            None => Err(SceneError::Inconsistent {
                path,
                why: "a param is a number or an array of numbers (an N-vector)".into(),
            }),
        };
        let value = match value {
            serde_json::Value::Array(items) => ParamValue::Vector(
                (items.iter().enumerate())
                    .map(|(k, v)| number(v, format!("{path}[{k}]")))
                    .collect::<Result<_, _>>()?,
            ),
            other => ParamValue::Scalar(number(other, path)?),
        };
        out.push((name.clone(), value));
    }
    Ok(out)
}
