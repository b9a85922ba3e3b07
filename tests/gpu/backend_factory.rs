//! `hyperpbd::load`: one factory for every backend. The CPU runs any plan;
//! a GPU kind gets the GPU backend of the plan's solver (`GpuBackend` for
//! XPBD, `GpuBarrierBackend` for the incremental potential — the former
//! refuses barrier plans, so loading one proves the choice). In f64 on
//! lavapipe the XPBD backend is bit-identical to the golden path and the
//! barrier backend within its `BarrierErrorModel` bound (its ln differs
//! from libm's by rounding).

use crate::common;

use common::gpu::adapter_or_skip;
use hyperpbd::{Backend, BackendKind, Plan, Precision, Scene, SolverPlan, State, scenes};
use hyperpbd_verify::compare::{Divergence, DivergenceModel, Frame};
use hyperpbd_verify::compare_barrier::BarrierErrorModel;
use hyperpbd_verify::compare_frame::FrameErrorModel;

fn compiled(scene: &Scene) -> (Plan, State) {
    (
        Plan::compile(scene).expect("built-in scene compiles"),
        State::from_scene(scene),
    )
}

/// Three steps on `backend`; the final state.
fn run(backend: &mut dyn Backend) -> State {
    for _ in 0..3 {
        backend.step().expect("step");
    }
    backend.read_state().expect("read_state")
}

/// Three frames of `other`, each also run by `golden` from `other`'s
/// previous state; the divergence of each frame against the per-frame model
/// of the plan's solver must be within its bound (XPBD in f64: exactly
/// zero).
fn within_the_model(plan: &Plan, golden: &mut dyn Backend, other: &mut dyn Backend, name: &str) {
    let mut model: Box<dyn DivergenceModel> = match plan.solver {
        SolverPlan::Xpbd => {
            Box::new(FrameErrorModel::new(plan, Precision::F64, &vec![0.0; plan.dim]).unwrap())
        }
        SolverPlan::IncrementalPotential(_) => {
            Box::new(BarrierErrorModel::new(plan, Precision::F64))
        }
    };
    for step in 1..=3 {
        let start = other.read_state().expect("gpu");
        golden.write_state(&start).expect("cpu write_state");
        let (a, b) = (
            golden.step().expect("cpu step"),
            other.step().expect("gpu step"),
        );
        let (x, y) = (
            golden.read_state().expect("cpu"),
            other.read_state().expect("gpu"),
        );
        let bounds = model
            .frame_bounds(Frame {
                start: &start,
                golden: (&a, &x),
                other: (&b, &y),
            })
            .expect("bounds");
        let d = Divergence::new(step, &x, &y, bounds);
        assert!(d.within(), "{name}: {d:?}");
        if plan.incremental_potential().is_none() {
            assert_eq!(x, y, "{name}: XPBD in f64 is bit-identical");
        }
    }
}

#[test]
fn the_cpu_kind_loads_both_solvers() {
    for scene in [scenes::chain2d(), scenes::barrier4d()] {
        let (plan, state) = compiled(&scene);
        let mut cpu = hyperpbd::load(plan, &state, BackendKind::Cpu).expect("cpu loads");
        assert_eq!(cpu.name(), "cpu-f64");
        assert!(run(cpu.as_mut()).positions.iter().all(|x| x.is_finite()));
    }
}

/// The GPU backend the factory picks runs each solver's plan, and in f64
/// it reproduces the CPU golden path bit for bit, whether the factory finds
/// the adapter itself or is handed one.
#[test]
fn a_gpu_kind_gets_the_backend_of_the_plans_solver() {
    let Some((adapter, _)) = adapter_or_skip("backend_factory_gpu", Precision::F64) else {
        return;
    };
    for scene in [scenes::chain2d(), scenes::barrier4d()] {
        let (plan, state) = compiled(&scene);
        let barrier = matches!(plan.solver, SolverPlan::IncrementalPotential(_));
        let cpu = || hyperpbd::load(plan.clone(), &state, BackendKind::Cpu).expect("cpu");
        let mut on_adapter =
            hyperpbd::load_on_adapter(&adapter, plan.clone(), &state, Precision::F64)
                .unwrap_or_else(|e| panic!("barrier plan {barrier}: {e}"));
        assert_eq!(on_adapter.name(), "gpu-f64");
        within_the_model(&plan, cpu().as_mut(), on_adapter.as_mut(), "on the adapter");
        let mut found = hyperpbd::load(plan.clone(), &state, BackendKind::Gpu(Precision::F64))
            .expect("gpu-f64 loads");
        within_the_model(&plan, cpu().as_mut(), found.as_mut(), "adapter found");
        // The XPBD backend refuses the barrier plan the factory routes to
        // GpuBarrierBackend.
        let direct =
            hyperpbd::gpu::GpuBackend::with_adapter(&adapter, plan, &state, Precision::F64);
        assert_eq!(direct.is_err(), barrier, "barrier plan {barrier}");
    }
}

/// `"primal_residual": true` loads through the factory on every backend
/// kind; what the GPU does not run of it yet (adaptive steps) is refused
/// by name, saying which backend runs it.
#[test]
fn the_primal_residual_update_loads_everywhere_or_is_refused_by_name() {
    let primal = |mut scene: hyperpbd::Scene| {
        scene.solver = hyperpbd::Solver::Xpbd(hyperpbd::XpbdSettings {
            primal_residual: true,
        });
        compiled(&scene)
    };
    let test = "the_primal_residual_update_loads_everywhere_or_is_refused_by_name";
    let (plan, state) = primal(scenes::chain2d());
    assert!(hyperpbd::load(plan.clone(), &state, BackendKind::Cpu).is_ok());
    for precision in [Precision::F32, Precision::F64] {
        match common::gpu::load_or_skip(test, BackendKind::Gpu(precision), plan.clone(), &state) {
            Ok(None) => return,
            Ok(Some(backend)) => assert_eq!(backend.name(), format!("gpu-{precision}")),
            Err(err) => panic!("{precision}: {err}"),
        }
    }
    // Adaptive steps: the CPU runs them, the GPU refuses them by name.
    let mut adaptive = scenes::chain2d();
    adaptive.guards = Some(hyperpbd::Guards {
        max_speed: Some(1e3),
        ..hyperpbd::Guards::default()
    });
    adaptive.adaptive = Some(hyperpbd::Adaptive {
        max_subdivisions: 2,
    });
    let (plan, state) = primal(adaptive);
    assert!(hyperpbd::load(plan.clone(), &state, BackendKind::Cpu).is_ok());
    match common::gpu::load_or_skip(test, BackendKind::Gpu(Precision::F64), plan, &state) {
        Ok(None) => {}
        Ok(Some(_)) => panic!("adaptive steps with the primal residual: loaded"),
        Err(err) => assert!(
            matches!(&err, hyperpbd::BackendError::Gpu(hyperpbd::GpuError::Unsupported { what })
                if what.contains("primal_residual") && what.contains("--backend cpu")),
            "{err:?}"
        ),
    }
}
