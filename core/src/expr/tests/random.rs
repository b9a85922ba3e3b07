//! A seeded generator of random well-typed expressions (deterministic:
//! xorshift64*), for derivative and evaluator tests here and in
//! `tests/gpu/expr_wgsl.rs` (which includes this file by path, so it depends on
//! nothing of the crate).

/// xorshift64* generator.
pub(crate) struct Rng(pub u64);

impl Rng {
    pub(crate) fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }

    pub(crate) fn below(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }

    /// Uniform in [lo, hi).
    pub(crate) fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * ((self.next() >> 11) as f64 / (1u64 << 53) as f64)
    }
}

/// A random scalar expression over x0 … x{arity−1} in R^dim, using every
/// construct of the language (divisions and logarithms kept away from 0,
/// exp from overflow), plus the param `c` (a vector).
pub(crate) fn scalar(rng: &mut Rng, depth: usize, arity: usize, dim: usize) -> String {
    if depth == 0 {
        return match rng.below(3) {
            0 => format!("{:.3}", rng.uniform(-2.0, 2.0)),
            _ => format!("x{}[{}]", rng.below(arity), rng.below(dim)),
        };
    }
    let d = depth - 1;
    macro_rules! s {
        () => {
            scalar(rng, d, arity, dim)
        };
    }
    match rng.below(17) {
        0 => format!("({} + {})", s!(), s!()),
        1 => format!("({} - {})", s!(), s!()),
        2 | 3 => format!("({} * {})", s!(), s!()),
        4 => format!("({} / (1.5 + {a} * {a}))", s!(), a = s!()),
        5 => format!("sqrt(1 + {a} * {a})", a = s!()),
        6 => format!("ln(0.5 + {a} * {a})", a = s!()),
        7 => format!("exp(0.25 * {})", s!()),
        8 => format!("min({}, {})", s!(), s!()),
        9 => format!("max({}, {})", s!(), s!()),
        10 => format!("abs({})", s!()),
        11 => format!("-{}", s!()),
        12 => format!(
            "dot({}, {})",
            vector(rng, d, arity, dim),
            vector(rng, d, arity, dim)
        ),
        13 => format!("norm({})", vector(rng, d, arity, dim)),
        14 => format!("({})[{}]", vector(rng, d, arity, dim), rng.below(dim)),
        15 if dim <= 4 => {
            let v: Vec<String> = (0..dim)
                .map(|_| vector(rng, d.min(1), arity, dim))
                .collect();
            format!("det({})", v.join(", "))
        }
        _ => s!(),
    }
}

/// A random vector expression.
pub(crate) fn vector(rng: &mut Rng, depth: usize, arity: usize, dim: usize) -> String {
    if depth == 0 {
        return match rng.below(4) {
            0 => "c".to_string(),
            _ => format!("x{}", rng.below(arity)),
        };
    }
    let d = depth - 1;
    match rng.below(6) {
        0 => format!(
            "({} + {})",
            vector(rng, d, arity, dim),
            vector(rng, d, arity, dim)
        ),
        1 => format!(
            "({} - {})",
            vector(rng, d, arity, dim),
            vector(rng, d, arity, dim)
        ),
        2 => format!(
            "{} * {}",
            scalar(rng, d, arity, dim),
            vector(rng, d, arity, dim)
        ),
        3 => format!(
            "{} / (2 + {a} * {a})",
            vector(rng, d, arity, dim),
            a = scalar(rng, d, arity, dim)
        ),
        4 => format!("-{}", vector(rng, d, arity, dim)),
        _ => format!("x{}", rng.below(arity)),
    }
}

/// A random program: two `let` bindings (one shadowing) and a result.
pub(crate) fn program(rng: &mut Rng, depth: usize, arity: usize, dim: usize) -> String {
    let a = scalar(rng, depth, arity, dim);
    let v = vector(rng, depth.min(2), arity, dim);
    let r = scalar(rng, depth, arity, dim);
    format!("let a = {a}; let v = {v}; let a = a * 0.5 + dot(v, c); {r} + a")
}

/// The value of the param `c` (a vector) used by [`program`].
pub(crate) fn param_c(dim: usize) -> Vec<f64> {
    (0..dim).map(|a| 0.25 * a as f64 - 0.3).collect()
}
