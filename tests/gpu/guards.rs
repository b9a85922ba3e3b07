//! Guards and adaptive steps on the GPU against the CPU golden path.
//!
//! ```text
//! the soft block of tests/cpu/guards.rs (2D Kuhn block dropped at 40 m/s onto
//! y = 0 in one substep of 1/30 s), and a 3D one; guards on the device
//! (shaders/guard.wgsl), their status read back with the step's own
//! ```
//! f64 on lavapipe: the same rejection as the CPU (guard, element or
//! particle, value bit for bit, substep), the state unchanged, and with
//! `adaptive` the same attempts and the same bytes frame after frame. f32:
//! the same guard rejects the unguarded drop and the state is unchanged
//! (which element rounds first to J ≤ 0 is precision, so it is not
//! compared).

use crate::common;

use common::exact::f64_identical;
use common::gpu::adapter_or_skip;
use common::guarded::{bits, orientation, rejection};
use hyperpbd::gpu::{GpuBackend, Precision};
use hyperpbd::{
    Backend, CpuBackend, GuardKind, GuardRejection, Guards, Kernel, Plan, Scene, State, StepReport,
};

/// The block of `common::guarded` in R^dim, every guard in `guards`.
fn block(dim: usize, speed: f64, guards: Guards, adaptive: Option<u32>) -> Scene {
    common::guarded::dropped_block(dim, speed, Some(guards), adaptive)
}

/// The CPU and the GPU (`precision`) on `scene`; `None` when skipped.
fn pair(test: &str, scene: &Scene, precision: Precision) -> Option<(CpuBackend, GpuBackend, bool)> {
    let (adapter, summary) = adapter_or_skip(test, precision)?;
    let plan = Plan::compile(scene).expect("plan");
    let state = State::from_scene(scene);
    let cpu = CpuBackend::with_threads(plan.clone(), &state, 1).expect("cpu");
    let gpu = GpuBackend::with_adapter(&adapter, plan, &state, precision).expect("gpu");
    let exact = precision == Precision::F64 && f64_identical(&summary);
    Some((cpu, gpu, exact))
}

/// Both backends reject the first step the same way (f64: identically)
/// and keep their state.
fn same_rejection(test: &str, scene: &Scene, precision: Precision) -> Option<GuardRejection> {
    let (mut cpu, mut gpu, exact) = pair(test, scene, precision)?;
    let before = bits(&gpu.read_state().expect("gpu state"));
    let c = rejection(cpu.step());
    let g = rejection(gpu.step());
    println!("{test} {precision}: cpu {c}\n{test} {precision}: gpu {g}");
    assert_eq!(g.guard, c.guard);
    assert_eq!(g.substep, c.substep);
    if exact {
        assert_eq!(g, c, "f64: the GPU rejects exactly where the CPU does");
        assert_eq!(g.value.to_bits(), c.value.to_bits());
    }
    assert_eq!(bits(&gpu.read_state().expect("gpu state")), before);
    // Again: the failed step left nothing behind.
    assert_eq!(rejection(gpu.step()).guard, g.guard);
    assert_eq!(bits(&gpu.read_state().expect("gpu state")), before);
    Some(g)
}

#[test]
fn orientation_rejection_matches_the_cpu() {
    for dim in [2, 3] {
        for precision in [Precision::F64, Precision::F32] {
            let scene = block(dim, 40.0, orientation(), None);
            let Some(r) = same_rejection("orientation", &scene, precision) else {
                return;
            };
            assert_eq!(r.guard, GuardKind::Orientation);
        }
    }
}

#[test]
fn min_measure_ratio_rejection_matches_the_cpu() {
    let guards = Guards {
        min_measure_ratio: Some(0.5),
        ..Guards::default()
    };
    let scene = block(2, 40.0, guards, None);
    if let Some(r) = same_rejection("min_measure_ratio", &scene, Precision::F64) {
        assert_eq!((r.guard, r.limit), (GuardKind::MinMeasureRatio, 0.5));
    }
}

#[test]
fn max_speed_rejection_matches_the_cpu() {
    let guards = Guards {
        max_speed: Some(30.0),
        ..Guards::default()
    };
    for precision in [Precision::F64, Precision::F32] {
        let mut scene = block(2, 40.0, guards.clone(), None);
        scene.obstacles.clear();
        let Some(r) = same_rejection("max_speed", &scene, precision) else {
            return;
        };
        assert_eq!(r.guard, GuardKind::MaxSpeed);
    }
}

