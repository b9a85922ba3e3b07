//! A friction sweep of a ball pit as one GPU batch against one GPU run per
//! world (issue 35's numbers for particle contact in a batch).
//!
//! ```text
//! worlds   8 × pit3d(16, 16): 4 096 balls, 8 substeps × 2 iterations,
//!          collisions.friction = 0, 0.1, …, 0.7 (world 0: the collide
//!          kernel's frictionless branch, as its own run); 8 × the 16k
//!          pit, pit3d(26, 24): 16 224 balls (issue 35's number); and 8 × a small
//!          pit, pit3d(4, 3): 48 balls (where the dispatches, not the
//!          balls, are the cost)
//! round    the batch steps FRAMES frames, then each world's own
//!          GpuBackend FRAMES frames, one after another; wall time of the
//!          steps only (loading and pipeline builds excluded)
//! warm-up  one step of the batch and of each single run first (lavapipe's
//!          first dispatches, the lists' first growth), untimed
//! rounds   interleaved (batch, singles, batch, …): medians
//! check    after every round each world's batch state is its own single
//!          run's, bit for bit (State::hash over to_bits), in gpu-f64 and
//!          — on one adapter, one origin per world — reported for gpu-f32
//! ```
//! `cargo bench --bench batch_contact [-- 4k|16k|48|f64|f32]` (a row runs when
//! its name, e.g. `4k f64`, holds every filter); without `--bench` (as
//! under `cargo test --all-targets`) a smoke run: 2 worlds of 18 balls.

use hyperpbd::batch::{Batch, GpuBatch};
use hyperpbd::gpu::GpuBackend;
use hyperpbd::{Backend, Plan, Precision, Scene, State, scenes};
use std::time::Instant;

/// The sweep's worlds: `count` copies of `base` with ball–ball friction
/// 0, 0.1, … (`collisions.friction=0:…`).
fn friction_sweep(base: &Scene, count: usize) -> Vec<Scene> {
    (0..count)
        .map(|k| {
            let mut scene = base.clone();
            if let Some(c) = scene.collisions.as_mut() {
                c.friction = 0.1 * k as f64;
            }
            scene
        })
        .collect()
}

fn median(values: &mut [f64]) -> f64 {
    values.sort_by(f64::total_cmp);
    values[values.len() / 2]
}

/// Seconds for `frames` steps of `step`.
fn timed(frames: usize, mut step: impl FnMut()) -> f64 {
    let start = Instant::now();
    for _ in 0..frames {
        step();
    }
    start.elapsed().as_secs_f64()
}

/// One precision's rows: the batch and the single runs, `rounds`
/// interleaved rounds of `frames` frames.
fn measure(precision: Precision, worlds: &[Scene], rounds: usize, frames: usize) {
    let Ok((adapter, summary)) = hyperpbd::gpu::request_adapter(precision) else {
        println!("SKIPPED gpu-{precision}: no adapter");
        return;
    };
    let batch = Batch::new(worlds).expect("one topology");
    let mut gpu = GpuBatch::on_adapter(&adapter, &batch, precision).expect("gpu batch");
    let mut singles: Vec<GpuBackend> = worlds
        .iter()
        .map(|s| {
            let plan = Plan::compile(s).expect("plan");
            GpuBackend::with_adapter(&adapter, plan, &State::from_scene(s), precision)
                .expect("single")
        })
        .collect();
    drop(gpu.step().expect("warm-up"));
    for single in &mut singles {
        drop(single.step().expect("warm-up"));
    }
    let (mut batch_s, mut single_s, mut ratios) = (Vec::new(), Vec::new(), Vec::new());
    let mut identical = true;
    for round in 0..rounds {
        let b = timed(frames, || drop(gpu.step().expect("batch step")));
        let mut s = 0.0;
        for single in &mut singles {
            s += timed(frames, || drop(single.step().expect("single step")));
        }
        let states = gpu.read_states().expect("states");
        for (k, single) in singles.iter_mut().enumerate() {
            let own = single.read_state().expect("state");
            let same = own.hash() == states[k].hash();
            identical &= same;
            if precision == Precision::F64 {
                assert!(same, "gpu-f64 world {k}, round {round}: not its own run");
            }
        }
        println!(
            "round {round}: gpu-{precision} batch {b:.3} s, {} single runs {s:.3} s, ratio {:.3}",
            worlds.len(),
            b / s
        );
        batch_s.push(b);
        single_s.push(s);
        ratios.push(b / s);
    }
    let n = worlds[0].particles.len();
    let (b, s, r) = (
        median(&mut batch_s),
        median(&mut single_s),
        median(&mut ratios),
    );
    println!(
        "| gpu-{precision} ({}) | {} × {n} balls | {frames} | {} | {b:.3} s | {s:.3} s | {r:.3} | {} |",
        summary.name,
        worlds.len(),
        gpu.dispatches_per_step()
            .map_or("-".into(), |d| d.to_string()),
        if identical { "bit for bit" } else { "differs" }
    );
}

fn main() {
    let filter: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| !a.starts_with('-'))
        .collect();
    let wanted = |n: &str| filter.iter().all(|f| n.contains(f.as_str()));
    let full = std::env::args().any(|a| a == "--bench");
    // (name, pit, worlds, rounds, frames)
    let rows = match full {
        true => vec![
            ("4k", scenes::pit3d(16, 16), 8, 3, 5),
            ("16k", scenes::pit3d(26, 24), 8, 3, 2),
            ("48", scenes::pit3d(4, 3), 8, 5, 40),
        ],
        false => vec![("smoke", scenes::pit3d(3, 2), 2, 1, 2)],
    };
    let load = std::fs::read_to_string("/proc/loadavg").unwrap_or_default();
    let lp = std::env::var("LP_NUM_THREADS").unwrap_or_else(|_| "unset".into());
    println!("load average before: {}", load.trim());
    println!(
        "| backend | worlds | frames | dispatches per step | batch (median) | W single runs (median) | batch / singles (median of rounds) | world k vs its run |"
    );
    println!("|---|---|---:|---:|---:|---:|---:|---|");
    for (pit, base, count, rounds, frames) in rows {
        let worlds = friction_sweep(&base, count);
        for (name, precision) in [("f64", Precision::F64), ("f32", Precision::F32)] {
            if wanted(&format!("{pit} {name}")) {
                measure(precision, &worlds, rounds, frames);
            }
        }
    }
    let load = std::fs::read_to_string("/proc/loadavg").unwrap_or_default();
    println!("load average after: {} (LP_NUM_THREADS={lp})", load.trim());
    if !full {
        println!("smoke run; `cargo bench --bench batch_contact` for the table");
    }
}
