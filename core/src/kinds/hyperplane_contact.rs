//! Hyperplane contact, compiled from a hyperplane obstacle: one element
//! per dynamic particle, an inequality C = n·x − (offset + radius) ≥ 0
//! (λ ≥ 0), with static friction in the projection and dynamic friction as
//! a velocity response (DESIGN.md, the golden algorithms).
//!
//! The update of one element, shared by every contact of the XPBD path
//! (static and moving planes, simplex meshes) in both precisions (the
//! golden path in f64, the f32 reference in f32, as `project.wgsl`):
//!
//! ```text
//! Δλ = (−C − α~ λ)/(w + α~)        (not finite: the element fails, nothing written)
//! Δλ = max(λ + Δλ, 0) − λ;  λ' = λ + Δλ;  x += w n Δλ
//! ```

// Coordinate loops index several arrays at once, as a kernel does.
#![allow(clippy::needless_range_loop)]

use super::ProjectionReal;
use super::relation::Relation;

pub(super) const RELATION: Relation = Relation::AtLeast;

/// The update of the module docs for C = `c` at multiplier `l` and
/// inverse mass `w`: moves `x` along `normal`, returns λ'; `None` when
/// the raw Δλ is not finite (checked before the clamp, which would hide a
/// NaN).
#[inline(always)]
pub fn contact_update<R: ProjectionReal>(
    c: R,
    (l, w, alpha_tilde): (R, R, R),
    normal: &[R],
    x: &mut [R],
) -> Option<R> {
    let raw = (-c - alpha_tilde * l) / (w + alpha_tilde);
    if !raw.finite() {
        return None;
    }
    let dl = (l + raw).max(R::constant(0.0)) - l;
    for a in 0..x.len() {
        x[a] += w * normal[a] * dl;
    }
    Some(l + dl)
}
