//! Guards over the material families on the GPU (issue 15 item 4 on both
//! backends): the 40 m/s Neo-Hookean drop of tests/materials/guards.rs and
//! its StVK twin, gpu-f64 against the CPU golden path — the same rejection
//! (guard, element, value, substep: the error text), the state unchanged
//! byte for byte, and adaptive steps accepted after the same attempts with
//! the same bytes.

use crate::common;

use common::exact::bits;
use common::gpu::load_or_skip;
use hyperpbd::{
    Backend, BackendKind, ConstraintKind, CpuBackend, Guards, Plan, Precision, Scene, State,
};

/// The 40 m/s drop of common::guarded, its simplices one `law` family.
fn material_block(dim: usize, law: ConstraintKind, guards: Guards, adaptive: Option<u32>) -> Scene {
    common::guarded::material_block(dim, 40.0, law, Some(guards), adaptive)
}

/// CPU and gpu-f64 backends of `scene` (`None`: the GPU test is skipped).
fn both(test: &str, scene: &Scene) -> Option<(CpuBackend, Box<dyn Backend>)> {
    let plan = Plan::compile(scene).expect("plan");
    let state = State::from_scene(scene);
    let cpu = CpuBackend::with_threads(plan.clone(), &state, 1).expect("cpu");
    let gpu = load_or_skip(test, BackendKind::Gpu(Precision::F64), plan, &state)
        .expect("the GPU serves guarded material scenes")?;
    Some((cpu, gpu))
}

#[test]
fn a_guarded_drop_is_rejected_on_the_gpu_as_on_the_cpu() {
    let test = "a_guarded_drop_is_rejected_on_the_gpu_as_on_the_cpu";
    let ratio = Guards {
        min_measure_ratio: Some(0.5),
        ..Guards::default()
    };
    for dim in [2, 3] {
        for law in [ConstraintKind::NeoHookean, ConstraintKind::Stvk] {
            for guards in [common::guarded::orientation(), ratio.clone()] {
                let scene = material_block(dim, law, guards, None);
                let Some((mut cpu, mut gpu)) = both(test, &scene) else {
                    return;
                };
                let before = bits(&gpu.read_state().expect("state"));
                let golden = cpu.step().expect_err("the CPU rejects").to_string();
                let got = gpu.step().expect_err("the GPU rejects").to_string();
                println!("{dim}D {law:?}: {got}");
                assert_eq!(got, golden, "{dim}D {law:?}");
                assert!(got.contains("guard"), "{got}");
                assert_eq!(bits(&gpu.read_state().expect("state")), before);
            }
        }
    }
}

#[test]
fn adaptive_material_steps_match_the_golden_path_attempt_for_attempt() {
    let test = "adaptive_material_steps_match_the_golden_path_attempt_for_attempt";
    for (dim, law) in [
        (2, ConstraintKind::NeoHookean),
        (3, ConstraintKind::NeoHookean),
        (2, ConstraintKind::Stvk),
    ] {
        let scene = material_block(dim, law, common::guarded::orientation(), Some(8));
        let Some((mut cpu, mut gpu)) = both(test, &scene) else {
            return;
        };
        for frame in 0..5 {
            let golden = cpu.step().expect("the CPU accepts");
            let got = gpu.step().expect("the GPU accepts");
            let attempts = |r: &hyperpbd::StepReport| -> Vec<u32> {
                r.attempts.iter().map(|a| a.substeps).collect()
            };
            assert_eq!(attempts(&got), attempts(&golden), "{dim}D frame {frame}");
            assert_eq!(
                got.attempts, golden.attempts,
                "{dim}D frame {frame}: the rejections"
            );
            assert_eq!(
                bits(&gpu.read_state().expect("state")),
                bits(&cpu.read_state().expect("state")),
                "{dim}D frame {frame}"
            );
        }
        println!("{dim}D {law:?}: 5 adaptive frames bit for bit");
    }
}
