//! Every error kind with its exact position (char offset, line, column).

use super::super::limits::{MAX_DEPTH, MAX_LETS, MAX_SOURCE_CHARS, MAX_TOKENS};
use super::super::{ExprErrorKind as K, ParamValue, ValueType, compile};

fn vector(name: &str, n: usize) -> (String, ParamValue) {
    (name.to_string(), ParamValue::Vector(vec![1.0; n]))
}

/// (source, params, arity, dim, position, line, column, kind).
type Case<'a> = (
    &'a str,
    &'a Vec<(String, ParamValue)>,
    usize,
    usize,
    usize,
    usize,
    usize,
    K,
);

#[test]
fn each_error_kind_at_its_position() {
    use ValueType::{Scalar as S, Vector as V};
    let mismatch = |expected, found| K::TypeMismatch { expected, found };
    let none: Vec<(String, ParamValue)> = Vec::new();
    let c3 = vec![vector("c", 3)];
    // (source, params, arity, dim, position, line, column, kind)
    let table: Vec<Case> = vec![
        (
            "norm(x1 - y)",
            &none,
            2,
            3,
            10,
            1,
            11,
            K::UnknownName { name: "y".into() },
        ),
        (
            "foo(x0)",
            &none,
            1,
            3,
            0,
            1,
            1,
            K::UnknownName { name: "foo".into() },
        ),
        (
            "norm(x3 - x0)",
            &none,
            2,
            3,
            5,
            1,
            6,
            K::ParticleOutOfRange { index: 3, arity: 2 },
        ),
        ("norm(x1 - x0) + x0", &none, 2, 3, 16, 1, 17, mismatch(S, V)),
        ("x0 + 1", &none, 1, 3, 5, 1, 6, mismatch(V, S)),
        ("x0 * x1", &none, 2, 3, 5, 1, 6, mismatch(S, V)),
        ("1 / x1", &none, 2, 3, 4, 1, 5, mismatch(S, V)),
        ("x1 - x0", &none, 2, 3, 0, 1, 1, mismatch(S, V)),
        (
            "let d = x1 - x0;\n  d",
            &none,
            2,
            3,
            19,
            2,
            3,
            mismatch(S, V),
        ),
        ("norm(1)", &none, 1, 3, 5, 1, 6, mismatch(V, S)),
        ("sqrt(x0)", &none, 1, 3, 5, 1, 6, mismatch(S, V)),
        ("dot(x0, 2)", &none, 1, 3, 8, 1, 9, mismatch(V, S)),
        ("(1 + 2)[0]", &none, 1, 3, 0, 1, 1, mismatch(V, S)),
        (
            "x0[3]",
            &none,
            1,
            3,
            3,
            1,
            4,
            K::IndexOutOfRange { index: 3, dim: 3 },
        ),
        (
            "det(x1 - x0, x2 - x0)",
            &none,
            3,
            3,
            0,
            1,
            1,
            K::ArgumentCount {
                function: "det",
                expected: "3 vectors (N) or k² scalars".into(),
                found: 2,
            },
        ),
        (
            "1 + det(1, 2, 3)",
            &none,
            1,
            2,
            4,
            1,
            5,
            K::ArgumentCount {
                function: "det",
                expected: "2 vectors (N) or k² scalars".into(),
                found: 3,
            },
        ),
        ("det(x0, 1)", &none, 1, 2, 8, 1, 9, mismatch(V, S)),
        (
            "min(1)",
            &none,
            1,
            2,
            0,
            1,
            1,
            K::ArgumentCount {
                function: "min",
                expected: "2 scalars".into(),
                found: 1,
            },
        ),
        (
            "dot(c, x0)",
            &c3,
            1,
            2,
            4,
            1,
            5,
            K::ParamLength {
                name: "c".into(),
                expected: 2,
                found: 3,
            },
        ),
        (
            "norm(x0 -)",
            &none,
            1,
            3,
            9,
            1,
            10,
            K::Syntax {
                expected: "a number, a name, `-` or `(`",
                found: "`)`".into(),
            },
        ),
        (
            "1 2",
            &none,
            1,
            3,
            2,
            1,
            3,
            K::Syntax {
                expected: "an operator or end of input",
                found: "number `2`".into(),
            },
        ),
        (
            "let a = 1 a",
            &none,
            1,
            3,
            10,
            1,
            11,
            K::Syntax {
                expected: "`;`",
                found: "`a`".into(),
            },
        ),
        (
            "x0[1.5]",
            &none,
            1,
            3,
            3,
            1,
            4,
            K::Syntax {
                expected: "an integer index",
                found: "number `1.5`".into(),
            },
        ),
        (
            "1 $ 2",
            &none,
            1,
            3,
            2,
            1,
            3,
            K::Syntax {
                expected: "a number, a name or one of + - * / ( ) [ ] , ; =",
                found: "`$`".into(),
            },
        ),
        (
            "1e999",
            &none,
            1,
            3,
            0,
            1,
            1,
            K::Syntax {
                expected: "a finite number",
                found: "`1e999`".into(),
            },
        ),
        (
            "let x1 = 2; 1",
            &none,
            2,
            3,
            4,
            1,
            5,
            K::ReservedName { name: "x1".into() },
        ),
        (
            "let norm = 2; 1",
            &none,
            2,
            3,
            4,
            1,
            5,
            K::ReservedName {
                name: "norm".into(),
            },
        ),
        (
            "1",
            &none,
            0,
            3,
            0,
            1,
            1,
            K::Shape {
                what: "arity",
                value: 0,
                max: 64,
            },
        ),
    ];
    for (src, params, arity, dim, position, line, column, kind) in table {
        let e = compile(src, params, arity, dim)
            .err()
            .unwrap_or_else(|| panic!("{src}: compiled"));
        assert_eq!(
            (e.position, e.line, e.column, &e.kind),
            (position, line, column, &kind),
            "{src}: {e}"
        );
    }
}

