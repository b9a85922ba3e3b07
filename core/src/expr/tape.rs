//! A tape: the live part of the graph for the requested outputs, renumbered
//! in the graph's (topological) order, so dead code is gone and every
//! evaluator runs the ops in the same order.
//!
//! ```text
//! outputs: C;  C, ∇C;  or C, ∇C, ∇²C (upper triangle, row-major, n(n+1)/2)
//! live = every node an output reaches;  slot = rank of the node among the live
//! ```

use super::error::{ExprError, ExprErrorKind};
use super::graph::{Exhausted, Graph, Op, Slot};
use super::limits::{MAX_GRAPH_NODES, MAX_TAPE_OPS};

/// Which outputs a tape computes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Outputs {
    /// C.
    Value,
    /// C and ∇C.
    ValueGradient,
    /// C, ∇C and ∇²C.
    ValueGradientHessian,
}

/// A straight-line scalar program: `ops[i]` defines slot i from earlier
/// slots.
#[derive(Debug, Clone, PartialEq)]
pub struct Tape {
    /// The operations; slot i is the result of `ops[i]`.
    pub ops: Vec<Op>,
    /// Coordinates the tape reads: `Op::Input(j)` with j < `inputs` =
    /// arity·dim is coordinate a of particle p at j = p·dim + a; the
    /// derivatives are taken by these.
    pub inputs: usize,
    /// Per-element constants: `Op::Input(inputs + m)`, m < `constants`
    /// (no derivative is taken by them).
    pub constants: usize,
    /// The slot of C.
    pub value: Slot,
    /// ∂C/∂input_j at `gradient[j]` (empty unless asked for).
    pub gradient: Vec<Slot>,
    /// ∂²C/∂input_j∂input_k for k ≥ j, row-major: entry j·n − j(j−1)/2 + (k − j)
    /// (empty unless asked for).
    pub hessian: Vec<Slot>,
}

impl Tape {
    /// The outputs in order: value, gradient, Hessian (the layout of the
    /// emitted WGSL function's result array).
    pub fn outputs(&self) -> impl Iterator<Item = Slot> + '_ {
        std::iter::once(self.value)
            .chain(self.gradient.iter().copied())
            .chain(self.hessian.iter().copied())
    }

    /// Index of ∂²C/∂j∂k in [`Tape::hessian`] (either order).
    pub fn hessian_index(&self, j: usize, k: usize) -> usize {
        let (j, k) = (j.min(k), j.max(k));
        j * self.inputs - j * j.saturating_sub(1) / 2 + (k - j)
    }
}

pub(crate) fn too_large(what: &'static str, limit: usize) -> ExprError {
    ExprError {
        position: 0,
        line: 1,
        column: 1,
        kind: ExprErrorKind::TooLarge { what, limit },
    }
}

pub(crate) fn exhausted(_: Exhausted) -> ExprError {
    too_large("operation count of the derivatives", MAX_GRAPH_NODES)
}

/// The tape of `value`, `gradient` and `hessian` (graph slots; `None` = 0).
pub(crate) fn extract(
    graph: &Graph,
    (inputs, constants): (usize, usize),
    value: Slot,
    gradient: &[Option<Slot>],
    hessian: &[Option<Slot>],
) -> Result<Tape, ExprError> {
    let mut graph = graph.clone();
    let zero = graph.constant(0.0).map_err(exhausted)?;
    let slot = |s: Option<Slot>| s.unwrap_or(zero);
    let roots: Vec<Slot> = std::iter::once(value)
        .chain(gradient.iter().map(|&s| slot(s)))
        .chain(hessian.iter().map(|&s| slot(s)))
        .collect();
    let mut live = vec![false; graph.nodes.len()];
    for &r in &roots {
        live[r] = true;
    }
    for i in (0..graph.nodes.len()).rev() {
        if live[i] {
            for o in graph.nodes[i].operands() {
                live[o] = true;
            }
        }
    }
    let count = live.iter().filter(|&&l| l).count();
    if count > MAX_TAPE_OPS {
        return Err(too_large("operation count of a tape", MAX_TAPE_OPS));
    }
    let mut rank = vec![usize::MAX; graph.nodes.len()];
    let mut ops = Vec::with_capacity(count);
    for (i, op) in graph.nodes.iter().enumerate() {
        if live[i] {
            rank[i] = ops.len();
            ops.push(op.map(|o| rank[o]));
        }
    }
    let n_grad = gradient.len();
    Ok(Tape {
        ops,
        inputs,
        constants,
        value: rank[roots[0]],
        gradient: roots[1..1 + n_grad].iter().map(|&r| rank[r]).collect(),
        hessian: roots[1 + n_grad..].iter().map(|&r| rank[r]).collect(),
    })
}
