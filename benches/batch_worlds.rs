//! Worlds·steps per second of a batch against one run per world.
//!
//! ```text
//! scenes   chain2d (20-link chain, 21 particles) and cloth(16) (16² sheet)
//! W        1, 16, 256, 4096 worlds (cloth: up to 1024), gravity[0] swept;
//!          and chain2d with damping.rate swept from 0 (world 0 has no
//!          damping stage: the batch runs the union of the worlds' stages)
//! batch    CpuBatch on every core, one thread per world
//! alone    the same worlds one after another, each its own CpuBackend
//!          on one thread (what a loop over single runs costs)
//! gpu      GpuBatch (gpu-f32): every world in the same dispatches, one
//!          per kernel; against single-world GpuBackend runs of worlds 0
//!          and W − 1 (their mean per step × W: every world runs the same
//!          schedule, so W single runs cost W times one), and against the
//!          CPU batch of the same W in this run
//! guarded  the guarded material sweep of `guarded_worlds` (16 worlds, 12
//!          and 60 frames from the start): a GpuBatch against the W single
//!          adaptive GpuBackend runs, interleaved rounds, the median
//! ```
//! `cargo bench --bench batch_worlds [-- chain|damping|cloth|guarded|implicit]` (without `--bench`,
//! as under `cargo test --all-targets`: a smoke run of 1 and 16 worlds). The CPU variants step
//! the same frames; the final states are asserted bit-identical, so a fast
//! wrong answer cannot pass (the GPU batch's worlds are held to their own
//! runs by tests/gpu/batch.rs). lavapipe's threads are the environment's:
//! run once with `LP_NUM_THREADS=0` (one thread: a dispatch costs ~1 µs)
//! and once without (its default two threads: ~50 µs per dispatch, twice
//! the lanes).

use hyperpbd::batch::{Batch, CpuBatch, GpuBatch};
use hyperpbd::gpu::GpuBackend;
use hyperpbd::{Backend, CpuBackend, Plan, Precision, Scene, State, scenes};
use std::time::Instant;

/// Steps timed per variant.
const STEPS: usize = 20;

/// Steps before timing (caches, page faults).
const WARMUP: usize = 3;

fn worlds(base: &Scene, count: usize) -> Vec<Scene> {
    (0..count)
        .map(|k| {
            let mut scene = base.clone();
            if let Some(g) = scene.gravity.as_mut() {
                g[0] = -1.0 + 2.0 * k as f64 / count.max(2) as f64;
            }
            scene
        })
        .collect()
}

/// `count` worlds of `base` with damping rates 0, 1/(count − 1), …, 1
/// (`damping.rate=0:1:count`).
fn damped_worlds(base: &Scene, count: usize) -> Vec<Scene> {
    (0..count)
        .map(|k| {
            let mut scene = base.clone();
            let rate = k as f64 / (count.max(2) - 1) as f64;
            scene.damping = Some(hyperpbd::Damping { rate });
            scene
        })
        .collect()
}

/// How a row's worlds are made from its scene.
type Worlds = fn(&Scene, usize) -> Vec<Scene>;

