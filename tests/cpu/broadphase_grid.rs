//! The uniform-grid broadphase (`grid_pairs`, and the CPU backend that runs
//! it on every core) against the exhaustive O(n²) reference.
//!
//! Bound: exact equality of the pair lists (pair set and canonical order):
//! every search decides overlap with the same closed-interval test on the
//! same f64 coordinates. Cases: the shared random boxes (duplicates,
//! touching and zero-width boxes) in 1..=8 dimensions, dense jittered
//! lattices (the granular column's worst case for the one-axis sweep),
//! mixed sizes with one huge box, non-finite coordinates (the sweep takes
//! over), and random clouds from proptest.

use crate::common;

use common::Lcg;
use common::boxes::random_boxes;
use hyperpbd::{Backend, CpuBackend, Plan, State};
use hyperpbd_core::broadphase::{Aabbs, exhaustive_pairs, grid_pairs};
use proptest::prelude::*;

const SIZES: [usize; 9] = [0, 1, 2, 3, 63, 64, 65, 257, 600];

#[test]
fn grid_equals_exhaustive_in_every_dimension_and_size() {
    let mut compared = 0usize;
    for dim in 1..=8 {
        for (s, &n) in SIZES.iter().enumerate() {
            for spread in [2.0, 12.0] {
                let boxes = random_boxes(dim, n, spread, 7000 + 100 * dim as u64 + s as u64);
                let reference = exhaustive_pairs(&boxes);
                assert_eq!(
                    grid_pairs(&boxes),
                    reference,
                    "dim {dim} n {n} spread {spread}: grid vs exhaustive"
                );
                compared += reference.len();
            }
        }
    }
    common::bound::print_bound(
        "cpu grid == exhaustive",
        format_args!("{compared} pairs compared"),
        "exact",
        "same f64 test",
    );
    assert!(compared > 10_000, "the cases must produce many pairs");
}

/// Balls of radius r (+ margin) on a jittered cubic lattice of spacing
/// 2.1 r: every ball's box overlaps its 26 neighbours' boxes.
fn lattice(dim: usize, side: usize, seed: u64) -> Aabbs {
    let mut rng = Lcg(seed);
    let (r, spacing) = (0.06, 0.105);
    let count = side.pow(dim as u32);
    let (mut min, mut max) = (Vec::new(), Vec::new());
    for k in 0..count {
        let mut rest = k;
        for _ in 0..dim {
            let c = (rest % side) as f64 * spacing + 0.002 * rng.next();
            rest /= side;
            min.push(c - r);
            max.push(c + r);
        }
    }
    Aabbs::new(dim, min, max)
}

#[test]
fn grid_equals_exhaustive_on_dense_lattices() {
    for (dim, side) in [(1, 500), (2, 30), (3, 11), (4, 5)] {
        let boxes = lattice(dim, side, 11 + dim as u64);
        let reference = exhaustive_pairs(&boxes);
        assert_eq!(
            grid_pairs(&boxes),
            reference,
            "dim {dim}, {side}^{dim} lattice"
        );
        eprintln!(
            "dim {dim}: {} boxes, {} pairs, grid == exhaustive",
            boxes.len(),
            reference.len()
        );
    }
}

#[test]
fn a_huge_box_and_non_finite_coordinates() {
    let mut boxes = lattice(3, 8, 5);
    // One box spanning everything: the grid grows coarse (or gives way to
    // the sweep); the pairs do not change.
    boxes.min[30..33].copy_from_slice(&[-50.0; 3]);
    boxes.max[30..33].copy_from_slice(&[50.0; 3]);
    assert_eq!(grid_pairs(&boxes), exhaustive_pairs(&boxes));
    for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
        let mut odd = lattice(2, 12, 9);
        odd.min[17] = bad;
        odd.max[40] = bad;
        assert_eq!(grid_pairs(&odd), exhaustive_pairs(&odd), "with {bad}");
    }
}

/// The backend's candidate pairs (boxes swept from p to x, radius +
/// margin, pairs of two fixed particles removed) on 1 and 2 threads, in
/// chunks of 4 boxes, equal the exhaustive reference on the same boxes.
#[test]
fn the_backend_broadphase_equals_exhaustive_on_any_thread_count() {
    let scene = hyperpbd::scenes::column3d(8, 10);
    let plan = Plan::compile(&scene).unwrap_or_else(|e| panic!("{e}"));
    let margin = plan.contacts.map_or(0.0, |c| c.margin);
    for threads in [1, 2] {
        let mut backend =
            CpuBackend::with_threads(plan.clone(), &State::from_scene(&scene), threads)
                .unwrap_or_else(|e| panic!("{e}"))
                .with_max_chunk(4);
        for _ in 0..3 {
            backend.step().unwrap_or_else(|e| panic!("{e}"));
        }
        let start = backend.read_state().unwrap_or_else(|e| panic!("{e}"));
        backend
            .run_kernel(hyperpbd::Kernel::Predict)
            .unwrap_or_else(|e| panic!("{e}"));
        backend
            .run_kernel(hyperpbd::Kernel::Broadphase)
            .unwrap_or_else(|e| panic!("{e}"));
        let predicted = backend.read_state().unwrap_or_else(|e| panic!("{e}"));
        let boxes = Aabbs::swept_particles(
            plan.dim,
            &start.positions,
            &predicted.positions,
            &plan.radius,
            margin,
        );
        let mut reference = exhaustive_pairs(&boxes);
        let w = &plan.inverse_mass;
        reference.retain(|&[i, j]| w[i as usize] + w[j as usize] > 0.0);
        assert_eq!(backend.contacts().pairs, reference, "{threads} threads");
        assert!(reference.len() > 1000, "the column must be in contact");
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn random_clouds(
        dim in 1usize..=5,
        n in 0usize..200,
        spread in 0.1f64..20.0,
        radius in 0.0f64..1.0,
        seed in any::<u64>(),
    ) {
        let mut rng = Lcg(seed);
        let (mut min, mut max) = (Vec::new(), Vec::new());
        for _ in 0..n {
            let r = radius * (rng.next() + 1.0);
            for _ in 0..dim {
                let c = spread * rng.next();
                min.push(c - r);
                max.push(c + r);
            }
        }
        let boxes = Aabbs::new(dim, min, max);
        prop_assert_eq!(grid_pairs(&boxes), exhaustive_pairs(&boxes));
    }
}
