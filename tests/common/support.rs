//! Helpers for the analytic and determinism tests (tests/cpu/): the CPU
//! golden backend, one step, dot products and the unit roundoff.

#![allow(dead_code)]

use hyperpbd::{Backend, CpuBackend, Scene, State, StepReport};

/// Unit roundoff of f64: u = 2^-53 (half the machine epsilon). A correctly
/// rounded operation returns x(1 + δ) with |δ| ≤ u.
pub const U: f64 = f64::EPSILON / 2.0;

/// The CPU golden backend for `scene` (panics with the library's message if
/// the scene does not compile: a test scene that fails to compile is a
/// broken test).
pub fn backend(scene: &Scene) -> CpuBackend {
    hyperpbd::cpu_backend(scene).unwrap_or_else(|e| panic!("scene does not compile: {e}"))
}

/// One step; panics with the step error.
pub fn step(b: &mut CpuBackend) -> StepReport {
    b.step().unwrap_or_else(|e| panic!("step failed: {e}"))
}

/// The resident state.
pub fn state(b: &mut CpuBackend) -> State {
    b.read_state()
        .unwrap_or_else(|e| panic!("read_state failed: {e}"))
}

/// a·b.
pub fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// |a|.
pub fn norm(a: &[f64]) -> f64 {
    dot(a, a).sqrt()
}

/// a − b.
pub fn sub(a: &[f64], b: &[f64]) -> Vec<f64> {
    a.iter().zip(b).map(|(x, y)| x - y).collect()
}

/// s·a.
pub fn scale(s: f64, a: &[f64]) -> Vec<f64> {
    a.iter().map(|x| s * x).collect()
}

/// a / |a|.
pub fn unit(a: &[f64]) -> Vec<f64> {
    scale(1.0 / norm(a), a)
}

/// max_a |x_a|.
pub fn max_abs(a: &[f64]) -> f64 {
    a.iter().fold(0.0, |m, x| m.max(x.abs()))
}

/// True when every position and velocity is finite.
pub fn all_finite(s: &State) -> bool {
    s.positions
        .iter()
        .chain(&s.velocities)
        .all(|x| x.is_finite())
}

/// Least-squares fit of s(t) ≈ c0 + c1 t + ½ a t²; returns (c0, c1, a).
/// Times are centred before fitting so the normal equations stay well
/// conditioned.
pub fn fit_quadratic(t: &[f64], s: &[f64]) -> (f64, f64, f64) {
    assert_eq!(t.len(), s.len());
    assert!(t.len() >= 3, "a quadratic fit needs at least 3 samples");
    let n = t.len() as f64;
    let tm = t.iter().sum::<f64>() / n;
    // Basis 1, τ, τ² with τ = t − tm.
    let mut a = nalgebra::Matrix3::<f64>::zeros();
    let mut b = nalgebra::Vector3::<f64>::zeros();
    for (&ti, &si) in t.iter().zip(s) {
        let tau = ti - tm;
        let phi = nalgebra::Vector3::new(1.0, tau, tau * tau);
        a += phi * phi.transpose();
        b += phi * si;
    }
    let c = a
        .lu()
        .solve(&b)
        .unwrap_or_else(|| panic!("singular quadratic fit"));
    // s = c0' + c1' τ + c2' τ²,  τ = t − tm.
    let accel = 2.0 * c[2];
    let c1 = c[1] - 2.0 * c[2] * tm;
    let c0 = c[0] - c[1] * tm + c[2] * tm * tm;
    (c0, c1, accel)
}

/// Times at which `s` crosses zero (either direction), by linear
/// interpolation between consecutive samples.
pub fn zero_crossings(t: &[f64], s: &[f64]) -> Vec<f64> {
    let mut out = Vec::new();
    for k in 1..s.len() {
        let (a, b) = (s[k - 1], s[k]);
        if (a < 0.0 && b >= 0.0) || (a > 0.0 && b <= 0.0) {
            let f = a / (a - b);
            out.push(t[k - 1] + f * (t[k] - t[k - 1]));
        }
    }
    out
}
