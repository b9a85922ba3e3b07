//! Simulation state: what changes from step to step.

use crate::Scene;

/// Positions and velocities, flat: `positions[i * dim + a]`.
#[derive(Debug, Clone, PartialEq)]
pub struct State {
    /// Dimension N.
    pub dim: usize,
    /// Positions, `particle_count × dim`.
    pub positions: Vec<f64>,
    /// Velocities, `particle_count × dim`.
    pub velocities: Vec<f64>,
}

impl State {
    /// The authored initial state of a scene.
    pub fn from_scene(scene: &Scene) -> State {
        let dim = scene.dim;
        let mut positions = Vec::with_capacity(scene.particles.len() * dim);
        let mut velocities = Vec::with_capacity(scene.particles.len() * dim);
        for p in &scene.particles {
            positions.extend_from_slice(&p.position);
            match &p.velocity {
                Some(v) => velocities.extend_from_slice(v),
                None => velocities.extend(std::iter::repeat_n(0.0, dim)),
            }
        }
        State {
            dim,
            positions,
            velocities,
        }
    }

    /// Number of particles.
    pub fn len(&self) -> usize {
        self.positions.len().checked_div(self.dim).unwrap_or(0)
    }

    /// True when there are no particles.
    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }

    /// Position of particle `i`.
    pub fn position(&self, i: usize) -> &[f64] {
        &self.positions[i * self.dim..(i + 1) * self.dim]
    }

    /// Velocity of particle `i`.
    pub fn velocity(&self, i: usize) -> &[f64] {
        &self.velocities[i * self.dim..(i + 1) * self.dim]
    }

    /// 64-bit FNV-1a hash of the exact bit patterns of all positions and
    /// velocities: equal hashes mean (with overwhelming probability)
    /// bit-identical states.
    pub fn hash(&self) -> u64 {
        let mut h: u64 = 0xcbf2_9ce4_8422_2325;
        for x in self.positions.iter().chain(&self.velocities) {
            for byte in x.to_bits().to_le_bytes() {
                h ^= u64::from(byte);
                h = h.wrapping_mul(0x0000_0100_0000_01b3);
            }
        }
        h
    }
}
