//! Tests of the expression compiler (no GPU): errors and their positions,
//! derivatives against finite differences, the built-in kinds written as
//! expressions, the evaluators against each other. `tests/gpu/expr_wgsl.rs`
//! holds WGSL to them bit for bit.

mod builtins;
mod derivatives;
mod emit;
mod errors;
mod evaluators;
pub(crate) mod random;

use super::{Columns, Compiled, Outputs, ParamValue, Tape, compile};

/// Compiles or panics with the error.
pub(crate) fn compiled(
    src: &str,
    params: &[(String, ParamValue)],
    arity: usize,
    dim: usize,
) -> Compiled {
    compile(src, params, arity, dim).unwrap_or_else(|e| panic!("{src}: {e}"))
}

/// The outputs of `tape` at `x` (one lane, f64): value, gradient, Hessian.
pub(crate) fn eval_one(tape: &Tape, x: &[f64]) -> Vec<f64> {
    let mut cols = Columns::new();
    tape.eval_f64(1, |j, _| x[j], &mut cols);
    tape.outputs().map(|s| cols.get(s, 0)).collect()
}

/// The param list of [`random::program`]: `c`, a vector.
pub(crate) fn params(dim: usize) -> Vec<(String, ParamValue)> {
    vec![("c".to_string(), ParamValue::Vector(random::param_c(dim)))]
}

/// The value + gradient + Hessian tape.
pub(crate) fn full(c: &Compiled) -> Tape {
    c.tape(Outputs::ValueGradientHessian).expect("Hessian tape")
}
