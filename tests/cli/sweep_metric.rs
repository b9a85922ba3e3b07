//! `hyperpbd sweep --plot kinetic_energy` weighs every dynamic particle by
//! its mass — authored, or lumped from a material family's density (a
//! particle without `mass` used to count as massless).

use crate::common;

use hyperpbd::sweep::Metric;
use hyperpbd::{Particle, Plan, Scene, State};

/// `common::materials::lumped_square` (particles 0..3 without mass,
/// lumped from density 3) plus particle 4 of 2 kg and a fixed particle 5.
fn scene() -> Scene {
    let mut scene = common::materials::lumped_square();
    scene.particles.push(Particle::new(vec![3.0, 0.0], 2.0));
    let mut fixed = Particle::new(vec![4.0, 0.0], 1.0);
    fixed.fixed = true;
    scene.particles.push(fixed);
    scene.validate().expect("valid");
    scene
}

#[test]
fn kinetic_energy_counts_lumped_masses() {
    let scene = scene();
    let masses = hyperpbd::particle_masses(&scene).expect("masses");
    // ρ · area / 3 per triangle: corners 0 and 2 are in both (2 · 0.5 each),
    // 1 and 3 in one (0.5 each); total ρ · 1 = 3 kg.
    let nominal = [1.0, 0.5, 1.0, 0.5, 2.0, 0.0];
    for (i, (m, n)) in masses.iter().zip(nominal).enumerate() {
        assert!(
            (m - n).abs() <= 4.0 * f64::EPSILON * n,
            "particle {i}: {m} vs {n}"
        );
    }
    let plan = Plan::compile(&scene).expect("plan");
    for (i, (&m, &w)) in masses.iter().zip(&plan.inverse_mass).enumerate() {
        let expected = if m > 0.0 { 1.0 / m } else { 0.0 };
        assert_eq!(w.to_bits(), expected.to_bits(), "particle {i}");
    }
    let mut state = State::from_scene(&scene);
    for (i, v) in state.velocities.chunks_mut(2).enumerate() {
        v.copy_from_slice(&[i as f64 + 1.0, 0.0]);
    }
    let ke = Metric::KineticEnergy.value(&scene, &state, None);
    // ½ Σ m v², v_i = i + 1; the fixed particle does not count.
    let expected = 0.5 * (1.0 * 1.0 + 0.5 * 4.0 + 1.0 * 9.0 + 0.5 * 16.0 + 2.0 * 25.0);
    println!("kinetic energy {ke} (expected {expected})");
    assert!(
        (ke - expected).abs() <= 1e-14 * expected,
        "{ke} vs {expected}"
    );
}
