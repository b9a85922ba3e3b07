//! llvmpipe's loop budget in the barrier / incremental-potential kernels
//! (shaders/barrier.wgsl, shaders/incremental_potential.wgsl): one
//! invocation per particle loops over every plane and over the obstacle
//! simplices within reach of it (the hierarchy walk: core/src/barrier.rs),
//! and llvmpipe ends all loops of a group of 8 invocations after 65 535
//! iterations, silently (the measurement: gpu/src/barrier.rs). Every entry
//! point ends with a probe; a cut is a typed error naming the budget, with
//! x and v exactly as before — never a silently wrong step.
//!
//! A ball of radius 0.005 falling at 1 m/s onto a flat triangle mesh,
//! 3 steps, f64, against the CPU golden path:
//!
//! ```text
//! mesh                  d^     before the hierarchy             now
//! 200 triangles         0.01   bit-identical                    bit-identical (required)
//! 1 800 triangles       0.01   bit-identical                    bit-identical (required)
//! 7 200 triangles       0.01   refused at step 0                bit-identical (required)
//! 66 248 triangles      0.01   refused                          bit-identical (required)
//! 66 248 triangles      30     refused                          refused on llvmpipe (every
//!                                                               simplex within reach: more
//!                                                               than the budget, the probe
//!                                                               must trip)
//! ```
//! "Refused" means `GpuError::Unsupported` naming the 65 535 budget and
//! the obstacle loops, x and v byte-identical to the state before the
//! step; any other adapter must match the CPU at every size. And many
//! balls over a 100 352-triangle mesh step bit for bit as the CPU does.

use crate::common;

use common::exact::bits;
use common::gpu::adapter_or_skip;
use hyperpbd::core::barrier::{ParticleBarrier, evaluate_particle_barrier};
use hyperpbd::gpu::barrier::BarrierKernels;
use hyperpbd::gpu::{GpuBarrierBackend, Precision};
use hyperpbd::{
    Backend, BackendError, Convergence, CpuBackend, GpuError, Kernel, Obstacle, Particle, Plan,
    Scene, State,
};

/// A ball of radius 0.005 at height 0.02 over (at, at), falling at 1 m/s
/// onto a flat `side` × `side` mesh of 2·side² triangles (cells 0.1),
/// barrier activation distance `reach`.
fn ball_over_mesh(side: usize, at: f64, reach: f64) -> Scene {
    let mut vertices = Vec::new();
    for j in 0..=side {
        for i in 0..=side {
            vertices.push(vec![i as f64 * 0.1, 0.0, j as f64 * 0.1]);
        }
    }
    let v = |i: usize, j: usize| j * (side + 1) + i;
    let mut simplices = Vec::new();
    for j in 0..side {
        for i in 0..side {
            simplices.push(vec![v(i, j), v(i + 1, j), v(i, j + 1)]);
            simplices.push(vec![v(i + 1, j), v(i + 1, j + 1), v(i, j + 1)]);
        }
    }
    let mut scene = Scene::new(3, 1.0 / 60.0, 1, 1);
    scene.gravity = Some(vec![0.0, -9.81, 0.0]);
    scene.particles.push(
        Particle::new(vec![at, 0.02, at], 1.0)
            .with_velocity(vec![0.0, -1.0, 0.0])
            .with_radius(0.005),
    );
    scene.obstacles.push(Obstacle::SimplexMesh {
        vertices,
        simplices,
        friction: 0.0,
        motion: Vec::new(),
    });
    scene.solver = hyperpbd::Solver::IncrementalPotential(hyperpbd::IncrementalPotentialSettings {
        barrier_stiffness: 1e3,
        activation_distance: reach,
        convergence: Convergence::PackedGradient { tolerance: 1e-8 },
        max_iterations: 50,
        cg_iterations: None,
        warm_start: None,
        friction_slip_velocity: None,
    });
    scene.validate().expect("valid scene");
    scene
}

/// (side, ball over (at, at), d^): 200, 1 800, 7 200 and 66 248 triangles
/// with a handful within reach, then the last with every one within reach.
const MESHES: [(usize, f64, f64); 5] = [
    (10, 0.95, 0.01),
    (30, 2.95, 0.01),
    (60, 0.05, 0.01),
    (182, 18.15, 0.01),
    (182, 18.15, 30.0),
];
/// Simplices within reach up to this many fit llvmpipe's budget (11
/// iterations per triangle and pass: gpu/src/barrier.rs) and must match the CPU.
const WITHIN_THE_BUDGET: usize = 1_800;
/// More simplices within reach than llvmpipe's whole budget: every
/// evaluation over them is cut there, whatever the per-simplex cost.
const OVER_THE_BUDGET: usize = 65_535;

