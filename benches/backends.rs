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
//! frame/{cpu-f64,gpu-P-M}/S          the issue-12 targets, one step each, on the
//!                                    GPU in f32 and f64 under each schedule
//!                                    M = exact, fused, small (dispatches per
//!                                    step printed; small only where it fits):
//!                                    cloth256 = scenes::cloth(256) (ground plane,
//!                                    friction, damping; 10 substeps × 1 iteration),
//!                                    chain20 = scenes::chain2d() at 10 substeps ×
//!                                    2 iterations (20 links, plane, friction, damping)
//! threads/gpu-f32/cloth{N}            the ground cloth at N = 16 … 181 (256 … 32,761
//!                                    particles): run once as is and once with
//!                                    LP_NUM_THREADS=0 in the shell to find
//!                                    lavapipe's thread crossover
//!                                    (gpu/src/software_threads.rs)
//! dispatch/gpu-{f32,f64}/K           one kernel of the 256² ground cloth, 20 calls
//!                                    in one pass and one submit: the per-element
//!                                    cost without a round trip per call
//! frame_cpu/{cpu-f64,gpu-P-fused}/S  frame/'s cloth256 and chain20, timed as
//!                                    the CPU time of the bench process (its
//!                                    threads' time ON a core, lavapipe's
//!                                    queue and worker threads included;
//!                                    /proc/self/task/*/schedstat), not wall
//!                                    time: it ignores the time other jobs on
//!                                    a shared machine hold the cores (the
//!                                    A/B measure on a loaded machine)
//! throughput                         distance projections per step (elem/s)
//! ```
//! The CPU golden step runs on one thread. lavapipe runs with the
//! environment's LP_NUM_THREADS, else its default (printed first).
//! GPU cases are skipped with a printed notice when no adapter exists.
//!
//! `cargo bench` passes `--bench`; `cargo test --all-targets` runs this
//! binary without it (criterion's test mode: each routine once): then a
//! smoke run ([`full`] false) runs every routine on the smallest of its
//! sizes only (N = 64 for step/ and step_1m/, cloth 16² for kernel/,
//! frame/, frame_cpu/ and dispatch/, N = 16 for threads/): the same
//! code on scenes that load in a fraction of the time.

use std::hint::black_box;
use std::time::Duration;

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use hyperpbd::gpu::{GpuBackend, StepMode, XpbdOptions};
use hyperpbd::{
    Backend, BackendKind, Kernel, Particle, Plan, Precision, Scene, SceneBuilder, State, scenes,
};

const GPU_F32: BackendKind = BackendKind::Gpu(Precision::F32);

