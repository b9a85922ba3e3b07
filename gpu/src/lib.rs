//! hyperpbd's wgpu backend: [`GpuBackend`] (the XPBD step) and
//! [`GpuBarrierBackend`] (the incremental-potential step), the kernel-level
//! entry points ([`GpuSweep`], [`GpuCollide`], [`barrier`]), and adapter
//! discovery ([`list_adapters`], [`request_adapter`], [`request_device`]).
//!
//! Asking for the GPU and not getting it is always a [`GpuError`], never a
//! silent fallback to the CPU.
//!
//! [`GpuError`]: hyperpbd_core::GpuError

#![deny(missing_docs)]

pub mod adapter;
mod backend;
pub mod barrier;
mod batch;
pub mod broadphase;
pub mod codes;
pub mod collide;
mod contact;
mod context;
mod coupled;
mod device_errors;
mod device_pool;
pub mod export;
mod incremental_potential;
mod ip_decision;
mod kernel_cache;
mod kernel_set;
pub mod layout;
mod lockstep;
mod loop_budget;
mod minimising;
pub mod no_contraction;
pub mod origin;
mod params;
mod readback;
mod resident;
mod resident_backend;
pub mod shader;
pub mod software_threads;
mod specialize;
pub mod spirv;
mod xpbd;

pub use adapter::*;
pub use backend::{GpuBackend, XpbdOptions, XpbdStep};
pub use batch::{GpuBatch, WorldError};
pub use broadphase::{GpuSweep, SweepStats};
pub use collide::{CollideInput, GpuCollide};
pub use coupled::{CoupledStep, GpuCoupledBackend};
pub use export::{EXPORT_BYTES_PER_PARTICLE, PositionExport};
pub use incremental_potential::{BarrierStep, GpuBarrierBackend};
pub use minimising::{Minimiser, Minimising};
pub use origin::SceneOrigin;
pub use params::{push_reals, read_reals};
pub use resident::PositionLayout;
pub use resident_backend::{Load, Resident, ResidentBackend, ResidentStep};
pub use spirv::{SHADER_PATH_VARIABLE, ShaderPath};
pub use xpbd::schedule::{StepMode, dispatches_per_step};
