//! Column-wise evaluation of a [`Tape`]: one op over all lanes at a time
//! (a column per slot), so the dispatch cost is paid per op and per colour,
//! not per element, and each inner loop is a plain loop over contiguous
//! slices. f64 and f32 run the same ops in the same order.
//!
//! ```text
//! column s = [value of slot s in lane 0 … lanes − 1]     (slot-major storage)
//! Const c: c (f32: c rounded once, f64 → f32);  Input j: input(j, lane)
//! Ln, Exp: material::ln / ln_f32, expr::exp_f64 / exp_f32 (never a libm call)
//! Select: lhs < rhs (or ≤) ? then : otherwise (false for NaN)
//! ```
//! Memory: ops × lanes reals, kept in [`Columns`] and reused: after the
//! first call of a size, a call allocates nothing.

use super::exp::{exp_f32, exp_f64};
use super::graph::{Cmp, Op, Slot};
use super::tape::Tape;
use crate::material::{ln, ln_f32};
use std::ops::{Add, Div, Mul, Neg, Sub};

/// A precision the evaluator runs in (f64, f32).
pub trait Real:
    Copy
    + Default
    + PartialOrd
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
{
    /// A tape constant in this precision (rounded once).
    fn constant(c: f64) -> Self;
    /// Correctly rounded √.
    fn sqrt(self) -> Self;
    /// |·|.
    fn abs(self) -> Self;
    /// The project's arithmetic ln.
    fn ln(self) -> Self;
    /// The project's arithmetic exp.
    fn exp(self) -> Self;
}

impl Real for f64 {
    fn constant(c: f64) -> Self {
        c
    }
    fn sqrt(self) -> Self {
        f64::sqrt(self)
    }
    fn abs(self) -> Self {
        f64::abs(self)
    }
    fn ln(self) -> Self {
        ln(self)
    }
    fn exp(self) -> Self {
        exp_f64(self)
    }
}

impl Real for f32 {
    fn constant(c: f64) -> Self {
        c as f32
    }
    fn sqrt(self) -> Self {
        f32::sqrt(self)
    }
    fn abs(self) -> Self {
        f32::abs(self)
    }
    fn ln(self) -> Self {
        ln_f32(self)
    }
    fn exp(self) -> Self {
        exp_f32(self)
    }
}

/// The columns of one evaluation (scratch reused across calls).
#[derive(Debug, Clone, Default)]
pub struct Columns<R> {
    data: Vec<R>,
    lanes: usize,
}

impl<R: Real> Columns<R> {
    /// Empty scratch.
    pub fn new() -> Self {
        Columns {
            data: Vec::new(),
            lanes: 0,
        }
    }

    /// Lanes of the last evaluation.
    pub fn lanes(&self) -> usize {
        self.lanes
    }

    /// Slot `slot` in every lane.
    pub fn column(&self, slot: Slot) -> &[R] {
        &self.data[slot * self.lanes..(slot + 1) * self.lanes]
    }

    /// Slot `slot` in lane `lane`.
    pub fn get(&self, slot: Slot, lane: usize) -> R {
        self.data[slot * self.lanes + lane]
    }
}

fn unary<R: Real>(out: &mut [R], a: &[R], f: impl Fn(R) -> R) {
    for (o, &x) in out.iter_mut().zip(a) {
        *o = f(x);
    }
}

fn binary<R: Real>(out: &mut [R], a: &[R], b: &[R], f: impl Fn(R, R) -> R) {
    for ((o, &x), &y) in out.iter_mut().zip(a).zip(b) {
        *o = f(x, y);
    }
}

impl Tape {
    /// Evaluates every slot in f64 over `lanes` lanes; `input(j, lane)` is
    /// coordinate j of that lane's element. Read the outputs from `scratch`.
    pub fn eval_f64(
        &self,
        lanes: usize,
        input: impl Fn(usize, usize) -> f64,
        scratch: &mut Columns<f64>,
    ) {
        self.eval(lanes, input, scratch);
    }

    /// [`Tape::eval_f64`] in f32 (constants rounded once to f32).
    pub fn eval_f32(
        &self,
        lanes: usize,
        input: impl Fn(usize, usize) -> f32,
        scratch: &mut Columns<f32>,
    ) {
        self.eval(lanes, input, scratch);
    }

    /// Evaluates every slot in precision `R`.
    pub fn eval<R: Real>(
        &self,
        lanes: usize,
        input: impl Fn(usize, usize) -> R,
        scratch: &mut Columns<R>,
    ) {
        scratch.lanes = lanes;
        scratch.data.resize(self.ops.len() * lanes, R::default());
        let data = &mut scratch.data[..];
        for (i, op) in self.ops.iter().enumerate() {
            let (done, rest) = data.split_at_mut(i * lanes);
            let col = |s: Slot| &done[s * lanes..(s + 1) * lanes];
            apply(*op, &mut rest[..lanes], col, |j, out| {
                for (lane, o) in out.iter_mut().enumerate() {
                    *o = input(j, lane);
                }
            });
        }
    }
}

/// `op` over the lanes of `out`, its operands' columns read with `col`
/// (`Input(j)`: `input(j, out)`): the one place each op's arithmetic is
/// written, for the column and the block evaluator.
#[inline(always)]
pub(super) fn apply<'a, R: Real + 'a>(
    op: Op,
    out: &mut [R],
    col: impl Fn(Slot) -> &'a [R],
    input: impl FnOnce(usize, &mut [R]),
) {
    match op {
        Op::Input(j) => input(j, out),
        Op::Const(c) => out.fill(R::constant(c)),
        Op::Add(a, b) => binary(out, col(a), col(b), |x, y| x + y),
        Op::Sub(a, b) => binary(out, col(a), col(b), |x, y| x - y),
        Op::Mul(a, b) => binary(out, col(a), col(b), |x, y| x * y),
        Op::Div(a, b) => binary(out, col(a), col(b), |x, y| x / y),
        Op::Neg(a) => unary(out, col(a), |x| -x),
        Op::Sqrt(a) => unary(out, col(a), R::sqrt),
        Op::Abs(a) => unary(out, col(a), R::abs),
        Op::Ln(a) => unary(out, col(a), R::ln),
        Op::Exp(a) => unary(out, col(a), R::exp),
        Op::Select(s) => {
            let [l, r, t, f] = s.operands().map(col);
            let lanes_iter = out.iter_mut().zip(l).zip(r).zip(t).zip(f);
            match s.cmp {
                Cmp::Lt => {
                    for ((((o, &l), &r), &t), &f) in lanes_iter {
                        *o = if l < r { t } else { f };
                    }
                }
                Cmp::Le => {
                    for ((((o, &l), &r), &t), &f) in lanes_iter {
                        *o = if l <= r { t } else { f };
                    }
                }
            }
        }
    }
}
