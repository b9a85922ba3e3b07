//! The evaluators against each other: many lanes at once = one lane at a
//! time, bit for bit (f64 and f32; a NaN equals any NaN: IEEE leaves its
//! sign and payload to the hardware, and vector and scalar units differ); f32 = f64 within a running error bound
//! of the f32 evaluation.
//!
//! ```text
//! u = 2^-24 (f32 unit roundoff); e_s = bound on |f32(s) − f64(s)| per slot:
//! Input, Const: u|v|            (rounded once to f32)
//! a ± b:  e_a + e_b + u|r|      a·b: |b|e_a + |a|e_b + e_a e_b + u|r|
//! a / b:  (e_a + |r| e_b)/(|b| − e_b) + u|r|      (|b| ≤ e_b: lane not bounded)
//! √a:     e_a/(√(a − e_a) + √a) + u|r|            −a, |a|: e_a
//! ln a:   e_a/(a − e_a) + 2u|r| + 2u·1 (≤ 1 ulp + the f64 side's rounding)
//! exp a:  |r|(e^{e_a} − 1) + 2u|r|·e^{e_a}
//! select: e_t or e_f; a comparison within e_l + e_r of a tie: not bounded
//! ```
//! The f64 side's own rounding (≈ 2^-53 relative per op) is covered by the
//! slack of using u|r| on values that are themselves computed in f64.
//! Lanes that are not bounded are counted; at most 2 % may be.

use super::random::{Rng, program};
use super::{compiled, full, params};
use crate::expr::{Cmp, Columns, Op, Tape};

fn bounds(tape: &Tape, v: &Columns<f64>, lane: usize) -> Option<Vec<f64>> {
    let u = f64::from(f32::EPSILON) / 2.0;
    let mut e = vec![0.0f64; tape.ops.len()];
    for (i, op) in tape.ops.iter().enumerate() {
        let r = v.get(i, lane).abs();
        let val = |s| v.get(s, lane);
        e[i] = match *op {
            Op::Input(_) | Op::Const(_) => u * r,
            Op::Add(a, b) | Op::Sub(a, b) => e[a] + e[b] + u * r,
            Op::Mul(a, b) => val(b).abs() * e[a] + val(a).abs() * e[b] + e[a] * e[b] + u * r,
            Op::Div(a, b) => {
                if val(b).abs() <= e[b] {
                    return None;
                }
                (e[a] + r * e[b]) / (val(b).abs() - e[b]) + u * r
            }
            Op::Neg(a) | Op::Abs(a) => e[a],
            Op::Sqrt(a) => {
                if val(a) - e[a] < 0.0 {
                    return None;
                }
                e[a] / ((val(a) - e[a]).sqrt() + val(a).sqrt()) + u * r
            }
            Op::Ln(a) => {
                if val(a) - e[a] <= 0.0 {
                    return None;
                }
                e[a] / (val(a) - e[a]) + 2.0 * u * r + 2.0 * u
            }
            Op::Exp(a) => r * (e[a].exp() - 1.0) + 2.0 * u * r * e[a].exp(),
            Op::Select(s) => {
                let [lhs, rhs, then, otherwise] = s.operands();
                if (val(lhs) - val(rhs)).abs() <= e[lhs] + e[rhs] {
                    return None;
                }
                let holds = match s.cmp {
                    Cmp::Lt => val(lhs) < val(rhs),
                    Cmp::Le => val(lhs) <= val(rhs),
                };
                if holds { e[then] } else { e[otherwise] }
            }
        };
        if !e[i].is_finite() {
            return None;
        }
    }
    Some(e)
}

/// Case `case` of a random-program test: the tape (C, ∇C, ∇²C) of a
/// random program of arity 1 + case % 3 in R^(1 + case % 4), and its
/// inputs per lane.
fn random_tape(rng: &mut Rng, case: usize) -> (Tape, usize) {
    let (dim, arity) = (1 + case % 4, 1 + case % 3);
    let source = program(rng, 3, arity, dim);
    (
        full(&compiled(&source, &params(dim), arity, dim)),
        arity * dim,
    )
}

/// `a` and `b` have the same bits, or are both NaN (f32 values widened:
/// exact, so bits equal in f32 iff equal in f64).
fn assert_same(a: f64, b: f64) {
    assert!(
        a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan()),
        "{a:e} {b:e}"
    );
}

