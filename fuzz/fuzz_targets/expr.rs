//! Arbitrary bytes through the expression compiler.
//!
//! ```text
//! bytes ─▶ (arity, dim, source) ─▶ expr::compile ─▶ tapes ─▶ eval_f64, eval_f32, emit_wgsl
//! ```
//! Compilation must answer with a program or a typed error (with a
//! position inside the source), never a panic, an abort or a hang; a
//! compiled program's tapes evaluate and emit without panicking.

#![no_main]

use hyperpbd_core::Precision;
use hyperpbd_core::expr::{Columns, Outputs, ParamValue, compile, emit_wgsl};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let [a, d, rest @ ..] = data else {
        return;
    };
    let Ok(src) = std::str::from_utf8(rest) else {
        return;
    };
    let (arity, dim) = (usize::from(a % 5), usize::from(d % 6));
    let params = vec![
        ("c".to_string(), ParamValue::Vector(vec![0.5; dim])),
        ("r".to_string(), ParamValue::Scalar(0.25)),
    ];
    let compiled = match compile(src, &params, arity, dim) {
        Ok(c) => c,
        Err(e) => {
            assert!(e.position <= src.chars().count(), "{e}");
            return;
        }
    };
    let _ = compiled.stats();
    for outputs in [Outputs::Value, Outputs::ValueGradient, Outputs::ValueGradientHessian] {
        let Ok(tape) = compiled.tape(outputs) else {
            continue;
        };
        if tape.ops.len() > 20_000 {
            continue;
        }
        let mut c64 = Columns::new();
        tape.eval_f64(3, |j, l| (j + l) as f64 * 0.37 - 1.0, &mut c64);
        let mut c32 = Columns::new();
        tape.eval_f32(3, |j, l| (j + l) as f32 * 0.37 - 1.0, &mut c32);
        let _ = emit_wgsl(&tape, "f", Precision::F32);
        let _ = emit_wgsl(&tape, "f", Precision::F64);
    }
});
