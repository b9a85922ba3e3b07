//! Particles: mass, fixed particles, radius.

use super::*;

#[test]
fn non_positive_mass() {
    let e = error(|s| s.particles[2].mass = Some(0.0));
    assert_eq!(
        e,
        SceneError::NonPositiveMass {
            path: "particles[2].mass".into(),
            value: 0.0
        }
    );
    let e = error(|s| s.particles[3].mass = Some(-1.5));
    assert_eq!(
        e,
        SceneError::NonPositiveMass {
            path: "particles[3].mass".into(),
            value: -1.5
        }
    );
}

#[test]
fn mass_on_a_fixed_particle_is_still_checked() {
    // A fixed particle may carry its mass (the builder's `fix` keeps it);
    // a nonpositive one is still rejected.
    let e = error(|s| s.particles[1].mass = Some(0.0));
    assert_eq!(
        e,
        SceneError::NonPositiveMass {
            path: "particles[1].mass".into(),
            value: 0.0
        }
    );
}

#[test]
fn missing_mass() {
    let e = error(|s| s.particles[2].mass = None);
    assert_eq!(
        e,
        SceneError::MissingMass {
            path: "particles[2].mass".into()
        }
    );
}

#[test]
fn fixed_particle_with_velocity() {
    let e = error(|s| s.particles[1].velocity = Some(vec![0.0, 0.0, 1e-300]));
    assert_eq!(
        e,
        SceneError::FixedParticleVelocity {
            path: "particles[1].velocity".into()
        }
    );
}

#[test]
fn negative_radius() {
    let e = error(|s| s.particles[3].radius = -0.25);
    assert_eq!(
        e,
        SceneError::Negative {
            path: "particles[3].radius".into(),
            value: -0.25
        }
    );
}
