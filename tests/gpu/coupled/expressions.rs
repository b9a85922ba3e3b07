//! Expression families (and bending) in the GPU's coupled step: their ∇²C
//! springs (shaders/coupled_material.wgsl's dense blocks, the WGSL generated
//! by gpu/src/coupled/expression.rs) against the golden path
//! (core/src/implicit/expression_spring.rs), bit for bit in f64 on lavapipe:
//! the distance and tether written as expressions, a folded hinge unfolding
//! (cosine bending, its K projected to PSD), a cloth with bending; what is not
//! built yet (f32, arity > N + 1) is refused by name.

use super::*;
use common::expressions::as_expressions;
use common::implicit_scenes::{bending_cloth, chain_of, folded_hinge};
use hyperpbd::kinds::{BendingModel, Relation};

/// Every coordinate finite (the evidence off lavapipe: the bits are the
/// evidence there).
fn finite(s: &State) -> (f64, f64) {
    let ok = s
        .positions
        .iter()
        .chain(&s.velocities)
        .all(|v| v.is_finite());
    (if ok { 0.0 } else { f64::INFINITY }, 0.0)
}

#[test]
fn distance_and_tether_expressions_are_the_golden_path() {
    for (kind, relation) in [
        (ConstraintKind::Distance, Relation::Equal),
        (ConstraintKind::Tether, Relation::AtMost),
    ] {
        let scene = as_expressions(&chain_of(kind, 8), kind, "norm(x1 - x0)", relation);
        differential(&format!("{kind:?} as an expression"), &scene, 12, finite);
    }
}

#[test]
fn a_folded_hinge_and_a_cloth_with_bending_are_the_golden_path() {
    differential("folded hinge (cosine bending)", &folded_hinge(), 24, finite);
    differential(
        "cloth 6² with cosine bending",
        &bending_cloth(BendingModel::Cosine),
        4,
        finite,
    );
    // Quadratic bending: per-element constants (material_rest).
    differential(
        "cloth 6² with quadratic bending",
        &bending_cloth(BendingModel::Quadratic),
        4,
        finite,
    );
}

#[test]
fn expression_families_the_gpu_does_not_run_yet_are_refused_by_name() {
    let Some((adapter, _)) = adapter_or_skip("coupled expression refusals", Precision::F64) else {
        return;
    };
    let what = refusal(&adapter, &folded_hinge(), Precision::F32);
    assert!(
        what.contains("expression family") && what.contains("f32"),
        "{what}"
    );
    // Four particles in R² (N + 1 = 3).
    let mut wide = chain_of(ConstraintKind::Distance, 4);
    wide.constraints.push(ConstraintFamily::expression(
        "norm(x3 - x0) + norm(x2 - x1)",
        1e-4,
        vec![vec![1, 2, 3, 4]],
    ));
    let what = refusal(&adapter, &wide, Precision::F64);
    assert!(what.contains("arity 4"), "{what}");
}
