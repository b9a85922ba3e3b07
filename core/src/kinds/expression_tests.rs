//! The block-wise projection (`kinds::project`, blocks of `expr::BLOCK`
//! slots) against projecting the same slots one call per slot (one lane
//! per block), bit for bit: positions, multipliers and the first failing
//! slot, for each relation, with fixed particles, coincident points (no
//! response) and a non-finite value (a failing slot) among them; the
//! shapes compiled for their (arity, N) against the run-time shape, and
//! the block values against C element by element; the lane-by-lane sums
//! of w|∇C|² against the member-by-member ones.

use super::expression::ExpressionKind;
use super::expression_projection::{
    Colour, ProjectionScratch, project, project_any, values, weights_both,
};
use super::relation::Relation;
use crate::expr::BLOCK;

fn run(
    kind: &ExpressionKind,
    x: &mut [f64],
    lambda: &mut [f64],
    slots: &[std::ops::Range<usize>],
) -> Vec<usize> {
    let count = lambda.len();
    let elements: Vec<u32> = (0..2 * count as u32).collect();
    let rest: Vec<f64> = (0..count).map(|e| 0.5 + 0.01 * (e % 7) as f64).collect();
    let inverse_mass: Vec<f64> = (0..2 * count)
        .map(|i| {
            if i % 11 == 3 {
                0.0
            } else {
                1.0 + (i % 3) as f64
            }
        })
        .collect();
    let mut scratch = ProjectionScratch::new();
    let mut failures = Vec::new();
    for range in slots {
        let colour = Colour {
            kind,
            dim: 3,
            elements: &elements,
            rest: &rest,
            constants: &[],
            alpha_tilde: 1e-3,
            inverse_mass: &inverse_mass,
            slots: range.clone(),
        };
        if let Err(e) = project(&colour, x, &mut lambda[range.clone()], &mut scratch) {
            failures.push(e);
        }
    }
    failures
}

#[test]
fn blocks_project_as_slot_by_slot_bit_for_bit() {
    let count = 2 * BLOCK + 19;
    for (relation, source) in [
        (Relation::Equal, "norm(x1 - x0)"),
        (Relation::AtLeast, "norm(x1 - x0)"),
        (Relation::AtMost, "sqrt(x1[0] - x0[0]) + norm(x1 - x0)"),
    ] {
        let kind =
            ExpressionKind::new("expression", source, &[], relation, 2, 3).expect("compiles");
        let mut x: Vec<f64> = (0..6 * count)
            .map(|k| ((k * 7919) % 101) as f64 * 0.013 - 0.6)
            .collect();
        // Element 5: coincident points (∇C undefined: no response).
        let (a, b) = x.split_at_mut(33);
        b[..3].copy_from_slice(&a[30..33]);
        let mut lambda: Vec<f64> = (0..count).map(|e| 1e-3 * (e % 5) as f64 - 2e-3).collect();
        let (mut x1, mut lambda1) = (x.clone(), lambda.clone());
        let whole = 0..count;
        let blocks = run(&kind, &mut x, &mut lambda, std::slice::from_ref(&whole));
        let singles: Vec<_> = (0..count).map(|e| e..e + 1).collect();
        let one_by_one = run(&kind, &mut x1, &mut lambda1, &singles);
        assert_eq!(blocks.first(), one_by_one.first(), "{source}");
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&x), bits(&x1), "{source}");
        assert_eq!(bits(&lambda), bits(&lambda1), "{source}");
        assert!(x.iter().zip(&x1).all(|(a, b)| a.to_bits() == b.to_bits()));
        if relation == Relation::AtMost {
            // sqrt of a negative difference: some slots fail.
            assert!(!blocks.is_empty());
        }
    }
}

