//! The GPU broadphase (hashed grid, per-box sorted lists) against the
//! exhaustive reference (and so against the CPU sweep), f32 and f64, on
//! random boxes in 1..=8 dimensions with duplicates, touching and
//! zero-width boxes, sizes around the workgroup size (64) and the scan
//! block, every choice of first grid axis; and the list regrowth from a
//! capacity of one slot.
//!
//! Bound: exact equality of the pair lists. The test boxes lie on a 1/8
//! grid, so f32 and f64 hold the same numbers; the overlap test is the same
//! closed-interval comparison, the grid only chooses which boxes are
//! tested (monotone cells, every box within two cells per axis), and each
//! list is sorted, so the pairs come out canonical. Any difference is a
//! bug, never rounding.

use crate::common;

use common::Lcg;
use common::bound::print_bound;
use common::boxes::random_boxes;
use common::gpu::adapter_or_skip;
use hyperpbd_core::broadphase::{Aabbs, exhaustive_pairs, sweep_pairs};
use hyperpbd_gpu::{GpuSweep, Precision};

const SIZES: [usize; 12] = [0, 1, 2, 3, 63, 64, 65, 255, 256, 257, 600, 1100];

fn every_dimension(precision: Precision) {
    let test = format!("gpu_sweep_equals_exhaustive_{precision}");
    let Some((adapter, _)) = adapter_or_skip(&test, precision) else {
        return;
    };
    let mut compared = 0usize;
    let mut regrowths = 0u32;
    for dim in 1..=8 {
        let mut gpu = GpuSweep::with_adapter(&adapter, dim, precision, 64).expect("broadphase");
        for (s, &n) in SIZES.iter().enumerate() {
            for spread in [2.0, 12.0] {
                let boxes = random_boxes(dim, n, spread, 1000 * dim as u64 + s as u64);
                let reference = exhaustive_pairs(&boxes);
                let axes: Vec<usize> = if n >= 600 {
                    vec![0, dim - 1]
                } else {
                    (0..dim).collect()
                };
                for axis in axes {
                    let pairs = gpu.sweep(&boxes, axis).expect("gpu sweep");
                    assert_eq!(
                        pairs.len(),
                        reference.len(),
                        "{precision} dim {dim} n {n} spread {spread} axis {axis}: pair count"
                    );
                    assert_eq!(
                        pairs, reference,
                        "{precision} dim {dim} n {n} spread {spread} axis {axis}: gpu sweep vs exhaustive"
                    );
                    assert_eq!(sweep_pairs(&boxes, axis), reference);
                    regrowths += gpu.stats().regrowths;
                }
                compared += reference.len();
            }
        }
    }
    print_bound(
        format_args!("gpu {precision} sweep == exhaustive (1..=8 dims)"),
        format_args!("{compared} pairs, {regrowths} regrowths"),
        "exact",
        "same boxes, same closed-interval test",
    );
    assert!(compared > 10_000);
}

#[test]
fn gpu_sweep_equals_exhaustive_f32() {
    every_dimension(Precision::F32);
}

#[test]
fn gpu_sweep_equals_exhaustive_f64() {
    every_dimension(Precision::F64);
}

/// Off-grid f64 boxes and extreme values (beyond f32 range, tiny, signed
/// zeros): the f64 kernel rounds its f32 keys outward without a bitcast of
/// f64; the exact test stays in f64.
#[test]
fn gpu_f64_sweep_equals_exhaustive_on_off_grid_and_extreme_boxes() {
    let Some((adapter, _)) = adapter_or_skip("gpu_f64_off_grid", Precision::F64) else {
        return;
    };
    let mut rng = Lcg(99);
    let specials: [f64; 12] = [
        -1e300,
        -3.5e38,
        -1.0,
        -1e-40,
        -0.0,
        0.0,
        1e-40,
        1e-310,
        0.1,
        0.1 + 1e-17,
        3.5e38,
        1e300,
    ];
    for dim in [1usize, 2, 3, 5] {
        let mut gpu =
            GpuSweep::with_adapter(&adapter, dim, Precision::F64, 16).expect("broadphase");
        // Off-grid: close values that round to the same f32.
        let n = 500;
        let mut min = Vec::new();
        let mut max = Vec::new();
        for _ in 0..n * dim {
            let a = 1.0 + rng.next() * 1e-7;
            let w = (rng.next() + 1.0) * 1e-8;
            min.push(a);
            max.push(a + w);
        }
        let boxes = Aabbs::new(dim, min, max);
        let reference = exhaustive_pairs(&boxes);
        assert!(!reference.is_empty());
        assert_eq!(
            gpu.sweep(&boxes, 0).expect("sweep"),
            reference,
            "off-grid dim {dim}"
        );
        let mut min = Vec::new();
        let mut max = Vec::new();
        for _ in 0..300 * dim {
            let a = specials[((rng.next() + 1.0) * 6.0) as usize % specials.len()];
            let b = specials[((rng.next() + 1.0) * 6.0) as usize % specials.len()];
            min.push(a.min(b));
            max.push(a.max(b));
        }
        let boxes = Aabbs::new(dim, min, max);
        let reference = exhaustive_pairs(&boxes);
        for axis in 0..dim {
            assert_eq!(
                gpu.sweep(&boxes, axis).expect("sweep"),
                reference,
                "extreme dim {dim} axis {axis}"
            );
        }
    }
}

