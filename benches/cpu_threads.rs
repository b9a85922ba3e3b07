//! The CPU golden path on one thread and on every core, measured
//! interleaved in one process (so machine noise hits both alike).
//!
//! ```text
//! peer cloth N²   hyperpbd::scenes::peer_cloth(N), N = 32 … 512: two
//!                 backends (1 thread, all threads) from the same warmed
//!                 state; rounds alternate a batch of frames on each; the
//!                 median batch per frame is reported, and the best single
//!                 frame of each (on a loaded machine: the frame least
//!                 disturbed by other processes)
//! column 100k     hyperpbd::scenes::column3d(40, 64) (102,400 balls): both
//!                 backends step the same frames from the initial state
//!                 (their states stay bit-identical), frame by frame,
//!                 alternating; the median frame is reported
//! speed-up        t(1 thread) / t(all threads); efficiency = speed-up / threads
//! Taichi peer     peer cloth 128² against benches/peers/taichi_cloth.py on
//!                 one thread and on all cores, in three rounds of ours then
//!                 Taichi's: the median batch of each (the best beside it),
//!                 and the issue's ratio (all threads against Taichi on one)
//! ```
//! `cargo bench --bench cpu_threads [-- peer [SIZES…]|column|taichi]`;
//! prints the `cpu-threads` table rows of docs/performance-log.md and then (with no filter)
//! the Taichi table. Every run asserts that both backends end in the same
//! state (hash), so a fast wrong answer cannot pass. Without `--bench` (as
//! under `cargo test --all-targets`) a smoke run of two small cloths only.

use std::time::Instant;

use hyperpbd::{Backend, CpuBackend, Plan, Scene, State, scenes};

/// Frames before measuring (so the state is not the flat initial one).
const WARMUP_FRAMES: usize = 10;

/// Rounds of the interleaved peer-cloth measurement.
const ROUNDS: usize = 9;

/// Rounds of ours-then-Taichi in the Taichi comparison.
const PEER_ROUNDS: usize = 3;

/// Frames of the column measurement.
const COLUMN_FRAMES: usize = 3;

fn backend(scene: &Scene, threads: usize) -> CpuBackend {
    let plan = Plan::compile(scene).expect("scene compiles");
    CpuBackend::with_threads(plan, &State::from_scene(scene), threads).expect("backend loads")
}

fn step(backend: &mut CpuBackend, frames: usize) -> f64 {
    let start = Instant::now();
    for _ in 0..frames {
        backend.step().expect("step");
    }
    start.elapsed().as_secs_f64() / frames as f64
}

/// `frames` frames timed one by one: the mean frame and the best (the
/// least disturbed by other processes on a loaded machine).
fn timed(backend: &mut CpuBackend, frames: usize) -> (f64, f64) {
    let each: Vec<f64> = (0..frames).map(|_| step(backend, 1)).collect();
    let best = each.iter().copied().fold(f64::INFINITY, f64::min);
    (each.iter().sum::<f64>() / frames as f64, best)
}

/// The median of the rounds' mean frames and the best frame of all.
fn summary(rounds: &[(f64, f64)]) -> (f64, f64) {
    let best = rounds.iter().map(|t| t.1).fold(f64::INFINITY, f64::min);
    (median(rounds.iter().map(|t| t.0).collect()), best)
}

fn median(mut values: Vec<f64>) -> f64 {
    values.sort_by(f64::total_cmp);
    values[values.len() / 2]
}

fn hash(backend: &mut CpuBackend) -> u64 {
    backend.read_state().expect("read").hash()
}

/// One table row: size, particles, 1 thread, all threads, speed-up,
/// efficiency, and the best frames (1 thread / all threads) where known.
fn row(what: &str, particles: usize, serial: f64, parallel: f64, threads: usize, best: String) {
    let speedup = serial / parallel;
    println!(
        "| {what} | {particles} | {} | {} | {speedup:.2}× | {:.0} % | {best} |",
        time(serial),
        time(parallel),
        100.0 * speedup / threads as f64
    );
}

fn time(seconds: f64) -> String {
    if seconds >= 1.0 {
        format!("{seconds:.2} s")
    } else {
        format!("{:.3} ms", seconds * 1e3)
    }
}

/// Particle-frames per timed batch of the full run (≈ 20 ms of serial work).
const BATCH_WORK: usize = 1 << 22;

/// Particle-frames per batch and rounds of the full run.
const FULL: (usize, usize) = (BATCH_WORK, ROUNDS);

/// Particle-frames per batch and rounds of the smoke run.
const SMOKE: (usize, usize) = (1 << 15, 1);

