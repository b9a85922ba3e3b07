//! The relation an element imposes on C = value − rest: an equality, or
//! one of the two inequalities (λ ≥ 0 pushes, λ ≤ 0 pulls).

use serde::{Deserialize, Serialize};

/// The relation an element imposes on C = value − rest (an expression
/// family's `relation` key).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Relation {
    /// C = 0 (λ free).
    #[serde(rename = "==")]
    Equal,
    /// C ≤ 0 (λ ≤ 0: it only pulls).
    #[serde(rename = "<=")]
    AtMost,
    /// C ≥ 0 (λ ≥ 0: it only pushes).
    #[serde(rename = ">=")]
    AtLeast,
}

impl Relation {
    /// As written in a scene.
    pub fn as_str(self) -> &'static str {
        match self {
            Relation::Equal => "==",
            Relation::AtMost => "<=",
            Relation::AtLeast => ">=",
        }
    }
}
