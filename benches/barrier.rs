//! Criterion benchmark of the barrier path (quick sample sizes).
//!
//! ```text
//! barrier_eval/{cpu-f64,gpu-f32,gpu-f64}/N   per-particle barrier evaluation (energy,
//!                                            gradient, Hessian block) of N particles
//!                                            against 10 obstacles (2 planes, 8 triangles
//!                                            in R^3); throughput = particle·obstacle
//!                                            evaluations per second. The GPU figure is
//!                                            one dispatch + wait on resident buffers.
//! newton_budget/cpu-f64/K                    one step of 100 particles dropped at 10 m/s
//!                                            with at most K Newton iterations; the
//!                                            accuracy after 30 steps against a converged
//!                                            reference is printed (ACCURACY lines)
//! ```
//! GPU cases are skipped with a printed notice when no adapter exists.
//! Without `--bench` (`cargo test --all-targets`) a smoke run: N = 10 000
//! and budgets 1 and 32 only, the same routines.

use std::hint::black_box;
use std::time::Duration;

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use hyperpbd::barrier::{BarrierLaw, BarrierObstacles, ParticleBarrier, evaluate_particle_barrier};
use hyperpbd::gpu::Precision;
use hyperpbd::gpu::barrier::BarrierKernels;
use hyperpbd::{
    Backend, Convergence, CpuBackend, IncrementalPotentialSettings, Obstacle, Particle, Plan,
    Scene, SceneBuilder, Solver, State,
};

const LAW: BarrierLaw = BarrierLaw {
    stiffness: 1e3,
    activation_distance: 0.1,
};

fn obstacle_scene() -> Scene {
    let mut b = SceneBuilder::new(3);
    b.hyperplane(vec![0.0, 1.0, 0.0], -0.05, 0.0);
    b.hyperplane(vec![1.0, 0.0, 0.0], -0.2, 0.0);
    b.triangle_grid([0, 2], 3, 0.5);
    // Not validated: XPBD would refuse the mesh; only its obstacles are used.
    b.scene().clone()
}

/// `n` particles just above the mesh, most inside the activation band.
fn particles(n: usize) -> (Vec<f64>, Vec<f64>) {
    let mut x = Vec::with_capacity(3 * n);
    let mut state: u64 = 12345;
    let mut next = || {
        state = state
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    for _ in 0..n {
        x.extend([next(), 0.01 + 0.1 * next(), next()]);
    }
    (x, vec![0.0; n])
}

/// Whether this is a measuring run (`cargo bench` passes `--bench`), not
/// the smoke run of `cargo test --all-targets` (criterion's test mode).
fn full() -> bool {
    std::env::args().any(|a| a == "--bench")
}

fn barrier_eval(c: &mut Criterion) {
    let scene = obstacle_scene();
    let obstacles = BarrierObstacles::compile(&scene);
    let per_particle = obstacles.len() as u64;
    let mut group = c.benchmark_group("barrier_eval");
    group
        .sample_size(10)
        .warm_up_time(Duration::from_millis(200))
        .measurement_time(Duration::from_secs(2));
    let sizes: &[usize] = if full() {
        &[10_000, 100_000, 1_000_000]
    } else {
        &[10_000]
    };
    for &n in sizes {
        let (x, r) = particles(n);
        group.throughput(Throughput::Elements(n as u64 * per_particle));
        group.bench_with_input(BenchmarkId::new("cpu-f64", n), &n, |b, _| {
            let mut out = ParticleBarrier::new(3);
            b.iter(|| {
                let mut energy = 0.0;
                for i in 0..n {
                    evaluate_particle_barrier(
                        &LAW,
                        &obstacles,
                        &x[3 * i..3 * i + 3],
                        r[i],
                        &mut out,
                    );
                    energy += out.energy;
                }
                black_box(energy)
            });
        });
        for (name, precision) in [("gpu-f32", Precision::F32), ("gpu-f64", Precision::F64)] {
            let adapter = match hyperpbd::gpu::request_adapter(precision) {
                Ok((a, _)) => a,
                Err(e) => {
                    eprintln!("SKIPPED {name}: {e}");
                    continue;
                }
            };
            let kernels = match BarrierKernels::new(&adapter, precision, 3, LAW, &obstacles) {
                Ok(k) => k,
                Err(e) => {
                    eprintln!("SKIPPED {name}: {e}");
                    continue;
                }
            };
            let batch = match kernels.prepare(&x, &r, &[], n) {
                Ok(b) => b,
                Err(e) => {
                    eprintln!("SKIPPED {name} at {n}: {e}");
                    continue;
                }
            };
            group.bench_with_input(BenchmarkId::new(name, n), &n, |b, _| {
                b.iter(|| kernels.dispatch_evaluate(&batch, 1).expect("dispatch"));
            });
        }
    }
    group.finish();
}

fn drop_scene(max_iterations: u32, tolerance: f64) -> Scene {
    let mut scene = Scene::new(3, 1.0 / 60.0, 1, 1);
    scene.gravity = Some(vec![0.0, -9.81, 0.0]);
    for i in 0..100 {
        let k = f64::from(i);
        scene.particles.push(
            Particle::new(vec![0.01 * k, 0.5 + 0.005 * k, 0.0], 1.0)
                .with_velocity(vec![0.0, -10.0, 0.0])
                .with_radius(0.02),
        );
    }
    scene.obstacles.push(Obstacle::Hyperplane {
        normal: vec![0.0, 1.0, 0.0],
        offset: 0.0,
        friction: 0.0,
        compliance: 0.0,
        motion: Vec::new(),
    });
    scene.solver = Solver::IncrementalPotential(IncrementalPotentialSettings {
        barrier_stiffness: 1e3,
        activation_distance: 0.01,
        convergence: Convergence::MaxAccelerationResidual { tolerance },
        max_iterations,
        cg_iterations: None,
        warm_start: None,
        friction_slip_velocity: None,
    });
    scene
}

fn run(scene: &Scene, steps: usize) -> State {
    let plan = Plan::compile(scene).expect("valid");
    let mut b = CpuBackend::new(plan, &State::from_scene(scene)).expect("loads");
    for _ in 0..steps {
        b.step().expect("step");
    }
    b.read_state().expect("state")
}

fn newton_budget(c: &mut Criterion) {
    let reference = run(&drop_scene(500, 1e-9), 30);
    let mut group = c.benchmark_group("newton_budget");
    group
        .sample_size(10)
        .warm_up_time(Duration::from_millis(200))
        .measurement_time(Duration::from_secs(1));
    let budgets: &[u32] = if full() {
        &[1, 2, 4, 8, 16, 32]
    } else {
        &[1, 32]
    };
    for &budget in budgets {
        // Tolerance 1e-12 m/s²: the budget, not the criterion, stops it.
        let scene = drop_scene(budget, 1e-12);
        let after = run(&scene, 30);
        let error = hyperpbd_verify::compare::max_abs_diff(&after.positions, &reference.positions);
        println!(
            "ACCURACY | newton budget {budget} | max |x − x_ref| after 30 steps {error:.3e} m"
        );
        let plan = Plan::compile(&scene).expect("valid");
        let mut b = CpuBackend::new(plan, &State::from_scene(&scene)).expect("loads");
        group.bench_with_input(BenchmarkId::new("cpu-f64", budget), &budget, |bench, _| {
            bench.iter(|| black_box(b.step().expect("step")));
        });
    }
    group.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default().without_plots();
    targets = barrier_eval, newton_budget
}
criterion_main!(benches);
