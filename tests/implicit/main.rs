//! The incremental-potential (barrier) path and the coupled implicit step
//! on the CPU: the barrier law and filter, every energy term, whole steps,
//! materials, expressions and refusals, one test binary (each module was its
//! own binary before, issue 33; the GPU's are in tests/gpu/).

#[path = "../common/mod.rs"]
mod common;

mod barrier;
mod expressions;
mod materials;
mod mesh_friction;
mod refusals;
mod step;
mod terms;