fn peer_cloth(threads: usize, sizes: &[usize], (work, rounds): (usize, usize)) {
    for &n in sizes {
        let scene = scenes::peer_cloth(n);
        let (mut one, mut all) = (backend(&scene, 1), backend(&scene, threads));
        step(&mut one, WARMUP_FRAMES);
        step(&mut all, WARMUP_FRAMES);
        let frames = (work / (n * n).max(1)).clamp(2, 2000);
        let (mut serial, mut parallel) = (Vec::new(), Vec::new());
        for _ in 0..rounds {
            serial.push(timed(&mut one, frames));
            parallel.push(timed(&mut all, frames));
        }
        assert_eq!(
            hash(&mut one),
            hash(&mut all),
            "peer cloth {n}²: states differ"
        );
        let ((serial, best_serial), (parallel, best_parallel)) =
            (summary(&serial), summary(&parallel));
        row(
            &format!("peer cloth {n}² (ms/frame)"),
            n * n,
            serial,
            parallel,
            threads,
            format!("{} / {}", time(best_serial), time(best_parallel)),
        );
    }
}

fn column(threads: usize) {
    let scene = scenes::column3d(40, 64);
    let particles = scene.particles.len();
    let (mut one, mut all) = (backend(&scene, 1), backend(&scene, threads));
    let (mut serial, mut parallel) = (Vec::new(), Vec::new());
    for _ in 0..COLUMN_FRAMES {
        serial.push(step(&mut one, 1));
        parallel.push(step(&mut all, 1));
    }
    assert_eq!(hash(&mut one), hash(&mut all), "column: states differ");
    row(
        &format!("column 100k, frames 1–{COLUMN_FRAMES} (s/frame)"),
        particles,
        median(serial),
        median(parallel),
        threads,
        "–".into(),
    );
}

/// `profile SCENE N THREADS FRAMES`: just step (for `perf`).
fn profile(args: &[String]) {
    let number =
        |k: usize, default: usize| args.get(k).and_then(|a| a.parse().ok()).unwrap_or(default);
    let (n, threads, frames) = (number(2, 128), number(3, 1), number(4, 100));
    let scene = match args.get(1).map(String::as_str) {
        Some("column") => scenes::column3d(40, 64),
        _ => scenes::peer_cloth(n),
    };
    let mut b = backend(&scene, threads);
    let seconds = step(&mut b, frames);
    println!("{} ms/frame, hash {:#018x}", seconds * 1e3, hash(&mut b));
}

/// `kernels N THREADS [NAME]`: µs per call of each kernel of the peer
/// cloth (or only NAME: predict, project, velocity), 3 rounds.
fn kernels(args: &[String]) {
    use hyperpbd::Kernel;
    let number =
        |k: usize, default: usize| args.get(k).and_then(|a| a.parse().ok()).unwrap_or(default);
    let (n, threads) = (number(1, 128), number(2, 1));
    let only = args.get(3).map(String::as_str);
    let scene = scenes::peer_cloth(n);
    let mut b = backend(&scene, threads);
    step(&mut b, WARMUP_FRAMES);
    let calls = (1 << 24) / (n * n);
    let kernels = [
        ("predict", Kernel::Predict),
        (
            "project",
            Kernel::Project {
                family: 0,
                color: 0,
            },
        ),
        ("velocity", Kernel::Velocity),
    ];
    for round in 0..3 {
        let mut line = format!("round {round}:");
        for (name, kernel) in kernels {
            if only.is_some_and(|o| o != name) {
                continue;
            }
            let start = Instant::now();
            for _ in 0..calls {
                b.run_kernel(kernel).expect("kernel");
            }
            let us = start.elapsed().as_secs_f64() / calls as f64 * 1e6;
            line += &format!("  {name} {us:.1} µs");
        }
        println!("{line}");
    }
}