#[test]
fn compiled_shapes_project_as_the_run_time_shape_bit_for_bit() {
    // (2, 3) and (3, 4) are compiled shapes; (5, 4) runs the run-time
    // shape with its column map on the heap (20 coordinates).
    for (source, arity, dim) in [
        ("norm(x1 - x0)", 2, 3),
        ("dot(x1 - x0, x2 - x0) + norm(x2 - x1)", 3, 4),
        ("norm(x4 - x0) + norm(x3 - x1) * x2[0]", 5, 4),
    ] {
        let kind = ExpressionKind::new("expression", source, &[], Relation::Equal, arity, dim)
            .expect("compiles");
        let count = BLOCK + 23;
        let elements: Vec<u32> = (0..(arity * count) as u32).collect();
        let rest: Vec<f64> = (0..count).map(|e| 0.3 + 0.01 * (e % 5) as f64).collect();
        let inverse_mass: Vec<f64> = (0..arity * count)
            .map(|i| {
                if i % 7 == 2 {
                    0.0
                } else {
                    1.0 + (i % 4) as f64
                }
            })
            .collect();
        let x: Vec<f64> = (0..arity * count * dim)
            .map(|k| ((k * 7919) % 103) as f64 * 0.011 - 0.5)
            .collect();
        let colour = Colour {
            kind: &kind,
            dim,
            elements: &elements,
            rest: &rest,
            constants: &[],
            alpha_tilde: 1e-3,
            inverse_mass: &inverse_mass,
            slots: 0..count,
        };
        let (mut x0, mut x1) = (x.clone(), x.clone());
        let (mut l0, mut l1) = (vec![1e-3; count], vec![1e-3; count]);
        let mut scratch = ProjectionScratch::new();
        let r0 = project(&colour, &mut x0[..], &mut l0, &mut scratch);
        let r1 = project_any(&colour, &mut x1[..], &mut l1, &mut scratch);
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(r0, r1, "{source}");
        assert_eq!(bits(&x0), bits(&x1), "{source}");
        assert_eq!(bits(&l0), bits(&l1), "{source}");
        assert_ne!(
            bits(&x0),
            bits(&x),
            "{source}: the projection moved nothing"
        );
        // C by blocks = C element by element.
        let mut block = crate::expr::Block::new();
        let mut columns = crate::expr::Columns::new();
        let mut seen = 0;
        values(&kind, dim, &elements, 3..count, &x, &mut block, |e, c| {
            let points = &x[e * arity * dim..(e + 1) * arity * dim];
            let one = kind.value_at(e, points, &mut columns);
            assert_eq!(c.to_bits(), one.to_bits(), "{source}, slot {e}");
            seen += 1;
        });
        assert_eq!(seen, count - 3, "{source}");
    }
}

#[test]
fn lane_by_lane_weights_are_member_by_member_bit_for_bit() {
    // ∂C columns with zeros, signed zeros, tiny, huge, ∞ and NaN entries,
    // read in a scrambled order; fixed members (w = 0) on some lanes.
    let specials = [0.0, -0.0, 1e-300, 1e300, f64::INFINITY, f64::NAN, -3.5];
    for (arity, dim) in [(2, 3), (3, 2), (4, 4), (1, 1)] {
        let n = arity * dim;
        let columns: Vec<[f64; BLOCK]> = (0..n + 3)
            .map(|c| {
                std::array::from_fn(|l| match (c * 31 + l * 17) % 23 {
                    k if k < specials.len() => specials[k],
                    k => (k as f64 - 11.0) * 0.37,
                })
            })
            .collect();
        let gradient: Vec<usize> = (0..n).map(|k| (k * 5 + 2) % (n + 3)).collect();
        let weight: Vec<[f64; BLOCK]> = (0..arity)
            .map(|j| {
                std::array::from_fn(|l| {
                    if (l + j) % 5 == 0 {
                        0.0
                    } else {
                        0.5 + j as f64
                    }
                })
            })
            .collect();
        let [(sum, wg), (sum_m, wg_m)] = weights_both((arity, dim), &columns, &gradient, &weight);
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&sum), bits(&sum_m), "({arity}, {dim})");
        assert_eq!(
            bits(wg.as_flattened()),
            bits(wg_m.as_flattened()),
            "({arity}, {dim})"
        );
        assert!(sum.iter().any(|s| s.is_nan()) && sum.iter().any(|s| s.is_finite()));
    }
}
