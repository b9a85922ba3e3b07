//! The WGSL emitter's text: no source name reaches it, constants are
//! typed literals that read back as the same bits, and the sizes
//! `docs/expressions.md` quotes.

use super::compiled;
use crate::Precision;
use crate::expr::{Outputs, ParamValue, literal};

#[test]
fn names_from_the_scene_never_reach_wgsl() {
    let params = vec![
        (
            "evil_param".to_string(),
            ParamValue::Vector(vec![1.0, 2.0, 3.0]),
        ),
        ("fn_main".to_string(), ParamValue::Scalar(0.5)),
    ];
    let src = "let injected_binding = x1 - x0; let other = dot(evil_param, injected_binding); \
               norm(injected_binding) * fn_main + ln(1 + other * other) + exp(-other)";
    let c = compiled(src, &params, 2, 3);
    for outputs in [
        Outputs::Value,
        Outputs::ValueGradient,
        Outputs::ValueGradientHessian,
    ] {
        let tape = c.tape(outputs).expect("tape");
        for precision in [Precision::F32, Precision::F64] {
            let text = crate::expr::emit_wgsl(&tape, "generated", precision);
            for name in ["evil_param", "fn_main", "injected_binding", "other"] {
                assert!(!text.contains(name), "{name} in\n{text}");
            }
        }
    }
}

#[test]
fn literals_read_back_as_the_same_bits() {
    let values = [
        0.0,
        -0.0,
        1.0,
        0.1,
        -2.5e-300,
        1.0 / 3.0,
        6.02214076e23,
        f64::MAX,
        f64::MIN_POSITIVE,
        1e39,
        1e-40,
    ];
    for &v in &values {
        let l = literal(v, Precision::F64);
        let text = l.strip_suffix("lf").expect("lf suffix");
        assert_eq!(
            text.parse::<f64>().expect("number").to_bits(),
            v.to_bits(),
            "{l}"
        );
        let l = literal(v, Precision::F32);
        let r = v as f32;
        if r.is_finite() {
            let text = l.strip_suffix('f').expect("f suffix");
            assert_eq!(
                text.parse::<f32>().expect("number").to_bits(),
                r.to_bits(),
                "{l}"
            );
        } else {
            assert_eq!(l, format!("bitcast<f32>({:#010x}u)", r.to_bits()));
        }
    }
}

#[test]
fn distance_sizes() {
    let c = compiled("norm(x1 - x0)", &[], 2, 3);
    let s = c.stats();
    assert_eq!((s.inputs, s.gradient_size, s.hessian_size), (6, 6, 21));
    // 6 inputs, 3 sub, 3 mul, 2 add, sqrt = 15 (quoted in the docs with
    // the derivative tapes' sizes).
    assert_eq!(s.value_ops, 15);
    assert_eq!((s.gradient_ops, s.hessian_ops), (27, Some(110)));
    eprintln!("norm(x1 - x0), R^3: {s:?}");
    assert_eq!(
        c.tape(Outputs::ValueGradient).expect("tape").ops.len(),
        s.gradient_ops
    );
}
