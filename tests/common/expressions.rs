//! Scenes with their built-in families written as expressions
//! (tests/cpu/expressions.rs, tests/gpu/expressions.rs).

use hyperpbd::kinds::Relation;
use hyperpbd::{ConstraintFamily, ConstraintKind, Scene};

/// `scene` with every family of `kind` replaced by the expression `value`
/// (relation `relation`), elements, compliance and rest kept.
pub fn as_expressions(
    scene: &Scene,
    kind: ConstraintKind,
    value: &str,
    relation: Relation,
) -> Scene {
    let mut out = scene.clone();
    let mut replaced = 0;
    for family in &mut out.constraints {
        if family.kind == kind {
            let mut expression =
                ConstraintFamily::expression(value, family.compliance, family.elements.clone())
                    .with_relation(relation);
            expression.rest = family.rest.clone();
            *family = expression;
            replaced += 1;
        }
    }
    assert!(replaced > 0, "the scene has a {kind:?} family");
    out
}
