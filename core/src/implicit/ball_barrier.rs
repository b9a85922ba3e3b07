//! The barrier between two balls: the obstacles' clamped-log law
//! ([`crate::barrier::BarrierLaw`]) of the gap between particles i and j.
//!
//! ```text
//! points (x_i, x_j),  e = x_j − x_i,  ℓ = |e|,  n = e/ℓ      (geometry::distance)
//! d = ℓ − r_i − r_j
//! energy b(d);   ∇_j = b'(d) n,  ∇_i = −b'(d) n
//! a radial potential (radial.rs) with φ' = b', φ'' = b'':
//!   K  = b'' n nᵀ + (b'/ℓ)(I − n nᵀ)        b' ≤ 0: the transverse part is NSD
//!   K⁺ = b'' n nᵀ                           (b'' > 0 on (0, d^))
//! d ≥ d^:  0, 0, 0          d ≤ 0:  energy +∞, gradient and curvature 0
//! ```
//! The projected block is the obstacles' b'' n nᵀ (barrier.rs) between two
//! moving points: [[K⁺, −K⁺], [−K⁺, K⁺]]. The pair's forces are equal and
//! opposite, so the ball barriers never change the total momentum.

use super::RadialCurvature;
use crate::barrier::BarrierLaw;
use crate::geometry::distance;

/// One ball pair's barrier terms.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BallPair {
    /// b(d) (+∞ when d ≤ 0; 0 when d ≥ d^).
    pub energy: f64,
    /// d = |x_j − x_i| − r_i − r_j.
    pub distance: f64,
    /// b'(d) ≤ 0 (0 outside (0, d^)): −b' is the normal force.
    pub slope: f64,
    /// K⁺ along and across n = ∇_j d.
    pub curvature: RadialCurvature,
}

/// The barrier of the pair `points` = (x_i, x_j) (2 × `dim`) with radii
/// `radii` = (r_i, r_j). Writes ∇d (= (−n, n)) into `distance_gradient` and
/// the energy gradient into `gradient` (both 2 × `dim`).
pub fn ball_pair_barrier(
    law: &BarrierLaw,
    points: &[f64],
    radii: (f64, f64),
    dim: usize,
    distance_gradient: &mut [f64],
    gradient: &mut [f64],
) -> BallPair {
    let length = distance(points, dim, distance_gradient);
    let d = length - radii.0 - radii.1;
    gradient[..2 * dim].fill(0.0);
    if d >= law.activation_distance {
        return BallPair {
            energy: 0.0,
            distance: d,
            slope: 0.0,
            curvature: RadialCurvature::default(),
        };
    }
    if d <= 0.0 || d.is_nan() {
        return BallPair {
            energy: f64::INFINITY,
            distance: d,
            slope: 0.0,
            curvature: RadialCurvature::default(),
        };
    }
    let (b, b1, b2) = law.evaluate(d);
    for c in 0..2 * dim {
        gradient[c] = b1 * distance_gradient[c];
    }
    BallPair {
        energy: b,
        distance: d,
        slope: b1,
        curvature: RadialCurvature::exact(b1, b2, length).projected(),
    }
}