#[test]
fn display_names_the_position() {
    let e = compile("norm(y)", &[], 1, 3).expect_err("error");
    assert_eq!(e.to_string(), "at 1:6: unknown name `y`");
}

#[test]
fn params_are_checked() {
    let bad =
        |params: Vec<(String, ParamValue)>| compile("1", &params, 1, 2).expect_err("error").kind;
    assert!(matches!(bad(vec![vector("x0", 2)]), K::InvalidParam { .. }));
    assert!(matches!(
        bad(vec![vector("a b", 2)]),
        K::InvalidParam { .. }
    ));
    assert!(matches!(
        bad(vec![vector("c", 2), vector("c", 2)]),
        K::InvalidParam { .. }
    ));
    assert!(matches!(
        bad(vec![("s".into(), ParamValue::Scalar(f64::NAN))]),
        K::InvalidParam { .. }
    ));
    assert!(matches!(bad(vec![vector("c", 1)]), K::ParamLength { .. }));
}

#[test]
fn hostile_sizes_are_refused() {
    let too_large = |src: &str| match compile(src, &[], 2, 3) {
        Err(e) => match e.kind {
            K::TooLarge { what, limit } => (what, limit, e.position),
            other => panic!("{other}"),
        },
        Ok(_) => panic!("compiled"),
    };
    let long = "1+".repeat(MAX_SOURCE_CHARS / 2) + "1";
    assert_eq!(
        too_large(&long),
        (
            "source length (characters)",
            MAX_SOURCE_CHARS,
            MAX_SOURCE_CHARS
        )
    );
    let tokens = "1 + ".repeat(MAX_TOKENS / 2 + 1) + "1";
    assert_eq!(too_large(&tokens).0, "token count");
    let deep = "(".repeat(MAX_DEPTH + 1) + "1" + &")".repeat(MAX_DEPTH + 1);
    assert_eq!(too_large(&deep), ("nesting depth", MAX_DEPTH, MAX_DEPTH));
    let minus = "-".repeat(MAX_DEPTH + 1) + "1";
    assert_eq!(too_large(&minus).0, "nesting depth");
    let lets = "let a = 1; ".repeat(MAX_LETS + 1) + "a";
    assert_eq!(too_large(&lets), ("`let` count", MAX_LETS, 11 * MAX_LETS));
    assert_eq!(
        compile("det(x0, x1, x0)", &[], 2, 11).err().map(|e| e.kind),
        Some(K::ArgumentCount {
            function: "det",
            expected: "11 vectors (N) or k² scalars".into(),
            found: 3,
        })
    );
    let det11 = format!("det({})", ["x0"; 11].join(", "));
    assert_eq!(
        compile(&det11, &[], 1, 11).err().map(|e| e.kind),
        Some(K::TooLarge {
            what: "determinant order",
            limit: 10
        })
    );
}

#[test]
fn sixty_squarings_compile_in_linear_size() {
    for n in [10, 20, 60] {
        let src = format!("let a = norm(x1 - x0);{} a", " let a = a * a;".repeat(n));
        let c = compile(&src, &[], 2, 3).expect("compiles");
        let s = c.stats();
        // value: 6 inputs, 3 sub, 3 mul, 2 add, sqrt, n squarings.
        assert_eq!(s.value_ops, 15 + n, "{s:?}");
        assert!(s.gradient_ops <= 6 * s.value_ops, "{s:?}");
        let h = s.hessian_ops.expect("Hessian fits");
        assert!(h <= 6 * 6 * s.value_ops * 4, "{s:?}");
    }
}
