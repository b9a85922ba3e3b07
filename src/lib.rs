//! hyperpbd: N-dimensional particle physics with an f64 CPU golden path and
//! a wgpu backend.
//!
//! ```text
//! Scene ──validate──▶ Plan::compile ──▶ CpuBackend / GPU backend ──▶ State
//! ```
//! This crate re-exports the pieces and ships the built-in scenes used by
//! the CLI (`hyperpbd demo`, `hyperpbd scene NAME`), the tests and the
//! benchmarks.

pub use hyperpbd_core as core;
pub use hyperpbd_core::*;
pub use hyperpbd_cpu::CpuBackend;
pub use hyperpbd_gpu as gpu;

pub mod accuracy;
pub mod compare;
pub mod compare_barrier;
pub mod scenes;

#[doc = include_str!("../README.md")]
#[cfg(doctest)]
pub struct ReadmeDoctests;

/// Compiles `scene` and loads it on the CPU golden backend.
pub fn cpu_backend(scene: &Scene) -> Result<CpuBackend, String> {
    let plan = Plan::compile(scene).map_err(|e| e.to_string())?;
    CpuBackend::new(plan, &State::from_scene(scene)).map_err(|e| e.to_string())
}
