//! The GPU step's schedules hold the golden path bit for bit.
//!
//! ```text
//! f64 on the GPU, every schedule (exact: one dispatch per call; fused:
//! per-particle runs in one dispatch; small: the whole step in one
//! workgroup) == the CPU golden path, every coordinate, every step
//! (to_bits equality, not a bound)
//! f32: the schedules agree with each other bit for bit
//! a failure inside a fused or small dispatch names the kernel, substep
//! and element the CPU names, and rolls the state back byte for byte
//! a prefetched state (copied out inside the step's submission) is the
//! state read_state copies out
//! ```
//! lavapipe offers f64, so on CI these are exact-equality tests of every
//! kernel the step runs: prediction, distance / tether / measure / contact
//! projection, velocity, friction, damping, and the residual report.

use crate::common;

use common::gpu::adapter_or_skip;
use hyperpbd::gpu::{GpuBackend, Precision, StepMode, XpbdOptions};
use hyperpbd::{
    Backend, BackendError, ConstraintFamily, ConstraintKind, CpuBackend, Particle, Plan, Scene,
    SceneBuilder, State, StepError, scenes,
};

fn bits(state: &State) -> (Vec<u64>, Vec<u64>) {
    (
        state.positions.iter().map(|x| x.to_bits()).collect(),
        state.velocities.iter().map(|x| x.to_bits()).collect(),
    )
}

fn gpu(adapter: &wgpu::Adapter, scene: &Scene, precision: Precision, mode: StepMode) -> GpuBackend {
    let plan = Plan::compile(scene).expect("valid scene");
    GpuBackend::with_options(
        adapter,
        plan,
        &State::from_scene(scene),
        precision,
        XpbdOptions::mode(mode),
    )
    .unwrap_or_else(|e| panic!("GPU backend ({mode:?}): {e}"))
}

/// A chain of `n` links in R^`dim` hanging from its first particle, a
/// tether from end to end, a frictional plane and a frictionless one,
/// damping, an authored force: every per-particle kernel and both
/// one-sided projections.
fn chain(dim: usize, n: usize) -> Scene {
    let mut b = SceneBuilder::new(dim)
        .dt(1.0 / 60.0)
        .substeps(6)
        .iterations(3)
        .gravity_along(1, 9.81)
        .damping(0.5);
    for k in 0..n {
        let mut x = vec![0.0; dim];
        x[0] = 0.1 * k as f64;
        x[dim - 1] += 0.02 * (k % 3) as f64;
        b.particle(Particle::new(x, 1.0 + 0.1 * (k % 4) as f64));
    }
    b.fix(0);
    b.family(ConstraintFamily::new(
        ConstraintKind::Distance,
        1e-7,
        (1..n).map(|k| vec![k - 1, k]).collect(),
    ));
    b.family(ConstraintFamily::new(
        ConstraintKind::Tether,
        0.0,
        vec![vec![0, n - 1]],
    ));
    let mut up = vec![0.0; dim];
    up[1] = 1.0;
    b.hyperplane(up, -0.25, 0.4);
    let mut side = vec![0.0; dim];
    side[0] = -1.0;
    b.hyperplane(side, -0.2 * n as f64, 0.0);
    let mut scene = b.build().expect("valid");
    scene.particles[n / 2].force = Some({
        let mut f = vec![0.0; dim];
        f[0] = 2.0;
        f
    });
    scene.validate().expect("valid");
    scene
}

/// Steps the CPU and the GPU in `mode` and asserts identical states and
/// reports after every step.
fn identical_to_cpu(
    adapter: &wgpu::Adapter,
    name: &str,
    scene: &Scene,
    mode: StepMode,
    steps: usize,
) {
    let plan = Plan::compile(scene).expect("valid");
    let mut cpu = CpuBackend::new(plan, &State::from_scene(scene)).expect("cpu");
    let mut gpu = gpu(adapter, scene, Precision::F64, mode);
    assert_eq!(gpu.step_mode(), mode);
    for step in 0..steps {
        let rc = cpu.step().expect("cpu step");
        let rg = gpu.step().expect("gpu step");
        let (c, g) = (cpu.read_state().unwrap(), gpu.read_state().unwrap());
        let (cb, gb) = (bits(&c), bits(&g));
        let differ = |a: &[u64], b: &[u64]| a.iter().zip(b).filter(|(x, y)| x != y).count();
        assert!(
            cb == gb,
            "{name} {mode:?} step {step}: f64 GPU state differs from the CPU golden path \
             in {} position and {} velocity coordinates",
            differ(&cb.0, &gb.0),
            differ(&cb.1, &gb.1)
        );
        assert_eq!(
            rc.residuals, rg.residuals,
            "{name} {mode:?} step {step}: residuals"
        );
        assert_eq!(
            rc.active_contacts, rg.active_contacts,
            "{name} {mode:?} step {step}"
        );
        assert_eq!(
            rc.kernel_calls, rg.kernel_calls,
            "{name} {mode:?} step {step}"
        );
    }
    println!(
        "EXACT | {name} | {mode:?} | {steps} steps | {} dispatches per step",
        gpu.dispatches_per_step()
    );
}