/// The CPU rows of `base` at each of `counts` worlds; the CPU batch's
/// worlds·steps per second for each.
fn measure(name: &str, (base, worlds): (&Scene, Worlds), counts: &[usize]) -> Vec<f64> {
    let mut batch_rates = Vec::new();
    let threads = hyperpbd::default_threads().expect("threads");
    for &w in counts {
        let scenes = worlds(base, w);
        let batch = Batch::new(&scenes).expect("one topology");
        let mut batched = CpuBatch::new(&batch, threads).expect("batch");
        for _ in 0..WARMUP {
            batched.step().expect("step");
        }
        let start = Instant::now();
        for _ in 0..STEPS {
            batched.step().expect("step");
        }
        let batch_s = start.elapsed().as_secs_f64();
        let mut alone: Vec<CpuBackend> = scenes
            .iter()
            .map(|s| {
                let plan = Plan::compile(s).expect("plan");
                CpuBackend::with_threads(plan, &State::from_scene(s), 1).expect("backend")
            })
            .collect();
        for b in &mut alone {
            for _ in 0..WARMUP {
                b.step().expect("step");
            }
        }
        let start = Instant::now();
        for b in &mut alone {
            for _ in 0..STEPS {
                b.step().expect("step");
            }
        }
        let alone_s = start.elapsed().as_secs_f64();
        for (k, b) in alone.iter_mut().enumerate() {
            let (a, c) = (
                b.read_state().expect("state"),
                batched.world(k).read_state().expect("state"),
            );
            assert_eq!(
                a.hash(),
                c.hash(),
                "{name} world {k}: batch differs from its own run"
            );
        }
        let rate = |s: f64| (w * STEPS) as f64 / s;
        println!(
            "| {name} | {w} | {:.3e} | {:.3e} | {:.2}× |",
            rate(alone_s),
            rate(batch_s),
            alone_s / batch_s
        );
        batch_rates.push(rate(batch_s));
    }
    batch_rates
}

/// Seconds per step of `step`, after the warm-up.
fn seconds_per_step(mut step: impl FnMut()) -> f64 {
    for _ in 0..WARMUP {
        step();
    }
    let start = Instant::now();
    for _ in 0..STEPS {
        step();
    }
    start.elapsed().as_secs_f64() / STEPS as f64
}

/// The GPU rows of `base` at each of `counts` worlds (`cpu`: the CPU
/// batch's rates of the same counts, from [`measure`]).
fn measure_gpu(name: &str, (base, worlds): (&Scene, Worlds), counts: &[usize], cpu: &[f64]) {
    let precision = Precision::F32;
    let Ok((adapter, _)) = hyperpbd::gpu::request_adapter(precision) else {
        println!("SKIPPED gpu rows of {name}: no adapter");
        return;
    };
    for (&w, &cpu_rate) in counts.iter().zip(cpu) {
        let scenes = worlds(base, w);
        let batch = Batch::new(&scenes).expect("one topology");
        let mut gpu = GpuBatch::on_adapter(&adapter, &batch, precision).expect("gpu batch");
        let batch_step = seconds_per_step(|| drop(gpu.step().expect("step")));
        let mut single = 0.0;
        let probes: Vec<usize> = if w > 1 { vec![0, w - 1] } else { vec![0] };
        for &k in &probes {
            let plan = Plan::compile(&scenes[k]).expect("plan");
            let state = State::from_scene(&scenes[k]);
            let mut b = GpuBackend::with_adapter(&adapter, plan, &state, precision).expect("gpu");
            single += seconds_per_step(|| drop(b.step().expect("step")));
        }
        let alone_step = single / probes.len() as f64 * w as f64;
        let rate = |s: f64| w as f64 / s;
        println!(
            "| {name} | {w} | gpu-{precision}, {} dispatches | {:.3e} | {:.3e} | {:.1}× ({:.4} of W runs) | {:.2}× |",
            gpu.dispatches_per_step()
                .map_or("-".into(), |d| d.to_string()),
            rate(alone_step),
            rate(batch_step),
            alone_step / batch_step,
            batch_step / alone_step,
            rate(batch_step) / cpu_rate,
        );
    }
}

