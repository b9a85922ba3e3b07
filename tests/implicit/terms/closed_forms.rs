//! The closed forms, consistent with the terms.

use super::*;

#[test]
fn closed_forms_are_consistent_with_the_terms() {
    let law = BarrierLaw {
        stiffness: 1e4,
        activation_distance: 0.01,
    };
    let gap = barrier_gap_under_load(&law, 9.81).expect("gap");
    let force = normal_force(&law, gap);
    bound(
        "barrier gap under load: |−b'(d) − W| / W",
        (force - 9.81).abs() / 9.81,
        1e-9,
        "bisection to adjacent floats",
    );
    let heights = stacked_ball_heights(&law, 0.0, 0.5, 1.0, 9.81, 10).expect("stack");
    assert!(
        heights
            .windows(2)
            .all(|w| w[1] - w[0] > 1.0 && w[1] - w[0] < 1.0 + 0.01)
    );
    // Lower contacts carry more, so they sit closer.
    assert!(heights[1] - heights[0] - 1.0 < heights[9] - heights[8] - 1.0);
    let stretch = hanging_chain_stretch(&[1.0, 1e-6, 1.0, 1e-6], 1e-8, 9.81);
    assert_eq!(stretch[3], 1e-8 * 9.81 * 1e-6);
    assert!((stretch[0] - 1e-8 * 9.81 * (2.0 + 2e-6)).abs() < 1e-22);
    let a = incline_acceleration(9.81, 0.5, 0.2);
    let s = backward_euler_slide(a, 1.0 / 60.0, 60);
    bound(
        "backward Euler slide vs ½at², 1 s at 60 Hz",
        s / (0.5 * a) - 1.0,
        1.0 / 60.0 + 1e-12,
        "h/t exactly",
    );
    // The creep speed puts the sticking force at the load: μλ f₁(y) = m g sin θ.
    let (mu, theta, slip_velocity, h) = (0.8, 0.4, 1e-3, 1.0 / 60.0);
    let speed = sticking_creep_speed(slip_velocity, theta, mu).expect("sticks");
    let (_, f1, _) = mollifier(speed * h, slip_velocity * h);
    bound(
        "creep: μ f₁(y) cos θ − sin θ",
        (mu * f1 * libm::cos(theta) - libm::sin(theta)).abs(),
        1e-12,
        "steady sticking slip",
    );
    assert!(sticking_creep_speed(slip_velocity, 0.9, 0.5).is_none());
}