/// The refusal of a cut loop: typed, naming the budget and the obstacles.
fn is_loop_budget_refusal(e: &BackendError) -> bool {
    matches!(e, BackendError::Gpu(GpuError::Unsupported { what })
        if what.contains("65 535") && what.contains("obstacle loops"))
}

/// Asserts `after` is `before`, byte for byte (x and v).
fn assert_unchanged(label: &str, before: &State, after: &State) {
    assert!(bits(after) == bits(before), "{label}: the state moved");
}

#[test]
fn barrier_steps_over_large_meshes_match_the_cpu_or_are_refused() {
    let Some((adapter, summary)) = adapter_or_skip("gpu_barrier_loop_budget", Precision::F64)
    else {
        return;
    };
    let llvmpipe = summary.name.contains("llvmpipe");
    let mut tripped = 0;
    for (side, at, reach) in MESHES {
        let triangles = 2 * side * side;
        // Every triangle within reach when d^ spans the mesh's diagonal
        // (cells 0.1); a few near the ball otherwise.
        let diagonal = 0.1 * side as f64 * 2f64.sqrt();
        let in_reach = if reach > diagonal { triangles } else { 16 };
        let scene = ball_over_mesh(side, at, reach);
        let plan = Plan::compile(&scene).expect("valid");
        let state = State::from_scene(&scene);
        let mut cpu = CpuBackend::new(plan.clone(), &state).expect("cpu");
        let mut gpu =
            GpuBarrierBackend::with_adapter(&adapter, plan, &state, Precision::F64).expect("gpu");
        for step in 0..3 {
            cpu.step().expect("cpu step");
            let before = gpu.read_state().expect("read");
            let label = format!("{triangles} triangles, d^ {reach}, step {step}");
            match gpu.step() {
                Ok(_) => {
                    assert!(
                        !(llvmpipe && in_reach > OVER_THE_BUDGET),
                        "{label}: llvmpipe cannot finish these loops, yet the step succeeded"
                    );
                    let (c, g) = (
                        cpu.read_state().expect("read"),
                        gpu.read_state().expect("read"),
                    );
                    assert!(bits(&c) == bits(&g), "{label}: x or v differ from the CPU");
                }
                Err(e) => {
                    assert!(
                        is_loop_budget_refusal(&e),
                        "{label}: refused for another reason than the loop budget: {e}"
                    );
                    assert!(
                        llvmpipe,
                        "{label}: refused on {}, which cuts no loops: any other adapter \
                         must match the CPU at every size ({e})",
                        summary.name
                    );
                    assert!(
                        in_reach > WITHIN_THE_BUDGET,
                        "{label}: a mesh the kernels fit in the budget was refused: {e}"
                    );
                    assert_unchanged(&label, &before, &gpu.read_state().expect("read"));
                    common::bound::print_bound(
                        format_args!("loop budget, {label} on {}", summary.name),
                        "typed error, state unchanged",
                        "—",
                        "never a silently cut step",
                    );
                    tripped += usize::from(in_reach > OVER_THE_BUDGET);
                    break;
                }
            }
        }
    }
    if llvmpipe {
        assert_eq!(tripped, 1, "the mesh over the budget refused on llvmpipe");
    }
}

