//! Worlds·steps per second of a batch against one run per world.
//!
//! ```text
//! scenes   chain2d (20-link chain, 21 particles) and cloth(16) (16² sheet)
//! W        1, 16, 256, 4096 worlds (cloth: up to 1024), gravity[0] swept
//! batch    CpuBatch on every core, one thread per world
//! alone    the same worlds one after another, each its own CpuBackend
//!          on one thread (what a loop over single runs costs)
//! ```
//! `cargo bench --bench batch_worlds [-- chain|cloth]` (without `--bench`,
//! as under `cargo test --all-targets`: a smoke run of 1 and 16 worlds). Both variants step
//! the same frames; the final states are asserted bit-identical, so a fast
//! wrong answer cannot pass. The GPU batch (one dispatch per kernel for all
//! worlds) is not built yet; a single-world GPU run costs what
//! `cargo bench --bench backends` reports per frame.

use hyperpbd::batch::{Batch, CpuBatch};
use hyperpbd::{Backend, CpuBackend, Plan, Scene, State, scenes};
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

fn measure(name: &str, base: &Scene, counts: &[usize]) {
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
    }
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
    if wanted("chain") {
        let counts: &[usize] = if full { &[1, 16, 256, 4096] } else { &[1, 16] };
        measure("chain2d", &scenes::chain2d(), counts);
    }
    if wanted("cloth") {
        let counts: &[usize] = if full { &[1, 16, 256, 1024] } else { &[1, 16] };
        measure("cloth 16²", &scenes::cloth(16), counts);
    }
    if !full {
        println!("smoke run; `cargo bench --bench batch_worlds` for the table");
    }
}
