//! Parse, type-check and unroll in one pass: each construct becomes its
//! scalar operations in the hash-consed [`Graph`] as soon as it is read
//! (vectors are `dim` slots), so a `let` binds slots, never text, and the
//! program is linear in the source.
//!
//! ```text
//! program = ("let" name "=" expr ";")* expr          (the result: a scalar)
//! expr    = term (("+" | "-") term)*
//! term    = unary (("*" | "/") unary)*
//! unary   = "-" unary | postfix
//! postfix = primary ("[" integer "]")*
//! primary = number | name | name "(" expr ("," expr)* ")" | "(" expr ")"
//!
//! s ± s, v ± v;  s·s, s·v, v·s;  s/s, v/s;  −s, −v;  v[i] (i < N)
//! dot(v, v) = Σ_a v_a w_a (a = 0 … N−1, left to right);  norm(v) = √dot(v, v)
//! sqrt, abs, ln, exp: s → s;  min, max: (s, s) → s
//! det(v1, …, vN) = det[v1 … vN] (columns);  det(s_1, …, s_{k²}) = det of the
//!   k×k matrix given row by row;  Laplace expansion along the rows with
//!   every minor built once (≤ k·2^k products)
//! ```

use super::ParamValue;
use super::error::{ExprError, ExprErrorKind, ValueType};
use super::graph::{Built, Exhausted, Graph, Op, Slot};
use super::lex::{Token, is_function, tokens};
use super::limits::{MAX_DEPTH, MAX_GRAPH_NODES, MAX_LETS};
use std::collections::HashMap;

#[derive(Debug, Clone)]
pub(super) enum Val {
    S(Slot),
    V(Vec<Slot>),
}

impl Val {
    pub(super) fn ty(&self) -> ValueType {
        match self {
            Val::S(_) => ValueType::Scalar,
            Val::V(_) => ValueType::Vector,
        }
    }
}

/// `x<digits>`: a particle name, with its index.
pub(crate) fn particle_index(name: &str) -> Option<usize> {
    let digits = name.strip_prefix('x')?;
    if digits.is_empty() || !digits.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    Some(digits.parse().unwrap_or(usize::MAX))
}

fn is_identifier(name: &str) -> bool {
    let mut chars = name.chars();
    chars
        .next()
        .is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
        && chars.all(|c| c.is_ascii_alphanumeric() || c == '_')
}

/// Whether `name` is a particle, a function or `let`.
fn reserved(name: &str) -> bool {
    name == "let" || particle_index(name).is_some() || is_function(name)
}

pub(super) struct Parser<'a> {
    pub(super) src: &'a str,
    pub(super) toks: Vec<(Token, usize)>,
    pub(super) at: usize,
    pub(super) depth: usize,
    pub(super) graph: Graph,
    pub(super) arity: usize,
    pub(super) dim: usize,
    pub(super) params: HashMap<&'a str, Val>,
    pub(super) lets: Vec<(String, Val)>,
}

pub(super) type Parsed<T> = Result<T, ExprError>;

