//! Device faults surface as typed errors, never as panics or silent
//! fallbacks: a lost device (`GpuError::DeviceLost`) and a scene whose
//! buffers exceed the device's limits (`GpuError::BufferTooLarge`).
//! (Out-of-memory is mapped from wgpu's `OutOfMemory` error scope around
//! all allocations and from uncaptured errors that say so; lavapipe
//! allocates host memory and does not refuse, so it is not triggered
//! here.)

use crate::common;

use common::gpu::adapter_or_skip;
use hyperpbd::gpu::{GpuBackend, Precision};
use hyperpbd::{Backend, BackendError, GpuError, Particle, Plan, SceneBuilder, State};

/// A chain of 3 particles falling under gravity.
fn small_scene() -> hyperpbd::Scene {
    let mut b = SceneBuilder::new(3)
        .dt(1.0 / 60.0)
        .substeps(4)
        .gravity_along(1, 9.81);
    for i in 0..3 {
        b.particle(Particle::new(vec![i as f64 * 0.1, 1.0, 0.0], 1.0));
    }
    b.build().expect("valid")
}

#[test]
fn a_lost_device_is_a_typed_error_on_every_call() {
    for precision in [Precision::F32, Precision::F64] {
        let Some((adapter, _)) = adapter_or_skip("a_lost_device_is_a_typed_error", precision)
        else {
            continue;
        };
        let scene = small_scene();
        let plan = Plan::compile(&scene).expect("valid");
        let state = State::from_scene(&scene);
        let shared =
            GpuBackend::with_adapter(&adapter, plan.clone(), &state, precision).expect("gpu");
        assert!(
            matches!(shared.destroy_device(), Err(GpuError::Unsupported { .. })),
            "{precision}: the shared device must not be destroyed"
        );
        let mut gpu =
            GpuBackend::with_private_device(&adapter, plan, &state, precision).expect("gpu");
        gpu.step().expect("a step before the loss");
        gpu.destroy_device().expect("a private device");
        let step = gpu.step();
        assert!(
            matches!(step, Err(BackendError::Gpu(GpuError::DeviceLost { .. }))),
            "{precision}: step after the loss: {step:?}"
        );
        let read = gpu.read_state();
        assert!(
            matches!(read, Err(BackendError::Gpu(GpuError::DeviceLost { .. }))),
            "{precision}: read_state after the loss: {read:?}"
        );
        println!(
            "FAULT | device lost | gpu-{precision} | {}",
            step.err().map(|e| e.to_string()).unwrap_or_default()
        );
    }
}

/// One parameter block per kernel call of a step: a one-particle R^8
/// scene in f64 with enough substeps (≈ 350 000 on lavapipe) needs more
/// parameter bytes than the device's storage-binding limit (128 MiB on
/// lavapipe) — valid input the GPU cannot hold. The backend
/// refuses the scene with `BufferTooLarge` naming the buffer, before
/// asking the device for anything that large.
#[test]
fn a_scene_over_the_buffer_limit_is_refused_with_buffer_too_large() {
    let Some((adapter, summary)) = adapter_or_skip("a_scene_over_the_buffer_limit", Precision::F64)
    else {
        return;
    };
    let dim = 8;
    // Predict and Velocity per substep, each block ≥ 32 + (4 + 2N)·8 bytes.
    let block = 32 + (4 + 2 * dim as u64) * 8;
    let limit = summary
        .max_storage_buffer_binding_size
        .min(summary.max_buffer_size);
    let substeps = u32::try_from(limit / (2 * block) + 1).expect("a u32 substep count");
    let params_bytes = 2 * u64::from(substeps) * block;
    assert!(params_bytes > limit);
    let mut b = SceneBuilder::new(dim).dt(1.0).substeps(substeps);
    b.particle(Particle::new(vec![0.0; dim], 1.0));
    let scene = b.build().expect("valid");
    let plan = Plan::compile(&scene).expect("valid");
    let result =
        GpuBackend::with_adapter(&adapter, plan, &State::from_scene(&scene), Precision::F64);
    match result {
        Err(BackendError::Gpu(GpuError::BufferTooLarge {
            buffer,
            requested,
            maximum,
        })) => {
            assert_eq!(buffer, "params");
            assert!(
                requested > maximum && requested >= params_bytes,
                "{requested} {maximum}"
            );
            println!("FAULT | buffer too large | gpu-f64 | params {requested} B > {maximum} B");
        }
        Err(e) => panic!("expected BufferTooLarge, got {e:?}"),
        Ok(_) => panic!("a {params_bytes} B parameter buffer was accepted"),
    }
}