/// The kernel-level entry points (`run_kernel`, `BarrierKernels`) refuse a
/// cut evaluation the same way: no result, the state as before.
#[test]
fn cut_kernel_calls_are_refused_with_the_state_unchanged() {
    let Some((adapter, summary)) = adapter_or_skip("gpu_barrier_loop_budget", Precision::F64)
    else {
        return;
    };
    if !summary.name.contains("llvmpipe") {
        println!(
            "{}: no loop budget to trip on this adapter; the calls must match the CPU",
            summary.name
        );
    }
    let (side, at, reach) = MESHES[4];
    let scene = ball_over_mesh(side, at, reach);
    let plan = Plan::compile(&scene).expect("valid");
    let state = State::from_scene(&scene);

    let mut gpu = GpuBarrierBackend::with_adapter(&adapter, plan.clone(), &state, Precision::F64)
        .expect("gpu");
    let llvmpipe = summary.name.contains("llvmpipe");
    match gpu.run_kernel(Kernel::Minimise) {
        Ok(()) => {
            assert!(
                !llvmpipe,
                "run_kernel over {} triangles succeeded on llvmpipe",
                2 * side * side
            );
            // Elsewhere no loop is cut: the kernel's minimiser is the CPU's.
            let mut cpu = CpuBackend::new(plan.clone(), &state).expect("cpu");
            cpu.run_kernel(Kernel::Minimise).expect("cpu minimise");
            let (c, g) = (
                cpu.read_state().expect("read"),
                gpu.read_state().expect("read"),
            );
            assert!(
                bits(&c) == bits(&g),
                "run_kernel on {}: x or v differ from the CPU",
                summary.name
            );
        }
        Err(e) => {
            assert!(is_loop_budget_refusal(&e), "unexpected error: {e}");
            assert!(
                llvmpipe,
                "run_kernel refused on {}, which cuts no loops: {e}",
                summary.name
            );
            assert_unchanged("run_kernel", &state, &gpu.read_state().expect("read"));
        }
    }

    let ip = plan.incremental_potential().expect("barrier plan");
    let kernels =
        BarrierKernels::new(&adapter, Precision::F64, 3, ip.law, &ip.obstacles).expect("kernels");
    let x = state.positions.clone();
    let radii = plan.radius.clone();
    let evaluated = kernels.evaluate(&x, &radii);
    // A step as long as the mesh: every triangle within the filter's reach.
    let filtered = kernels.filter_fractions(&x, &radii, &[0.0, -30.0, 0.0]);
    if summary.name.contains("llvmpipe") {
        for (what, result) in [
            ("evaluate", evaluated.map(|_| ())),
            ("filter_fractions", filtered.map(|_| ())),
        ] {
            let e = result.expect_err(what);
            assert!(
                is_loop_budget_refusal(&BackendError::Gpu(e.clone())),
                "{what}: unexpected error {e}"
            );
        }
    } else {
        let evaluated = evaluated.expect("evaluate");
        let mut expected = ParticleBarrier::new(3);
        evaluate_particle_barrier(&ip.law, &ip.obstacles, &x, radii[0], &mut expected);
        assert_eq!(
            evaluated.min_distance[0].to_bits(),
            expected.min_distance.to_bits()
        );
    }
}

/// 1 024 balls falling onto a 100 352-triangle mesh (side 224): every
/// evaluation walks a handful of triangles, so lavapipe steps the scene
/// without a refusal, bit for bit as the CPU golden path.
#[test]
fn many_balls_over_a_100k_triangle_mesh_match_the_cpu() {
    let Some((adapter, summary)) = adapter_or_skip("gpu_barrier_loop_budget", Precision::F64)
    else {
        return;
    };
    let side = 224;
    let mut scene = ball_over_mesh(side, 0.05, 0.01);
    for k in 1..1024 {
        let (i, j) = (k % 32, k / 32);
        let at = |c: usize| 0.05 + 0.7 * c as f64;
        scene.particles.push(
            Particle::new(vec![at(i), 0.02 + 0.001 * (k % 7) as f64, at(j)], 1.0)
                .with_velocity(vec![0.0, -1.0, 0.0])
                .with_radius(0.005),
        );
    }
    scene.validate().expect("valid scene");
    let plan = Plan::compile(&scene).expect("valid");
    let state = State::from_scene(&scene);
    let mut cpu = CpuBackend::new(plan.clone(), &state).expect("cpu");
    let mut gpu =
        GpuBarrierBackend::with_adapter(&adapter, plan, &state, Precision::F64).expect("gpu");
    for step in 0..3 {
        cpu.step().expect("cpu step");
        gpu.step()
            .unwrap_or_else(|e| panic!("step {step} on {}: {e}", summary.name));
        let (c, g) = (
            cpu.read_state().expect("read"),
            gpu.read_state().expect("read"),
        );
        assert!(
            bits(&c) == bits(&g),
            "step {step}: x or v differ from the CPU"
        );
    }
    let moved = cpu.read_state().expect("read");
    assert!(
        moved.positions[1] < 0.02 && moved.positions[1] > 0.005,
        "the first ball fell onto the mesh and stopped above it: y = {}",
        moved.positions[1]
    );
}
