//! The CPU sweeps: exhaustive O(n²) reference vs sort-and-sweep, on random
//! boxes in 1..=8 dimensions with duplicates, touching and zero-width boxes,
//! every sweep axis, and sizes around the GPU workgroup sizes (64, 256).
//!
//! Bound: exact equality of the pair lists (pair-set and order), not a
//! tolerance: both decide overlap with the same closed-interval test on the
//! same f64 coordinates, and both return (i < j) pairs in lexicographic order.

use crate::common;

use common::Lcg;
use common::bound::print_bound;
use common::boxes::random_boxes;
use hyperpbd_core::broadphase::{Aabbs, exhaustive_pairs, sweep_axis, sweep_pairs};

const SIZES: [usize; 9] = [0, 1, 2, 3, 63, 64, 65, 257, 600];

#[test]
fn sweep_equals_exhaustive_in_every_dimension_axis_and_size() {
    let mut compared = 0usize;
    for dim in 1..=8 {
        for (s, &n) in SIZES.iter().enumerate() {
            for spread in [2.0, 12.0] {
                let boxes = random_boxes(dim, n, spread, 1000 * dim as u64 + s as u64);
                let reference = exhaustive_pairs(&boxes);
                for axis in 0..dim {
                    let swept = sweep_pairs(&boxes, axis);
                    assert_eq!(
                        swept, reference,
                        "dim {dim} n {n} spread {spread} axis {axis}: sweep vs exhaustive"
                    );
                }
                compared += reference.len();
            }
        }
    }
    print_bound(
        "cpu sweep == exhaustive",
        format_args!("{compared} pairs compared"),
        "exact",
        "same f64 test",
    );
    assert!(compared > 10_000, "the cases must produce many pairs");
}

#[test]
fn exhaustive_reference_follows_its_definition() {
    // Two touching boxes, a duplicate, a disjoint one, a zero-width one on
    // the shared face.
    let boxes = Aabbs::new(
        2,
        vec![0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 5.0, 5.0, 1.0, 0.5],
        vec![1.0, 1.0, 2.0, 1.0, 1.0, 1.0, 6.0, 6.0, 1.0, 0.5],
    );
    assert_eq!(
        exhaustive_pairs(&boxes),
        vec![[0, 1], [0, 2], [0, 4], [1, 2], [1, 4], [2, 4]]
    );
    for axis in 0..2 {
        assert_eq!(sweep_pairs(&boxes, axis), exhaustive_pairs(&boxes));
    }
}

#[test]
fn sweep_handles_extreme_coordinates() {
    // Values beyond f32 range, denormal-size values and signed zeros: the
    // f32 sort keys round outward, the overlap test stays exact in f64.
    let mut rng = Lcg(7);
    let specials: [f64; 11] = [
        -1e300, -3.5e38, -1.0, -1e-40, -0.0, 0.0, 1e-40, 1e-310, 0.1, 3.5e38, 1e300,
    ];
    for dim in 1..=3 {
        let n = 200;
        let mut min = Vec::new();
        let mut max = Vec::new();
        for _ in 0..n * dim {
            let a = specials[((rng.next() + 1.0) * 5.5) as usize % specials.len()];
            let b = specials[((rng.next() + 1.0) * 5.5) as usize % specials.len()];
            min.push(a.min(b));
            max.push(a.max(b));
        }
        let boxes = Aabbs::new(dim, min, max);
        for axis in 0..dim {
            assert_eq!(sweep_pairs(&boxes, axis), exhaustive_pairs(&boxes));
        }
    }
}

#[test]
fn particle_boxes_pad_by_radius_and_margin_and_sweep_over_the_step() {
    let x = [0.0, 0.0, 3.0, 1.0];
    let y = [1.0, -1.0, 3.0, 1.0];
    let radius = [0.5, 0.25];
    let still = Aabbs::particles(2, &x, &radius, 0.125);
    assert_eq!(still.min, vec![-0.625, -0.625, 2.625, 0.625]);
    assert_eq!(still.max, vec![0.625, 0.625, 3.375, 1.375]);
    let swept = Aabbs::swept_particles(2, &x, &y, &radius, 0.0);
    assert_eq!(swept.min, vec![-0.5, -1.5, 2.75, 0.75]);
    assert_eq!(swept.max, vec![1.5, 0.5, 3.25, 1.25]);
    let triangle = Aabbs::simplices(2, &[0.0, 0.0, 2.0, 1.0, 1.0, -3.0], &[0, 1, 2], 3, 0.5);
    assert_eq!(triangle.min, vec![-0.5, -3.5]);
    assert_eq!(triangle.max, vec![2.5, 1.5]);
}

#[test]
fn sweep_axis_is_the_widest_spread_of_centers() {
    let boxes = random_boxes(3, 50, 4.0, 3);
    let mut stretched = boxes.clone();
    for i in 0..50 {
        stretched.min[i * 3 + 2] *= 10.0;
        stretched.max[i * 3 + 2] *= 10.0;
    }
    assert_eq!(sweep_axis(&stretched), 2);
    assert_eq!(sweep_axis(&Aabbs::new(3, vec![], vec![])), 0);
}
