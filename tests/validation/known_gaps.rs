//! Known gaps: scenes that pass validation yet strain `Plan::compile`
//! (extreme normals, a huge dim).

use super::*;

/// A normal whose squared length underflows passes validation (it is not
/// all zeros), but `Plan::compile` divides by the underflowed length
/// (plan.rs, `let length = normal.iter().map(|x| x * x).sum::<f64>().sqrt()`)
/// and the compiled normal is non-finite; with 1e200 the length overflows
/// and the compiled normal is silently zero.
#[test]
fn extreme_normal_magnitudes_compile_to_a_unit_normal() {
    for scale in [1e-200, 1e200] {
        let mut s = base();
        *hyperplane(&mut s).0 = vec![0.0, scale, 0.0];
        if s.validate().is_err() {
            continue; // rejecting it is a fine answer too
        }
        let plan = Plan::compile(&s).expect("compiles");
        let normal = plan
            .families
            .iter()
            .find_map(|f| match &f.kind {
                hyperpbd::FamilyKind::HyperplaneContact { normal, .. } => Some(normal.clone()),
                _ => None,
            })
            .expect("contact family");
        let length: f64 = normal.iter().map(|x| x * x).sum::<f64>().sqrt();
        assert!(
            (length - 1.0).abs() < 1e-12,
            "scale {scale}: compiled normal {normal:?}"
        );
    }
}

/// A scene with no vectors at all accepts any `dim`; compiling it then
/// allocates `dim` gravity components and panics (capacity overflow) or
/// aborts (out of memory) instead of returning an error.
#[test]
fn huge_dimension_does_not_panic() {
    let s = Scene::new(1 << 62, 0.01, 1, 1);
    let result = std::panic::catch_unwind(|| Plan::compile(&s).map(|_| ()));
    assert!(result.is_ok(), "Plan::compile panicked");
}
