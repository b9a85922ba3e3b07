//! Criterion benchmark of the expression evaluator against the built-in
//! kernel it replaces: C and ∇C of `norm(x1 − x0)` over 16 384 elements in
//! R^3, block-wise as the projection runs it (`Tape::eval_block`, one op
//! over 64 lanes at a time) vs `geometry::distance` element by element —
//! each side gathering its element's coordinates from one particle array
//! and writing C (summed) and ∇C (to an array), one thread.
//!
//! ```text
//! expression/builtin      distance() per element
//! expression/expression   eval_block over blocks of 64 lanes
//! (interleaved only)       eval_f64 over all 16 384 lanes at once (the
//!                          column evaluator; outputs left in the columns)
//! ```
//! Before criterion runs, both are timed interleaved (A, B, A, B, … 201
//! rounds, so drift of the machine hits both alike) and the ratio of the
//! medians is printed: `expression/builtin median ratio`.
//!
//! Then whole steps: the 128² peer cloth (`scenes::peer_cloth(128)`) with
//! its distance families as built-ins and as `norm(x1 - x0)` expressions,
//! interleaved, medians: on the CPU (one thread) and, when an adapter is
//! there, gpu-f32 (`step ratio` lines; on Linux also of the thread's CPU
//! time, which a loaded machine inflates less than wall time).

use std::hint::black_box;
use std::time::{Duration, Instant};

use criterion::{Criterion, Throughput, criterion_group};
use hyperpbd::core::expr::{BLOCK, Block, Columns, Outputs, Tape, compile};
use hyperpbd::core::geometry::distance;

const DIM: usize = 3;
const LANES: usize = 16_384;

struct Data {
    positions: Vec<f64>,
    elements: Vec<[usize; 2]>,
}

fn data() -> Data {
    // A 128 × 128 grid's horizontal and vertical edges (16 256 + …), cut to LANES.
    let n = 128;
    let mut positions = Vec::with_capacity(n * n * DIM);
    let mut s = 0x1234_5678_9abc_def0u64;
    for i in 0..n * n {
        for a in 0..DIM {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            let jitter = (s >> 11) as f64 / (1u64 << 53) as f64 * 1e-3;
            let base = match a {
                0 => (i % n) as f64,
                1 => (i / n) as f64,
                _ => 0.0,
            };
            positions.push(base / n as f64 + jitter);
        }
    }
    let mut elements = Vec::with_capacity(LANES);
    for i in 0..n * n {
        if i % n + 1 < n {
            elements.push([i, i + 1]);
        }
        if i + n < n * n {
            elements.push([i, i + n]);
        }
    }
    elements.truncate(LANES);
    Data {
        positions,
        elements,
    }
}

fn builtin(d: &Data, grad: &mut [f64]) -> f64 {
    let mut points = [0.0; 2 * DIM];
    let mut sum = 0.0;
    for (e, el) in d.elements.iter().enumerate() {
        for (j, &p) in el.iter().enumerate() {
            points[j * DIM..(j + 1) * DIM].copy_from_slice(&d.positions[p * DIM..(p + 1) * DIM]);
        }
        sum += distance(&points, DIM, &mut grad[e * 2 * DIM..(e + 1) * 2 * DIM]);
    }
    sum
}

fn expression(d: &Data, tape: &Tape, cols: &mut Block<f64>, grad: &mut [f64]) -> f64 {
    let mut sum = 0.0;
    for (b, elements) in d.elements.chunks(BLOCK).enumerate() {
        tape.eval_block(cols, |j, column| {
            for (l, el) in elements.iter().enumerate() {
                column[l] = d.positions[el[j / DIM] * DIM + j % DIM];
            }
        });
        let value = cols.column(tape.value);
        for (l, v) in value[..elements.len()].iter().enumerate() {
            sum += v;
            let e = b * BLOCK + l;
            for (k, &g) in tape.gradient.iter().enumerate() {
                grad[e * 2 * DIM + k] = cols.column(g)[l];
            }
        }
    }
    sum
}

fn columns(d: &Data, tape: &Tape, cols: &mut Columns<f64>) -> f64 {
    let lanes = d.elements.len();
    tape.eval_f64(
        lanes,
        |j, l| d.positions[d.elements[l][j / DIM] * DIM + j % DIM],
        cols,
    );
    cols.get(tape.value, lanes - 1)
}

fn median(mut v: Vec<Duration>) -> Duration {
    v.sort();
    v[v.len() / 2]
}

fn interleaved(d: &Data, tape: &Tape) {
    let mut grad = vec![0.0; d.elements.len() * 2 * DIM];
    let mut cols = Block::new();
    let mut all = Columns::new();
    let (mut a, mut b, mut c) = (Vec::new(), Vec::new(), Vec::new());
    for _ in 0..201 {
        let t = Instant::now();
        black_box(builtin(black_box(d), &mut grad));
        a.push(t.elapsed());
        let t = Instant::now();
        black_box(expression(black_box(d), tape, &mut cols, &mut grad));
        b.push(t.elapsed());
        let t = Instant::now();
        black_box(columns(black_box(d), tape, &mut all));
        c.push(t.elapsed());
    }
    let (ma, mb, mc) = (median(a), median(b), median(c));
    println!(
        "expression/builtin median ratio: {:.3} (built-in {:?}, expression {:?}, {} elements, dim {DIM}, {} ops; all lanes at once {:?}, ratio {:.3})",
        mb.as_secs_f64() / ma.as_secs_f64(),
        ma,
        mb,
        d.elements.len(),
        tape.ops.len(),
        mc,
        mc.as_secs_f64() / ma.as_secs_f64(),
    );
}