/// The graph of `src` (inputs are nodes 0 … arity·dim − 1, then the
/// per-element constants `constants`, scalars, at arity·dim + m) and the
/// slot of its scalar result.
pub(crate) fn lower(
    src: &str,
    params: &[(String, ParamValue)],
    constants: &[&str],
    arity: usize,
    dim: usize,
) -> Parsed<(Graph, Slot)> {
    let toks = tokens(src)?;
    let mut p = Parser {
        src,
        toks,
        at: 0,
        depth: 0,
        graph: Graph::default(),
        arity,
        dim,
        params: HashMap::new(),
        lets: Vec::new(),
    };
    for j in 0..arity * dim {
        let s = p.graph.push(Op::Input(j));
        p.built(s)?;
    }
    p.bind_params(params)?;
    p.bind_constants(constants)?;
    let mut count = 0;
    while p.peek() == &Token::Name("let".into()) {
        count += 1;
        if count > MAX_LETS {
            return Err(p.error(ExprErrorKind::TooLarge {
                what: "`let` count",
                limit: MAX_LETS,
            }));
        }
        p.next();
        let (name, at) = match p.next() {
            (Token::Name(name), at) => (name, at),
            (other, at) => {
                return Err(p.error_at(
                    at,
                    ExprErrorKind::Syntax {
                        expected: "a name after `let`",
                        found: other.describe(),
                    },
                ));
            }
        };
        if reserved(&name) {
            return Err(p.error_at(at, ExprErrorKind::ReservedName { name }));
        }
        p.expect('=', "`=`")?;
        let value = p.expr()?;
        p.expect(';', "`;`")?;
        p.lets.push((name, value));
    }
    let start = p.position();
    let result = p.expr()?;
    if p.peek() != &Token::End {
        let found = p.peek().describe();
        return Err(p.error(ExprErrorKind::Syntax {
            expected: "an operator or end of input",
            found,
        }));
    }
    match result {
        Val::S(s) => Ok((p.graph, s)),
        Val::V(_) => Err(p.error_at(
            start,
            ExprErrorKind::TypeMismatch {
                expected: ValueType::Scalar,
                found: ValueType::Vector,
            },
        )),
    }
}

impl<'a> Parser<'a> {
    pub(super) fn peek(&self) -> &Token {
        &self.toks[self.at].0
    }

    pub(super) fn position(&self) -> usize {
        self.toks[self.at].1
    }

    pub(super) fn next(&mut self) -> (Token, usize) {
        let t = self.toks[self.at].clone();
        if self.at + 1 < self.toks.len() {
            self.at += 1;
        }
        t
    }

    pub(super) fn error_at(&self, at: usize, kind: ExprErrorKind) -> ExprError {
        ExprError::at(self.src, at, kind)
    }

    pub(super) fn error(&self, kind: ExprErrorKind) -> ExprError {
        self.error_at(self.position(), kind)
    }

    pub(super) fn built(&self, b: Built) -> Parsed<Slot> {
        b.map_err(|Exhausted| {
            self.error(ExprErrorKind::TooLarge {
                what: "operation count",
                limit: MAX_GRAPH_NODES,
            })
        })
    }

    pub(super) fn expect(&mut self, c: char, expected: &'static str) -> Parsed<()> {
        if self.peek() == &Token::Symbol(c) {
            self.next();
            Ok(())
        } else {
            let found = self.peek().describe();
            Err(self.error(ExprErrorKind::Syntax { expected, found }))
        }
    }

