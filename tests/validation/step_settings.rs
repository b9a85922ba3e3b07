//! Step settings: dim, dt, substeps, iterations.

use super::*;

#[test]
fn dim_zero() {
    let e = error(|s| {
        *s = Scene::new(0, 0.01, 1, 1);
    });
    assert_eq!(e, SceneError::ZeroDimension);
    assert!(e.to_string().starts_with("dim: "));
}

#[test]
fn dt_zero_and_negative() {
    assert_eq!(
        error(|s| s.dt = 0.0),
        SceneError::NonPositiveTimeStep { value: 0.0 }
    );
    assert_eq!(
        error(|s| s.dt = -0.01),
        SceneError::NonPositiveTimeStep { value: -0.01 }
    );
    let e = error(|s| s.dt = -0.0);
    assert!(matches!(e, SceneError::NonPositiveTimeStep { value } if value == 0.0));
    assert!(e.to_string().starts_with("dt: "));
}

#[test]
fn dt_non_finite() {
    assert_non_finite(error(|s| s.dt = f64::NAN), "dt", f64::is_nan);
    assert_non_finite(error(|s| s.dt = f64::INFINITY), "dt", |v| {
        v == f64::INFINITY
    });
    assert_non_finite(error(|s| s.dt = f64::NEG_INFINITY), "dt", |v| {
        v == f64::NEG_INFINITY
    });
}

#[test]
fn substeps_zero() {
    let e = error(|s| s.substeps = 0);
    assert_eq!(e, SceneError::ZeroSubsteps);
    assert!(e.to_string().starts_with("substeps: "));
}

#[test]
fn iterations_zero() {
    let e = error(|s| s.iterations = 0);
    assert_eq!(e, SceneError::ZeroIterations);
    assert!(e.to_string().starts_with("iterations: "));
}