/// Off-grid and extreme f64 boxes through the f32 kernels: the device
/// holds each box rounded outward, so its pairs equal the exhaustive pairs
/// of the rounded boxes and contain every pair of the f64 boxes (a pair
/// touching within half an f32 ulp is never lost).
#[test]
fn gpu_f32_sweep_never_loses_a_pair_of_off_grid_boxes() {
    let Some((adapter, _)) = adapter_or_skip("gpu_f32_off_grid", Precision::F32) else {
        return;
    };
    let mut rng = Lcg(77);
    for dim in [1usize, 2, 3, 5, 8] {
        let mut gpu =
            GpuSweep::with_adapter(&adapter, dim, Precision::F32, 16).expect("broadphase");
        // Boxes 0.1 + k·1e-9 wide near 1: far below one f32 ulp (1.2e-7),
        // so nearest rounding would collapse or separate touching boxes.
        let n = 400;
        let (mut min, mut max) = (Vec::new(), Vec::new());
        for _ in 0..n * dim {
            let a = 1.0 + (rng.next() + 1.0) * 0.5;
            let w = (rng.next() + 1.0) * 1e-9;
            min.push(a);
            max.push(a + w);
        }
        // Exactly touching neighbours, off the f32 grid.
        for k in 1..n.min(40) {
            for a in 0..dim {
                let width = max[k * dim + a] - min[k * dim + a];
                min[k * dim + a] = max[(k - 1) * dim + a];
                max[k * dim + a] = min[k * dim + a] + width;
            }
        }
        let boxes = Aabbs::new(dim, min, max);
        let exact = exhaustive_pairs(&boxes);
        let rounded = exhaustive_pairs(&boxes.rounded_outward_to_f32());
        assert!(
            exact.len() >= 39,
            "dim {dim}: the touching chain is in the reference"
        );
        for axis in [0, dim - 1] {
            let pairs = gpu.sweep(&boxes, axis).expect("sweep");
            assert_eq!(
                pairs, rounded,
                "dim {dim} axis {axis}: f32 sweep vs rounded boxes"
            );
            let missing = exact
                .iter()
                .filter(|p| pairs.binary_search(p).is_err())
                .count();
            assert_eq!(missing, 0, "dim {dim} axis {axis}: f64 pairs lost in f32");
        }
    }
}

/// 100 000 sparse boxes (a hash table of 262 144 buckets, a three-block
/// scan) equal the CPU sweep (itself equal to the exhaustive reference
/// above).
#[test]
fn gpu_sweep_of_100k_sparse_boxes_equals_the_cpu_sweep() {
    let Some((adapter, _)) = adapter_or_skip("gpu_sweep_100k", Precision::F64) else {
        return;
    };
    let dim = 3;
    let boxes = random_boxes(dim, 100_000, 60.0, 5);
    let mut gpu = GpuSweep::with_adapter(&adapter, dim, Precision::F64, 16).expect("broadphase");
    let pairs = gpu.sweep(&boxes, 0).expect("gpu sweep");
    let reference = sweep_pairs(&boxes, 0);
    assert!(!reference.is_empty());
    assert_eq!(pairs, reference);
}

/// The longest contact list of `pairs`: the slots a box needs.
fn longest_list(pairs: &[[u32; 2]], n: usize) -> usize {
    let mut degree = vec![0usize; n];
    for &[i, j] in pairs {
        degree[i as usize] += 1;
        degree[j as usize] += 1;
    }
    degree.into_iter().max().unwrap_or(0)
}

/// A starting capacity of one list slot per box: the sweep must grow its
/// lists, rerun and return every pair; a later, denser scene grows again.
#[test]
fn gpu_sweep_grows_overflowing_lists_and_drops_nothing() {
    for precision in [Precision::F32, Precision::F64] {
        let Some((adapter, _)) = adapter_or_skip("gpu_sweep_regrowth", precision) else {
            return;
        };
        let mut gpu = GpuSweep::with_adapter(&adapter, 3, precision, 1).expect("broadphase");
        assert_eq!(gpu.capacity(), 1);
        let boxes = random_boxes(3, 700, 2.0, 5);
        let reference = exhaustive_pairs(&boxes);
        assert!(reference.len() > 1000);
        let pairs = gpu.sweep(&boxes, 0).expect("sweep");
        let stats = gpu.stats();
        assert!(
            stats.regrowths >= 1,
            "{precision}: no regrowth from capacity 1"
        );
        assert_eq!(stats.pairs, reference.len());
        let longest = longest_list(&reference, 700);
        assert!(longest > 1);
        assert!(stats.capacity >= longest);
        assert_eq!(pairs, reference, "{precision}: after regrowth");
        // Same boxes again: no regrowth needed.
        assert_eq!(gpu.sweep(&boxes, 1).expect("sweep"), reference);
        assert_eq!(gpu.stats().regrowths, 0);
        // All boxes overlapping: n (n − 1) / 2 pairs.
        let n = 300;
        let all = Aabbs::new(3, vec![0.0; 3 * n], vec![1.0; 3 * n]);
        let pairs = gpu.sweep(&all, 2).expect("sweep");
        assert_eq!(pairs.len(), n * (n - 1) / 2);
        assert_eq!(pairs, exhaustive_pairs(&all));
        print_bound(
            format_args!("gpu {precision} regrowth from capacity 1"),
            format_args!(
                "{} pairs, longest list {longest}, capacity {}",
                reference.len(),
                stats.capacity
            ),
            "exact",
            "nothing dropped",
        );
    }
}
