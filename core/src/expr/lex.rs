//! Tokens of the expression language, with their character offsets.
//!
//! ```text
//! number  = digit+ ('.' digit*)? ([eE] [+-]? digit+)?
//! name    = [A-Za-z_] [A-Za-z0-9_]*
//! symbols = + - * / ( ) [ ] , ; =
//! spaces, tabs and newlines separate tokens
//! ```

use super::error::{ExprError, ExprErrorKind};
use super::limits::{MAX_SOURCE_CHARS, MAX_TOKENS};

/// One token.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Token {
    /// A number, with its text (an index needs the digits).
    Number(f64, String),
    Name(String),
    Symbol(char),
    End,
}

impl Token {
    pub(crate) fn describe(&self) -> String {
        match self {
            Token::Number(_, text) => format!("number `{text}`"),
            Token::Name(name) => format!("`{name}`"),
            Token::Symbol(c) => format!("`{c}`"),
            Token::End => "end of input".to_string(),
        }
    }
}

/// `src` as tokens with character offsets, ending with [`Token::End`].
/// The built-in functions' names (reserved: no `let` or param may take
/// them; functions.rs maps each to its rule).
pub(super) const FUNCTION_NAMES: [&str; 9] = [
    "dot", "norm", "sqrt", "abs", "min", "max", "ln", "exp", "det",
];

/// Whether `name` is a built-in function.
pub(super) fn is_function(name: &str) -> bool {
    FUNCTION_NAMES.contains(&name)
}

pub(crate) fn tokens(src: &str) -> Result<Vec<(Token, usize)>, ExprError> {
    let chars: Vec<char> = src.chars().collect();
    if chars.len() > MAX_SOURCE_CHARS {
        return Err(ExprError::at(
            src,
            MAX_SOURCE_CHARS,
            ExprErrorKind::TooLarge {
                what: "source length (characters)",
                limit: MAX_SOURCE_CHARS,
            },
        ));
    }
    let mut out = Vec::new();
    let mut i = 0;
    while i < chars.len() {
        let c = chars[i];
        let start = i;
        if c.is_whitespace() {
            i += 1;
            continue;
        }
        if out.len() >= MAX_TOKENS {
            return Err(ExprError::at(
                src,
                start,
                ExprErrorKind::TooLarge {
                    what: "token count",
                    limit: MAX_TOKENS,
                },
            ));
        }
        let token = if c.is_ascii_digit() {
            let digits = |i: &mut usize| {
                while *i < chars.len() && chars[*i].is_ascii_digit() {
                    *i += 1;
                }
            };
            digits(&mut i);
            if i < chars.len() && chars[i] == '.' {
                i += 1;
                digits(&mut i);
            }
            if i < chars.len() && (chars[i] == 'e' || chars[i] == 'E') {
                let mut j = i + 1;
                if j < chars.len() && (chars[j] == '+' || chars[j] == '-') {
                    j += 1;
                }
                if j < chars.len() && chars[j].is_ascii_digit() {
                    i = j;
                    digits(&mut i);
                }
            }
            let text: String = chars[start..i].iter().collect();
            match text.parse::<f64>() {
                Ok(v) if v.is_finite() => Token::Number(v, text),
                _ => {
                    return Err(ExprError::at(
                        src,
                        start,
                        ExprErrorKind::Syntax {
                            expected: "a finite number",
                            found: format!("`{text}`"),
                        },
                    ));
                }
            }
        } else if c.is_ascii_alphabetic() || c == '_' {
            while i < chars.len() && (chars[i].is_ascii_alphanumeric() || chars[i] == '_') {
                i += 1;
            }
            Token::Name(chars[start..i].iter().collect())
        } else if "+-*/()[],;=".contains(c) {
            i += 1;
            Token::Symbol(c)
        } else {
            return Err(ExprError::at(
                src,
                start,
                ExprErrorKind::Syntax {
                    expected: "a number, a name or one of + - * / ( ) [ ] , ; =",
                    found: format!("`{c}`"),
                },
            ));
        };
        out.push((token, start));
    }
    out.push((Token::End, chars.len()));
    Ok(out)
}
