//! Helpers shared by the integration tests. Each test binary compiles this
//! module on its own and uses only part of it.

#![allow(dead_code)]

pub mod bound;
pub mod boxes;
pub mod coupled_f32;
pub mod differential;
pub mod exact;
pub mod expressions;
pub mod force_scenes;
pub mod gpu;
pub mod guarded;
pub mod hinges;
pub mod implicit_scenes;
pub mod materials;
pub mod meshes;
pub mod motion_scenes;

use hyperpbd::{Scene, State};
// support.rs (the CPU-only helpers of tests/cpu/analytic/ and
// tests/cpu/determinism.rs; it uses nalgebra, which report/tests/, also
// including this module, does not link) is a module of tests/cpu/ itself.

/// A deterministic pseudo-random number generator (64-bit LCG), so test
/// scenes are jittered the same way on every run.
pub struct Lcg(pub u64);

impl Lcg {
    /// The next number in [−1, 1).
    pub fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        ((self.0 >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
    }
}

/// How many positions and velocities of `a` and `b` differ in their bits
/// (byte-identity tests: thread counts, rollbacks).
pub fn differing_values(a: &hyperpbd::State, b: &hyperpbd::State) -> usize {
    let values = |s: &hyperpbd::State| -> Vec<u64> {
        s.positions
            .iter()
            .chain(&s.velocities)
            .map(|v| v.to_bits())
            .collect()
    };
    values(a)
        .iter()
        .zip(values(b))
        .filter(|(x, y)| **x != *y)
        .count()
}

/// Prints the `BOUND` line of [`differing_values`] of `a` and `b` (bound 0,
/// rationale `why`) and asserts they are byte-identical.
pub fn check_byte_identical(
    name: impl std::fmt::Display,
    a: &hyperpbd::State,
    b: &hyperpbd::State,
    why: &str,
) {
    let differing = differing_values(a, b);
    bound::print_bound(&name, differing, 0, why);
    assert_eq!(differing, 0, "{name}: {why}");
}

/// `scene` on the CPU with `threads` threads; with more than one, every
/// chunk is one item long (the finest split a thread-count test can ask).
pub fn cpu_backend(scene: &hyperpbd::Scene, threads: usize) -> hyperpbd::CpuBackend {
    let plan = hyperpbd::Plan::compile(scene).expect("scene compiles");
    let state = hyperpbd::State::from_scene(scene);
    let cpu = hyperpbd::CpuBackend::with_threads(plan, &state, threads).expect("loads");
    if threads > 1 {
        cpu.with_max_chunk(1)
    } else {
        cpu
    }
}

/// Kinetic + gravitational potential energy of the dynamic particles:
/// Σ ½ m |v|² − m s (g · x).
pub fn energy(scene: &Scene, state: &State) -> f64 {
    let g = scene
        .gravity
        .clone()
        .unwrap_or_else(|| vec![0.0; scene.dim]);
    let mut e = 0.0;
    for (i, p) in scene.particles.iter().enumerate() {
        let Some(m) = p.mass.filter(|_| !p.fixed) else {
            continue;
        };
        let v2: f64 = state.velocity(i).iter().map(|v| v * v).sum();
        let gx: f64 = state.position(i).iter().zip(&g).map(|(x, g)| x * g).sum();
        e += 0.5 * m * v2 - m * p.gravity_scale * gx;
    }
    e
}