fn load(scene: &Scene, backend: BackendKind) -> Option<Box<dyn Backend>> {
    // The CPU golden step on one thread: the reference the GPU targets name.
    hyperpbd::set_default_threads(std::num::NonZeroUsize::new(1));
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

/// Whether this is a measuring run (`cargo bench` passes `--bench`), not
/// the smoke run of `cargo test --all-targets`.
fn full() -> bool {
    std::env::args().any(|a| a == "--bench")
}

/// `sizes` in a measuring run, its first (smallest) alone in the smoke run.
fn sizes<T: Copy>(sizes: &[T]) -> &[T] {
    if full() { sizes } else { &sizes[..1] }
}

/// The ground cloth of the kernel, frame and dispatch cases: 256² when
/// measuring, 16² in the smoke run; its name.
fn ground_cloth() -> (String, Scene) {
    let n = if full() { 256 } else { 16 };
    (format!("cloth{n}"), scenes::cloth(n))
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
    for &n in sizes(&[64, 128, 256, 512]) {
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
    let n = if full() { 1024 } else { 64 };
    let scene = scenes::hanging_cloth(n);
    if let Some(mut b) = load(&scene, GPU_F32) {
        group.throughput(Throughput::Elements(projections(b.plan())));
        group.bench_function(BenchmarkId::new("gpu-f32", n), |bench| {
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
    let scene = scenes::hanging_cloth(if full() { 256 } else { 16 });
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
    for (name, scene) in [("chain20".to_string(), chain20()), ground_cloth()] {
        if let Some(mut b) = load(&scene, BackendKind::Cpu) {
            group.bench_function(BenchmarkId::new("cpu-f64", &name), |bench| {
                bench.iter(|| black_box(b.step().expect("step")));
            });
        }
        for precision in [Precision::F32, Precision::F64] {
            for mode in [StepMode::Exact, StepMode::Fused, StepMode::Small] {
                let Some(mut b) = load_mode(&scene, precision, mode) else {
                    continue;
                };
                let id = format!("gpu-{precision}-{}", mode.as_str());
                eprintln!(
                    "frame/{id}/{name}: {} dispatches per step",
                    b.dispatches_per_step()
                );
                group.bench_function(BenchmarkId::new(id, &name), |bench| {
                    bench.iter(|| black_box(b.step().expect("step")));
                });
            }
        }
    }
    group.finish();
}

/// Time the threads of this process have run on a CPU core (Linux:
/// /proc/self/task/*/schedstat, nanoseconds); `None` where it is missing.
fn on_cpu() -> Option<Duration> {
    let mut ns = 0u64;
    for task in std::fs::read_dir("/proc/self/task").ok()? {
        let text = std::fs::read_to_string(task.ok()?.path().join("schedstat")).ok()?;
        ns += text.split_whitespace().next()?.parse::<u64>().ok()?;
    }
    Some(Duration::from_nanos(ns))
}

/// `frame/`'s cloth256 and chain20 (cpu-f64 and the fused GPU steps) in
/// the process's CPU time per step.
fn frames_on_cpu(c: &mut Criterion) {
    if on_cpu().is_none() {
        eprintln!("SKIPPED frame_cpu: no /proc/self/task/*/schedstat");
        return;
    }
    let mut group = c.benchmark_group("frame_cpu");
    group
        .sample_size(10)
        .warm_up_time(Duration::from_millis(300))
        .measurement_time(Duration::from_secs(3));
    let timed = |step: &mut dyn FnMut(), iterations: u64| {
        let start = on_cpu().unwrap_or_default();
        for _ in 0..iterations {
            step();
        }
        on_cpu().unwrap_or_default().saturating_sub(start)
    };
    for (name, scene) in [("chain20".to_string(), chain20()), ground_cloth()] {
        if let Some(mut b) = load(&scene, BackendKind::Cpu) {
            group.bench_function(BenchmarkId::new("cpu-f64", &name), |bench| {
                bench.iter_custom(|n| timed(&mut || drop(black_box(b.step().expect("step"))), n));
            });
        }
        for precision in [Precision::F32, Precision::F64] {
            let Some(mut b) = load_mode(&scene, precision, StepMode::Fused) else {
                continue;
            };
            group.bench_function(
                BenchmarkId::new(format!("gpu-{precision}-fused"), &name),
                |bench| {
                    bench.iter_custom(|n| {
                        timed(&mut || drop(black_box(b.step().expect("step"))), n)
                    });
                },
            );
        }
    }
    group.finish();
}

/// The GPU backend on `scene` with its step formed as `mode` says, three
/// steps in; `None` (with the reason printed) when there is no adapter or
/// the mode does not fit the scene.
fn load_mode(scene: &Scene, precision: Precision, mode: StepMode) -> Option<GpuBackend> {
    let plan = Plan::compile(scene).expect("scene compiles");
    let state = State::from_scene(scene);
    // A mode the adapter refuses at its first steps (llvmpipe's loop
    // budget on the small schedule of a large scene) is skipped, never
    // timed.
    let loaded = hyperpbd::gpu::request_adapter(precision)
        .map_err(|e| e.to_string())
        .and_then(|(adapter, _)| {
            GpuBackend::with_options(&adapter, plan, &state, precision, XpbdOptions::mode(mode))
                .map_err(|e| e.to_string())
        })
        .and_then(|mut b| {
            for _ in 0..3 {
                b.step().map_err(|e| format!("warm-up step: {e}"))?;
            }
            Ok(b)
        });
    match loaded {
        Ok(b) => Some(b),
        Err(e) => {
            eprintln!("SKIPPED gpu-{precision}-{}: {e}", mode.as_str());
            None
        }
    }
}

/// lavapipe's threads for this whole run: the environment's LP_NUM_THREADS
/// (set it in the shell: the bench never writes its own environment), else
/// lavapipe's default.
fn software_threads(_: &mut Criterion) {
    let variable = hyperpbd::gpu::software_threads::VARIABLE;
    match std::env::var(variable) {
        Ok(value) => eprintln!("backends bench: {variable}={value}"),
        Err(_) => eprintln!("backends bench: lavapipe's default threads ({variable} unset)"),
    }
}

fn threads(c: &mut Criterion) {
    let mut group = c.benchmark_group("threads");
    group
        .sample_size(10)
        .warm_up_time(Duration::from_millis(300))
        .measurement_time(Duration::from_secs(2));
    for &n in sizes(&[16, 32, 64, 90, 128, 181]) {
        let scene = scenes::cloth(n);
        let Some(mut b) = load(&scene, GPU_F32) else {
            continue;
        };
        group.bench_function(BenchmarkId::new("gpu-f32", format!("cloth{n}")), |bench| {
            bench.iter(|| black_box(b.step().expect("step")));
        });
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
    let (_, scene) = ground_cloth();
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
    targets = software_threads, step, kernels, overhead, frames, frames_on_cpu, threads, dispatches
);
criterion_main!(benches);
