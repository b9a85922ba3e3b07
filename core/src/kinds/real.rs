//! The precisions the numeric code of both paths runs in: f64 (the golden
//! path) and f32 (the f32 reference). Functions written once over
//! [`ProjectionReal`] run the same operations in the same order in either
//! precision; docs/bounds.md ("One numeric code for both precisions")
//! lists them and the named divergences.

use crate::expr::Real;
use std::ops::{AddAssign, DivAssign, MulAssign, SubAssign};

/// A precision of the shared numeric code (module docs): f64 or f32.
pub trait ProjectionReal: Real + AddAssign + SubAssign + MulAssign + DivAssign {
    /// Neither NaN nor ±∞.
    fn finite(self) -> bool;
    /// The smaller of the two; the other when one is NaN (`f64::min`).
    fn min(self, other: Self) -> Self;
    /// The larger of the two; the other when one is NaN (`f64::max`).
    fn max(self, other: Self) -> Self;
    /// NaN.
    fn is_nan(self) -> bool;
    /// The machine epsilon (1 ulp of 1).
    fn epsilon() -> Self;
    /// The value in f64 (exact).
    fn to_f64(self) -> f64;
}

impl ProjectionReal for f64 {
    fn finite(self) -> bool {
        self.is_finite()
    }
    fn min(self, other: Self) -> Self {
        f64::min(self, other)
    }
    fn max(self, other: Self) -> Self {
        f64::max(self, other)
    }
    fn is_nan(self) -> bool {
        f64::is_nan(self)
    }
    fn epsilon() -> Self {
        f64::EPSILON
    }
    fn to_f64(self) -> f64 {
        self
    }
}

impl ProjectionReal for f32 {
    fn finite(self) -> bool {
        self.is_finite()
    }
    fn min(self, other: Self) -> Self {
        f32::min(self, other)
    }
    fn max(self, other: Self) -> Self {
        f32::max(self, other)
    }
    fn is_nan(self) -> bool {
        f32::is_nan(self)
    }
    fn epsilon() -> Self {
        f32::EPSILON
    }
    fn to_f64(self) -> f64 {
        f64::from(self)
    }
}
