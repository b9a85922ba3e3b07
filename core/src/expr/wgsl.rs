//! WGSL from a [`Tape`]: one function whose body is the tape's ops, one
//! `let` per slot, in order — the same operations as the CPU evaluators,
//! so on an adapter that neither contracts nor reorders (lavapipe) the
//! results are theirs bit for bit.
//!
//! ```text
//! fn NAME(x: array<T, K>, opaque: bool) -> array<T, M>   K = arity·dim + constants,  M = 1 + |∇C| + |∇²C|
//!   let v<i>: T = <op of earlier v's>;       generated identifiers only
//!   arithmetic:  let r<i> = <op>;  let v<i> = select(r<i>, −r<i>, opaque)
//!   (the host passes an `opaque` that is false at run time but unknown to
//!    the compiler, e.g. `arrayLength(&buffer) == 0u`: WGSL cannot forbid
//!    contraction or regrouping, and lavapipe (Mesa 22) regroups sums and
//!    fuses a·b + c across slots when it can see through them — measured:
//!    ~3 % of outputs off by an ulp without it; same trick as step.wgsl's
//!    `kept`)
//!   result = [C, ∇C…, ∇²C…]                    (Tape::outputs order)
//! constants: typed literals (`1.5lf`, `0.1f`), the shortest text of the
//!   value already rounded to T (so no abstract-float evaluation happens);
//!   a non-finite f32 constant is a bitcast
//! Ln, Exp → ln_real, exp_real of [`wgsl_support`] (never a built-in)
//! Select → select(otherwise, then, lhs < rhs)
//! ```
//! No name from the source reaches the output: params are constants,
//! bindings are slots.

use super::exp::{
    EXP_INV_LN2_F32, EXP_INV_LN2_F64, EXP_LN2_HI_F32, EXP_LN2_HI_F64, EXP_LN2_LO_F32,
    EXP_LN2_LO_F64, EXP_MAX_F32, EXP_MAX_F64, EXP_MIN_F32, EXP_MIN_F64, EXP_SERIES_F32,
    EXP_SERIES_F64,
};
use super::graph::{Cmp, Op};
use super::tape::Tape;
use crate::Precision;
use crate::material::{ATANH_SERIES, ATANH_TERMS_F32};
use std::fmt::Write;

const LN_F32: &str = include_str!("../../../shaders/ln_f32.wgsl");
const LN_F64: &str = include_str!("../../../shaders/ln_f64.wgsl");
const EXP_F32: &str = include_str!("../../../shaders/exp_f32.wgsl");
const EXP_F64: &str = include_str!("../../../shaders/exp_f64.wgsl");

/// The literal of `c` rounded to `precision`.
pub fn literal(c: f64, precision: Precision) -> String {
    match precision {
        Precision::F64 => format!("{c:?}lf"),
        Precision::F32 => {
            let v = c as f32;
            if v.is_finite() {
                format!("{v:?}f")
            } else {
                format!("bitcast<f32>({:#010x}u)", v.to_bits())
            }
        }
    }
}

/// The WGSL function `fn_name` (a WGSL identifier chosen by the host)
/// computing `tape`'s outputs in `precision`. Needs [`wgsl_support`]'s
/// `ln_real` / `exp_real` in the module when the tape has Ln / Exp.
pub fn emit_wgsl(tape: &Tape, fn_name: &str, precision: Precision) -> String {
    let t = precision.as_str();
    let outputs: Vec<usize> = tape.outputs().collect();
    let mut s = String::new();
    // Writing to a String cannot fail.
    let _ = writeln!(
        s,
        "// generated from an expression: {} ops, outputs [C, ∇C ({}), ∇²C ({})]\n\
         fn {fn_name}(x: array<{t}, {k}>, opaque: bool) -> array<{t}, {m}> {{",
        tape.ops.len(),
        tape.gradient.len(),
        tape.hessian.len(),
        k = (tape.inputs + tape.constants).max(1),
        m = outputs.len(),
    );
    for (i, op) in tape.ops.iter().enumerate() {
        // Arithmetic results pass through `select(r, −r, opaque)`: exactly r
        // at run time (the host passes false), but the optimiser cannot see
        // it, so it can neither regroup a sum nor fuse a·b + c across slots.
        let (rhs, arithmetic) = match *op {
            Op::Input(j) => (format!("x[{j}]"), false),
            Op::Const(c) => (literal(c, precision), false),
            Op::Add(a, b) => (format!("v{a} + v{b}"), true),
            Op::Sub(a, b) => (format!("v{a} - v{b}"), true),
            Op::Mul(a, b) => (format!("v{a} * v{b}"), true),
            Op::Div(a, b) => (format!("v{a} / v{b}"), true),
            Op::Neg(a) => (format!("-v{a}"), true),
            Op::Sqrt(a) => (format!("sqrt(v{a})"), true),
            Op::Abs(a) => (format!("abs(v{a})"), true),
            Op::Ln(a) => (format!("ln_real(v{a})"), true),
            Op::Exp(a) => (format!("exp_real(v{a})"), true),
            Op::Select(s) => {
                let c = match s.cmp {
                    Cmp::Lt => "<",
                    Cmp::Le => "<=",
                };
                let [lhs, rhs, then, otherwise] = s.operands();
                (
                    format!("select(v{otherwise}, v{then}, v{lhs} {c} v{rhs})"),
                    false,
                )
            }
        };
        if arithmetic {
            let _ = writeln!(
                s,
                "    let r{i}: {t} = {rhs};\n    let v{i}: {t} = select(r{i}, -r{i}, opaque);"
            );
        } else {
            let _ = writeln!(s, "    let v{i}: {t} = {rhs};");
        }
    }
    let list: Vec<String> = outputs.iter().map(|o| format!("v{o}")).collect();
    let _ = writeln!(
        s,
        "    return array<{t}, {}>({});\n}}",
        outputs.len(),
        list.join(", ")
    );
    s
}

