//! Chains: `count` particles on a straight line joined by distance links.
//!
//! ```text
//! x_i = start + i · spacing · direction        links (i, i + 1)
//! ```

use super::SceneBuilder;
use super::grid::Grid;
use crate::{ConstraintFamily, ConstraintKind, Particle};

/// A chain to add.
#[derive(Debug, Clone)]
pub struct ChainSpec {
    /// Position of particle 0.
    pub start: Vec<f64>,
    /// Direction of the chain (normalized here).
    pub direction: Vec<f64>,
    /// Number of particles.
    pub count: usize,
    /// Link length.
    pub spacing: f64,
    /// Mass of each particle.
    pub mass: f64,
    /// Compliance of the links.
    pub compliance: f64,
    /// Fix particle 0.
    pub fix_first: bool,
}

impl SceneBuilder {
    /// Adds the chain's particles and its link family.
    pub fn chain(&mut self, spec: &ChainSpec) -> Grid {
        let first = self.scene().particles.len();
        let length = spec.direction.iter().map(|x| x * x).sum::<f64>().sqrt();
        for i in 0..spec.count {
            let position: Vec<f64> = spec
                .start
                .iter()
                .zip(&spec.direction)
                .map(|(s, d)| s + i as f64 * spec.spacing * d / length)
                .collect();
            let mut particle = Particle::new(position, spec.mass);
            if i == 0 && spec.fix_first {
                particle.fixed = true;
            }
            self.particle(particle);
        }
        let elements = (1..spec.count)
            .map(|i| vec![first + i - 1, first + i])
            .collect();
        let family = self.family(ConstraintFamily::new(
            ConstraintKind::Distance,
            spec.compliance,
            elements,
        ));
        Grid {
            first,
            counts: vec![spec.count],
            family,
        }
    }
}