/// `count` worlds of a guarded material sweep: the 2D Neo-Hookean block
/// of tests/common/guarded.rs (6² cells of 0.1 m, E = 2e5 Pa, ν = 0.3,
/// one substep of 1/30 s) dropped at 40 m/s under the orientation guard,
/// adaptive up to 2^6 substeps, onto a plane 3 m … 0 m lower
/// (`obstacles[0].offset=-3:0:count`): each world's steps are rejected
/// and retried in the frames where it lands, its own frames.
fn guarded_worlds(count: usize) -> Vec<Scene> {
    let mut b = hyperpbd::SceneBuilder::new(2)
        .dt(1.0 / 30.0)
        .substeps(1)
        .iterations(10)
        .gravity_along(1, -9.81);
    b.soft_block(&hyperpbd::builders::BlockSpec {
        cells: vec![6; 2],
        origin: vec![0.0, 0.2],
        spacing: 0.1,
        mass: 0.1,
        compliance: 1e-7,
        edge_compliance: None,
    });
    b.hyperplane(vec![0.0, 1.0], 0.0, 0.0);
    let mut base = b.build().expect("valid block");
    let elements = base.constraints[0].elements.clone();
    let law = hyperpbd::ConstraintKind::NeoHookean;
    base.constraints = vec![hyperpbd::ConstraintFamily::material(
        law, 2e5, 0.3, elements,
    )];
    for p in &mut base.particles {
        p.velocity = Some(vec![0.0, -40.0]);
    }
    base.guards = Some(hyperpbd::Guards {
        orientation: true,
        ..hyperpbd::Guards::default()
    });
    base.adaptive = Some(hyperpbd::Adaptive {
        max_subdivisions: 6,
    });
    (0..count)
        .map(|k| {
            let mut scene = base.clone();
            let offset = -3.0 + 3.0 * k as f64 / (count.max(2) - 1) as f64;
            if let Some(hyperpbd::Obstacle::Hyperplane { offset: o, .. }) =
                scene.obstacles.first_mut()
            {
                *o = offset;
            }
            scene
        })
        .collect()
}

/// A sweep's row against its single runs (issue 35 item 5): gpu-f32, the
/// worlds of `scenes`, `frames` steps from the start, one GpuBatch against
/// the W single GPU runs one after another (loads not timed), `rounds`
/// interleaved rounds after an untimed one; the median of batch / W single
/// runs, with the host waits of both.
fn measure_sweep(label: &str, scenes: &[Scene], frames: usize, rounds: usize) {
    let precision = Precision::F32;
    let Ok((adapter, _)) = hyperpbd::gpu::request_adapter(precision) else {
        println!("SKIPPED {label} row: no adapter");
        return;
    };
    let w = scenes.len();
    let batch = Batch::new(scenes).expect("one topology");
    let mut ratios = Vec::new();
    let (mut retried, mut waits, mut alone_waits) = (0, 0, 0);
    for round in 0..=rounds {
        let mut gpu = GpuBatch::on_adapter(&adapter, &batch, precision).expect("gpu batch");
        let start = Instant::now();
        for _ in 0..frames {
            let reports = gpu.step().expect("batch step");
            waits += reports[0].host_waits;
            retried += reports.iter().map(|r| r.retries()).sum::<usize>();
        }
        let batch_s = start.elapsed().as_secs_f64();
        let mut alone_s = 0.0;
        for s in scenes {
            let (plan, state) = (Plan::compile(s).expect("plan"), State::from_scene(s));
            let mut b = hyperpbd::load_on_adapter(&adapter, plan, &state, precision).expect("gpu");
            let start = Instant::now();
            for _ in 0..frames {
                alone_waits += b.step().expect("step").host_waits;
            }
            alone_s += start.elapsed().as_secs_f64();
        }
        if round > 0 {
            println!(
                "| {label}, round {round} | {w} | {frames} frames | {:.3} s | {:.3} s | {:.3} |",
                alone_s,
                batch_s,
                batch_s / alone_s
            );
            ratios.push(batch_s / alone_s);
        }
    }
    ratios.sort_by(f64::total_cmp);
    let per_round = (rounds + 1) as f64;
    println!(
        "| {label}, median of {rounds} | {w} | {:.0} retries; host waits per run: {:.0} batched, {:.0} alone | | | **{:.3}** |",
        retried as f64 / per_round,
        waits as f64 / per_round,
        alone_waits as f64 / per_round,
        ratios.get(ratios.len() / 2).copied().unwrap_or(f64::NAN)
    );
}