#[test]
fn adaptive_steps_match_the_cpu_attempt_for_attempt() {
    for dim in [2, 3] {
        let scene = block(dim, 40.0, orientation(), Some(4));
        let Some((mut cpu, mut gpu, exact)) = pair("adaptive", &scene, Precision::F64) else {
            return;
        };
        for frame in 0..6 {
            let c = cpu.step().expect("cpu frame");
            let g = gpu.step().expect("gpu frame");
            let substeps: Vec<u32> = g.attempts.iter().map(|a| a.substeps).collect();
            println!("adaptive dim {dim} frame {frame}: gpu attempts {substeps:?}");
            if frame == 0 {
                assert!(g.retries() > 0, "the drop must be retried: {substeps:?}");
            }
            if exact {
                assert_eq!(StepReport { threads: 0, ..c }, g);
                assert_eq!(
                    bits(&cpu.read_state().expect("cpu")),
                    bits(&gpu.read_state().expect("gpu"))
                );
            } else {
                assert_eq!(c.attempts.len(), g.attempts.len());
            }
        }
    }
}

#[test]
fn scenes_without_guards_run_no_guard_dispatch() {
    let Some((adapter, _)) = adapter_or_skip("no_guard_dispatch", Precision::F64) else {
        return;
    };
    let mut scene = block(2, 1.0, orientation(), None);
    let plan = Plan::compile(&scene).expect("plan");
    let state = State::from_scene(&scene);
    let guarded = GpuBackend::with_adapter(&adapter, plan, &state, Precision::F64).expect("gpu");
    scene.guards = None;
    let plan = Plan::compile(&scene).expect("plan");
    let plain = GpuBackend::with_adapter(&adapter, plan, &state, Precision::F64).expect("gpu");
    println!(
        "dispatches per step: {} guarded, {} plain",
        guarded.dispatches_per_step(),
        plain.dispatches_per_step()
    );
    assert!(guarded.dispatches_per_step() > plain.dispatches_per_step());
}

#[test]
fn guard_kernels_run_alone_reject_as_the_cpu_does() {
    let guards = Guards {
        max_speed: Some(30.0),
        ..orientation()
    };
    let mut scene = block(2, 40.0, guards, None);
    scene.obstacles.clear();
    let Some((mut cpu, mut gpu, exact)) = pair("guard_alone", &scene, Precision::F64) else {
        return;
    };
    cpu.run_kernel(Kernel::GuardMeasure { family: 0 })
        .expect("the authored block is oriented");
    gpu.run_kernel(Kernel::GuardMeasure { family: 0 })
        .expect("the authored block is oriented");
    let c = rejection(
        cpu.run_kernel(Kernel::GuardSpeed)
            .map(|()| StepReport::default()),
    );
    let g = rejection(
        gpu.run_kernel(Kernel::GuardSpeed)
            .map(|()| StepReport::default()),
    );
    println!("run alone: cpu {c}\nrun alone: gpu {g}");
    assert_eq!(g.guard, GuardKind::MaxSpeed);
    if exact {
        assert_eq!(g, c);
    }
}

#[test]
fn guards_on_the_particle_contact_path_match_the_cpu() {
    let mut scene = block(2, 40.0, orientation(), Some(3));
    for p in &mut scene.particles {
        p.radius = 0.02;
    }
    scene.collisions = Some(hyperpbd::Collisions {
        friction: 0.0,
        margin: 0.01,
    });
    scene.validate().expect("valid");
    let mut single = scene.clone();
    single.adaptive = None;
    if same_rejection("contact_path", &single, Precision::F64).is_none() {
        return;
    }
    let Some((mut cpu, mut gpu, exact)) = pair("contact_path", &scene, Precision::F64) else {
        return;
    };
    for _ in 0..3 {
        let c = cpu.step().expect("cpu");
        let g = gpu.step().expect("gpu");
        println!(
            "contact path attempts {:?}",
            g.attempts.iter().map(|a| a.substeps).collect::<Vec<_>>()
        );
        if exact {
            assert_eq!(StepReport { threads: 0, ..c }, g);
            assert_eq!(
                bits(&cpu.read_state().expect("cpu")),
                bits(&gpu.read_state().expect("gpu"))
            );
        }
    }
}
