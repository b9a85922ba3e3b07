//! hyperpbd's wgpu backend.
//!
//! For now this crate only finds adapters and creates devices
//! ([`list_adapters`], [`request_adapter`], [`request_device`]); the step
//! kernels come with the GPU-backend issue.
//!
//! Asking for the GPU and not getting it is always a [`GpuError`], never a
//! silent fallback to the CPU.
//!
//! [`GpuError`]: hyperpbd_core::GpuError

#![deny(missing_docs)]

pub mod adapter;
mod backend;
pub mod barrier;
pub mod broadphase;
pub mod collide;
mod contact;
mod context;
mod device_errors;
mod incremental_potential;
mod kernel_set;
pub mod layout;
pub mod origin;
mod params;
mod readback;
mod resident;
pub mod shader;
mod xpbd;

pub use adapter::*;
pub use backend::GpuBackend;
pub use broadphase::{GpuSweep, SweepStats};
pub use collide::{CollideInput, GpuCollide};
pub use incremental_potential::GpuBarrierBackend;
pub use origin::SceneOrigin;
pub use xpbd::schedule::StepMode;