#[test]
fn f64_gpu_states_equal_the_cpu_bit_for_bit_in_every_schedule() {
    let Some((adapter, _)) = adapter_or_skip("f64_gpu_states_equal_the_cpu", Precision::F64) else {
        return;
    };
    let all = [StepMode::Exact, StepMode::Fused, StepMode::Small];
    let cases: Vec<(String, Scene, &[StepMode])> = vec![
        ("chain2d".into(), scenes::chain2d(), &all),
        ("cloth 8x8 on a plane".into(), scenes::cloth(8), &all),
        ("incline5d".into(), scenes::incline5d(), &all),
        ("chain 2D(37)".into(), chain(2, 37), &all),
        ("chain 3D(70)".into(), chain(3, 70), &all),
        ("chain 8D(9)".into(), chain(8, 9), &all),
        (
            "hanging cloth 12x12".into(),
            scenes::hanging_cloth(12),
            &all,
        ),
        (
            "tesseract (measures)".into(),
            scenes::tesseract(),
            &[StepMode::Exact, StepMode::Fused],
        ),
    ];
    for (name, scene, modes) in &cases {
        for &mode in *modes {
            identical_to_cpu(&adapter, name, scene, mode, 4);
        }
    }
}

#[test]
fn f32_schedules_agree_bit_for_bit() {
    let Some((adapter, _)) = adapter_or_skip("f32_schedules_agree", Precision::F32) else {
        return;
    };
    for (name, scene) in [
        ("chain 3D(70)", chain(3, 70)),
        ("cloth 8x8", scenes::cloth(8)),
    ] {
        let mut runs: Vec<GpuBackend> = [StepMode::Exact, StepMode::Fused, StepMode::Small]
            .into_iter()
            .map(|mode| gpu(&adapter, &scene, Precision::F32, mode))
            .collect();
        for step in 0..4 {
            let states: Vec<_> = runs
                .iter_mut()
                .map(|g| {
                    g.step().expect("step");
                    bits(&g.read_state().unwrap())
                })
                .collect();
            assert!(
                states.windows(2).all(|w| w[0] == w[1]),
                "{name} step {step}: f32 schedules differ"
            );
        }
    }
}

#[test]
fn a_failure_in_a_shared_dispatch_is_named_like_the_cpu_and_rolled_back() {
    let Some((adapter, _)) = adapter_or_skip("a_failure_in_a_shared_dispatch", Precision::F64)
    else {
        return;
    };
    let scene = chain(3, 70);
    for mode in [StepMode::Fused, StepMode::Small] {
        let mut cpu = CpuBackend::new(Plan::compile(&scene).unwrap(), &State::from_scene(&scene))
            .expect("cpu");
        let mut g = gpu(&adapter, &scene, Precision::F64, mode);
        // Non-finite forces on two particles: predict fails, the lower wins.
        let plan = g.plan().clone();
        let mut forces = plan.force.clone();
        for p in [50, 20] {
            forces[p * 3 + 1] = f64::NAN;
        }
        cpu.set_forces(&forces).unwrap();
        g.set_forces(&forces).unwrap();
        let before = bits(&g.read_state().unwrap());
        let (ec, eg) = (cpu.step().unwrap_err(), g.step().unwrap_err());
        assert_eq!(ec, eg, "{mode:?}: predict failure");
        assert!(matches!(
            eg,
            BackendError::Step(StepError::NonFiniteParticle { particle: 20, .. })
        ));
        assert_eq!(bits(&g.read_state().unwrap()), before, "{mode:?}: rollback");
        // A position far enough to overflow a link: projection fails.
        cpu.set_forces(&plan.force).unwrap();
        g.set_forces(&plan.force).unwrap();
        let mut state = g.read_state().unwrap();
        state.positions[40 * 3] = 1e300;
        cpu.write_state(&state).unwrap();
        g.write_state(&state).unwrap();
        let (ec, eg) = (cpu.step().unwrap_err(), g.step().unwrap_err());
        assert_eq!(ec, eg, "{mode:?}: projection failure");
        assert_eq!(
            bits(&g.read_state().unwrap()),
            bits(&state),
            "{mode:?}: rollback"
        );
        println!("FAULT | {mode:?} | {eg}");
    }
}

#[test]
fn a_prefetched_state_is_the_state() {
    let Some((adapter, _)) = adapter_or_skip("a_prefetched_state_is_the_state", Precision::F32)
    else {
        return;
    };
    let scene = scenes::cloth(8);
    let mut a = gpu(&adapter, &scene, Precision::F32, StepMode::Fused);
    let mut b = gpu(&adapter, &scene, Precision::F32, StepMode::Fused);
    for step in 0..6 {
        // Prefetch on some steps only, and once without reading it.
        if step % 2 == 0 {
            a.prefetch_state();
        }
        a.step().unwrap();
        b.step().unwrap();
        if step != 4 {
            assert_eq!(
                bits(&a.read_state().unwrap()),
                bits(&b.read_state().unwrap()),
                "step {step}"
            );
        }
    }
    // A write after a prefetched step replaces the snapshot.
    a.prefetch_state();
    a.step().unwrap();
    let mut state = a.read_state().unwrap();
    state.positions[0] += 0.5;
    a.write_state(&state).unwrap();
    assert_eq!(bits(&a.read_state().unwrap()), bits(&state));
}

#[test]
fn the_small_mode_is_refused_where_it_does_not_apply() {
    let Some((adapter, _)) = adapter_or_skip("the_small_mode_is_refused", Precision::F32) else {
        return;
    };
    let scene = scenes::tesseract();
    let plan = Plan::compile(&scene).unwrap();
    let result = GpuBackend::with_options(
        &adapter,
        plan,
        &State::from_scene(&scene),
        Precision::F32,
        XpbdOptions::mode(StepMode::Small),
    );
    assert!(matches!(result, Err(BackendError::InvalidCall(_))));
}
