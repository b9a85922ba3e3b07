//! hyperpbd-cpu: the f64 golden backend.
//!
//! Deterministic, and simple enough to audit line by line against
//! DESIGN.md: every kernel of [`hyperpbd_core::Kernel`] is one function in
//! its own file, run in the order the [`hyperpbd_core::Plan`] lists. The
//! serial schedule is the definition; the kernels split independent items
//! (a colour's elements, particles, pairs) over every core and give the
//! same bytes for any thread count (`parallel.rs`, [`default_threads`]).
//! The transcendental (damping factor) goes through `libm`, so results are
//! bit-identical across runs and machines.

mod backend;
mod carried;
pub mod collide;
mod colours;
mod consistent;
mod constraint_force;
mod contact_forces;
mod coupled;
mod dim;
pub mod f32_reference;
mod friction;
mod guard;
pub mod incremental_potential;
mod integrate;
mod material;
mod mesh_contact;
mod motion;
mod parallel;
mod project;
mod residual;
mod schedule;
mod threads;

pub use backend::CpuBackend;
pub use constraint_force::{constraint_force, elastic_force};
pub use coupled::coupled_gradient;
pub use threads::{
    THREADS_VARIABLE, all_cores, default_threads, parse_threads, set_default_threads,
};
