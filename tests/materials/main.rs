//! StVK and Neo-Hookean k-simplices on the CPU: the laws, closed forms,
//! guards and scenes, one test binary (each module was its own binary
//! before, issue 33; the GPU's are in tests/gpu/).

#[path = "../common/mod.rs"]
mod common;

mod closed_forms;
mod guards;
mod law;
mod scene;
