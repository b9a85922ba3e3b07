//! Criterion benchmark of granular steps: the one-thread CPU golden step
//! against the GPU backend (contact on the device), in one run.
//!
//! ```text
//! granular/{cpu-f64,gpu-f32}/pit16k        scenes::pit3d(26, 24): 16,224 balls,
//!                                          8 substeps × 2 iterations
//! granular/{cpu-f64,gpu-f32}/column3d      the shipped column3d: 4,320 balls
//! granular_100k/{cpu-f64,gpu-f32}/column3d_100k   102,400 balls
//! ```
//! With `HYPERPBD_RATIO=1` the benchmark instead steps the CPU and the GPU
//! alternately from the same start (so both see the same phase of the
//! flow), takes the median of each and prints the per-frame table with the
//! ratio CPU time / GPU time (≥ 1: the GPU is faster) and the host's waits
//! for the device per GPU frame (`GpuBackend::host_waits`). `HYPERPBD_FRAMES`
//! sets the frames timed per scene (default 12; 3 for the 100k column),
//! `HYPERPBD_SCENES=pit16k,column3d` the scenes (default: all).
//!
//! `cargo bench` passes `--bench`; `cargo test --all-targets` runs this
//! binary without it (criterion's test mode: each routine once): then only
//! the smallest scene, column3d, runs.
//!
//! The CPU runs on one thread (`RAYON_NUM_THREADS=1` is set before any
//! work), the reference of issue 12. GPU cases are skipped with a printed
//! notice when no adapter exists.

use std::hint::black_box;
use std::time::{Duration, Instant};

use criterion::measurement::WallTime;
use criterion::{BenchmarkGroup, BenchmarkId, Criterion, criterion_group};
use hyperpbd::gpu::{GpuBackend, Precision};
use hyperpbd::{Backend, CpuBackend, Plan, Scene, State, scenes};

fn cases() -> Vec<(&'static str, Scene, usize)> {
    vec![
        ("pit16k", scenes::pit3d(26, 24), 12),
        (
            "column3d",
            scenes::by_name("column3d").expect("shipped scene"),
            12,
        ),
        (
            "column3d_100k",
            scenes::by_name("column3d_100k").expect("built-in scene"),
            3,
        ),
    ]
}

fn cpu(scene: &Scene) -> CpuBackend {
    let plan = Plan::compile(scene).expect("scene compiles");
    CpuBackend::new(plan, &State::from_scene(scene)).expect("cpu loads")
}

fn gpu(scene: &Scene) -> Option<GpuBackend> {
    let plan = Plan::compile(scene).expect("scene compiles");
    match GpuBackend::new(plan, &State::from_scene(scene), Precision::F32) {
        Ok(g) => Some(g),
        Err(e) => {
            eprintln!("SKIPPED gpu-f32: {e}");
            None
        }
    }
}

fn median(mut t: Vec<f64>) -> f64 {
    t.sort_by(f64::total_cmp);
    t[t.len() / 2]
}

/// Steps both backends alternately `frames` times; prints the medians.
fn ratio_table() {
    let frames: Option<usize> = std::env::var("HYPERPBD_FRAMES")
        .ok()
        .and_then(|f| f.parse().ok());
    let only = std::env::var("HYPERPBD_SCENES").ok();
    println!(
        "| scene | balls | substeps | cpu-f64 ms/frame | gpu-f32 ms/frame | cpu / gpu | gpu host waits/frame |"
    );
    println!("|---|---|---|---|---|---|---|");
    for (name, scene, default_frames) in cases() {
        if only
            .as_ref()
            .is_some_and(|o| !o.split(',').any(|n| n == name))
        {
            continue;
        }
        let mut c = cpu(&scene);
        let Some(mut g) = gpu(&scene) else {
            return;
        };
        let (mut tc, mut tg) = (Vec::new(), Vec::new());
        let frames = frames.unwrap_or(default_frames);
        let waits = g.host_waits();
        for _ in 0..frames {
            let t = Instant::now();
            black_box(c.step().expect("cpu step"));
            tc.push(t.elapsed().as_secs_f64() * 1e3);
            let t = Instant::now();
            black_box(g.step().expect("gpu step"));
            tg.push(t.elapsed().as_secs_f64() * 1e3);
        }
        let (mc, mg) = (median(tc), median(tg));
        let waits = (g.host_waits() - waits) as f64 / frames.max(1) as f64;
        println!(
            "| {name} | {} | {} | {mc:.2} | {mg:.2} | {:.3} | {waits} |",
            scene.particles.len(),
            scene.substeps,
            mc / mg
        );
    }
}

/// One step of `scene` on the CPU golden path and, when an adapter exists,
/// on gpu-f32, as two benchmarks of `group`.
fn bench_both(group: &mut BenchmarkGroup<'_, WallTime>, name: &str, scene: &Scene) {
    let mut b = cpu(scene);
    group.bench_function(BenchmarkId::new("cpu-f64", name), |bench| {
        bench.iter(|| black_box(b.step().expect("step")));
    });
    if let Some(mut g) = gpu(scene) {
        group.bench_function(BenchmarkId::new("gpu-f32", name), |bench| {
            bench.iter(|| black_box(g.step().expect("step")));
        });
    }
}

fn granular(c: &mut Criterion) {
    let mut group = c.benchmark_group("granular");
    group
        .sample_size(10)
        .warm_up_time(Duration::from_millis(200))
        .measurement_time(Duration::from_secs(4));
    // `cargo bench` passes --bench; the smoke run of `cargo test
    // --all-targets` steps the smallest scene only.
    let measuring = std::env::args().any(|a| a == "--bench");
    let mut large = Vec::new();
    for (name, scene, frames) in cases() {
        if !measuring && name != "column3d" {
            continue;
        }
        if frames < 12 {
            large.push((name, scene));
            continue;
        }
        bench_both(&mut group, name, &scene);
    }
    group.finish();
    let mut group = c.benchmark_group("granular_100k");
    group
        .sample_size(10)
        .warm_up_time(Duration::from_millis(1))
        .measurement_time(Duration::from_secs(20));
    for (name, scene) in large {
        bench_both(&mut group, name, &scene);
    }
    group.finish();
}

criterion_group!(benches, granular);

fn main() {
    // SAFETY: set before any thread exists (criterion and rayon start later).
    unsafe { std::env::set_var("RAYON_NUM_THREADS", "1") };
    if std::env::var_os("HYPERPBD_RATIO").is_some() {
        ratio_table();
        return;
    }
    benches();
    Criterion::default().configure_from_args().final_summary();
}
