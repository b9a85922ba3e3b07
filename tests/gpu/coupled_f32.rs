//! The coupled implicit step on the GPU in f32 (issue 16, item 4;
//! docs/implicit.md §12, docs/bounds.md "Coupled implicit step in f32")
//! against the golden path, step by step: before every step the CPU is
//! restarted from the GPU's state, both take the step, and the host
//! recomputes ∇F in f64 at both iterates (`hyperpbd::coupled_gradient`,
//! the golden gradient code) to bound their distance with the per-particle
//! modulus of `hyperpbd_verify::compare_coupled`. Asserted every step: the bound
//! (where the module states one), every gap > 0 against the authored
//! geometry in f64, every value finite.
//! `cargo test --release --test gpu -- coupled_f32:: --nocapture | grep '^BOUND'`.
//! Every GPU test runs on one lavapipe thread
//! (`common::gpu::on_one_lavapipe_thread`): the coupled step waits on the
//! host hundreds of times per step, and lavapipe's worker pool adds
//! 35–63 µs to each small dispatch (20 s of CPU for this binary with the
//! pool, 8.6 s with one thread, measured 2026-11-28 at load ≈ 8).

use crate::common;

use common::bound::print_bound;
use common::coupled_f32::F32Check;
use common::gpu::{adapter_or_skip, on_one_lavapipe_thread, test_name};
use common::implicit_scenes::{
    alternating_chain, balls_in_a_v, glancing, head_on, incline, spring_tetrahedron, stack,
};
use hyperpbd::{Backend, Plan, Scene, State};
use hyperpbd_gpu::{GpuCoupledBackend, Precision};

/// `scene` with one substep per frame (same h): the bound is per
/// minimisation, and the CPU restarts from the GPU's state before each.
fn per_substep(mut scene: Scene) -> Scene {
    scene.dt /= f64::from(scene.substeps);
    scene.substeps = 1;
    scene
}

/// Steps `scene` `steps` times on the GPU in f32 with `F32Check` (the CPU
/// restarted from the GPU's state before every step; the bound asserted
/// where stated, gaps > 0), prints BOUND lines; the worst measured /
/// bound, `None` where no bound is stated.
fn f32_against_cpu(test: &str, scene: Scene, steps: usize) -> Option<f64> {
    let (adapter, summary) = adapter_or_skip(test, Precision::F32)?;
    let scene = per_substep(scene);
    let plan = Plan::compile(&scene).expect("compiles");
    let state = State::from_scene(&scene);
    let mut gpu = GpuCoupledBackend::with_adapter(&adapter, plan.clone(), &state, Precision::F32)
        .unwrap_or_else(|e| panic!("{test}: the GPU takes the coupled step in f32: {e}"));
    let mut check = F32Check::new(&plan, &state);
    let mut statuses = std::collections::BTreeMap::<String, usize>::new();
    for step in 0..steps {
        let start = gpu.read_state().expect("gpu state");
        let report = gpu
            .step()
            .unwrap_or_else(|e| panic!("{test}: gpu-f32 step {step}: {e}"));
        for m in &report.minimisation {
            *statuses.entry(format!("{:?}", m.status)).or_default() += 1;
        }
        check.step(test, &start, &gpu.read_state().expect("gpu"));
    }
    let rule = format!("f32 ({}), statuses {statuses:?}", summary.name);
    let name = format!("gpu-f32 coupled {test} | position |x_gpu − x_cpu| per particle");
    if let Some((step, why)) = &check.unbounded {
        print_bound(
            format!("{name} | {steps}"),
            format_args!("{:.3e}", check.largest),
            format!("none stated (step {step}: {why})"),
            &rule,
        );
        return None;
    }
    let (ratio, step, measured, bound) = check.worst;
    print_bound(
        format!(
            "{name} (worst particle of worst step {step}: measured/bound {ratio:.6}; \
             min μ_i/m_i {:.3}; max |dx| {:.3e}; gradient rounding ≤ {:.1e} of a bound) | {steps}",
            check.modulus_fraction, check.largest, check.rounding_share
        ),
        format_args!("{measured:.3e}"),
        format_args!("{bound:.3e}"),
        &rule,
    );
    let (ratio_v, step_v, measured_v, bound_v) = check.worst_velocity;
    print_bound(
        format!(
            "gpu-f32 coupled {test} | velocity |v_gpu − v_cpu| per particle \
             (worst particle of worst step {step_v}: measured/bound {ratio_v:.6}; \
             bound B_i/h + 3 u32 |v| + 2 eps64 (|x| + |x^t|)/h) | {steps}"
        ),
        format_args!("{measured_v:.3e}"),
        format_args!("{bound_v:.3e}"),
        &rule,
    );
    if check.closest.is_finite() {
        print_bound(
            format!("gpu-f32 coupled {test} | smallest gap (f64, authored geometry) | {steps}"),
            format_args!("{:.3e}", check.closest),
            "> 0",
            &rule,
        );
    }
    Some(ratio)
}

