//! The smallest material scene of the material tests.

use hyperpbd::{ConstraintFamily, ConstraintKind, Particle, Scene};

/// Two Neo-Hookean triangles of the unit square in 2D (E = 100 Pa,
/// ν = 0.3), no authored masses: density 3 lumps 1, 0.5, 1, 0.5 kg onto
/// the corners. dt 0.01 s, one substep, one iteration, no gravity.
pub fn lumped_square() -> Scene {
    let mut scene = Scene::new(2, 0.01, 1, 1);
    for p in [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]] {
        let mut particle = Particle::new(p.to_vec(), 1.0);
        particle.mass = None;
        scene.particles.push(particle);
    }
    scene.constraints.push(
        ConstraintFamily::material(
            ConstraintKind::NeoHookean,
            100.0,
            0.3,
            vec![vec![0, 1, 2], vec![0, 2, 3]],
        )
        .with_density(3.0),
    );
    scene
}
