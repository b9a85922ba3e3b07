//! A failing kernel call names its SMALLEST failing element, whatever
//! order the device's invocations record their failures in — as the CPU
//! names the first failing element of a colour (step.wgsl `record_failure`:
//! for the first failing call, the minimum of every failing index).
//!
//! ```text
//! 130 disjoint distance pairs (one colour), pairs 1 and 64 flying apart
//! at ±1e203 m/s: after predict |x1 − x0|² overflows, so both fail in the
//! first projection
//! small mode   ONE workgroup of 64 invocations strides over the colour:
//!              invocation 0 meets element 64 (its second element) and
//!              records it before invocation 1 records element 1 — the
//!              minimum must still come out as 1
//! ```

use crate::common;

use common::gpu::adapter_or_skip;
use hyperpbd::gpu::StepMode;
use hyperpbd::{
    Backend, BackendError, ConstraintFamily, ConstraintKind, CpuBackend, Particle, Plan, Precision,
    Scene, State, StepError,
};

fn pairs_with_two_overflows() -> Scene {
    let mut scene = Scene::new(2, 1.0 / 60.0, 1, 1);
    let mut elements = Vec::new();
    for k in 0..130 {
        let y = k as f64;
        let v = if k == 1 || k == 64 { 1e203 } else { 0.0 };
        scene
            .particles
            .push(Particle::new(vec![0.0, y], 1.0).with_velocity(vec![-v, 0.0]));
        scene
            .particles
            .push(Particle::new(vec![1.0, y], 1.0).with_velocity(vec![v, 0.0]));
        elements.push(vec![2 * k, 2 * k + 1]);
    }
    scene.constraints.push(ConstraintFamily::new(
        ConstraintKind::Distance,
        0.0,
        elements,
    ));
    scene.validate().expect("valid pairs");
    scene
}

/// The failing element of a step error.
fn element(error: &BackendError) -> usize {
    match error {
        BackendError::Step(StepError::NonFiniteConstraint { element, .. }) => *element,
        other => panic!("expected NonFiniteConstraint, got {other}"),
    }
}

#[test]
fn every_step_mode_names_the_smallest_failing_element() {
    let scene = pairs_with_two_overflows();
    let plan = Plan::compile(&scene).expect("plan");
    assert_eq!(
        plan.families[0].color_count(),
        1,
        "one colour of disjoint pairs"
    );
    let state = State::from_scene(&scene);
    let mut cpu = CpuBackend::new(plan.clone(), &state).expect("cpu");
    let golden = cpu.step().expect_err("the CPU fails");
    println!("cpu: {golden}");
    assert_eq!(element(&golden), 1);
    // f64 only: the golden path fails where f64 overflows (an f32 device
    // would already hold ±inf after predict, a different failure).
    let precision = Precision::F64;
    let test = "every_step_mode_names_the_smallest_failing_element";
    let Some((adapter, _)) = adapter_or_skip(test, precision) else {
        return;
    };
    for mode in [StepMode::Small, StepMode::Exact, StepMode::Fused] {
        let mut gpu =
            common::gpu::in_mode(&adapter, (&plan, &state), precision, mode).expect("gpu");
        let error = gpu.step().expect_err("the GPU fails");
        println!("gpu-{precision} {mode:?}: {error}");
        assert_eq!(
            error.to_string(),
            golden.to_string(),
            "{precision} {mode:?}"
        );
    }
}
