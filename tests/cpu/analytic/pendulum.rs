//! The small-angle pendulum period.

use super::*;

/// Runs a rigid pendulum (distance constraint, compliance 0, to a fixed
/// pivot at the origin) of length `length` in R^dim, released from rest at
/// angle `theta0` from the downward vertical (−e_`up`) in the plane spanned
/// by e_`up` and the unit horizontal `swing`; returns the measured period
/// from the zero crossings of the horizontal displacement swing·x.
fn pendulum_period(
    dim: usize,
    up: usize,
    swing: &[f64],
    length: f64,
    theta0: f64,
    seconds: f64,
) -> (f64, usize, f64) {
    let dt = 1.0 / 60.0;
    let mut b = SceneBuilder::new(dim)
        .dt(dt)
        .substeps(20)
        .iterations(1)
        .gravity_along(up, G);
    let pivot = b.particle(Particle::fixed(vec![0.0; dim]));
    let mut bob: Vec<f64> = scale(length * theta0.sin(), swing);
    bob[up] -= length * theta0.cos();
    let bob_index = b.particle(Particle::new(bob, 0.3));
    b.family(ConstraintFamily::new(
        ConstraintKind::Distance,
        0.0,
        vec![vec![pivot, bob_index]],
    ));
    let scene = b.build().expect("valid scene");
    let mut sim = backend(&scene);
    let steps = (seconds / dt).round() as usize;
    let (mut t, mut s) = (vec![0.0], vec![dot(swing, &scene.particles[1].position)]);
    let mut worst_residual: f64 = 0.0;
    for k in 1..=steps {
        let report = step(&mut sim);
        worst_residual = worst_residual.max(report.max_violation());
        let st = state(&mut sim);
        t.push(k as f64 * dt);
        s.push(dot(swing, st.position(1)));
    }
    let crossings = zero_crossings(&t, &s);
    assert!(
        crossings.len() >= 5,
        "pendulum crossed zero only {} times in {seconds} s",
        crossings.len()
    );
    // Consecutive crossings are half a period apart.
    let half_periods = (crossings.len() - 1) as f64;
    let period = 2.0 * (crossings[crossings.len() - 1] - crossings[0]) / half_periods;
    (period, crossings.len(), worst_residual)
}

/// Small-angle pendulum period against 2π√(L/g).
///
/// θ0 = 0.05 rad: the finite-amplitude correction is θ0²/16 ≈ 1.6e-4, and
/// XPBD with h = 1/1200 s (ωh ≈ 2.6e-3) adds a phase error of O((ωh)²) per
/// unit time. Crossings are located by linear interpolation between frames:
/// near a zero crossing the swing coordinate is at an inflection point, so
/// the interpolation error is O(ω³ dt³ · amplitude) — negligible. The bound
/// is the 0.5%, which every one of these effects is well below and
/// which a wrong projection (e.g. a compliance or mass-weighting error that
/// lets the rod stretch, or a missing substep scaling of g) exceeds. The
/// 5-D case runs the generic (dimension > 4) distance path with the swing
/// plane mixing three axes.
#[test]
fn small_angle_pendulum_period() {
    let theta0: f64 = 0.05;
    let length = 0.8;
    let expected = 2.0 * std::f64::consts::PI * (length / G).sqrt();
    let cases: Vec<(usize, usize, Vec<f64>)> = vec![
        (2, 1, vec![1.0, 0.0]),
        (3, 1, vec![1.0, 0.0, -0.5]),
        (5, 4, vec![0.6, -0.3, 0.7, 0.0, 0.0]),
    ];
    let mut periods = Vec::new();
    for (dim, up, swing) in cases {
        let swing = unit(&swing);
        let (period, crossings, residual) =
            pendulum_period(dim, up, &swing, length, theta0, 6.0 * expected);
        let rel = (period - expected).abs() / expected;
        let amplitude_corrected = expected * (1.0 + theta0 * theta0 / 16.0);
        let bound = 5e-3;
        eprintln!(
            "pendulum R^{dim}: period {period:.6} s vs 2π√(L/g) = {expected:.6} s over {crossings} crossings: \
             relative error {rel:e} / bound {bound:e}; vs the amplitude-corrected period T0(1 + θ0²/16): {:e}",
            (period - amplitude_corrected) / amplitude_corrected
        );
        assert!(
            rel <= bound,
            "pendulum period off by {rel:e} (> {bound:e}) in R^{dim}"
        );
        // One rigid constraint against a fixed pivot is projected exactly
        // in one iteration; what is left is the rounding of the difference,
        // the length, Δλ and the coordinate updates, each ≲ u·L: bound 16u·L.
        let rod_bound = 16.0 * U * length;
        eprintln!("pendulum R^{dim}: rod residual {residual:e} / bound {rod_bound:e}");
        assert!(
            residual <= rod_bound,
            "rigid pendulum rod residual {residual:e} > {rod_bound:e} in R^{dim}"
        );
        periods.push((dim, period));
    }
    // The motion is planar in every case, so the dimensions differ only in
    // rounding (different arithmetic order, the generic path for R^5); a
    // stable oscillator keeps those differences growing at most linearly:
    // ~steps·substeps·u ≈ 1e-11 relative. Bound 1e-9.
    let (_, reference) = periods[0];
    for &(dim, period) in &periods[1..] {
        let rel = (period - reference).abs() / reference;
        eprintln!("pendulum R^{dim} vs R^2 period: relative difference {rel:e} / bound 1e-9");
        assert!(
            rel <= 1e-9,
            "pendulum period in R^{dim} differs from R^2 by {rel:e}: the dimension-generic paths disagree"
        );
    }
}
