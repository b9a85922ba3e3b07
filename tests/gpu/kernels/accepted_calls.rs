//! What both backends accept: the empty scene steps; `run_kernel` takes
//! the same kernels.

use super::*;

use super::cases::{chain3d, contacts};

/// The empty scene: loads, steps (no kernel calls), reads back empty, on
/// both backends and both precisions.
#[test]
fn empty_scene_steps_and_stays_empty() {
    let scene = build(SceneBuilder::new(3).gravity_along(1, 9.81).damping(1.0));
    let plan = Plan::compile(&scene).unwrap();
    assert!(plan.substep_kernels.is_empty());
    let state = State::from_scene(&scene);
    let mut cpu = CpuBackend::new(plan.clone(), &state).unwrap();
    let cpu_report = cpu.step().expect("CPU steps an empty scene");
    // Equal to the GPU's but for the CPU thread count (who computed, not what).
    let cpu_report = hyperpbd::StepReport {
        threads: 0,
        ..cpu_report
    };
    assert!(cpu_report.kernel_calls.is_empty() && cpu_report.residuals.is_empty());
    assert!(cpu.read_state().unwrap().is_empty());
    for precision in [Precision::F32, Precision::F64] {
        let Some((adapter, _)) = adapter_or_skip("empty_scene_steps_and_stays_empty", precision)
        else {
            return;
        };
        let mut gpu = GpuBackend::with_adapter(&adapter, plan.clone(), &state, precision).unwrap();
        for _ in 0..3 {
            let report = gpu.step().expect("GPU steps an empty scene");
            assert_eq!(report, cpu_report, "{precision}: empty-scene reports");
        }
        let read = gpu.read_state().unwrap();
        assert!(read.is_empty() && read.velocities.is_empty() && read.dim == 3);
        gpu.write_state(&read)
            .expect("write_state of the empty state");
    }
}

/// FORMER MISMATCH (fixed; this test keeps the two agreeing). `run_kernel`
/// accepts different kernel sets on the two backends:
///
/// - CPU: `check_kernel` (core/src/backend.rs) only checks that the kernel
///   names something in the plan, so `Friction { family }` of a contact
///   family with μ = 0, and `Predict` / `Velocity` on a plan with no dynamic
///   particle (empty schedule), run.
/// - GPU: additionally requires the kernel to be in `plan.substep_kernels`
///   (it only has parameter blocks for scheduled calls) and returns
///   `InvalidCall("… is not in this plan's schedule")`.
///
/// Measured before the fix (lavapipe): frictionless plane `Friction { family: 1 }`: CPU
/// `Ok(())`, GPU `Err(InvalidCall)`; all-fixed scene `Predict` and
/// `Velocity`: CPU `Ok(())`, GPU `Err(InvalidCall)`. Kernel-level
/// comparisons need one rule for both (most simply: `check_kernel` also
/// requires `plan.substep_kernels.contains(&kernel)`).
#[test]
fn run_kernel_accepts_the_same_kernels_on_both_backends() {
    let Some((adapter, _)) = adapter_or_skip(
        "run_kernel_accepts_the_same_kernels_on_both_backends",
        Precision::F32,
    ) else {
        return;
    };
    let mut frictionless = contacts(3, 5);
    frictionless.constraints.clear();
    if let hyperpbd::Obstacle::Hyperplane { friction, .. } = &mut frictionless.obstacles[0] {
        *friction = 0.0;
    }
    let mut frozen = chain3d(5);
    for p in &mut frozen.particles {
        p.fixed = true;
        p.velocity = None;
    }
    let cases = [
        (&frictionless, Kernel::Friction { family: 0 }),
        (&frozen, Kernel::Predict),
        (&frozen, Kernel::Velocity),
    ];
    let mut mismatches = Vec::new();
    for (scene, kernel) in cases {
        let plan = Plan::compile(scene).unwrap();
        let state = State::from_scene(scene);
        let mut cpu = CpuBackend::new(plan.clone(), &state).unwrap();
        let mut gpu = GpuBackend::with_adapter(&adapter, plan, &state, Precision::F32).unwrap();
        let (c, g) = (
            cpu.run_kernel(kernel).is_ok(),
            gpu.run_kernel(kernel).is_ok(),
        );
        if c != g {
            mismatches.push(format!("{kernel:?}: cpu ok = {c}, gpu ok = {g}"));
        }
    }
    assert!(mismatches.is_empty(), "{}", mismatches.join("\n"));
}
