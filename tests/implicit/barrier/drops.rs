//! Drops: d > 0 always; resting contact at the force balance.

use super::*;
fn drop_never_reaches_contact(speed: f64) {
    let scene = drop_scene(speed, 0.01);
    let mut b = cpu(&scene);
    let mut smallest = f64::INFINITY;
    for _ in 0..240 {
        let report = b.step().expect("step");
        for m in &report.minimisation {
            assert_eq!(m.status, MinimisationStatus::Converged, "{m:?}");
        }
        let s = b.read_state().expect("state");
        let d = min_distance(&scene, &s);
        assert!(d > 0.0, "speed {speed}: d = {d} <= 0");
        smallest = smallest.min(d);
    }
    println!("drop at {speed} m/s: smallest d over 240 steps {smallest:e}");
}

#[test]
fn drop_at_100_m_per_s_never_reaches_the_plane() {
    for speed in [1.0, 10.0, 100.0] {
        drop_never_reaches_contact(speed);
    }
}

/// The stability suite cites this one: 1e4 m/s at dt = 1/60 moves 167 m per
/// step toward a plane 2 m away, and the barrier path still never tunnels.
#[test]
fn drop_at_1e4_m_per_s_never_tunnels() {
    drop_never_reaches_contact(1e4);
}

/// A resting particle settles where the barrier force balances gravity:
/// −b'(d*) = m g. d* by bisection on the law; the simulated rest distance
/// must match it to the acceleration tolerance over the stiffness b''(d*).
#[test]
fn resting_particle_settles_at_the_force_balance() {
    let scene = drop_scene(0.0, 0.01);
    let law = BarrierLaw {
        stiffness: 1e3,
        activation_distance: 0.01,
    };
    let (mut lo, mut hi) = (1e-12, 0.01);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if -law.evaluate(mid).1 > 9.81 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let d_star = 0.5 * (lo + hi);
    let mut b = cpu(&scene);
    for _ in 0..600 {
        b.step().expect("step");
    }
    let s = b.read_state().expect("state");
    let d = min_distance(&scene, &s);
    let stiffness = law.evaluate(d_star).2;
    bound(
        "resting contact: |d − d*|",
        (d - d_star).abs(),
        1e-4 / stiffness + 1e-12,
        "converged to acceleration residual 1e-4 m/s²: force error ≤ m·1e-4, distance error ≤ that / b''(d*); settled after 10 s",
    );
    assert!(
        s.velocities.iter().all(|v| v.abs() < 1e-6),
        "{:?}",
        s.velocities
    );
}
