//! Reverse-mode differentiation of the scalar graph, in the graph itself:
//! the adjoints are new hash-consed nodes, so a derivative is a program of
//! the same operations, and differentiating it again gives the Hessian.
//!
//! ```text
//! ā_out = 1;  for each node i from the output down, with adjoint ā_i ≠ 0:
//!   a + b:  ā += ā_i;        b̄ += ā_i
//!   a − b:  ā += ā_i;        b̄ += −ā_i
//!   a · b:  ā += ā_i·b;      b̄ += ā_i·a
//!   y = a / b:  ā += ā_i / b;   b̄ += −((ā_i·y) / b)
//!   −a:     ā += −ā_i
//!   y = √a: ā += ā_i / (y + y)            (a = 0: ±∞ or NaN)
//!   |a|:    ā += (a < 0 ? −ā_i : ā_i)     (abs'(0) = +1)
//!   ln a:   ā += ā_i / a
//!   y = exp a: ā += ā_i·y
//!   select(l cmp r, t, f):  t̄ += (l cmp r ? ā_i : 0);  f̄ += (l cmp r ? 0 : ā_i)
//!           (the comparison is held fixed: min/max ties follow the branch
//!            taken, i.e. the first argument)
//! "+=" on a zero adjoint is the contribution itself (no 0 + x node).
//! ∇C_j = adjoint of input j (0 when the output does not depend on it)
//! ∇²C row j = the adjoints of input k in the reverse pass of ∇C_j
//! ```
//! Every pass visits each node at most once and adds at most five nodes per
//! visited node: a gradient is at most ~6× the value's size, a Hessian row
//! at most ~6× the gradient's.

use super::graph::{Built, Cmp, Graph, Op, Slot};

/// ∂output/∂input_j for the inputs `0..inputs` (nodes 0… are the inputs);
/// `None` where it is identically zero.
pub(crate) fn gradient(
    g: &mut Graph,
    output: Slot,
    inputs: usize,
) -> Result<Vec<Option<Slot>>, super::graph::Exhausted> {
    let mut adj: Vec<Option<Slot>> = vec![None; output + 1];
    adj[output] = Some(g.constant(1.0)?);
    for i in (0..=output).rev() {
        let Some(bar) = adj[i] else { continue };
        let op = g.nodes[i];
        match op {
            Op::Input(_) | Op::Const(_) => {}
            Op::Add(a, b) => {
                accumulate(g, &mut adj, a, Ok(bar))?;
                accumulate(g, &mut adj, b, Ok(bar))?;
            }
            Op::Sub(a, b) => {
                accumulate(g, &mut adj, a, Ok(bar))?;
                let c = g.neg(bar);
                accumulate(g, &mut adj, b, c)?;
            }
            Op::Mul(a, b) => {
                let c = g.mul(bar, b);
                accumulate(g, &mut adj, a, c)?;
                let c = g.mul(bar, a);
                accumulate(g, &mut adj, b, c)?;
            }
            Op::Div(a, b) => {
                let c = g.div(bar, b);
                accumulate(g, &mut adj, a, c)?;
                let t = g.mul(bar, i)?;
                let t = g.div(t, b)?;
                let c = g.neg(t);
                accumulate(g, &mut adj, b, c)?;
            }
            Op::Neg(a) => {
                let c = g.neg(bar);
                accumulate(g, &mut adj, a, c)?;
            }
            Op::Sqrt(a) => {
                let twice = g.add(i, i)?;
                let c = g.div(bar, twice);
                accumulate(g, &mut adj, a, c)?;
            }
            Op::Abs(a) => {
                let zero = g.constant(0.0)?;
                let minus = g.neg(bar)?;
                let c = g.select(Cmp::Lt, a, zero, minus, bar);
                accumulate(g, &mut adj, a, c)?;
            }
            Op::Ln(a) => {
                let c = g.div(bar, a);
                accumulate(g, &mut adj, a, c)?;
            }
            Op::Exp(a) => {
                let c = g.mul(bar, i);
                accumulate(g, &mut adj, a, c)?;
            }
            Op::Select(s) => {
                let zero = g.constant(0.0)?;
                let c = g.select(s.cmp, s.lhs, s.rhs, bar, zero);
                accumulate(g, &mut adj, s.then, c)?;
                let c = g.select(s.cmp, s.lhs, s.rhs, zero, bar);
                accumulate(g, &mut adj, s.otherwise, c)?;
            }
        }
    }
    Ok((0..inputs).map(|j| adj.get(j).copied().flatten()).collect())
}

fn accumulate(
    g: &mut Graph,
    adj: &mut [Option<Slot>],
    to: Slot,
    contribution: Built,
) -> Result<(), super::graph::Exhausted> {
    let c = contribution?;
    adj[to] = Some(match adj[to] {
        None => c,
        Some(prev) => g.add(prev, c)?,
    });
    Ok(())
}