/// The implicit chain (scenes/chain2d_implicit.json, the coupled step)
/// with gravity[1] swept over −12…−6 m/s² (`gravity[1]=-12:-6:count`).
fn implicit_chains(count: usize) -> Vec<Scene> {
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/chain2d_implicit.json");
    let base = Scene::from_json_file(&path).expect("chain2d_implicit");
    (0..count)
        .map(|k| {
            let mut scene = base.clone();
            let g = -12.0 + 6.0 * k as f64 / (count.max(2) - 1) as f64;
            scene.gravity.as_mut().expect("gravity")[1] = g;
            scene
        })
        .collect()
}

fn main() {
    let filter: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| !a.starts_with('-'))
        .collect();
    let wanted = |n: &str| filter.is_empty() || filter.iter().any(|f| n.contains(f.as_str()));
    let threads = hyperpbd::default_threads().expect("threads");
    // `cargo bench` passes --bench; `cargo test --all-targets` runs this
    // main without it: then a smoke run (few worlds, every check) only.
    let full = std::env::args().any(|a| a == "--bench");
    println!(
        "| scene | worlds | alone (worlds·steps/s) | batch, {threads} threads | batch / alone |"
    );
    println!("|---|---:|---:|---:|---:|");
    let chain_counts: &[usize] = if full { &[1, 16, 256, 4096] } else { &[1, 16] };
    let cloth_counts: &[usize] = if full { &[1, 16, 256, 1024] } else { &[1, 16] };
    let (chain, cloth) = (scenes::chain2d(), scenes::cloth(16));
    let gravity: Worlds = worlds;
    let damped: Worlds = damped_worlds;
    let (mut chain_cpu, mut damped_cpu, mut cloth_cpu) = (Vec::new(), Vec::new(), Vec::new());
    if wanted("chain") {
        chain_cpu = measure("chain2d", (&chain, gravity), chain_counts);
    }
    if wanted("damping") {
        damped_cpu = measure("chain2d, damping 0..1", (&chain, damped), chain_counts);
    }
    if wanted("cloth") {
        cloth_cpu = measure("cloth 16²", (&cloth, gravity), cloth_counts);
    }
    let lp = std::env::var("LP_NUM_THREADS").unwrap_or_else(|_| "unset".into());
    println!();
    println!(
        "| scene | worlds | GPU batch (LP_NUM_THREADS={lp}) | alone (worlds·steps/s) | batch | batch / alone | GPU batch / CPU batch ({threads} threads) |"
    );
    println!("|---|---:|---|---:|---:|---:|---:|");
    if wanted("chain") {
        measure_gpu("chain2d", (&chain, gravity), chain_counts, &chain_cpu);
    }
    if wanted("damping") {
        let name = "chain2d, damping 0..1";
        measure_gpu(name, (&chain, damped), chain_counts, &damped_cpu);
    }
    if wanted("cloth") {
        measure_gpu("cloth 16²", (&cloth, gravity), cloth_counts, &cloth_cpu);
    }
    if wanted("guarded") {
        println!();
        println!("| guarded (gpu-f32) | worlds | | W single runs | batch | batch / W runs |");
        println!("|---|---:|---|---:|---:|---:|");
        // 12 frames: every world lands (its retried frames weigh most);
        // 60: it then rests, accepted in the batch.
        let rows: &[(usize, usize, usize)] = match full {
            true => &[(16, 12, 3), (16, 60, 3)],
            false => &[(2, 4, 1)],
        };
        for &(w, frames, rounds) in rows {
            measure_sweep("guarded material sweep", &guarded_worlds(w), frames, rounds);
        }
    }
    if wanted("implicit") {
        println!();
        println!("| implicit (gpu-f32) | worlds | | W single runs | batch | batch / W runs |");
        println!("|---|---:|---|---:|---:|---:|");
        let (w, frames, rounds) = if full { (16, 30, 3) } else { (2, 2, 1) };
        measure_sweep(
            "implicit chain, gravity swept",
            &implicit_chains(w),
            frames,
            rounds,
        );
    }
    if !full {
        println!("smoke run; `cargo bench --bench batch_worlds` for the table");
    }
}
