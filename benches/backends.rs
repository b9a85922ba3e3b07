//! Criterion benchmark: CPU golden path against the GPU backend, measured in
//! one run so the ratios are comparable.
//!
//! ```text
//! step/{cpu-f64,gpu-f32,gpu-f64}/N   hanging N × N cloth (scenes::hanging_cloth),
//!                                    N = 64, 128, 256, 512; one step = 10 substeps
//! step_1m/gpu-f32/1024               1024 × 1024 cloth: 1,048,576 particles
//! kernel/{cpu-f64,gpu-f32}/..        one kernel call on the 256² cloth (the GPU
//!                                    figure includes one submit + wait round trip)
//! overhead/{cpu-f64,gpu-f32}         a one-particle scene: fixed cost of a step
//! frame/{cpu-f64,gpu-f32,gpu-f64}/S  the issue-12 targets, one step each:
//!                                    cloth256 = scenes::cloth(256) (ground plane,
//!                                    friction, damping; 10 substeps × 1 iteration),
//!                                    chain20 = scenes::chain2d() at 10 substeps ×
//!                                    2 iterations (20 links, plane, friction, damping)
//! dispatch/gpu-{f32,f64}/K           one kernel of the 256² ground cloth, 20 calls
//!                                    in one pass and one submit: the per-element
//!                                    cost without a round trip per call
//! throughput                         distance projections per step (elem/s)
//! ```
//! The CPU golden step runs on one thread.
//! GPU cases are skipped with a printed notice when no adapter exists.

use std::hint::black_box;
use std::time::Duration;

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use hyperpbd::gpu::{GpuBackend, Precision};
use hyperpbd::{Backend, CpuBackend, Kernel, Particle, Plan, Scene, SceneBuilder, State, scenes};

fn load(scene: &Scene, backend: &str) -> Option<Box<dyn Backend>> {
    let plan = Plan::compile(scene).expect("scene compiles");
    let state = State::from_scene(scene);
    let mut b: Box<dyn Backend> = match backend {
        "cpu-f64" => Box::new(CpuBackend::new(plan, &state).expect("cpu loads")),
        other => {
            let precision = if other == "gpu-f64" {
                Precision::F64
            } else {
                Precision::F32
            };
            match GpuBackend::new(plan, &state, precision) {
                Ok(g) => Box::new(g),
                Err(e) => {
                    eprintln!("SKIPPED {other}: {e}");
                    return None;
                }
            }
        }
    };
    for _ in 0..3 {
        b.step().expect("warm-up step");
    }
    Some(b)
}

fn projections(plan: &Plan) -> u64 {
    plan.projections_per_step()
}

fn step(c: &mut Criterion) {
    let mut group = c.benchmark_group("step");
    group
        .sample_size(10)
        .warm_up_time(Duration::from_millis(300))
        .measurement_time(Duration::from_secs(3));
    for n in [64, 128, 256, 512] {
        let scene = scenes::hanging_cloth(n);
        for backend in ["cpu-f64", "gpu-f32", "gpu-f64"] {
            let Some(mut b) = load(&scene, backend) else {
                continue;
            };
            group.throughput(Throughput::Elements(projections(b.plan())));
            group.bench_function(BenchmarkId::new(backend, n), |bench| {
                bench.iter(|| black_box(b.step().expect("step")));
            });
        }
    }
    group.finish();

    let mut group = c.benchmark_group("step_1m");
    group
        .sample_size(10)
        .warm_up_time(Duration::from_millis(100))
        .measurement_time(Duration::from_secs(10));
    let scene = scenes::hanging_cloth(1024);
    if let Some(mut b) = load(&scene, "gpu-f32") {
        group.throughput(Throughput::Elements(projections(b.plan())));
        group.bench_function(BenchmarkId::new("gpu-f32", 1024), |bench| {
            bench.iter(|| black_box(b.step().expect("step")));
        });
    }
    group.finish();
}

