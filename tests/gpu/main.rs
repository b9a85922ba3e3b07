//! The GPU backends and their kernels, one test binary: each module was
//! its own binary before (issue 33: one link of wgpu instead of ~40). A
//! module runs as it did alone; tests that need lavapipe on one thread run
//! themselves again in a child process (`common::gpu::on_one_lavapipe_thread`,
//! by full name, so `--exact` finds them here). Filter by module:
//! `cargo test --release --test gpu -- kernels::`.

#[path = "../common/mod.rs"]
mod common;

mod adapter;
mod backend_factory;
mod barrier;
mod barrier_loop_budget;
mod batch;
mod batch_contact;
mod batch_guards;
mod batch_implicit;
mod broadphase;
mod collide;
mod contact_forces;
mod contact_step;
mod coupled;
mod coupled_f32;
mod coverage;
mod determinism;
mod differential;
mod drum_scenes;
mod example_wgpu_render;
mod export;
mod expr_wgsl;
mod expressions;
mod failure_index;
mod faults;
mod granular;
mod guards;
mod host_waits;
mod kernels;
mod llvmpipe_loop_budget;
mod loop_budget;
mod material_guards;
mod material_ln;
mod materials;
mod materials_closed_forms;
mod motion;
mod pivot_ties;
mod plan_dispatches;
mod primal;
mod schedules;
mod shader_codes;
mod shader_path;
mod shaders;
mod swept_boxes;
mod xpbd_mesh;
