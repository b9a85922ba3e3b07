//! The CPU broadphase on dense cubes: the one-axis sort-and-sweep
//! (`sweep_pairs`) against the uniform grid (`grid_pairs`), one thread each.
//!
//! ```text
//! boxes   balls of radius 0.5 (+ margin 0.02) on a jittered cubic lattice of
//!         spacing 1.05, side = n^(1/3): every box overlaps its 26
//!         neighbours' boxes; the sweep's slab along its axis holds n^(2/3)
//!         boxes, the grid's query a few dozen
//! timing  median of 5 runs per search; both must return the same pairs
//! fit     the log–log slope of time against n
//! ```
//! `cargo bench --bench broadphase_grid`; prints a markdown table (without
//! `--bench`, as under `cargo test --all-targets`: a smoke run of two small
//! cubes).

use std::time::Instant;

use hyperpbd_core::broadphase::{Aabbs, grid_pairs, sweep_axis, sweep_pairs};

/// A deterministic jitter in [−1, 1) for value `k` (a multiplicative hash).
fn jitter(k: usize) -> f64 {
    let h = (k as u64 + 1).wrapping_mul(0x9e37_79b9_7f4a_7c15) >> 11;
    h as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
}

fn cube(side: usize) -> Aabbs {
    let n = side * side * side;
    let mut x = Vec::with_capacity(3 * n);
    for k in 0..n {
        for (a, coord) in [k % side, (k / side) % side, k / (side * side)]
            .into_iter()
            .enumerate()
        {
            x.push(1.05 * coord as f64 + 0.05 * jitter(3 * k + a));
        }
    }
    Aabbs::particles(3, &x, &vec![0.5; n], 0.02)
}

fn median_seconds(mut run: impl FnMut()) -> f64 {
    let mut times: Vec<f64> = (0..5)
        .map(|_| {
            let start = Instant::now();
            run();
            start.elapsed().as_secs_f64()
        })
        .collect();
    times.sort_by(f64::total_cmp);
    times[2]
}

/// Least-squares slope of log t against log n.
fn slope(points: &[(f64, f64)]) -> f64 {
    let logs: Vec<(f64, f64)> = points.iter().map(|&(n, t)| (n.ln(), t.ln())).collect();
    let k = logs.len() as f64;
    let (mx, my) = logs
        .iter()
        .fold((0.0, 0.0), |(a, b), &(x, y)| (a + x / k, b + y / k));
    let (sxy, sxx) = logs.iter().fold((0.0, 0.0), |(a, b), &(x, y)| {
        (a + (x - mx) * (y - my), b + (x - mx) * (x - mx))
    });
    sxy / sxx
}

fn main() {
    println!("| n (dense cube) | pairs | CPU sort-and-sweep | CPU grid | sweep / grid |");
    println!("|---:|---:|---:|---:|---:|");
    let (mut sweep_points, mut grid_points) = (Vec::new(), Vec::new());
    // `cargo bench` passes --bench; `cargo test --all-targets` runs this
    // main without it: then a smoke run (two small cubes) only.
    let full = std::env::args().any(|a| a == "--bench");
    let sides: &[usize] = if full {
        &[10, 20, 32, 40, 50]
    } else {
        &[10, 12]
    };
    for &side in sides {
        let boxes = cube(side);
        let n = boxes.len();
        let axis = sweep_axis(&boxes);
        let pairs = grid_pairs(&boxes);
        assert_eq!(sweep_pairs(&boxes, axis), pairs, "{n} boxes: grid vs sweep");
        let sweep = median_seconds(|| {
            std::hint::black_box(sweep_pairs(&boxes, axis));
        });
        let grid = median_seconds(|| {
            std::hint::black_box(grid_pairs(&boxes));
        });
        sweep_points.push((n as f64, sweep));
        grid_points.push((n as f64, grid));
        println!(
            "| {n} | {} | {:.2} ms | {:.2} ms | {:.1}× |",
            pairs.len(),
            sweep * 1e3,
            grid * 1e3,
            sweep / grid
        );
    }
    println!(
        "| fitted exponent | | {:.2} | {:.2} | |",
        slope(&sweep_points),
        slope(&grid_points)
    );
}