/// The peer cloth with its distance families written as expressions.
fn expressed(scene: &hyperpbd::Scene) -> hyperpbd::Scene {
    let mut out = scene.clone();
    for family in &mut out.constraints {
        if family.kind == hyperpbd::ConstraintKind::Distance {
            let mut e = hyperpbd::ConstraintFamily::expression(
                "norm(x1 - x0)",
                family.compliance,
                family.elements.clone(),
            );
            e.rest = family.rest.clone();
            *family = e;
        }
    }
    out
}

/// This thread's time on a core so far, in ns (Linux:
/// `/proc/thread-self/schedstat`, first field; `None` elsewhere): unlike
/// wall time, it leaves out the time the thread waited for a core on a
/// loaded machine.
fn cpu_ns() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    text.split_whitespace().next()?.parse().ok()
}

/// Interleaved whole steps of `a` and `b` (`rounds` each after one warm-up
/// step), the median ratio b / a printed as `label`, of wall time and, with
/// `cpu_time` (a backend that steps on this thread) where the OS reports
/// it, of this thread's CPU time.
fn step_ratio(
    label: &str,
    a: &mut dyn hyperpbd::Backend,
    b: &mut dyn hyperpbd::Backend,
    rounds: usize,
    cpu_time: bool,
) {
    let (mut ta, mut tb) = (Vec::new(), Vec::new());
    let (mut ca, mut cb) = (Vec::new(), Vec::new());
    let ok = a.step().is_ok() && b.step().is_ok();
    for _ in 0..rounds {
        let (t, c) = (Instant::now(), cpu_ns());
        let ra = a.step();
        ta.push(t.elapsed());
        ca.extend(
            c.zip(cpu_ns())
                .map(|(c0, c1)| Duration::from_nanos(c1 - c0)),
        );
        let (t, c) = (Instant::now(), cpu_ns());
        let rb = b.step();
        tb.push(t.elapsed());
        cb.extend(
            c.zip(cpu_ns())
                .map(|(c0, c1)| Duration::from_nanos(c1 - c0)),
        );
        if ra.is_err() || rb.is_err() || !ok {
            println!("{label}: a step failed");
            return;
        }
    }
    let (ma, mb) = (median(ta), median(tb));
    println!(
        "{label} step ratio: {:.3} (built-in {:?}, expression {:?}, median of {rounds})",
        mb.as_secs_f64() / ma.as_secs_f64(),
        ma,
        mb
    );
    if cpu_time && ca.len() == rounds && cb.len() == rounds {
        let (ma, mb) = (median(ca), median(cb));
        println!(
            "{label} step ratio, CPU time: {:.3} (built-in {:?}, expression {:?})",
            mb.as_secs_f64() / ma.as_secs_f64(),
            ma,
            mb
        );
    }
}

fn whole_steps() {
    use hyperpbd::{BackendKind, Plan, State};
    let scene = hyperpbd::scenes::peer_cloth(128);
    let other = expressed(&scene);
    let load = |s: &hyperpbd::Scene, kind| {
        let plan = Plan::compile(s).expect("compiles");
        hyperpbd::load(plan, &State::from_scene(s), kind)
    };
    let cpu = |s: &hyperpbd::Scene| {
        let plan = Plan::compile(s).expect("compiles");
        hyperpbd::CpuBackend::with_threads(plan, &State::from_scene(s), 1).expect("cpu")
    };
    let (mut a, mut b) = (cpu(&scene), cpu(&other));
    step_ratio(
        "peer cloth 128², cpu-f64 one thread",
        &mut a,
        &mut b,
        31,
        true,
    );
    let gpu = BackendKind::Gpu(hyperpbd::gpu::Precision::F32);
    match (load(&scene, gpu), load(&other, gpu)) {
        (Ok(mut a), Ok(mut b)) => step_ratio(
            "peer cloth 128², gpu-f32",
            a.as_mut(),
            b.as_mut(),
            11,
            false,
        ),
        (a, b) => println!(
            "peer cloth 128², gpu-f32: skipped ({:?})",
            a.err().or(b.err()).map(|e| e.to_string())
        ),
    }
}

fn bench(c: &mut Criterion) {
    whole_steps();
    let d = data();
    let tape = compile("norm(x1 - x0)", &[], 2, DIM)
        .and_then(|c| c.tape(Outputs::ValueGradient))
        .expect("compiles");
    interleaved(&d, &tape);
    let mut group = c.benchmark_group("expression");
    group.throughput(Throughput::Elements(d.elements.len() as u64));
    let mut grad = vec![0.0; d.elements.len() * 2 * DIM];
    group.bench_function("builtin", |b| b.iter(|| builtin(black_box(&d), &mut grad)));
    let mut cols = Block::new();
    group.bench_function("expression", |b| {
        b.iter(|| expression(black_box(&d), &tape, &mut cols, &mut grad))
    });
    group.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default().without_plots();
    targets = bench
}

fn main() {
    benches();
    Criterion::default().configure_from_args().final_summary();
}
