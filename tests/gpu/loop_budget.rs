//! llvmpipe's loop budget in the XPBD step kernels: the small step loops
//! over its calls, so a step with very many substeps runs more loop
//! iterations in one invocation than llvmpipe allows (65 535, all loops
//! together, then silently cut). The kernels end with a probe
//! (shaders/step.wgsl `check_loops`); a cut is a typed error with x and v
//! exactly as before — never a silently short step (measured before the
//! probe: 20 000 substeps gave a step 1e-3 m off the CPU's, with no
//! error). A fused `particles` dispatch runs at most 8 calls, unrolled
//! (gpu/src/xpbd/schedule.rs), so the fused step stays within the budget
//! and must match the CPU bit for bit at any substep count.
//!
//! ```text
//! 100 substeps      f64 fused and small: bit-identical to the CPU (bound 0)
//! 20 000 substeps   llvmpipe, small: GpuError::Unsupported naming the
//!                   budget, state unchanged; fused, or any other adapter:
//!                   bit-identical to the CPU
//! ```

use crate::common;

use common::gpu::adapter_or_skip;
use hyperpbd::{
    Backend, BackendError, CpuBackend, GpuError, Particle, Plan, Scene, SceneBuilder, State,
};
use hyperpbd_gpu::{Precision, StepMode};

fn bits(values: &[f64]) -> Vec<u64> {
    values.iter().map(|v| v.to_bits()).collect()
}

/// Four balls falling onto a plane: every call per-particle, so the whole
/// step is one fused run of 7 calls per substep.
fn falling_balls(substeps: u32) -> Scene {
    let mut b = SceneBuilder::new(2)
        .dt(1.0 / 60.0)
        .substeps(substeps)
        .iterations(4)
        .gravity_along(1, 9.81);
    for k in 0..4 {
        b.particle(Particle::new(vec![0.3 * k as f64, 0.5], 1.0).with_radius(0.05));
    }
    b.hyperplane(vec![0.0, 1.0], 0.0, 0.4);
    b.build().expect("valid scene")
}

#[test]
fn a_step_longer_than_the_loop_budget_is_refused_never_cut() {
    let Some((adapter, summary)) = adapter_or_skip("gpu_loop_budget", Precision::F64) else {
        return;
    };
    let llvmpipe = summary.name.contains("llvmpipe");
    let mut refused = 0;
    for substeps in [100, 20_000] {
        let scene = falling_balls(substeps);
        let plan = Plan::compile(&scene).expect("valid");
        let state = State::from_scene(&scene);
        let mut cpu = CpuBackend::new(plan.clone(), &state).expect("cpu");
        cpu.step().expect("cpu step");
        let expected = cpu.read_state().expect("read");
        for mode in [StepMode::Fused, StepMode::Small] {
            let label = format!("{substeps} substeps, {}", mode.as_str());
            let mut gpu =
                common::gpu::in_mode(&adapter, (&plan, &state), Precision::F64, mode).expect("gpu");
            match gpu.step() {
                Ok(_) => {
                    assert!(
                        !(llvmpipe && substeps > 10_000 && mode == StepMode::Small),
                        "{label}: llvmpipe cannot run these loops to the end, yet the step succeeded"
                    );
                    let s = gpu.read_state().expect("read");
                    assert!(
                        bits(&s.positions) == bits(&expected.positions),
                        "{label}: positions differ from the CPU"
                    );
                    assert!(
                        bits(&s.velocities) == bits(&expected.velocities),
                        "{label}: velocities differ from the CPU"
                    );
                }
                Err(e) => {
                    assert!(
                        matches!(&e, BackendError::Gpu(GpuError::Unsupported { what })
                            if what.contains("65 535")),
                        "{label}: unexpected error {e}"
                    );
                    assert!(
                        substeps > 10_000 && mode == StepMode::Small,
                        "{label}: a short step or a fused one was refused: {e}"
                    );
                    let s = gpu.read_state().expect("read");
                    assert!(
                        bits(&s.positions) == bits(&state.positions),
                        "{label}: x moved"
                    );
                    assert!(
                        bits(&s.velocities) == bits(&state.velocities),
                        "{label}: v moved"
                    );
                    refused += 1;
                    common::bound::print_bound(
                        format_args!("loop budget, {label} on {}", summary.name),
                        "typed error, state unchanged",
                        "—",
                        "never a silently cut step",
                    );
                }
            }
        }
    }
    if llvmpipe {
        assert_eq!(refused, 1, "the long small step refused on llvmpipe");
    }
}
