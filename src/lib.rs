//! hyperpbd: N-dimensional particle physics with an f64 CPU golden path and
//! a wgpu backend.
//!
//! ```text
//! Scene ──validate──▶ Plan::compile ──▶ load(plan, state, BackendKind) ──▶ step … read_state
//! ```
//! This crate re-exports the pieces, holds the one backend factory
//! ([`load`]: the CPU golden path or the GPU backend of the plan's solver),
//! atomic output files, and the built-in
//! scenes used by the CLI (`hyperpbd demo`, `hyperpbd scene NAME`), the
//! tests and the benchmarks. The CPU/GPU error models and comparers live
//! beside it in `hyperpbd-verify` (used by `hyperpbd compare` and the
//! tests, not re-exported here).

pub use hyperpbd_core as core;
pub use hyperpbd_core::*;
pub use hyperpbd_cpu::f32_reference::{F32Reference, ReferenceError};
pub use hyperpbd_cpu::{
    CpuBackend, THREADS_VARIABLE, constraint_force, coupled_gradient, default_threads,
    elastic_force, set_default_threads,
};
pub use hyperpbd_gpu as gpu;

pub mod atomic_file;
pub mod batch;
mod load;
pub mod scenes;
pub mod sweep;

pub use load::{BackendKind, Loaded, load, load_on_adapter, load_with};

#[doc = include_str!("../README.md")]
#[cfg(doctest)]
pub struct ReadmeDoctests;

/// An error and every source under it, `: `-separated, as the CLI and the
/// Python package print it (a failed rollback names the step failure it
/// could not undo).
pub fn with_sources(error: &dyn std::error::Error) -> String {
    let mut text = error.to_string();
    let mut source = error.source();
    while let Some(e) = source {
        text.push_str(&format!(": {e}"));
        source = e.source();
    }
    text
}

/// Compiles `scene` and loads it on the CPU golden backend.
pub fn cpu_backend(scene: &Scene) -> Result<CpuBackend, String> {
    let plan = Plan::compile(scene).map_err(|e| e.to_string())?;
    CpuBackend::new(plan, &State::from_scene(scene)).map_err(|e| e.to_string())
}