/// `ln_real` and `exp_real` for `precision`: `shaders/ln_*.wgsl` and
/// `shaders/exp_*.wgsl` with their constants and Horner lines written from
/// the Rust tables (`material::ATANH_SERIES`, [`EXP_SERIES_F64`],
/// [`EXP_SERIES_F32`]), so the shader's constants are the CPU's bits.
pub fn wgsl_support(precision: Precision) -> String {
    let (ln, exp) = match precision {
        Precision::F64 => {
            let mut ln = format!("var poly: f64 = {:?};", ATANH_SERIES[0]);
            for c in &ATANH_SERIES[1..] {
                let _ = write!(ln, "\n    poly = poly * s2 + {c:?};");
            }
            let consts = [
                ("EXP_INV_LN2", EXP_INV_LN2_F64),
                ("EXP_LN2_HI", EXP_LN2_HI_F64),
                ("EXP_LN2_LO", EXP_LN2_LO_F64),
                ("EXP_MAX", EXP_MAX_F64),
                ("EXP_MIN", EXP_MIN_F64),
            ];
            let consts: Vec<String> = consts
                .iter()
                .map(|(n, v)| format!("const {n}: f64 = {};", literal(*v, precision)))
                .collect();
            let mut series = format!("var q: f64 = {};", literal(EXP_SERIES_F64[0], precision));
            for &c in &EXP_SERIES_F64[1..] {
                let _ = write!(series, "\n    q = q * r + {};", literal(c, precision));
            }
            (
                LN_F64.replacen("// ATANH_SERIES", &ln, 1),
                EXP_F64
                    .replacen("// EXP_CONSTANTS", &consts.join("\n"), 1)
                    .replacen("// EXP_SERIES", &series, 1),
            )
        }
        Precision::F32 => {
            let n = ATANH_SERIES.len();
            let terms = &ATANH_SERIES[n - ATANH_TERMS_F32..n - 1];
            let lit = |c: f64| format!("{:?}", f64::from(c as f32));
            let mut ln = format!("var poly: f32 = {};", lit(terms[0]));
            for &c in &terms[1..] {
                let _ = write!(ln, "\n    poly = poly * s2 + {};", lit(c));
            }
            let consts = [
                ("EXP_INV_LN2", EXP_INV_LN2_F32),
                ("EXP_LN2_HI", EXP_LN2_HI_F32),
                ("EXP_LN2_LO", EXP_LN2_LO_F32),
                ("EXP_MAX", EXP_MAX_F32),
                ("EXP_MIN", EXP_MIN_F32),
            ];
            let consts: Vec<String> = consts
                .iter()
                .map(|(n, v)| format!("const {n}: f32 = {};", literal(f64::from(*v), precision)))
                .collect();
            let mut series = format!(
                "var q: f32 = {};",
                literal(f64::from(EXP_SERIES_F32[0]), precision)
            );
            for &c in &EXP_SERIES_F32[1..] {
                let _ = write!(
                    series,
                    "\n    q = q * r + {};",
                    literal(f64::from(c), precision)
                );
            }
            (
                LN_F32.replacen("// ATANH_SERIES", &ln, 1),
                EXP_F32
                    .replacen("// EXP_CONSTANTS", &consts.join("\n"), 1)
                    .replacen("// EXP_SERIES", &series, 1),
            )
        }
    };
    format!("{ln}\n{exp}\n")
}
