//! hyperpbd-cpu: the f64 golden backend.
//!
//! Sequential, deterministic, and simple enough to audit line by line
//! against DESIGN.md: every kernel of [`hyperpbd_core::Kernel`] is one
//! function in its own file, run in the order the [`hyperpbd_core::Plan`] lists. The
//! transcendental (damping factor) goes through `libm`, so results are
//! bit-identical across runs and machines.

mod backend;
pub mod collide;
mod dim;
mod friction;
pub mod incremental_potential;
mod integrate;
mod project;
mod residual;

pub use backend::CpuBackend;
