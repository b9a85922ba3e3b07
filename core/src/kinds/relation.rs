//! The relation an element imposes on C = value − rest: an equality, or
//! one of the two inequalities (λ ≥ 0 pushes, λ ≤ 0 pulls).

use serde::{Deserialize, Serialize};

use super::real::ProjectionReal;

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
    /// λ clamped by the relation, by comparison (−0 and NaN go to +0, as
    /// `shaders/primal.wgsl`'s select sends them); the primal-residual
    /// update of both precisions.
    pub fn clamp<R: ProjectionReal>(self, l: R) -> R {
        let zero = R::constant(0.0);
        match self {
            Relation::Equal => l,
            Relation::AtLeast => {
                if l > zero {
                    l
                } else {
                    zero
                }
            }
            Relation::AtMost => {
                if l < zero {
                    l
                } else {
                    zero
                }
            }
        }
    }

    /// As written in a scene.
    pub fn as_str(self) -> &'static str {
        match self {
            Relation::Equal => "==",
            Relation::AtMost => "<=",
            Relation::AtLeast => ">=",
        }
    }
}
