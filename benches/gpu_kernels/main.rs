//! Criterion benchmark: which memory layout, access width and workgroup size
//! the XPBD kernels should use, measured on this machine's adapter
//! (lavapipe here) next to a plain copy kernel (the bandwidth floor).
//!
//! ```text
//! layout/{f32,f64}/{kernel}/{candidate}/wg{W}
//!   kernel     copy       y[i] = x[i], one particle vector per element (floor)
//!              predict    w = 0 skips; v += h s g; p = x; x += h v; finite check
//!              velocity   w = 0 skips; v = (x − p) / h; finite check
//!              project    one colour of XPBD distance projections (32,768 edges
//!                         of a 256 × 256 grid, λ and α~ as in shaders/project.wgsl)
//!   candidate  interleaved  x[i·3 + a], one scalar access per component (before)
//!              soa          x[a·n + i], component-major structure of arrays
//!              vec4         x[i] as vec4 (w padding), one access per vector
//!              vec4w        vec4 with the inverse mass in w (project only)
//!              vec4x4       vec4, 4 particles per invocation (a loop)
//!              dense4       x[i·3 + a] read as vec4: 4 particles in 3 accesses
//!   wg         workgroup size (64, 128, 256; copy and predict also 32 and 512)
//! ```
//! 65,536 particles (a 256² cloth), R = 20 dispatches of one kernel in one
//! compute pass and one submit per iteration; criterion's elem/s is
//! particles (edges for project) × R per second, so 1e9 / (elem/s) is ns per
//! element. Every candidate's result is checked against the same arithmetic
//! on the host before it is timed (f64: bit for bit; f32: bit for bit as
//! well — the same IEEE operations in the same order).
//!
//! Run: `NODEVICE_SELECT=1 cargo bench --bench gpu_kernels` (add
//! `LP_NUM_THREADS=0` for lavapipe on one thread). The choice this bench
//! informs is recorded in docs/performance.md.

use std::time::Duration;

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group};
use hyperpbd::gpu::{Precision, request_adapter, request_device};

mod candidate;
mod device;
mod reference;
mod wgsl;

use candidate::*;
use device::*;
use reference::*;
use wgsl::*;

const SIDE: usize = 256;
const N: usize = SIDE * SIDE;
const EDGES: usize = SIDE * SIDE / 2;
const REPEATS: u32 = 20;
const H: f64 = 1.0 / 600.0;
const G: [f64; 3] = [0.0, -9.81, 0.0];

fn candidates(kernel: Kernel) -> Vec<Candidate> {
    let mut out = Vec::new();
    let layouts: &[Layout] = match kernel {
        Kernel::Project => &[
            Layout::Interleaved,
            Layout::Soa,
            Layout::Vec4,
            Layout::Vec4W,
        ],
        Kernel::Copy => &[
            Layout::Interleaved,
            Layout::Soa,
            Layout::Vec4,
            Layout::Vec4x4,
            Layout::Dense4,
        ],
        _ => &[
            Layout::Interleaved,
            Layout::Soa,
            Layout::Vec4,
            Layout::Vec4W,
            Layout::Vec4x4,
            Layout::Dense4,
        ],
    };
    let plain = |layout, wg| Candidate {
        layout,
        wg,
        extra: Extra::None,
    };
    for &layout in layouts {
        for wg in [64, 256] {
            out.push(plain(layout, wg));
        }
    }
    if matches!(kernel, Kernel::Copy | Kernel::Predict) {
        for wg in [32, 128, 512] {
            out.push(plain(Layout::Vec4, wg));
        }
    }
    if kernel != Kernel::Copy {
        for extra in [Extra::StorageParams, Extra::AtomicCheck] {
            out.push(Candidate {
                layout: Layout::Vec4,
                wg: 64,
                extra,
            });
        }
    }
    out
}

fn layouts(c: &mut Criterion) {
    let d = data();
    for precision in [Precision::F32, Precision::F64] {
        let Some(gpu) = setup(precision) else {
            continue;
        };
        let mut group = c.benchmark_group(format!("layout/{precision}"));
        group
            .sample_size(10)
            .warm_up_time(Duration::from_millis(200))
            .measurement_time(Duration::from_secs(2));
        for kernel in [
            Kernel::Copy,
            Kernel::Predict,
            Kernel::Velocity,
            Kernel::Project,
        ] {
            for candidate in candidates(kernel) {
                let (layout, wg) = (candidate.layout, candidate.wg);
                let case = gpu.build(precision, kernel, candidate, &d);
                verify(&gpu, &case, kernel, layout, precision, &d);
                group.throughput(Throughput::Elements(
                    kernel.elements() as u64 * u64::from(REPEATS),
                ));
                group.bench_function(
                    BenchmarkId::new(
                        format!("{}/{}", kernel.name(), candidate.name()),
                        format!("wg{wg}"),
                    ),
                    |b| b.iter(|| gpu.dispatch(&case, REPEATS)),
                );
            }
        }
        group.finish();
    }
}
/// Instruction-count mode (no criterion): `GPU_KERNELS_CASE=f32/predict/vec4/wg64
/// GPU_KERNELS_CALLS=K` builds and verifies one case, then submits K × 20
/// dispatches. `perf stat -e instructions` of K = 0 and K > 0 gives the
/// instructions per element, independent of the machine's load.
fn count(case: &str) {
    let parts: Vec<&str> = case.split('/').collect();
    let [precision, kernel, candidate, wg] = parts[..] else {
        panic!("GPU_KERNELS_CASE: precision/kernel/candidate/wgN, got {case}");
    };
    let precision = if precision == "f64" {
        Precision::F64
    } else {
        Precision::F32
    };
    let kernel = [
        Kernel::Copy,
        Kernel::Predict,
        Kernel::Velocity,
        Kernel::Project,
    ]
    .into_iter()
    .find(|k| k.name() == kernel)
    .expect("kernel name");
    let wg: u32 = wg.trim_start_matches("wg").parse().expect("wgN");
    let candidate = candidates(kernel)
        .into_iter()
        .find(|c| c.name() == candidate && c.wg == wg)
        .expect("a candidate of this bench");
    let calls: u32 = std::env::var("GPU_KERNELS_CALLS")
        .ok()
        .and_then(|c| c.parse().ok())
        .unwrap_or(0);
    let Some(gpu) = setup(precision) else {
        return;
    };
    let d = data();
    let built = gpu.build(precision, kernel, candidate, &d);
    verify(&gpu, &built, kernel, candidate.layout, precision, &d);
    for _ in 0..calls {
        gpu.dispatch(&built, REPEATS);
    }
    println!(
        "{case}: {calls} × {REPEATS} dispatches of {} elements",
        kernel.elements()
    );
}

criterion_group!(
    name = benches;
    // No plots: plotters needs system fonts, which CI images may lack.
    config = Criterion::default().without_plots();
    targets = layouts
);

fn main() {
    if let Ok(case) = std::env::var("GPU_KERNELS_CASE") {
        count(&case);
        return;
    }
    benches();
    Criterion::default().configure_from_args().final_summary();
}
