//! Helpers shared by the integration tests. Each test binary compiles this
//! module on its own and uses only part of it.

#![allow(dead_code)]

pub mod bound;
pub mod boxes;
pub mod differential;
pub mod exact;
pub mod gpu;
pub mod guarded;
pub mod materials;

/// A deterministic pseudo-random number generator (64-bit LCG), so test
/// scenes are jittered the same way on every run.
pub struct Lcg(pub u64);

impl Lcg {
    /// The next number in [−1, 1).
    pub fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        ((self.0 >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
    }
}
