//! Non-finite values, named by their field path.

use super::*;

#[test]
fn non_finite_position() {
    let e = error(|s| s.particles[1].position[2] = f64::NAN);
    assert_non_finite(e, "particles[1].position[2]", f64::is_nan);
}

#[test]
fn non_finite_velocity() {
    let e = error(|s| s.particles[0].velocity = Some(vec![0.0, f64::INFINITY, 0.0]));
    assert_non_finite(e, "particles[0].velocity[1]", f64::is_infinite);
}

#[test]
fn non_finite_force() {
    let e = error(|s| s.particles[3].force = Some(vec![f64::NAN, 0.0, 0.0]));
    assert_non_finite(e, "particles[3].force[0]", f64::is_nan);
}

#[test]
fn non_finite_gravity() {
    let e = error(|s| s.gravity = Some(vec![0.0, 0.0, f64::NEG_INFINITY]));
    assert_non_finite(e, "gravity[2]", |v| v == f64::NEG_INFINITY);
}

#[test]
fn non_finite_mass() {
    let e = error(|s| s.particles[2].mass = Some(f64::NAN));
    assert_non_finite(e, "particles[2].mass", f64::is_nan);
    let e = error(|s| s.particles[2].mass = Some(f64::INFINITY));
    assert_non_finite(e, "particles[2].mass", f64::is_infinite);
}

#[test]
fn non_finite_radius() {
    let e = error(|s| s.particles[0].radius = f64::NAN);
    assert_non_finite(e, "particles[0].radius", f64::is_nan);
    let e = error(|s| s.particles[0].radius = f64::INFINITY);
    assert_non_finite(e, "particles[0].radius", f64::is_infinite);
}

#[test]
fn non_finite_gravity_scale() {
    let e = error(|s| s.particles[3].gravity_scale = f64::NAN);
    assert_non_finite(e, "particles[3].gravity_scale", f64::is_nan);
}

#[test]
fn non_finite_constraint_compliance() {
    let e = error(|s| s.constraints[1].compliance = f64::NAN);
    assert_non_finite(e, "constraints[1].compliance", f64::is_nan);
    let e = error(|s| s.constraints[2].compliance = f64::INFINITY);
    assert_non_finite(e, "constraints[2].compliance", f64::is_infinite);
}

#[test]
fn non_finite_rest() {
    let e = error(|s| s.constraints[0].rest = Some(vec![1.0, f64::NAN]));
    assert_non_finite(e, "constraints[0].rest[1]", f64::is_nan);
}

#[test]
fn non_finite_normal() {
    let e = error(|s| *hyperplane(s).0 = vec![0.0, f64::NAN, 0.0]);
    assert_non_finite(e, "obstacles[0].normal[1]", f64::is_nan);
}

#[test]
fn non_finite_offset() {
    let e = error(|s| *hyperplane(s).1 = f64::NEG_INFINITY);
    assert_non_finite(e, "obstacles[0].offset", f64::is_infinite);
}

#[test]
fn non_finite_friction() {
    let e = error(|s| *hyperplane(s).2 = f64::NAN);
    assert_non_finite(e, "obstacles[0].friction", f64::is_nan);
}

#[test]
fn non_finite_obstacle_compliance() {
    let e = error(|s| *hyperplane(s).3 = f64::INFINITY);
    assert_non_finite(e, "obstacles[0].compliance", f64::is_infinite);
}

#[test]
fn non_finite_damping_rate() {
    let e = error(|s| s.damping = Some(Damping { rate: f64::NAN }));
    assert_non_finite(e, "damping.rate", f64::is_nan);
}
