//! The seed's backward-Euler example for both convergence criteria.

use super::*;

/// One free unit-mass particle under a constant 1000 N force over a fixed
/// 1e-3 s horizon: the packed-gradient criterion (tolerance 1e-8, unit
/// mass·length) resolves forces only down to 1e-8 / dt², so at dt = 2e-6
/// (floor 2500 N) every step converges at the warm start and the particle
/// never moves: exactly 0 m/s. At dt = 5e-6 (floor 400 N) each step takes
/// the exact Newton step of the quadratic: backward Euler, 1 m/s. The
/// acceleration criterion (tolerance in length/time²) gives 1 m/s at both.
fn seed_example(dt: f64, convergence: Convergence) -> (f64, Vec<hyperpbd::MinimisationStatus>) {
    let mut scene = Scene::new(1, dt, 1, 1);
    scene
        .particles
        .push(Particle::new(vec![0.0], 1.0).with_force(vec![1000.0]));
    scene.solver = ip(1.0, 0.1, convergence, 20);
    let mut b = cpu(&scene);
    let steps = (1e-3 / dt).round() as usize;
    let mut statuses = Vec::new();
    for _ in 0..steps {
        let report = b.step().expect("step");
        assert_eq!(report.minimisation.len(), 1);
        let m = &report.minimisation[0];
        assert_eq!(m.criterion, convergence);
        assert!(m.initial_residual.is_some() && m.final_residual.is_some());
        statuses.push(m.status.clone());
    }
    (b.read_state().expect("state").velocities[0], statuses)
}

#[test]
fn seed_backward_euler_example_packed_gradient() {
    let packed = Convergence::PackedGradient { tolerance: 1e-8 };
    let (v, statuses) = seed_example(5e-6, packed);
    assert!(statuses.iter().all(|s| *s == MinimisationStatus::Converged));
    bound(
        "seed example: packed gradient, dt 5e-6: |v − 1 m/s|",
        (v - 1.0).abs(),
        1e-9,
        "200 exact Newton steps of a quadratic; each v rounds at ~u·|x|/h ~ 1e-13",
    );
    let (v, statuses) = seed_example(2e-6, packed);
    assert!(statuses.iter().all(|s| *s == MinimisationStatus::Converged));
    assert_eq!(
        v, 0.0,
        "dt 2e-6: converged at the warm start, identically 0 m/s"
    );
}

#[test]
fn seed_backward_euler_example_acceleration_residual() {
    let acceleration = Convergence::MaxAccelerationResidual { tolerance: 1e-3 };
    for dt in [5e-6, 2e-6] {
        let (v, statuses) = seed_example(dt, acceleration);
        assert!(statuses.iter().all(|s| *s == MinimisationStatus::Converged));
        bound(
            &format!("seed example: acceleration residual, dt {dt:e}: |v − 1 m/s|"),
            (v - 1.0).abs(),
            1e-9,
            "exact Newton steps of a quadratic; rounding ~u·|x|/h per step",
        );
    }
}
