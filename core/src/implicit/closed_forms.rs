//! Closed forms the evidence scenes of the implicit path are checked
//! against (docs/implicit.md §7 derives each).
//!
//! ```text
//! static equilibrium of one implicit step (v = 0, x~ = x): ∇U(x) = 0, independent of h
//! hanging chain (top fixed):   C_k = α_k g Σ_{i below link k} m_i           (link k stretch)
//! barrier under a load W:      −b'(d) = W, one root on (0, d^) (b'' > 0, −b' falls from ∞ to 0)
//! stack on a plane:            contact k (0 = plane) carries W_k = (count − k) m g
//!                              height_0 = c + r + d_0,  height_{k} = height_{k−1} + 2r + d_k
//! incline, sliding (μ < tan θ):  a = g (sin θ − μ cos θ)
//!   backward Euler from rest:   v_n = n h a,  s_n = ½ a h² n (n + 1) = ½ a t (t + h)
//! incline, sticking (μ > tan θ), smoothed Coulomb with ε = ε_v h:
//!   steady slip per step y with μ λ f₁(y) = m g sin θ, λ = m g cos θ
//!   ⇒ f₁(y) = s := tan θ / μ < 1,  y = ε (1 − √(1 − s)),  creep speed ε_v (1 − √(1 − s))
//! ```

use crate::barrier::BarrierLaw;

/// Stretch of every link of a chain hanging from a fixed top particle at
/// static equilibrium: `masses[k]` is the particle below link k, links in
/// order from the top; C_k = α g Σ_{i ≥ k} `masses[i]`.
pub fn hanging_chain_stretch(masses: &[f64], compliance: f64, gravity: f64) -> Vec<f64> {
    let mut below = 0.0;
    let mut stretch = vec![0.0; masses.len()];
    for k in (0..masses.len()).rev() {
        below += masses[k];
        stretch[k] = compliance * gravity * below;
    }
    stretch
}

/// The distance d ∈ (0, d^) at which the barrier pushes with force `load`
/// (−b'(d) = load > 0), by bisection to adjacent floats; `None` for a
/// load that is not positive and finite.
pub fn barrier_gap_under_load(law: &BarrierLaw, load: f64) -> Option<f64> {
    if load.is_nan() || load <= 0.0 || load.is_infinite() {
        return None;
    }
    let mut low = 0.0f64;
    let mut high = law.activation_distance;
    loop {
        let middle = 0.5 * (low + high);
        if middle <= low || middle >= high {
            return Some(high);
        }
        if -law.evaluate(middle).1 > load {
            low = middle;
        } else {
            high = middle;
        }
    }
}

/// Heights (along the plane normal, plane offset `offset`) of `count`
/// equal balls (radius `radius`, mass `mass`) stacked at rest under
/// gravity `gravity` (> 0, towards the plane), each contact at the gap
/// where the barrier carries the weight above it.
pub fn stacked_ball_heights(
    law: &BarrierLaw,
    offset: f64,
    radius: f64,
    mass: f64,
    gravity: f64,
    count: usize,
) -> Option<Vec<f64>> {
    let mut heights = Vec::with_capacity(count);
    let mut height = offset - radius;
    for k in 0..count {
        let gap = barrier_gap_under_load(law, (count - k) as f64 * mass * gravity)?;
        height += 2.0 * radius + gap;
        heights.push(height);
    }
    Some(heights)
}

/// a = g (sin θ − μ cos θ) of a particle sliding down an incline.
pub fn incline_acceleration(gravity: f64, angle: f64, friction: f64) -> f64 {
    gravity * (libm::sin(angle) - friction * libm::cos(angle))
}

/// Distance slid after `steps` backward-Euler steps of length h from rest
/// under constant acceleration a: ½ a h² n (n + 1).
pub fn backward_euler_slide(acceleration: f64, h: f64, steps: u32) -> f64 {
    let n = f64::from(steps);
    0.5 * acceleration * h * h * n * (n + 1.0)
}

/// Steady creep speed of a particle held by smoothed Coulomb friction on
/// an incline with tan θ < μ: ε_v (1 − √(1 − tan θ / μ)); `None` when
/// tan θ ≥ μ (it slides).
pub fn sticking_creep_speed(slip_velocity: f64, angle: f64, friction: f64) -> Option<f64> {
    let s = libm::tan(angle) / friction;
    if s.is_nan() || s >= 1.0 {
        return None;
    }
    Some(slip_velocity * (1.0 - (1.0 - s).sqrt()))
}
