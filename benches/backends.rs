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
//! throughput                         distance projections per step (elem/s)
//! ```
//! GPU cases are skipped with a printed notice when no adapter exists.

use std::hint::black_box;
use std::time::Duration;

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use hyperpbd::{
    Backend, BackendKind, Kernel, Particle, Plan, Precision, Scene, SceneBuilder, State, scenes,
};

const GPU_F32: BackendKind = BackendKind::Gpu(Precision::F32);

fn load(scene: &Scene, backend: BackendKind) -> Option<Box<dyn Backend>> {
    let plan = Plan::compile(scene).expect("scene compiles");
    let mut b = match hyperpbd::load(plan, &State::from_scene(scene), backend) {
        Ok(b) => b,
        Err(e) => {
            eprintln!("SKIPPED {backend}: {e}");
            return None;
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
        for backend in BackendKind::ALL {
            let Some(mut b) = load(&scene, backend) else {
                continue;
            };
            group.throughput(Throughput::Elements(projections(b.plan())));
            group.bench_function(BenchmarkId::new(backend.name(), n), |bench| {
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
    if let Some(mut b) = load(&scene, GPU_F32) {
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
    for backend in [BackendKind::Cpu, GPU_F32] {
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
            group.bench_function(BenchmarkId::new(backend.name(), name), |bench| {
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
    for backend in [BackendKind::Cpu, GPU_F32] {
        let Some(mut b) = load(&scene, backend) else {
            continue;
        };
        group.bench_function(
            BenchmarkId::new(backend.name(), "one_particle_step"),
            |bench| {
                bench.iter(|| black_box(b.step().expect("step")));
            },
        );
    }
    group.finish();
}

criterion_group!(benches, step, kernels, overhead);
criterion_main!(benches);