    /// Per-element constants become inputs arity·dim + m (scalars, read
    /// per element like the coordinates; no derivative is taken by them).
    fn bind_constants(&mut self, constants: &[&'a str]) -> Parsed<()> {
        let base = self.arity * self.dim;
        for (m, &name) in constants.iter().enumerate() {
            self.check_name(name)?;
            let s = self.graph.push(Op::Input(base + m));
            let slot = self.built(s)?;
            self.params.insert(name, Val::S(slot));
        }
        Ok(())
    }

    /// Where `name` is first used, and an error if it cannot name a param
    /// or a per-element constant (not an identifier, reserved, given twice).
    fn check_name(&self, name: &str) -> Parsed<usize> {
        let at = self
            .toks
            .iter()
            .find(|(t, _)| matches!(t, Token::Name(n) if n == name))
            .map_or(0, |&(_, at)| at);
        let invalid = |reason| ExprErrorKind::InvalidParam {
            name: name.to_string(),
            reason,
        };
        if !is_identifier(name) {
            return Err(self.error_at(at, invalid("not a name ([A-Za-z_][A-Za-z0-9_]*)")));
        }
        if reserved(name) {
            return Err(self.error_at(at, invalid("reserved (a particle, a function or `let`)")));
        }
        if self.params.contains_key(name) {
            return Err(self.error_at(at, invalid("given twice")));
        }
        Ok(at)
    }

    /// Params become constants; their errors point at their first use.
    fn bind_params(&mut self, params: &'a [(String, ParamValue)]) -> Parsed<()> {
        for (name, value) in params {
            let at = self.check_name(name)?;
            let invalid = |reason| ExprErrorKind::InvalidParam {
                name: name.clone(),
                reason,
            };
            let val = match value {
                ParamValue::Scalar(v) => {
                    if !v.is_finite() {
                        return Err(self.error_at(at, invalid("not finite")));
                    }
                    Val::S({
                        let t = self.graph.constant(*v);
                        self.built(t)
                    }?)
                }
                ParamValue::Vector(v) => {
                    if v.len() != self.dim {
                        return Err(self.error_at(
                            at,
                            ExprErrorKind::ParamLength {
                                name: name.clone(),
                                expected: self.dim,
                                found: v.len(),
                            },
                        ));
                    }
                    if !v.iter().all(|c| c.is_finite()) {
                        return Err(self.error_at(at, invalid("not finite")));
                    }
                    let mut slots = Vec::with_capacity(v.len());
                    for &c in v {
                        let s = self.graph.constant(c);
                        slots.push(self.built(s)?);
                    }
                    Val::V(slots)
                }
            };
            self.params.insert(name, val);
        }
        Ok(())
    }

    pub(super) fn enter(&mut self) -> Parsed<()> {
        self.depth += 1;
        if self.depth > MAX_DEPTH {
            return Err(self.error(ExprErrorKind::TooLarge {
                what: "nesting depth",
                limit: MAX_DEPTH,
            }));
        }
        Ok(())
    }

    pub(super) fn expr(&mut self) -> Parsed<Val> {
        self.enter()?;
        let mut left = self.term()?;
        while let Token::Symbol(op @ ('+' | '-')) = *self.peek() {
            self.next();
            let at = self.position();
            let right = self.term()?;
            left = self.additive(op, left, right, at)?;
        }
        self.depth -= 1;
        Ok(left)
    }

    fn additive(&mut self, op: char, left: Val, right: Val, at: usize) -> Parsed<Val> {
        let f = |g: &mut Graph, a, b| if op == '+' { g.add(a, b) } else { g.sub(a, b) };
        match (left, right) {
            (Val::S(a), Val::S(b)) => Ok(Val::S({
                let t = f(&mut self.graph, a, b);
                self.built(t)
            }?)),
            (Val::V(a), Val::V(b)) => {
                let mut out = Vec::with_capacity(a.len());
                for (&x, &y) in a.iter().zip(&b) {
                    out.push({
                        let t = f(&mut self.graph, x, y);
                        self.built(t)
                    }?);
                }
                Ok(Val::V(out))
            }
            (l, r) => Err(self.error_at(
                at,
                ExprErrorKind::TypeMismatch {
                    expected: l.ty(),
                    found: r.ty(),
                },
            )),
        }
    }

    fn term(&mut self) -> Parsed<Val> {
        let mut left = self.unary()?;
        while let Token::Symbol(op @ ('*' | '/')) = *self.peek() {
            self.next();
            let at = self.position();
            let right = self.unary()?;
            left = self.multiplicative(op, left, right, at)?;
        }
        Ok(left)
    }

    fn multiplicative(&mut self, op: char, left: Val, right: Val, at: usize) -> Parsed<Val> {
        let f = |g: &mut Graph, a, b| if op == '*' { g.mul(a, b) } else { g.div(a, b) };
        match (left, right) {
            (Val::S(a), Val::S(b)) => Ok(Val::S({
                let t = f(&mut self.graph, a, b);
                self.built(t)
            }?)),
            (Val::V(v), Val::S(s)) => {
                let mut out = Vec::with_capacity(v.len());
                for &x in &v {
                    out.push({
                        let t = f(&mut self.graph, x, s);
                        self.built(t)
                    }?);
                }
                Ok(Val::V(out))
            }
            (Val::S(s), Val::V(v)) if op == '*' => {
                let mut out = Vec::with_capacity(v.len());
                for &x in &v {
                    out.push({
                        let t = self.graph.mul(s, x);
                        self.built(t)
                    }?);
                }
                Ok(Val::V(out))
            }
            (_, right) => Err(self.error_at(
                at,
                ExprErrorKind::TypeMismatch {
                    expected: ValueType::Scalar,
                    found: right.ty(),
                },
            )),
        }
    }

    fn unary(&mut self) -> Parsed<Val> {
        if self.peek() == &Token::Symbol('-') {
            self.enter()?;
            self.next();
            let v = self.unary()?;
            self.depth -= 1;
            return match v {
                Val::S(a) => Ok(Val::S({
                    let t = self.graph.neg(a);
                    self.built(t)
                }?)),
                Val::V(v) => {
                    let mut out = Vec::with_capacity(v.len());
                    for &x in &v {
                        out.push({
                            let t = self.graph.neg(x);
                            self.built(t)
                        }?);
                    }
                    Ok(Val::V(out))
                }
            };
        }
        self.postfix()
    }

    fn postfix(&mut self) -> Parsed<Val> {
        let start = self.position();
        let mut v = self.primary()?;
        while self.peek() == &Token::Symbol('[') {
            self.next();
            let (tok, at) = self.next();
            let index = match &tok {
                Token::Number(_, text) if text.bytes().all(|b| b.is_ascii_digit()) => {
                    text.parse::<usize>().unwrap_or(usize::MAX)
                }
                other => {
                    return Err(self.error_at(
                        at,
                        ExprErrorKind::Syntax {
                            expected: "an integer index",
                            found: other.describe(),
                        },
                    ));
                }
            };
            self.expect(']', "`]`")?;
            v = match v {
                Val::V(c) => match c.get(index) {
                    Some(&s) => Val::S(s),
                    None => {
                        return Err(self.error_at(
                            at,
                            ExprErrorKind::IndexOutOfRange {
                                index,
                                dim: self.dim,
                            },
                        ));
                    }
                },
                Val::S(_) => {
                    return Err(self.error_at(
                        start,
                        ExprErrorKind::TypeMismatch {
                            expected: ValueType::Vector,
                            found: ValueType::Scalar,
                        },
                    ));
                }
            };
        }
        Ok(v)
    }

    fn primary(&mut self) -> Parsed<Val> {
        let (tok, at) = self.next();
        match tok {
            Token::Number(v, _) => Ok(Val::S({
                let t = self.graph.constant(v);
                self.built(t)
            }?)),
            Token::Symbol('(') => {
                let v = self.expr()?;
                self.expect(')', "`)`")?;
                Ok(v)
            }
            Token::Name(name) if self.peek() == &Token::Symbol('(') => self.call(name, at),
            Token::Name(name) => self.name(name, at),
            other => Err(self.error_at(
                at,
                ExprErrorKind::Syntax {
                    expected: "a number, a name, `-` or `(`",
                    found: other.describe(),
                },
            )),
        }
    }

    fn name(&mut self, name: String, at: usize) -> Parsed<Val> {
        if let Some((_, v)) = self.lets.iter().rev().find(|(n, _)| *n == name) {
            return Ok(v.clone());
        }
        if let Some(v) = self.params.get(name.as_str()) {
            return Ok(v.clone());
        }
        if let Some(index) = particle_index(&name) {
            if index >= self.arity {
                return Err(self.error_at(
                    at,
                    ExprErrorKind::ParticleOutOfRange {
                        index,
                        arity: self.arity,
                    },
                ));
            }
            return Ok(Val::V((index * self.dim..(index + 1) * self.dim).collect()));
        }
        Err(self.error_at(at, ExprErrorKind::UnknownName { name }))
    }

    pub(super) fn scalar(&self, (at, v): &(usize, Val)) -> Parsed<Slot> {
        match v {
            Val::S(s) => Ok(*s),
            Val::V(_) => Err(self.error_at(
                *at,
                ExprErrorKind::TypeMismatch {
                    expected: ValueType::Scalar,
                    found: ValueType::Vector,
                },
            )),
        }
    }

    pub(super) fn vector(&self, (at, v): &(usize, Val)) -> Parsed<Vec<Slot>> {
        match v {
            Val::V(v) => Ok(v.clone()),
            Val::S(_) => Err(self.error_at(
                *at,
                ExprErrorKind::TypeMismatch {
                    expected: ValueType::Vector,
                    found: ValueType::Scalar,
                },
            )),
        }
    }
}