#[test]
fn alternating_chain_in_f32() {
    if !on_one_lavapipe_thread(&test_name(module_path!(), "alternating_chain_in_f32")) {
        return;
    }
    f32_against_cpu("chain 1:1e6", alternating_chain(), 20);
}

#[test]
fn head_on_balls_in_f32() {
    if !on_one_lavapipe_thread(&test_name(module_path!(), "head_on_balls_in_f32")) {
        return;
    }
    f32_against_cpu("head-on", head_on(), 120);
}

#[test]
fn inclines_in_f32() {
    if !on_one_lavapipe_thread(&test_name(module_path!(), "inclines_in_f32")) {
        return;
    }
    for (name, mu) in [("incline stick", 0.5), ("incline slide", 0.2)] {
        f32_against_cpu(name, incline(mu).0, 30);
    }
}

#[test]
fn stack_of_ten_balls_in_f32() {
    if !on_one_lavapipe_thread(&test_name(module_path!(), "stack_of_ten_balls_in_f32")) {
        return;
    }
    f32_against_cpu("stack of 10", stack().0, 30);
}

#[test]
fn glancing_balls_with_pair_friction_in_f32() {
    if !on_one_lavapipe_thread(&test_name(
        module_path!(),
        "glancing_balls_with_pair_friction_in_f32",
    )) {
        return;
    }
    f32_against_cpu("glancing balls, pair friction", glancing(), 120);
}

/// Three balls on distance springs dropped into a V of two segments.
#[test]
fn simplex_mesh_obstacles_in_f32() {
    if !on_one_lavapipe_thread(&test_name(module_path!(), "simplex_mesh_obstacles_in_f32")) {
        return;
    }
    let scene = balls_in_a_v();
    f32_against_cpu("three balls in a V of segments", scene, 80);
}

/// The V of segments with friction μ = 0.4 on the mesh (issue 31 item 4).
#[test]
fn simplex_mesh_friction_in_f32() {
    if !on_one_lavapipe_thread(&test_name(module_path!(), "simplex_mesh_friction_in_f32")) {
        return;
    }
    let mut scene = balls_in_a_v();
    for obstacle in &mut scene.obstacles {
        if let hyperpbd::Obstacle::SimplexMesh { friction, .. } = obstacle {
            *friction = 0.4;
        }
    }
    f32_against_cpu("three balls in a V of segments, mesh μ = 0.4", scene, 80);
}

/// The 3D tetrahedron of distance, tether and measure springs on a
/// frictional plane ("previous" warm start, packed criterion).
#[test]
fn measures_tethers_and_previous_warm_start_in_f32() {
    if !on_one_lavapipe_thread(&test_name(
        module_path!(),
        "measures_tethers_and_previous_warm_start_in_f32",
    )) {
        return;
    }
    let scene = spring_tetrahedron();
    f32_against_cpu("tetrahedron of springs on a frictional plane", scene, 80);
}

/// No GPU needed: `coupled_gradient` at the CPU's own iterate gives the
/// residual the CPU reported for it (the same gradient code over the same
/// terms; pairs beyond d^ add exact zeros), so the host's recomputation at
/// the GPU's iterate measures what the golden path would.
#[test]
fn coupled_gradient_reproduces_the_cpus_final_residual() {
    let (stack, _) = stack();
    for (name, scene) in [
        ("head-on", per_substep(head_on())),
        ("incline", incline(0.5).0),
        ("stack", stack),
        ("chain", alternating_chain()),
    ] {
        let plan = Plan::compile(&scene).expect("compiles");
        let mut cpu = common::cpu_backend(&scene, 1);
        let h2 = plan.h * plan.h;
        for step in 0..12 {
            let start = cpu.read_state().expect("cpu");
            let report = cpu.step().expect("steps");
            let x = cpu.read_state().expect("cpu").positions;
            let from = (&start.positions[..], &start.velocities[..]);
            let g = hyperpbd::coupled_gradient(&plan, from, &plan.force, &x).expect("gradient");
            let residual = (0..plan.particle_count())
                .filter(|&i| plan.inverse_mass[i] > 0.0)
                .map(|i| {
                    let gi = &g[i * plan.dim..(i + 1) * plan.dim];
                    gi.iter().map(|v| v * v).sum::<f64>().sqrt() * plan.inverse_mass[i] / h2
                })
                .fold(0.0, f64::max);
            let reported = report.minimisation[0].final_residual.expect("a residual");
            assert!(
                (residual - reported).abs() <= 1e-12 * reported.max(1e-300),
                "{name}: step {step}: recomputed {residual:e}, reported {reported:e}"
            );
        }
    }
}