/// `taichi`: the peer cloth 128² against the Taichi peer
/// (`benches/peers/taichi_cloth.py`, one thread and all cores), in
/// [`PEER_ROUNDS`] rounds of ours (9 interleaved batches of 200 frames on
/// one thread and on all cores), then the peer on one thread and on all
/// cores (9 batches each), so a drift of the machine hits both sides
/// alike. Each side's number is the median over the rounds of its median
/// batch (the best batch beside it). Skipped, saying so, where python3 has
/// no Taichi.
fn taichi(threads: usize) {
    let n = 128;
    // (median batch, best batch) of the peer on `peer_threads` (0: all).
    let peer = |peer_threads: usize| -> Option<(f64, f64)> {
        let script = concat!(env!("CARGO_MANIFEST_DIR"), "/benches/peers/taichi_cloth.py");
        let output = std::process::Command::new("python3")
            .args([
                script,
                "--n",
                &n.to_string(),
                "--repeats",
                &ROUNDS.to_string(),
            ])
            .args(["--threads", &peer_threads.to_string()])
            .output()
            .ok()?;
        let text = String::from_utf8_lossy(&output.stdout);
        let line = text.lines().find(|l| l.starts_with("taichi peer_cloth"))?;
        // "… median batch M ms/frame, best batch B ms/frame …"
        let after = |key: &str| -> Option<f64> {
            let rest = &line[line.find(key)? + key.len()..];
            rest.split_whitespace().next()?.parse().ok()
        };
        Some((after("median batch ")? * 1e-3, after("best batch ")? * 1e-3))
    };
    let scene = scenes::peer_cloth(n);
    let batches = |rounds: &[(f64, f64)]| {
        let means: Vec<f64> = rounds.iter().map(|t| t.0).collect();
        let best = means.iter().copied().fold(f64::INFINITY, f64::min);
        (median(means), best)
    };
    let ours = || {
        let (mut one, mut all) = (backend(&scene, 1), backend(&scene, threads));
        step(&mut one, WARMUP_FRAMES);
        step(&mut all, WARMUP_FRAMES);
        let (mut serial, mut parallel) = (Vec::new(), Vec::new());
        for _ in 0..ROUNDS {
            serial.push(timed(&mut one, 200));
            parallel.push(timed(&mut all, 200));
        }
        assert_eq!(
            hash(&mut one),
            hash(&mut all),
            "peer cloth {n}²: states differ"
        );
        (batches(&serial), batches(&parallel))
    };
    // Per side: the rounds' (median batch, best batch).
    let mut sides: [Vec<(f64, f64)>; 4] = Default::default();
    for _ in 0..PEER_ROUNDS {
        let (serial, parallel) = ours();
        let (Some(taichi_serial), Some(taichi_all)) = (peer(1), peer(0)) else {
            println!("taichi peer: not run (python3 cannot import taichi)");
            return;
        };
        for (side, t) in sides
            .iter_mut()
            .zip([serial, parallel, taichi_serial, taichi_all])
        {
            side.push(t);
        }
    }
    // (median of the rounds' median batches, best batch of all).
    let [serial, parallel, taichi_serial, taichi_all] = sides.map(|rounds| {
        let best = rounds.iter().map(|t| t.1).fold(f64::INFINITY, f64::min);
        (median(rounds.iter().map(|t| t.0).collect()), best)
    });
    println!(
        "| peer cloth {n}² | hyperpbd, median batch | Taichi, median batch | Taichi / hyperpbd | hyperpbd, best batch | Taichi, best batch | Taichi / hyperpbd |"
    );
    println!("|---|---:|---:|---:|---:|---:|---:|");
    for (what, ours, theirs) in [
        ("1 thread".to_string(), serial, taichi_serial),
        (format!("{threads} threads"), parallel, taichi_all),
        (
            format!("{threads} threads vs Taichi 1 thread"),
            parallel,
            taichi_serial,
        ),
    ] {
        println!(
            "| {what} | {} | {} | {:.2}× | {} | {} | {:.2}× |",
            time(ours.0),
            time(theirs.0),
            theirs.0 / ours.0,
            time(ours.1),
            time(theirs.1),
            theirs.1 / ours.1
        );
    }
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let filter: Vec<String> = args
        .iter()
        .filter(|a| !a.starts_with('-'))
        .cloned()
        .collect();
    let threads = hyperpbd_cpu::all_cores();
    // `cargo bench` passes --bench; `cargo test --all-targets` runs this
    // main without it: then a smoke run (small sizes, every check) only.
    if !args.iter().any(|a| a == "--bench") {
        peer_cloth(threads.max(2), &[16, 48], SMOKE);
        println!("smoke run; `cargo bench --bench cpu_threads` for the table");
        return;
    }
    if filter.first().is_some_and(|a| a == "profile") {
        return profile(&filter);
    }
    if filter.first().is_some_and(|a| a == "kernels") {
        return kernels(&filter);
    }
    let sizes: Vec<usize> = filter.iter().filter_map(|a| a.parse().ok()).collect();
    if filter.first().is_some_and(|a| a == "taichi") {
        return taichi(threads);
    }
    let wanted = |name: &str| filter.is_empty() || filter.iter().any(|f| name.contains(f.as_str()));
    println!(
        "| scene | particles | 1 thread | {threads} threads | speed-up | efficiency | best frame, 1 / {threads} threads |"
    );
    println!("|---|---:|---:|---:|---:|---:|---:|");
    if wanted("peer") {
        let all = [32, 64, 128, 256, 512];
        peer_cloth(threads, if sizes.is_empty() { &all } else { &sizes }, FULL);
    }
    if wanted("column") {
        column(threads);
    }
    if filter.is_empty() {
        println!();
        taichi(threads);
    }
}
