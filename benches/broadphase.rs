//! Criterion benchmark of the broadphase and the granular step.
//!
//! ```text
//! broadphase/exhaustive/n        O(n²) reference, n = 1k, 4k
//! broadphase/cpu_sweep/n         CPU sort-and-sweep, n = 1k, 10k, 100k
//! broadphase/gpu_sweep_f32/n     GPU sort-and-sweep (upload, sorts, sweep,
//!                                pair sort, readback), n = 1k, 10k, 100k
//! granular/{cpu_step,gpu_f32_step}/column3d_4320
//!                                one step of the shipped column3d scene
//! ```
//! Boxes: particles of radius 0.5 on a jittered lattice with spacing 1.05
//! shaped as a column 16 × 16 × (n / 256) long along the sweep axis — the
//! granular-column layout, where each box meets a bounded number of others
//! along the axis (about 2.3 pairs per particle). Coordinates are rounded
//! to f32, so the f64 CPU and f32 GPU sweeps see the same boxes (the
//! scaling mode asserts that they return the same pairs).
//!
//! With `HYPERPBD_SCALING=1` the benchmark instead times each sweep at
//! n = 1k … 1M (median of a few runs), fits the log–log exponent and prints
//! the table in docs/performance-log.md, plus a dense cube (every box's slab along the axis holds
//! n^(2/3) boxes: the one-axis sweep's bad case) up to 256k.
//! GPU cases are skipped with a printed notice when no adapter exists.

use std::hint::black_box;
use std::time::{Duration, Instant};

use criterion::{BenchmarkId, Criterion, criterion_group};
use hyperpbd::gpu::{GpuSweep, Precision};
use hyperpbd::{BackendKind, Plan, State, scenes};
use hyperpbd_core::broadphase::{Aabbs, exhaustive_pairs, sweep_pairs};

/// A deterministic jitter in [−1, 1).
struct Lcg(u64);