#[test]
fn lanes_at_once_equal_one_lane_at_a_time_bit_for_bit() {
    let mut rng = Rng(21);
    let mut compared = 0usize;
    for case in 0..40 {
        let (tape, n) = random_tape(&mut rng, case);
        let lanes = 37 + case;
        let x: Vec<f64> = (0..n * lanes).map(|_| rng.uniform(-1.5, 1.5)).collect();
        let (mut all64, mut one64) = (Columns::new(), Columns::new());
        let (mut all32, mut one32) = (Columns::<f32>::new(), Columns::<f32>::new());
        tape.eval_f64(lanes, |j, l| x[l * n + j], &mut all64);
        tape.eval_f32(lanes, |j, l| x[l * n + j] as f32, &mut all32);
        for l in 0..lanes {
            tape.eval_f64(1, |j, _| x[l * n + j], &mut one64);
            tape.eval_f32(1, |j, _| x[l * n + j] as f32, &mut one32);
            for s in tape.outputs() {
                assert_same(all64.get(s, l), one64.get(s, 0));
                assert_same(all32.get(s, l).into(), one32.get(s, 0).into());
                compared += 2;
            }
        }
    }
    assert!(compared > 10_000, "{compared}");
}

#[test]
fn f32_is_f64_within_f32_rounding() {
    let mut rng = Rng(23);
    let (mut compared, mut lanes_total, mut unbounded) = (0usize, 0usize, 0usize);
    let mut worst: f64 = 0.0;
    for case in 0..60 {
        let (tape, n) = random_tape(&mut rng, case);
        let lanes = 64;
        // Inputs exactly representable in f32, so both sides read the same numbers.
        let x: Vec<f32> = (0..n * lanes)
            .map(|_| rng.uniform(-1.5, 1.5) as f32)
            .collect();
        let (mut c64, mut c32) = (Columns::new(), Columns::<f32>::new());
        tape.eval_f64(lanes, |j, l| f64::from(x[l * n + j]), &mut c64);
        tape.eval_f32(lanes, |j, l| x[l * n + j], &mut c32);
        for l in 0..lanes {
            lanes_total += 1;
            let Some(e) = bounds(&tape, &c64, l) else {
                unbounded += 1;
                continue;
            };
            for s in tape.outputs() {
                let (a, b) = (c64.get(s, l), f64::from(c32.get(s, l)));
                assert!(
                    (a - b).abs() <= e[s],
                    "slot {s}: f64 {a:e}, f32 {b:e}, bound {:e}",
                    e[s]
                );
                if e[s] > 0.0 {
                    worst = worst.max((a - b).abs() / e[s]);
                }
                compared += 1;
            }
        }
    }
    eprintln!(
        "f32 vs f64: {compared} outputs, {unbounded}/{lanes_total} lanes unbounded, worst measured/bound {worst:.3}"
    );
    assert!(compared > 50_000, "{compared}");
    assert!(
        unbounded * 50 <= lanes_total,
        "{unbounded} of {lanes_total}"
    );
}

#[test]
fn blocks_equal_all_lanes_at_once_bit_for_bit() {
    use crate::expr::{BLOCK, Block};
    let mut rng = Rng(29);
    let mut compared = 0usize;
    for case in 0..24 {
        let (tape, n) = random_tape(&mut rng, case);
        // Whole blocks, a partial last block, and fewer lanes than a block.
        let lanes = [BLOCK + 37, 2 * BLOCK, 5][case % 3];
        let x: Vec<f64> = (0..n * lanes).map(|_| rng.uniform(-1.5, 1.5)).collect();
        let mut all = Columns::new();
        tape.eval_f64(lanes, |j, l| x[l * n + j], &mut all);
        let mut block = Block::<f64>::new();
        for first in (0..lanes).step_by(BLOCK) {
            let len = BLOCK.min(lanes - first);
            tape.eval_block(&mut block, |j, column| {
                for (l, c) in column[..len].iter_mut().enumerate() {
                    *c = x[(first + l) * n + j];
                }
            });
            for s in tape.outputs() {
                for l in 0..len {
                    assert_same(block.column(s)[l], all.get(s, first + l));
                    compared += 1;
                }
            }
        }
    }
    assert!(compared > 10_000, "{compared}");
}
