//! Criterion timings behind the accuracy report (`hyperpbd-report`, report/src/).
//!
//! ```text
//! accuracy/{backend}/{case}/s{S}i{I}   one step (1/60 s) of the accuracy
//!                                      sweep's scenes: cloth (16 × 16
//!                                      hanging), pendulum, tesseract, at
//!                                      S substeps × I iterations
//! effects/{backend}/{k}                one step of rung k of the effect
//!                                      ladder (effects::ladder(32):
//!                                      0 no forces … 5 full cloth; 6–8 controls)
//! ```
//! The report command takes medians of its own repetitions; this bench
//! gives the same step times with criterion's statistics. GPU cases are
//! skipped with a printed notice when no adapter exists. Without `--bench`
//! (`cargo test --all-targets`) a smoke run: s1i1 and s4i4 only, and the
//! ladder at 8 × 8, every rung.

use std::hint::black_box;
use std::time::Duration;

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use hyperpbd::{Backend, BackendKind, Plan, Scene, State};
use hyperpbd_report::{CaseId, effects};

fn load(scene: &Scene, backend: BackendKind) -> Option<Box<dyn Backend>> {
    let plan = Plan::compile(scene).expect("reference scenes compile");
    match hyperpbd::load(plan, &State::from_scene(scene), backend) {
        Ok(mut b) => {
            b.step().expect("warm-up step");
            Some(b)
        }
        Err(e) => {
            eprintln!("SKIPPED {}: {e}", backend.name());
            None
        }
    }
}

/// Whether this is a measuring run (`cargo bench` passes `--bench`), not
/// the smoke run of `cargo test --all-targets` (criterion's test mode).
fn full() -> bool {
    std::env::args().any(|a| a == "--bench")
}

fn sweep(c: &mut Criterion) {
    let mut group = c.benchmark_group("accuracy");
    group
        .sample_size(10)
        .warm_up_time(Duration::from_millis(200))
        .measurement_time(Duration::from_secs(2));
    let configs: &[(u32, u32)] = if full() {
        &[(1, 1), (4, 1), (16, 1), (4, 4), (16, 4)]
    } else {
        &[(1, 1), (4, 4)]
    };
    for case in [CaseId::Cloth, CaseId::Pendulum, CaseId::Tesseract] {
        for backend in BackendKind::ALL {
            for &(s, i) in configs {
                if !case.uses_iterations() && i > 1 {
                    continue;
                }
                let scene = case.scene(s, i, 16);
                let Some(mut b) = load(&scene, backend) else {
                    break;
                };
                group.throughput(Throughput::Elements(b.plan().projections_per_step()));
                group.bench_function(
                    BenchmarkId::new(
                        format!("{}/{}", backend.name(), case.name()),
                        format!("s{s}i{i}"),
                    ),
                    |bench| bench.iter(|| black_box(b.step().expect("step"))),
                );
            }
        }
    }
    group.finish();
}

fn effect_ladder(c: &mut Criterion) {
    let mut group = c.benchmark_group("effects");
    group
        .sample_size(10)
        .warm_up_time(Duration::from_millis(200))
        .measurement_time(Duration::from_secs(2));
    let ladder = effects::ladder(if full() { 32 } else { 8 });
    for backend in BackendKind::ALL {
        for (k, (_, scene, _)) in ladder.iter().enumerate() {
            let Some(mut b) = load(scene, backend) else {
                break;
            };
            group.bench_function(BenchmarkId::new(backend.name(), k), |bench| {
                bench.iter(|| black_box(b.step().expect("step")))
            });
        }
    }
    group.finish();
}

criterion_group!(benches, sweep, effect_ladder);
criterion_main!(benches);
