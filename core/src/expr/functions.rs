//! The built-in functions: their typing and their scalar programs.
//!
//! ```text
//! dot(v, w) = Σ_a v_a w_a (left to right);  norm(v) = √dot(v, v)
//! sqrt, abs, ln, exp: s → s;  min(a, b) = a ≤ b ? a : b;  max(a, b) = b ≤ a ? a : b
//! det(v1, …, vN): columns v_j;  det(s_1, …, s_{k²}): k×k, row by row
//! det by Laplace expansion along the rows, every minor (a set of columns)
//! built once: ≤ k·2^k products instead of k!
//! det(rows r…, cols S) = Σ_{c ∈ S, i-th} (−1)^i a[r][c]·det(rows r+1…, S∖{c})
//! ```

use super::error::{ExprError, ExprErrorKind};
use super::graph::{Built, Cmp, Exhausted, Op, Slot};
use super::lex::Token;
use super::limits::MAX_DET_ORDER;
use super::parse::{Parsed, Parser, Val};
use std::collections::HashMap;

/// A built-in function.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Function {
    Dot,
    Norm,
    Sqrt,
    Abs,
    Min,
    Max,
    Ln,
    Exp,
    Det,
}

/// The built-in function of `name` (the names are `lex::FUNCTION_NAMES`,
/// reserved: no `let` or param may take them).
fn function_of(name: &str) -> Option<Function> {
    Some(match name {
        "dot" => Function::Dot,
        "norm" => Function::Norm,
        "sqrt" => Function::Sqrt,
        "abs" => Function::Abs,
        "min" => Function::Min,
        "max" => Function::Max,
        "ln" => Function::Ln,
        "exp" => Function::Exp,
        "det" => Function::Det,
        _ => return None,
    })
}

impl Parser<'_> {
    pub(super) fn call(&mut self, name: String, at: usize) -> Parsed<Val> {
        let found = super::lex::FUNCTION_NAMES.iter().find(|n| **n == name);
        let Some((&function, f)) = found.and_then(|n| Some((n, function_of(n)?))) else {
            return Err(self.error_at(at, ExprErrorKind::UnknownName { name }));
        };
        self.enter()?;
        self.expect('(', "`(`")?;
        let mut args = vec![(self.position(), self.expr()?)];
        while self.peek() == &Token::Symbol(',') {
            self.next();
            args.push((self.position(), self.expr()?));
        }
        self.expect(')', "`,` or `)`")?;
        self.depth -= 1;
        let count = |n: usize, words: &str| -> Parsed<()> {
            if args.len() == n {
                Ok(())
            } else {
                Err(ExprError::at(
                    self.src,
                    at,
                    ExprErrorKind::ArgumentCount {
                        function,
                        expected: words.to_string(),
                        found: args.len(),
                    },
                ))
            }
        };
        let unary: fn(Slot) -> Op = match f {
            Function::Dot | Function::Norm => {
                let (v, w) = if f == Function::Dot {
                    count(2, "2 vectors")?;
                    (self.vector(&args[0])?, self.vector(&args[1])?)
                } else {
                    count(1, "1 vector")?;
                    (self.vector(&args[0])?, self.vector(&args[0])?)
                };
                let t = self.graph.mul(v[0], w[0]);
                let mut sum = self.built(t)?;
                for a in 1..v.len() {
                    let t = self.graph.mul(v[a], w[a]);
                    let t = self.built(t)?;
                    let s = self.graph.add(sum, t);
                    sum = self.built(s)?;
                }
                if f == Function::Norm {
                    let s = self.graph.unary(Op::Sqrt, sum);
                    sum = self.built(s)?;
                }
                return Ok(Val::S(sum));
            }
            Function::Min | Function::Max => {
                count(2, "2 scalars")?;
                let (a, b) = (self.scalar(&args[0])?, self.scalar(&args[1])?);
                // min: a ≤ b ? a : b;  max: b ≤ a ? a : b  (ties: a).
                let s = if f == Function::Min {
                    self.graph.select(Cmp::Le, a, b, a, b)
                } else {
                    self.graph.select(Cmp::Le, b, a, a, b)
                };
                return Ok(Val::S(self.built(s)?));
            }
            Function::Det => return self.det(args, at),
            Function::Sqrt => Op::Sqrt,
            Function::Abs => Op::Abs,
            Function::Ln => Op::Ln,
            Function::Exp => Op::Exp,
        };
        count(1, "1 scalar")?;
        let a = self.scalar(&args[0])?;
        let s = self.graph.unary(unary, a);
        Ok(Val::S(self.built(s)?))
    }

    fn det(&mut self, args: Vec<(usize, Val)>, at: usize) -> Parsed<Val> {
        let n = args.len();
        let miscount = ExprErrorKind::ArgumentCount {
            function: "det",
            expected: format!("{} vectors (N) or k² scalars", self.dim),
            found: n,
        };
        let (k, matrix) = match &args[0].1 {
            Val::V(_) => {
                if n != self.dim {
                    return Err(self.error_at(at, miscount));
                }
                let cols: Vec<Vec<Slot>> =
                    args.iter().map(|a| self.vector(a)).collect::<Parsed<_>>()?;
                (
                    n,
                    (0..n * n).map(|i| cols[i % n][i / n]).collect::<Vec<_>>(),
                )
            }
            Val::S(_) => {
                let k = (1..=n).find(|k| k * k >= n).unwrap_or(n);
                if k * k != n {
                    return Err(self.error_at(at, miscount));
                }
                let entries = args.iter().map(|a| self.scalar(a)).collect::<Parsed<_>>()?;
                (k, entries)
            }
        };
        if k > MAX_DET_ORDER {
            return Err(self.error_at(
                at,
                ExprErrorKind::TooLarge {
                    what: "determinant order",
                    limit: MAX_DET_ORDER,
                },
            ));
        }
        let mut memo = HashMap::new();
        let d = self.minor(&matrix, k, 0, (1u32 << k) - 1, &mut memo);
        Ok(Val::S(self.built(d)?))
    }

    /// det of rows row… and the columns in `cols` (a bit set), by Laplace
    /// expansion along row `row`; each minor built once.
    fn minor(
        &mut self,
        a: &[Slot],
        k: usize,
        row: usize,
        cols: u32,
        memo: &mut HashMap<u32, Slot>,
    ) -> Built {
        if let Some(&s) = memo.get(&cols) {
            return Ok(s);
        }
        if row + 1 == k {
            return Ok(a[row * k + cols.trailing_zeros() as usize]);
        }
        let mut acc: Option<Slot> = None;
        let mut sign_negative = false;
        for c in 0..k {
            if cols & (1 << c) == 0 {
                continue;
            }
            let m = self.minor(a, k, row + 1, cols & !(1 << c), memo)?;
            let term = self.graph.mul(a[row * k + c], m)?;
            acc = Some(match (acc, sign_negative) {
                (None, _) => term,
                (Some(s), false) => self.graph.add(s, term)?,
                (Some(s), true) => self.graph.sub(s, term)?,
            });
            sign_negative = !sign_negative;
        }
        let s = acc.ok_or(Exhausted)?;
        memo.insert(cols, s);
        Ok(s)
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn every_reserved_function_name_is_a_function() {
        for name in super::super::lex::FUNCTION_NAMES {
            assert!(super::function_of(name).is_some(), "{name}");
        }
        assert!(super::function_of("sin").is_none());
    }
}
