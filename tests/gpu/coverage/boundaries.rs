//! Decisions hit exactly, with coordinates that are exact in f32 and f64
//! (multiples of 1/8), whole steps against the golden path frame by frame
//! (`common::differential`):
//!
//! ```text
//! touching balls   |x_j − x_i| = r_i + r_j exactly (C = 0: not a contact),
//!                  next to an overlapping pair: the middle ball averages its
//!                  corrections over its active contacts, so counting the
//!                  touching pair would halve its correction
//! on the plane     particles exactly at n·x = offset + r (C = 0: λ stays 0)
//!                  next to penetrating ones, with friction
//! ```

use super::*;

use common::differential::both;
use hyperpbd::{Collisions, Obstacle, Particle, Plan};

/// Rows of three balls of radius 1/2 along x0: A at 0, B at 7/8 (overlap
/// 1/8 with A), C at 15/8 (exactly touching B), plus a fourth ball exactly
/// touching C across axis 1; no gravity, so the first substep's broadphase
/// and contact iteration see the exact configuration.
fn touching(dim: usize) -> Scene {
    let mut scene = Scene::new(dim, 1.0 / 60.0, 2, 2);
    let at =
        |c: &[f64]| -> Vec<f64> { (0..dim).map(|a| c.get(a).copied().unwrap_or(0.0)).collect() };
    for (row, lift) in [0.0, 4.0].into_iter().enumerate() {
        let masses = [1.0, 2.0 + row as f64, 0.5];
        for (k, x) in [0.0, 0.875, 1.875].into_iter().enumerate() {
            scene
                .particles
                .push(Particle::new(at(&[x, lift]), masses[k]).with_radius(0.5));
        }
        scene
            .particles
            .push(Particle::new(at(&[1.875, lift + 1.0]), 0.75).with_radius(0.5));
    }
    scene.collisions = Some(Collisions {
        friction: 0.3,
        margin: 0.0,
    });
    valid(scene)
}

#[test]
fn exactly_touching_balls_are_not_contacts() {
    for dim in [2, 3] {
        let scene = touching(dim);
        assert!(Plan::compile(&scene).unwrap().contacts.is_some());
        both(
            "exactly_touching_balls_are_not_contacts",
            &format!("touching balls {dim}D"),
            &scene,
            3,
        );
    }
}

/// Particles exactly on a plane (n·x = offset + r = 1/4, all exact) and
/// others 1/8 m into it, resting under gravity with friction μ = 0.5; the exact
/// ones start at C = 0.
fn on_the_plane(dim: usize) -> Scene {
    let mut scene = Scene::new(dim, 1.0 / 64.0, 4, 2);
    let mut g = vec![0.0; dim];
    g[1] = -8.0;
    scene.gravity = Some(g);
    for i in 0..8 {
        let mut x = vec![0.0; dim];
        x[0] = 0.25 * i as f64;
        x[1] = if i % 2 == 0 { 0.25 } else { 0.125 };
        let mut v = vec![0.0; dim];
        v[0] = if i % 3 == 0 { 0.5 } else { 0.0 };
        scene.particles.push(
            Particle::new(x, 1.0 + 0.25 * i as f64)
                .with_radius(0.125)
                .with_velocity(v),
        );
    }
    let mut normal = vec![0.0; dim];
    normal[1] = 1.0;
    scene.obstacles.push(Obstacle::Hyperplane {
        normal,
        offset: 0.125,
        friction: 0.5,
        compliance: 0.0,
        motion: Vec::new(),
    });
    valid(scene)
}

#[test]
fn particles_exactly_on_a_plane() {
    for dim in [2, 4] {
        both(
            "particles_exactly_on_a_plane",
            &format!("exactly on a plane {dim}D"),
            &on_the_plane(dim),
            20,
        );
    }
}
