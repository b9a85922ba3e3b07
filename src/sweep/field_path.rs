//! A field of a scene document addressed the way validation errors name
//! it: `obstacles[0].friction`, `damping.rate`, `gravity[1]`,
//! `constraints[2].compliance`, `particles[5].velocity[0]`.
//!
//! ```text
//! path     = key ( "." key | "[" index "]" )*
//! key      = [A-Za-z_][A-Za-z0-9_]*
//! index    = decimal
//! ```
//! Setting a path writes a number into the JSON document. A missing
//! optional vector on the way (a particle's `velocity` or `force`, which
//! default to zero) is created as N zeros, a missing object (`damping`)
//! as `{}`; anything the schema does not know is then refused by the
//! scene parser with its path, so a typo never passes silently.

use super::SweepError;
use serde_json::{Map, Value};
use std::fmt;
use std::str::FromStr;

/// One step of a [`FieldPath`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Segment {
    /// An object key.
    Key(String),
    /// An array index.
    Index(usize),
}

/// A parsed field path (see the module docs).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FieldPath {
    text: String,
    segments: Vec<Segment>,
}

impl FieldPath {
    /// The path as written.
    pub fn as_str(&self) -> &str {
        &self.text
    }

    /// Its segments, outermost first.
    pub fn segments(&self) -> &[Segment] {
        &self.segments
    }

    /// Writes `value` at this path of `document` (a scene of dimension
    /// `dim`), creating a missing optional vector or object on the way.
    /// The target must be a number or absent.
    pub fn set(&self, document: &mut Value, dim: usize, value: f64) -> Result<(), SweepError> {
        let error = |why: String| SweepError::Path {
            path: self.text.clone(),
            why,
        };
        let number = serde_json::Number::from_f64(value)
            .ok_or_else(|| error(format!("value {value} is not finite")))?;
        let mut node = document;
        for (k, segment) in self.segments.iter().enumerate() {
            let here = self.prefix(k + 1);
            let next = self.segments.get(k + 1);
            node = match (segment, node) {
                (Segment::Key(key), Value::Object(map)) => {
                    let fresh = match next {
                        Some(Segment::Index(_)) => Value::Array(vec![0.0.into(); dim]),
                        Some(Segment::Key(_)) => Value::Object(Map::new()),
                        None => Value::Null,
                    };
                    map.entry(key.clone()).or_insert(fresh)
                }
                (Segment::Index(i), Value::Array(items)) => {
                    let len = items.len();
                    items.get_mut(*i).ok_or_else(|| {
                        error(format!("{here}: index {i} is out of range ({len} entries)"))
                    })?
                }
                (Segment::Key(_), _) => {
                    return Err(error(format!("{}: is not an object", self.prefix(k))));
                }
                (Segment::Index(_), _) => {
                    return Err(error(format!("{}: is not an array", self.prefix(k))));
                }
            };
        }
        match node {
            Value::Number(_) | Value::Null => {
                *node = Value::Number(number);
                Ok(())
            }
            _ => Err(error("is not a number".into())),
        }
    }

    /// The text of the first `count` segments.
    fn prefix(&self, count: usize) -> String {
        let mut out = String::new();
        for segment in &self.segments[..count] {
            match segment {
                Segment::Key(key) if out.is_empty() => out.push_str(key),
                Segment::Key(key) => {
                    out.push('.');
                    out.push_str(key);
                }
                Segment::Index(i) => out.push_str(&format!("[{i}]")),
            }
        }
        if out.is_empty() {
            out.push_str("(document)");
        }
        out
    }
}

impl fmt::Display for FieldPath {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.text)
    }
}

impl FromStr for FieldPath {
    type Err = String;

    fn from_str(text: &str) -> Result<FieldPath, String> {
        let bad = |why: &str| format!("field path `{text}`: {why}");
        let mut segments = Vec::new();
        let mut rest = text;
        let mut expect_key = true;
        while !rest.is_empty() {
            if let Some(after) = rest.strip_prefix('[') {
                let close = after.find(']').ok_or_else(|| bad("unclosed `[`"))?;
                let index = after[..close]
                    .parse()
                    .map_err(|_| bad("an index must be a non-negative integer"))?;
                if segments.is_empty() {
                    return Err(bad("must start with a key"));
                }
                segments.push(Segment::Index(index));
                rest = &after[close + 1..];
                expect_key = false;
                continue;
            }
            let key_text = if expect_key {
                rest
            } else {
                rest.strip_prefix('.')
                    .ok_or_else(|| bad("expected `.key` or `[index]`"))?
            };
            let end = key_text.find(['.', '[']).unwrap_or(key_text.len());
            let key = &key_text[..end];
            let valid = key
                .chars()
                .next()
                .is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
                && key.chars().all(|c| c.is_ascii_alphanumeric() || c == '_');
            if !valid {
                return Err(bad("a key is letters, digits and `_`"));
            }
            segments.push(Segment::Key(key.to_owned()));
            rest = &key_text[end..];
            expect_key = false;
        }
        if segments.is_empty() {
            return Err(bad("empty"));
        }
        Ok(FieldPath {
            text: text.to_owned(),
            segments,
        })
    }
}
