//! The expression compiler: a constraint written once as a small typed
//! language, compiled to one scalar SSA program per (dimension, arity),
//! differentiated by program transformation, and run by three evaluators
//! that perform the same operation sequence: f64 and f32 on the CPU
//! (column-wise, [`Columns`]) and WGSL ([`emit_wgsl`]). The language and
//! its costs: `docs/expressions.md`.
//!
//! ```text
//! source ─lex/parse/type/unroll─▶ graph (hash-consed SSA; vectors = DIM scalars)
//!        ─reverse mode─▶ ∇C in the same graph ─reverse mode per ∇C_j─▶ ∇²C
//!        ─tape(outputs)─▶ live ops only ─▶ eval_f64 | eval_f32 | emit_wgsl
//! ```
//! Everything is linear in the source (bindings are slots, never re-expanded)
//! and bounded by [`limits`]: a hostile expression is refused with
//! [`ExprErrorKind::TooLarge`], never compiled in exponential time or memory.

mod block;
mod diff;
mod error;
mod eval;
mod exp;
mod functions;
mod graph;
mod lex;
mod parse;
mod tape;
mod wgsl;

pub use block::{BLOCK, Block, Column};
pub use error::{ExprError, ExprErrorKind, ValueType};
pub use eval::{Columns, Real};
pub use exp::{
    EXP_INV_LN2_F32, EXP_INV_LN2_F64, EXP_LN2_HI_F32, EXP_LN2_HI_F64, EXP_LN2_LO_F32,
    EXP_LN2_LO_F64, EXP_MAX_F32, EXP_MAX_F64, EXP_MIN_F32, EXP_MIN_F64, EXP_SERIES_F32,
    EXP_SERIES_F64, exp_f32, exp_f64,
};
pub use graph::{Cmp, Op, Select, Slot};
pub use tape::{Outputs, Tape};
pub use wgsl::{emit_wgsl, literal, wgsl_support};

/// The bounds every compilation stays within.
pub mod limits {
    /// Longest source, in characters.
    pub const MAX_SOURCE_CHARS: usize = 16_384;
    /// Most tokens in a source.
    pub const MAX_TOKENS: usize = 4_096;
    /// Most `let` bindings.
    pub const MAX_LETS: usize = 256;
    /// Deepest nesting of parentheses, calls and unary minus.
    pub const MAX_DEPTH: usize = 64;
    /// Largest determinant order (Laplace with shared minors: ≤ k·2^k products).
    pub const MAX_DET_ORDER: usize = 10;
    /// Largest arity (particles per element).
    pub const MAX_ARITY: usize = 64;
    /// Largest dimension.
    pub const MAX_DIM: usize = 256;
    /// Most nodes of the whole graph (value and derivatives together).
    pub const MAX_GRAPH_NODES: usize = 1_000_000;
    /// Most ops of one tape.
    pub const MAX_TAPE_OPS: usize = 250_000;
}

/// A param's value: a number or an N-vector.
#[derive(Debug, Clone, PartialEq)]
pub enum ParamValue {
    /// A number.
    Scalar(f64),
    /// An N-vector.
    Vector(Vec<f64>),
}

/// A compiled expression: the value and gradient graph (the Hessian is
/// derived on request by [`Compiled::tape`]).
#[derive(Debug, Clone)]
pub struct Compiled {
    graph: graph::Graph,
    inputs: usize,
    constants: usize,
    value: Slot,
    gradient: Vec<Option<Slot>>,
}

/// Sizes of a compiled expression, as `hyperpbd plan` prints them.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Stats {
    /// Inputs n = arity·dim.
    pub inputs: usize,
    /// Ops of the value tape.
    pub value_ops: usize,
    /// Ops of the value + gradient tape.
    pub gradient_ops: usize,
    /// Ops of the value + gradient + Hessian tape (`None`: over the limits).
    pub hessian_ops: Option<usize>,
    /// Gradient entries (n).
    pub gradient_size: usize,
    /// Hessian entries stored (upper triangle, n(n+1)/2).
    pub hessian_size: usize,
}

/// Compiles `src` for elements of `arity` particles in R^`dim`, with
/// `params` (in authored order) as constants.
pub fn compile(
    src: &str,
    params: &[(String, ParamValue)],
    arity: usize,
    dim: usize,
) -> Result<Compiled, ExprError> {
    compile_with_constants(src, params, &[], arity, dim)
}

