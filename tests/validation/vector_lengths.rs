//! Vectors whose length is not the scene's dim.

use super::*;

#[test]
fn wrong_length_position() {
    let e = error(|s| s.particles[2].position = vec![0.0, 1.0]);
    assert_eq!(e, wrong_length("particles[2].position", 2));
    assert_eq!(
        e.to_string(),
        "particles[2].position: expected 3 components (the scene dimension), found 2"
    );
}

#[test]
fn wrong_length_velocity() {
    let e = error(|s| s.particles[0].velocity = Some(vec![0.0; 4]));
    assert_eq!(e, wrong_length("particles[0].velocity", 4));
}

#[test]
fn wrong_length_force() {
    let e = error(|s| s.particles[3].force = Some(vec![]));
    assert_eq!(e, wrong_length("particles[3].force", 0));
}

#[test]
fn wrong_length_gravity() {
    let e = error(|s| s.gravity = Some(vec![-9.81]));
    assert_eq!(e, wrong_length("gravity", 1));
}

#[test]
fn wrong_length_normal() {
    let e = error(|s| *hyperplane(s).0 = vec![0.0, 1.0, 0.0, 0.0]);
    assert_eq!(e, wrong_length("obstacles[0].normal", 4));
}
