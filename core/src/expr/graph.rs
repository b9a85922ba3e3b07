//! The scalar SSA graph: every value is one IEEE operation on earlier
//! values, shared by hash-consing (building an operation that already
//! exists returns the existing slot), so a `let` chain of n squarings is n
//! nodes and a derivative reuses what the value computed.
//!
//! ```text
//! node i = op(operands < i)        (topological by construction)
//! a + b, a · b: operands ordered (IEEE + and · commute exactly)
//! 1 · a = a,  −(−a) = a,  −c = the constant −c   (exact rewrites only)
//! ```
//! No other rewrite is made: no reassociation, no contraction, no folding
//! of inexact constant arithmetic, so every evaluator performs the same
//! operations on the same operands.

use std::collections::HashMap;

/// A value's index: a node of the graph, or a column of a [`super::Tape`].
pub type Slot = usize;

/// The comparison of a [`Op::Select`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Cmp {
    /// `lhs < rhs`.
    Lt,
    /// `lhs <= rhs`.
    Le,
}

/// One IEEE operation; operands are earlier slots.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Op {
    /// Input coordinate j·dim + a (particle j, axis a).
    Input(usize),
    /// A constant (f64; rounded once to f32 by the f32 evaluator and the
    /// f32 WGSL).
    Const(f64),
    /// a + b.
    Add(Slot, Slot),
    /// a − b.
    Sub(Slot, Slot),
    /// a · b.
    Mul(Slot, Slot),
    /// a / b.
    Div(Slot, Slot),
    /// −a.
    Neg(Slot),
    /// √a (correctly rounded).
    Sqrt(Slot),
    /// |a|.
    Abs(Slot),
    /// ln a: `material::ln` (f64), `material::ln_f32` (f32), `ln_real` (WGSL).
    Ln(Slot),
    /// exp a: `expr::exp_f64`, `expr::exp_f32`, `exp_real` (WGSL).
    Exp(Slot),
    /// `if lhs cmp rhs { then } else { otherwise }`.
    Select(Select),
}

/// `if lhs cmp rhs { then } else { otherwise }` (a NaN comparison is
/// false).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Select {
    /// The comparison.
    pub cmp: Cmp,
    /// Its left operand.
    pub lhs: Slot,
    /// Its right operand.
    pub rhs: Slot,
    /// The value when it holds.
    pub then: Slot,
    /// The value when it does not.
    pub otherwise: Slot,
}

impl Select {
    /// `cmp` over the operands `[lhs, rhs, then, otherwise]`.
    pub fn new(cmp: Cmp, [lhs, rhs, then, otherwise]: [Slot; 4]) -> Select {
        Select {
            cmp,
            lhs,
            rhs,
            then,
            otherwise,
        }
    }

    /// The operands `[lhs, rhs, then, otherwise]`.
    pub fn operands(&self) -> [Slot; 4] {
        [self.lhs, self.rhs, self.then, self.otherwise]
    }
}

impl Op {
    /// The operands, in order.
    pub fn operands(&self) -> impl Iterator<Item = Slot> {
        let (n, a) = match *self {
            Op::Input(_) | Op::Const(_) => (0, [0; 4]),
            Op::Neg(a) | Op::Sqrt(a) | Op::Abs(a) | Op::Ln(a) | Op::Exp(a) => (1, [a, 0, 0, 0]),
            Op::Add(a, b) | Op::Sub(a, b) | Op::Mul(a, b) | Op::Div(a, b) => (2, [a, b, 0, 0]),
            Op::Select(s) => (4, s.operands()),
        };
        a.into_iter().take(n)
    }

    /// The same operation on renamed operands.
    pub(crate) fn map(&self, f: impl Fn(Slot) -> Slot) -> Op {
        match *self {
            Op::Input(j) => Op::Input(j),
            Op::Const(c) => Op::Const(c),
            Op::Add(a, b) => Op::Add(f(a), f(b)),
            Op::Sub(a, b) => Op::Sub(f(a), f(b)),
            Op::Mul(a, b) => Op::Mul(f(a), f(b)),
            Op::Div(a, b) => Op::Div(f(a), f(b)),
            Op::Neg(a) => Op::Neg(f(a)),
            Op::Sqrt(a) => Op::Sqrt(f(a)),
            Op::Abs(a) => Op::Abs(f(a)),
            Op::Ln(a) => Op::Ln(f(a)),
            Op::Exp(a) => Op::Exp(f(a)),
            Op::Select(s) => Op::Select(Select::new(s.cmp, s.operands().map(f))),
        }
    }

