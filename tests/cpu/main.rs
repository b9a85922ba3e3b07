//! The CPU golden path and its f32 reference, one test binary: closed
//! forms (`analytic`), pinned state hashes (`determinism`), thread counts,
//! contact, bending, broadphase, guards, motion, expressions, batches and
//! the shipped scenes. Each module was its own binary before (issue 33).

#[path = "../common/mod.rs"]
mod common;
#[path = "../common/support.rs"]
mod support;

mod analytic;
mod batch;
mod bending;
mod bending_quadratic;
mod broadphase;
mod broadphase_grid;
mod contact_forces;
mod determinism;
mod drum_energy;
mod expressions;
mod f32_reference;
mod granular;
mod guards;
mod motion;
mod moving_mesh;
mod scenes;
mod simplex_hierarchy;
mod threads;
mod xpbd_mesh;