impl Lcg {
    fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        ((self.0 >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
    }
}

/// `n` unit balls on a jittered lattice of `cross × cross × ⌈n / cross²⌉`,
/// the long side along axis 0.
fn lattice_boxes(n: usize, cross: usize) -> Aabbs {
    let mut rng = Lcg(11);
    let mut x = Vec::with_capacity(3 * n);
    for k in 0..n {
        let (a, b, c) = (k / (cross * cross), (k / cross) % cross, k % cross);
        for coord in [a, b, c] {
            x.push(1.05 * coord as f64 + 0.05 * rng.next());
        }
    }
    let mut boxes = Aabbs::particles(3, &x, &vec![0.5; n], 0.02);
    // Rounded to f32 so that every sweep (f64 CPU, f32 GPU) sees the same
    // boxes and must return the same pairs.
    for v in boxes.min.iter_mut().chain(boxes.max.iter_mut()) {
        *v = f64::from(*v as f32);
    }
    boxes
}

fn column(n: usize) -> Aabbs {
    lattice_boxes(n, 16)
}

fn cube(n: usize) -> Aabbs {
    let side = (n as f64).cbrt().ceil() as usize;
    lattice_boxes(n, side)
}

fn gpu_sweep() -> Option<GpuSweep> {
    match GpuSweep::new(3, Precision::F32, 32) {
        Ok(g) => Some(g),
        Err(e) => {
            eprintln!("SKIPPED gpu sweep: {e}");
            None
        }
    }
}

fn broadphase(c: &mut Criterion) {
    let mut group = c.benchmark_group("broadphase");
    group
        .sample_size(10)
        .warm_up_time(Duration::from_millis(200))
        .measurement_time(Duration::from_secs(2));
    for n in [1_000usize, 4_000] {
        let boxes = column(n);
        group.bench_with_input(BenchmarkId::new("exhaustive", n), &boxes, |b, boxes| {
            b.iter(|| black_box(exhaustive_pairs(boxes)))
        });
    }
    let mut gpu = gpu_sweep();
    for n in [1_000usize, 10_000, 100_000] {
        let boxes = column(n);
        group.bench_with_input(BenchmarkId::new("cpu_sweep", n), &boxes, |b, boxes| {
            b.iter(|| black_box(sweep_pairs(boxes, 0)))
        });
        if let Some(g) = gpu.as_mut() {
            group.bench_with_input(BenchmarkId::new("gpu_sweep_f32", n), &boxes, |b, boxes| {
                b.iter(|| black_box(g.sweep(boxes, 0).expect("gpu sweep")))
            });
        }
    }
    group.finish();
}

fn granular(c: &mut Criterion) {
    let mut group = c.benchmark_group("granular");
    group
        .sample_size(10)
        .warm_up_time(Duration::from_millis(200))
        .measurement_time(Duration::from_secs(3));
    let scene = scenes::column3d(12, 30);
    let plan = Plan::compile(&scene).expect("compiles");
    let state = State::from_scene(&scene);
    let mut b = hyperpbd::load(plan.clone(), &state, BackendKind::Cpu).expect("loads");
    group.bench_function("cpu_step/column3d_4320", |bench| {
        bench.iter(|| black_box(b.step().expect("step")))
    });
    match hyperpbd::load(plan, &state, BackendKind::Gpu(Precision::F32)) {
        Ok(mut g) => {
            group.bench_function("gpu_f32_step/column3d_4320", |bench| {
                bench.iter(|| black_box(g.step().expect("step")))
            });
        }
        Err(e) => eprintln!("SKIPPED gpu step: {e}"),
    }
    group.finish();
}

/// Median wall time of `runs` calls, in seconds.
fn median(runs: usize, mut f: impl FnMut()) -> f64 {
    let mut times: Vec<f64> = (0..runs)
        .map(|_| {
            let start = Instant::now();
            f();
            start.elapsed().as_secs_f64()
        })
        .collect();
    times.sort_by(f64::total_cmp);
    times[times.len() / 2]
}

/// Least-squares slope of log t against log n.
fn exponent(points: &[(usize, f64)]) -> f64 {
    let logs: Vec<(f64, f64)> = points
        .iter()
        .map(|&(n, t)| ((n as f64).ln(), t.ln()))
        .collect();
    let k = logs.len() as f64;
    let (mx, my) = (
        logs.iter().map(|p| p.0).sum::<f64>() / k,
        logs.iter().map(|p| p.1).sum::<f64>() / k,
    );
    let sxy: f64 = logs.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let sxx: f64 = logs.iter().map(|p| (p.0 - mx) * (p.0 - mx)).sum();
    sxy / sxx
}

fn scaling_report() {
    let mut gpu = gpu_sweep();
    for (layout, make, sizes) in [
        (
            "column 16×16×L",
            column as fn(usize) -> Aabbs,
            vec![1_000usize, 4_000, 16_000, 64_000, 256_000, 1_000_000],
        ),
        ("cube", cube, vec![1_000, 4_000, 16_000, 64_000, 256_000]),
    ] {
        println!("\n{layout}: time per sweep (median), pairs per box, GPU pair capacity bytes");
        println!("| n | pairs | exhaustive | CPU sweep | GPU f32 sweep (lavapipe) |");
        println!("|---|---|---|---|---|");
        let (mut cpu_points, mut gpu_points, mut ex_points) = (Vec::new(), Vec::new(), Vec::new());
        for &n in &sizes {
            let boxes = make(n);
            let runs = if n >= 256_000 { 3 } else { 5 };
            let pairs = sweep_pairs(&boxes, 0);
            let cpu = median(runs, || {
                black_box(sweep_pairs(&boxes, 0));
            });
            cpu_points.push((n, cpu));
            let ex = if n <= 16_000 {
                let t = median(3, || {
                    black_box(exhaustive_pairs(&boxes));
                });
                ex_points.push((n, t));
                format!("{:.3} ms", 1e3 * t)
            } else {
                "—".into()
            };
            let g = match gpu.as_mut() {
                Some(g) => {
                    let found = g.sweep(&boxes, 0).expect("gpu sweep");
                    assert_eq!(found, pairs, "gpu sweep differs at n = {n}");
                    let t = median(runs, || {
                        black_box(g.sweep(&boxes, 0).expect("gpu sweep"));
                    });
                    gpu_points.push((n, t));
                    format!("{:.3} ms", 1e3 * t)
                }
                None => "skipped".into(),
            };
            println!(
                "| {n} | {} ({:.2}/box) | {ex} | {:.3} ms | {g} |",
                pairs.len(),
                pairs.len() as f64 / n as f64,
                1e3 * cpu
            );
        }
        println!(
            "fitted exponent t ∝ n^k: exhaustive k = {:.2}, CPU sweep k = {:.2}, GPU sweep k = {}",
            exponent(&ex_points),
            exponent(&cpu_points),
            if gpu_points.is_empty() {
                "skipped".to_string()
            } else {
                format!("{:.2}", exponent(&gpu_points))
            }
        );
    }
    if let Some(g) = gpu.as_ref() {
        println!(
            "\nGPU device memory: {} bytes per box (f32, 3D) + 4 bytes per list slot; {} slots per box after the run",
            g.bytes_per_box(),
            g.capacity()
        );
    }
}

criterion_group! {
    name = benches;
    // No plots: plotters needs a system font that CI machines may lack.
    config = Criterion::default().without_plots();
    targets = broadphase, granular
}

fn main() {
    if std::env::var("HYPERPBD_SCALING").is_ok_and(|v| v == "1") {
        scaling_report();
        return;
    }
    benches();
    Criterion::default()
        .without_plots()
        .configure_from_args()
        .final_summary();
}
