//! Criterion benchmark of the coupled implicit step (docs/implicit.md §7,
//! §12): one frame on the CPU golden path (one thread) against the GPU's
//! `GpuCoupledBackend` in f64, measured in one run.
//!
//! ```text
//! frame/{cpu-f64,gpu-f64}/S   one step (one minimisation per frame) of the evidence
//!                             scenes S = chain (alternating 1:1e6, 12 links), head-on,
//!                             incline (μ = 0.2, sliding), stack (ten balls), from the
//!                             state after 10 frames; the GPU's host round trips per
//!                             frame are printed (ROUNDTRIPS lines)
//! cloth/{cpu-f64,gpu-f64}/N   an N × N cloth of springs (α = 1e-6 m/N) falling onto a
//!                             frictional plane, N = 8, 16, 32 (64 … 1024 particles)
//! ```
//! `cargo bench --bench implicit`. GPU cases are skipped with a printed
//! notice when no adapter runs them. Without `--bench` (`cargo test
//! --all-targets`) a smoke run: the cloth at N = 8 only, one warm-up frame.

use std::hint::black_box;
use std::time::Duration;

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use hyperpbd::builders::GridSpec;
use hyperpbd::gpu::GpuCoupledBackend;
use hyperpbd::{Backend, Plan, Precision, Scene, SceneBuilder, Solver, State};

#[path = "../tests/common/implicit_scenes.rs"]
#[allow(dead_code)]
mod implicit_scenes;

use implicit_scenes::{alternating_chain, head_on, incline, settings, stack};

/// The backends of one case: the CPU on one thread, the GPU in f64.
fn backends(scene: &Scene) -> Vec<(&'static str, Box<dyn Backend>)> {
    hyperpbd::set_default_threads(std::num::NonZeroUsize::new(1));
    let plan = Plan::compile(scene).expect("compiles");
    let state = State::from_scene(scene);
    let mut out: Vec<(&'static str, Box<dyn Backend>)> = vec![(
        "cpu-f64",
        hyperpbd::load(plan.clone(), &state, hyperpbd::BackendKind::Cpu).expect("cpu"),
    )];
    match GpuCoupledBackend::new(plan, &state, Precision::F64) {
        Ok(gpu) => out.push(("gpu-f64", Box::new(gpu))),
        Err(e) => eprintln!("SKIPPED gpu-f64: {e}"),
    }
    out
}

/// Frames per second of simulated time the case is stepped over.
fn bench_frames(c: &mut Criterion, group: &str, name: &str, scene: &Scene, warm: usize) {
    let mut g = c.benchmark_group(group);
    g.sample_size(10)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(3));
    // The smoke run steps once before its one iteration: it checks that
    // the case runs, not the state after `warm` frames.
    let warm = if full() { warm } else { 1 };
    for (backend, mut b) in backends(scene) {
        for _ in 0..warm {
            b.step().expect("warm-up step");
        }
        let start = b.read_state().expect("state");
        g.bench_with_input(BenchmarkId::new(backend, name), &(), |bench, _| {
            bench.iter(|| {
                b.write_state(&start).expect("write");
                black_box(b.step().expect("step"));
            })
        });
    }
    g.finish();
    if let Ok(mut gpu) = GpuCoupledBackend::new(
        Plan::compile(scene).expect("compiles"),
        &State::from_scene(scene),
        Precision::F64,
    ) {
        let before = gpu.host_waits();
        gpu.step().expect("step");
        println!(
            "ROUNDTRIPS {group}/gpu-f64/{name}: {} host waits in the first frame",
            gpu.host_waits() - before
        );
    }
}

fn evidence(c: &mut Criterion) {
    bench_frames(c, "frame", "chain", &alternating_chain(), 10);
    bench_frames(c, "frame", "head-on", &head_on(), 10);
    bench_frames(c, "frame", "incline", &incline(0.2).0, 10);
    bench_frames(c, "frame", "stack", &stack().0, 10);
}

/// An n × n cloth of distance springs 5 cm above a frictional plane.
fn cloth(n: usize) -> Scene {
    let mut b = SceneBuilder::new(3).dt(1.0 / 60.0).gravity_along(1, 9.81);
    let mut spec = GridSpec::cloth(n, n, 0.05, 0.05);
    spec.compliance = 1e-6;
    spec.mass = 0.01;
    b.grid(&spec);
    b.hyperplane(vec![0.0, 1.0, 0.0], 0.0, 0.4);
    b.scene_mut().solver = Solver::IncrementalPotential(settings(1e4, 0.01, 1e-2, 20));
    b.build().expect("valid")
}

/// Whether this is a measuring run (`cargo bench` passes `--bench`), not
/// the smoke run of `cargo test --all-targets` (criterion's test mode).
fn full() -> bool {
    std::env::args().any(|a| a == "--bench")
}

fn sizes(c: &mut Criterion) {
    let sizes: &[usize] = if full() { &[8, 16, 32] } else { &[8] };
    for &n in sizes {
        bench_frames(c, "cloth", &n.to_string(), &cloth(n), 5);
    }
}

criterion_group! {
    name = benches;
    config = Criterion::default().without_plots();
    targets = evidence, sizes
}
criterion_main!(benches);
