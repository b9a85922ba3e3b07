//! Typed compile errors of the expression language, each with the
//! character offset (and line:column, both 1-based) in the source where
//! it was found.

use std::fmt;

/// The type of an expression value.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ValueType {
    /// A number.
    Scalar,
    /// An N-vector (N = the scene's dimension).
    Vector,
}

impl fmt::Display for ValueType {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            ValueType::Scalar => "a scalar",
            ValueType::Vector => "a vector",
        })
    }
}

/// What went wrong.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ExprErrorKind {
    /// The text does not follow the grammar.
    #[error("syntax error: expected {expected}, found {found}")]
    Syntax {
        /// What the grammar allows here.
        expected: &'static str,
        /// What the source has (a token or "end of input").
        found: String,
    },
    /// A name that is neither a `let` binding, a param, a particle nor a
    /// function.
    #[error("unknown name `{name}`")]
    UnknownName {
        /// The name as written.
        name: String,
    },
    /// `x{index}` with index ≥ the family's arity.
    #[error("particle x{index} does not exist: the element has {arity} particles (x0 … x{last})", last = arity.saturating_sub(1))]
    ParticleOutOfRange {
        /// The particle index written.
        index: usize,
        /// The element length.
        arity: usize,
    },
    /// A value of the wrong type (a vector where a scalar is needed or the
    /// reverse).
    #[error("expected {expected}, found {found}")]
    TypeMismatch {
        /// The type needed here.
        expected: ValueType,
        /// The type written.
        found: ValueType,
    },
    /// A function called with the wrong number of arguments.
    #[error("`{function}` takes {expected}, found {found} arguments")]
    ArgumentCount {
        /// The function.
        function: &'static str,
        /// What it takes, in words.
        expected: String,
        /// How many were given.
        found: usize,
    },
    /// A vector param whose length is not the dimension.
    #[error("param `{name}` has {found} components; vectors have {expected}")]
    ParamLength {
        /// The param.
        name: String,
        /// The dimension N.
        expected: usize,
        /// Its length.
        found: usize,
    },
    /// A param that cannot be used: a name that is not an identifier, is
    /// reserved or repeated, or a value that is not finite.
    #[error("param `{name}`: {reason}")]
    InvalidParam {
        /// The param.
        name: String,
        /// Why.
        reason: &'static str,
    },
    /// `v[i]` with i ≥ N.
    #[error("index {index} is out of range for a vector of {dim} components")]
    IndexOutOfRange {
        /// The index written.
        index: usize,
        /// The dimension N.
        dim: usize,
    },
    /// A `let` name that is a particle (`x0`, …) or a function.
    #[error("`{name}` is reserved and cannot be bound by `let`")]
    ReservedName {
        /// The name.
        name: String,
    },
    /// A bound of [`super::limits`] exceeded.
    #[error("{what} exceeds the limit of {limit}")]
    TooLarge {
        /// Which quantity.
        what: &'static str,
        /// The bound.
        limit: usize,
    },
    /// An arity or dimension outside the compiler's range.
    #[error("{what} = {value} is outside 1..={max}")]
    Shape {
        /// `arity` or `dim`.
        what: &'static str,
        /// The value given.
        value: usize,
        /// The largest accepted.
        max: usize,
    },
}

/// A compile error: where and what.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("at {line}:{column}: {kind}")]
pub struct ExprError {
    /// Offset in characters (not bytes) from the start of the source.
    pub position: usize,
    /// 1-based line.
    pub line: usize,
    /// 1-based column, in characters.
    pub column: usize,
    /// What went wrong.
    pub kind: ExprErrorKind,
}

impl ExprError {
    /// The error `kind` at character offset `position` of `src`.
    pub(crate) fn at(src: &str, position: usize, kind: ExprErrorKind) -> Self {
        let (mut line, mut column) = (1, 1);
        for c in src.chars().take(position) {
            if c == '\n' {
                line += 1;
                column = 1;
            } else {
                column += 1;
            }
        }
        ExprError {
            position,
            line,
            column,
            kind,
        }
    }
}