/// [`compile`] with per-element constants: scalar names whose values each
/// element carries (tape inputs arity·dim + m, [`Tape::constants`]; the
/// derivatives are taken by the coordinates only).
pub fn compile_with_constants(
    src: &str,
    params: &[(String, ParamValue)],
    constants: &[&str],
    arity: usize,
    dim: usize,
) -> Result<Compiled, ExprError> {
    for (what, value, max) in [
        ("arity", arity, limits::MAX_ARITY),
        ("dim", dim, limits::MAX_DIM),
    ] {
        if value == 0 || value > max {
            return Err(ExprError::at(
                src,
                0,
                ExprErrorKind::Shape { what, value, max },
            ));
        }
    }
    let (mut graph, value) = parse::lower(src, params, constants, arity, dim)?;
    let inputs = arity * dim;
    let gradient = diff::gradient(&mut graph, value, inputs).map_err(tape::exhausted)?;
    let compiled = Compiled {
        graph,
        inputs,
        constants: constants.len(),
        value,
        gradient,
    };
    // The two tapes XPBD needs must fit.
    compiled.tape(Outputs::ValueGradient)?;
    Ok(compiled)
}

impl Compiled {
    /// Inputs n = arity·dim.
    pub fn inputs(&self) -> usize {
        self.inputs
    }

    /// Per-element constants m (tape inputs n … n + m − 1).
    pub fn constants(&self) -> usize {
        self.constants
    }

    /// The tape of `outputs`, dead code removed. Only the Hessian can fail
    /// (over [`limits::MAX_GRAPH_NODES`] or [`limits::MAX_TAPE_OPS`]).
    pub fn tape(&self, outputs: Outputs) -> Result<Tape, ExprError> {
        match outputs {
            Outputs::Value => tape::extract(&self.graph, self.shape(), self.value, &[], &[]),
            Outputs::ValueGradient => {
                tape::extract(&self.graph, self.shape(), self.value, &self.gradient, &[])
            }
            Outputs::ValueGradientHessian => {
                let mut graph = self.graph.clone();
                let n = self.inputs;
                let mut hessian = Vec::with_capacity(n * (n + 1) / 2);
                for j in 0..n {
                    match self.gradient[j] {
                        Some(g) => {
                            let row = diff::gradient(&mut graph, g, n).map_err(tape::exhausted)?;
                            hessian.extend_from_slice(&row[j..]);
                        }
                        None => hessian.extend(std::iter::repeat_n(None, n - j)),
                    }
                }
                tape::extract(&graph, self.shape(), self.value, &self.gradient, &hessian)
            }
        }
    }

    /// (inputs, constants) of every tape.
    fn shape(&self) -> (usize, usize) {
        (self.inputs, self.constants)
    }

    /// Op counts and derivative sizes.
    pub fn stats(&self) -> Stats {
        let ops = |o| self.tape(o).map(|t| t.ops.len());
        let n = self.inputs;
        Stats {
            inputs: n,
            value_ops: ops(Outputs::Value).unwrap_or(0),
            gradient_ops: ops(Outputs::ValueGradient).unwrap_or(0),
            hessian_ops: ops(Outputs::ValueGradientHessian).ok(),
            gradient_size: n,
            hessian_size: n * (n + 1) / 2,
        }
    }
}

#[cfg(test)]
pub(crate) mod tests;

/// Every ∂²C/∂j∂k (both triangles, row-major n×n) at `x`, each row from
/// its own reverse pass: the symmetry test compares the two triangles.
#[cfg(test)]
fn diff_full_hessian(c: &Compiled, x: &[f64]) -> Vec<f64> {
    let mut graph = c.graph.clone();
    let n = c.inputs;
    let mut entries = Vec::new();
    for j in 0..n {
        match c.gradient[j] {
            Some(g) => entries.extend(diff::gradient(&mut graph, g, n).expect("fits")),
            None => entries.extend(std::iter::repeat_n(None, n)),
        }
    }
    let t = tape::extract(&graph, c.shape(), c.value, &[], &entries).expect("fits");
    tests::eval_one(&t, x)[1..].to_vec()
}
