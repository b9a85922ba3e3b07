//! Hyperplane contact, compiled from a hyperplane obstacle: one element
//! per dynamic particle, an inequality C = n·x − (offset + radius) ≥ 0
//! (λ ≥ 0), with static friction in the projection and dynamic friction as
//! a velocity response (DESIGN.md, the golden algorithms).

use super::relation::Relation;

pub(super) const RELATION: Relation = Relation::AtLeast;