    /// A hashable identity: tag, operands, constant bits.
    fn key(&self) -> [u64; 5] {
        let s = |a: Slot| a as u64;
        match *self {
            Op::Input(j) => [0, s(j), 0, 0, 0],
            Op::Const(c) => [1, c.to_bits(), 0, 0, 0],
            Op::Add(a, b) => [2, s(a), s(b), 0, 0],
            Op::Sub(a, b) => [3, s(a), s(b), 0, 0],
            Op::Mul(a, b) => [4, s(a), s(b), 0, 0],
            Op::Div(a, b) => [5, s(a), s(b), 0, 0],
            Op::Neg(a) => [6, s(a), 0, 0, 0],
            Op::Sqrt(a) => [7, s(a), 0, 0, 0],
            Op::Abs(a) => [8, s(a), 0, 0, 0],
            Op::Ln(a) => [9, s(a), 0, 0, 0],
            Op::Exp(a) => [10, s(a), 0, 0, 0],
            Op::Select(select) => {
                let tag = match select.cmp {
                    Cmp::Lt => 11,
                    Cmp::Le => 12,
                };
                let [l, r, t, f] = select.operands().map(s);
                [tag, l, r, t, f]
            }
        }
    }
}

/// The node budget ran out ([`super::limits::MAX_GRAPH_NODES`]).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Exhausted;

/// The hash-consed graph under construction.
#[derive(Debug, Clone, Default)]
pub(crate) struct Graph {
    pub(crate) nodes: Vec<Op>,
    intern: HashMap<[u64; 5], Slot>,
}

pub(crate) type Built = Result<Slot, Exhausted>;

impl Graph {
    /// The slot of `op`, shared if it exists.
    pub(crate) fn push(&mut self, op: Op) -> Built {
        let key = op.key();
        if let Some(&slot) = self.intern.get(&key) {
            return Ok(slot);
        }
        if self.nodes.len() >= super::limits::MAX_GRAPH_NODES {
            return Err(Exhausted);
        }
        self.nodes.push(op);
        self.intern.insert(key, self.nodes.len() - 1);
        Ok(self.nodes.len() - 1)
    }

    fn constant_of(&self, a: Slot) -> Option<f64> {
        match self.nodes[a] {
            Op::Const(c) => Some(c),
            _ => None,
        }
    }

    pub(crate) fn constant(&mut self, c: f64) -> Built {
        self.push(Op::Const(c))
    }

    pub(crate) fn add(&mut self, a: Slot, b: Slot) -> Built {
        self.push(Op::Add(a.min(b), a.max(b)))
    }

    pub(crate) fn sub(&mut self, a: Slot, b: Slot) -> Built {
        self.push(Op::Sub(a, b))
    }

    pub(crate) fn mul(&mut self, a: Slot, b: Slot) -> Built {
        if self.constant_of(a) == Some(1.0) {
            return Ok(b);
        }
        if self.constant_of(b) == Some(1.0) {
            return Ok(a);
        }
        self.push(Op::Mul(a.min(b), a.max(b)))
    }

    pub(crate) fn div(&mut self, a: Slot, b: Slot) -> Built {
        self.push(Op::Div(a, b))
    }

    pub(crate) fn neg(&mut self, a: Slot) -> Built {
        match self.nodes[a] {
            Op::Neg(inner) => Ok(inner),
            Op::Const(c) => self.constant(-c),
            _ => self.push(Op::Neg(a)),
        }
    }

    pub(crate) fn unary(&mut self, make: fn(Slot) -> Op, a: Slot) -> Built {
        self.push(make(a))
    }

    pub(crate) fn select(
        &mut self,
        cmp: Cmp,
        lhs: Slot,
        rhs: Slot,
        then: Slot,
        otherwise: Slot,
    ) -> Built {
        if then == otherwise {
            return Ok(then);
        }
        self.push(Op::Select(Select::new(cmp, [lhs, rhs, then, otherwise])))
    }
}