fn kernels(c: &mut Criterion) {
    let mut group = c.benchmark_group("kernel");
    group
        .sample_size(20)
        .warm_up_time(Duration::from_millis(300))
        .measurement_time(Duration::from_secs(2));
    let scene = scenes::hanging_cloth(256);
    for backend in ["cpu-f64", "gpu-f32"] {
        let Some(mut b) = load(&scene, backend) else {
            continue;
        };
        b.run_kernel(Kernel::Predict).expect("predict");
        let color_len = b.plan().families[0].color(0).len() as u64;
        let cases = [
            ("predict", Kernel::Predict, b.plan().particle_count() as u64),
            (
                "project_distance_color0",
                Kernel::Project {
                    family: 0,
                    color: 0,
                },
                color_len,
            ),
            (
                "velocity",
                Kernel::Velocity,
                b.plan().particle_count() as u64,
            ),
        ];
        for (name, kernel, elements) in cases {
            group.throughput(Throughput::Elements(elements));
            group.bench_function(BenchmarkId::new(backend, name), |bench| {
                bench.iter(|| b.run_kernel(kernel).expect("kernel"));
            });
        }
    }
    group.finish();
}

fn overhead(c: &mut Criterion) {
    let mut group = c.benchmark_group("overhead");
    group
        .sample_size(20)
        .warm_up_time(Duration::from_millis(300))
        .measurement_time(Duration::from_secs(2));
    let mut b = SceneBuilder::new(3).substeps(10).gravity_along(1, 9.81);
    b.particle(Particle::new(vec![0.0, 1.0, 0.0], 1.0));
    let scene = b.build().expect("valid");
    for backend in ["cpu-f64", "gpu-f32"] {
        let Some(mut b) = load(&scene, backend) else {
            continue;
        };
        group.bench_function(BenchmarkId::new(backend, "one_particle_step"), |bench| {
            bench.iter(|| black_box(b.step().expect("step")));
        });
    }
    group.finish();
}

/// The 20-link chain of the issue-12 target: 10 substeps × 2 iterations.
fn chain20() -> Scene {
    let mut scene = scenes::chain2d();
    scene.substeps = 10;
    scene
}

fn frames(c: &mut Criterion) {
    let mut group = c.benchmark_group("frame");
    group
        .sample_size(10)
        .warm_up_time(Duration::from_millis(300))
        .measurement_time(Duration::from_secs(3));
    for (name, scene) in [("chain20", chain20()), ("cloth256", scenes::cloth(256))] {
        for backend in ["cpu-f64", "gpu-f32", "gpu-f64"] {
            let Some(mut b) = load(&scene, backend) else {
                continue;
            };
            group.bench_function(BenchmarkId::new(backend, name), |bench| {
                bench.iter(|| black_box(b.step().expect("step")));
            });
        }
    }
    group.finish();
}

fn dispatches(c: &mut Criterion) {
    const REPEATS: u32 = 20;
    let mut group = c.benchmark_group("dispatch");
    group
        .sample_size(10)
        .warm_up_time(Duration::from_millis(300))
        .measurement_time(Duration::from_secs(3));
    let scene = scenes::cloth(256);
    for precision in [Precision::F32, Precision::F64] {
        let plan = Plan::compile(&scene).expect("scene compiles");
        let state = State::from_scene(&scene);
        let mut b = match GpuBackend::new(plan, &state, precision) {
            Ok(b) => b,
            Err(e) => {
                eprintln!("SKIPPED gpu-{precision}: {e}");
                continue;
            }
        };
        b.step().expect("warm-up step");
        let particles = b.plan().particle_count() as u64;
        let color_len = b.plan().families[0].color(0).len() as u64;
        let cases = [
            ("predict", Kernel::Predict, particles),
            (
                "project_distance_color0",
                Kernel::Project {
                    family: 0,
                    color: 0,
                },
                color_len,
            ),
            ("velocity", Kernel::Velocity, particles),
        ];
        for (name, kernel, elements) in cases {
            group.throughput(Throughput::Elements(elements * u64::from(REPEATS)));
            group.bench_function(
                BenchmarkId::new(format!("gpu-{precision}"), name),
                |bench| {
                    bench.iter(|| b.repeat_kernel(kernel, REPEATS).expect("kernel"));
                },
            );
        }
    }
    group.finish();
}

criterion_group!(
    name = benches;
    // No plots: plotters needs system fonts, which CI images may lack.
    config = Criterion::default().without_plots();
    targets = step, kernels, overhead, frames, dispatches
);
criterion_main!(benches);
