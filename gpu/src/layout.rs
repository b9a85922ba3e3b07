//! How per-particle vectors (positions, velocities, forces) sit in device
//! buffers: one decision, used by the host here and by the kernels through
//! the record accessors of `shaders/prelude.wgsl`.
//!
//! ```text
//! record   VEC = ⌊N/4⌋ + 1 vec4 words per particle (N = DIM):
//!          lanes 0..N the coordinates, then zeros, and the last lane
//!          (4·VEC − 1) the particle's inverse mass in position records
//!          (x, p, saved x), 0 in the others (v, force)
//!            N = 3:  [x y z w]            N = 4:  [x0 x1 x2 x3][0 0 0 w]
//!            N = 2:  [x y 0 w]            N = 8:  [x0..x3][x4..x7][0 0 0 w]
//! dense    N reals per particle, [x_0 … x_{N−1}] (the barrier path)
//! ```
//! Why records (measured by `benches/gpu_kernels/`, see
//! docs/performance.md): a particle's vector is one access of 16·VEC bytes
//! (one instruction per lane on lavapipe instead of N; one 128-bit load per
//! thread on a GPU, neighbouring threads reading neighbouring 16-byte words:
//! coalesced), and a projection gathers each endpoint's position and inverse
//! mass in that one access.

/// vec4 words per particle record in dimension `dim`.
pub fn record_words(dim: usize) -> usize {
    dim / 4 + 1
}

/// How a buffer of per-particle vectors is laid out.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum VectorLayout {
    /// `dim` reals per particle.
    Dense,
    /// One record of [`record_words`] vec4 words per particle.
    Record,
}

impl VectorLayout {
    /// Reals per particle in the buffer.
    pub fn reals_per_particle(self, dim: usize) -> usize {
        match self {
            VectorLayout::Dense => dim,
            VectorLayout::Record => 4 * record_words(dim),
        }
    }

    /// `values` (flat, `dim` per particle) in this layout; `last_lane`
    /// (one value per particle, e.g. the inverse mass) fills the last lane
    /// of each record (zeros without it; ignored by the dense layout).
    pub fn pack(self, dim: usize, values: &[f64], last_lane: Option<&[f64]>) -> Vec<f64> {
        match self {
            VectorLayout::Dense => values.to_vec(),
            VectorLayout::Record => {
                let stride = self.reals_per_particle(dim);
                let particles = values.len() / dim.max(1);
                let mut out = vec![0.0; particles * stride];
                for (i, (record, vector)) in out
                    .chunks_exact_mut(stride)
                    .zip(values.chunks_exact(dim.max(1)))
                    .enumerate()
                {
                    record[..dim].copy_from_slice(vector);
                    if let Some(lane) = last_lane {
                        record[stride - 1] = lane.get(i).copied().unwrap_or(0.0);
                    }
                }
                out
            }
        }
    }

    /// The `dim` coordinates per particle of `reals` in this layout.
    pub fn unpack(self, dim: usize, reals: &[f64]) -> Vec<f64> {
        match self {
            VectorLayout::Dense => reals.to_vec(),
            VectorLayout::Record => reals
                .chunks_exact(self.reals_per_particle(dim))
                .flat_map(|record| record[..dim].iter().copied())
                .collect(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn records_hold_the_coordinates_and_the_last_lane() {
        assert_eq!(record_words(3), 1);
        assert_eq!(record_words(4), 2);
        assert_eq!(record_words(8), 3);
        let packed = VectorLayout::Record.pack(2, &[1.0, 2.0, 3.0, 4.0], Some(&[0.5, 0.0]));
        assert_eq!(packed, [1.0, 2.0, 0.0, 0.5, 3.0, 4.0, 0.0, 0.0]);
        assert_eq!(
            VectorLayout::Record.unpack(2, &packed),
            [1.0, 2.0, 3.0, 4.0]
        );
        let four = VectorLayout::Record.pack(4, &[1.0, 2.0, 3.0, 4.0], Some(&[9.0]));
        assert_eq!(four, [1.0, 2.0, 3.0, 4.0, 0.0, 0.0, 0.0, 9.0]);
        assert_eq!(VectorLayout::Dense.pack(2, &[1.0, 2.0], None), [1.0, 2.0]);
    }
}
