//! Tethers (long-range attachments): one-sided distance limits from an
//! anchor to many particles.
//!
//! ```text
//! element (anchor, p):  |x_p − x_anchor| ≤ rest_p,   rest_p = authored |x_p − x_anchor|
//! ```
//! A chain hanging from a fixed anchor converges slowly under
//! Gauss–Seidel when a heavy particle hangs below light ones: the heavy
//! end receives only m/(m + M) of each link correction. A tether from the
//! fixed anchor (inverse mass 0) moves the heavy particle by the whole
//! violation in one projection. Authored on a straight chain the rest
//! values are the path lengths along it, so the tethers are slack while
//! the chain holds its length and only pull when it stretches.

use super::SceneBuilder;
use crate::{ConstraintFamily, ConstraintKind};

impl SceneBuilder {
    /// Adds a tether family from `anchor` to each of `particles` (rest
    /// values from the authored geometry) with `compliance`; returns its
    /// index.
    pub fn tethers(&mut self, anchor: usize, particles: &[usize], compliance: f64) -> usize {
        let elements = particles
            .iter()
            .filter(|&&p| p != anchor)
            .map(|&p| vec![anchor, p])
            .collect();
        self.family(ConstraintFamily::new(
            ConstraintKind::Tether,
            compliance,
            elements,
        ))
    }
}
