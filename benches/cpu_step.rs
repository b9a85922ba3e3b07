//! Criterion benchmark of one CPU golden-path step on 3D cloth.
//!
//! ```text
//! cpu_step/hanging/N   hyperpbd::scenes::hanging_cloth(N): N × N cloth (edges
//!                      + shear diagonals, compliance 0), 10 substeps,
//!                      1 iteration, gravity, two corners of one edge fixed,
//!                      no obstacle: distance projections only
//! cpu_step/ground/N    hyperpbd::scenes::cloth(N): the same cloth dropped on
//!                      a ground plane with friction 0.4 and damping
//! throughput           distance-constraint projections per step
//!                      (Σ distance elements × iterations × substeps), so
//!                      criterion prints projections/s ("elem/s"); the ground
//!                      variant's contact projections are not counted
//! ```
//! The backend runs on one thread (the serial golden path; `cpu_threads`
//! measures one thread against all) and is created and warmed up once per
//! case; each iteration is one `step()` on the resident state (the report
//! included).

use std::hint::black_box;
use std::time::Duration;

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use hyperpbd::{Backend, CpuBackend, FamilyKind, Plan, Scene, State, scenes};

const SIZES: [usize; 3] = [64, 128, 256];

/// Steps taken before measuring, so the state is not the flat initial one.
const WARMUP_STEPS: usize = 5;

/// Distance-constraint projections per step.
fn distance_projections(plan: &Plan) -> u64 {
    let elements: u64 = plan
        .families
        .iter()
        .filter(|f| f.kind == FamilyKind::Distance)
        .map(|f| f.len() as u64)
        .sum();
    elements * u64::from(plan.iterations) * u64::from(plan.substeps)
}

fn warmed_backend(scene: &Scene) -> CpuBackend {
    let plan = Plan::compile(scene).expect("scene compiles");
    let mut backend =
        CpuBackend::with_threads(plan, &State::from_scene(scene), 1).expect("backend loads");
    for _ in 0..WARMUP_STEPS {
        backend.step().expect("warm-up step");
    }
    backend
}

fn bench_variant(c: &mut Criterion, name: &str, scene: fn(usize) -> Scene) {
    let mut group = c.benchmark_group(format!("cpu_step/{name}"));
    group
        .sample_size(10)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(3));
    for n in SIZES {
        let mut backend = warmed_backend(&scene(n));
        group.throughput(Throughput::Elements(distance_projections(backend.plan())));
        group.bench_function(BenchmarkId::from_parameter(n), |b| {
            b.iter(|| black_box(backend.step().expect("step")));
        });
    }
    group.finish();
}

fn cpu_step(c: &mut Criterion) {
    bench_variant(c, "hanging", scenes::hanging_cloth);
    bench_variant(c, "ground", scenes::cloth);
}

criterion_group! {
    name = benches;
    // No plots: plotters needs system fonts, which CI images may lack.
    config = Criterion::default().without_plots();
    targets = cpu_step
}
criterion_main!(benches);
