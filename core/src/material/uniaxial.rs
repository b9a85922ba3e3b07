//! Closed forms of uniaxial stretch with free lateral contraction, the
//! reference the material validation tests and the accuracy report compare
//! against (docs/materials.md derives them).
//!
//! ```text
//! principal stretches (s, t, …, t) (k − 1 lateral), lateral stress 0, P = nominal
//! (first Piola) stress: axial force per unit rest cross-section
//!
//! StVK:  a = (s² − 1)/2,   b = −λ a / (2μ + (k − 1) λ) = −ν a,   t² = 1 + 2b
//!        P = s (2μ a + λ (a + (k − 1) b))  =  E s (s² − 1)/2
//!        (no lateral state once t² ≤ 0, i.e. s² ≥ 1 + 1/ν)
//! NH:    u = t² solves  μ (u − 1) + λ (ln s + ((k − 1)/2) ln u) = 0
//!        (increasing in u for λ ≥ 0: one root, found by bisection)
//!        ln J = ln s + ((k − 1)/2) ln u,   P = (μ (s² − 1) + λ ln J) / s
//! k = 1: no lateral direction (t reported as 1), P as above with k − 1 = 0
//! ```
//! These are reference computations (plain `libm::log`, bisection to the
//! last bit), not kernel arithmetic.

use super::{Law, Material};

/// One homogeneous uniaxial state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UniaxialState {
    /// Axial stretch s.
    pub stretch: f64,
    /// Lateral stretch t (1 for k = 1).
    pub lateral_stretch: f64,
    /// Nominal stress P: axial force per unit rest cross-section
    /// ((k − 1)-measure).
    pub nominal_stress: f64,
}

/// The state of `material` (k-simplices, k = `order`) at axial stretch
/// `stretch` > 0; `None` where no lateral equilibrium exists (StVK with
/// s² ≥ 1 + 1/ν) or s is not a positive finite number.
pub fn uniaxial_state(material: &Material, order: usize, stretch: f64) -> Option<UniaxialState> {
    if !(stretch > 0.0 && stretch.is_finite()) {
        return None;
    }
    let (lateral_square, nominal_stress) = lateral_and_stress(material, order, stretch);
    if lateral_square.is_nan() || lateral_square <= 0.0 {
        return None;
    }
    Some(UniaxialState {
        stretch,
        lateral_stretch: lateral_square.sqrt(),
        nominal_stress,
    })
}

/// The state under nominal stress `nominal_stress` (tension > 0). `None`
/// where the law has no such state: StVK beyond its compressive limit
/// point P = −E/(3√3) at s = 1/√3, or beyond its lateral collapse; any
/// stress needing a stretch above 1e8 or below 1e−12.
pub fn uniaxial_stretch_under_stress(
    material: &Material,
    order: usize,
    nominal_stress: f64,
) -> Option<UniaxialState> {
    if !nominal_stress.is_finite() {
        return None;
    }
    let p = |s: f64| lateral_and_stress(material, order, s).1;
    let (mut lo, mut hi) = (1.0, 1.0);
    if nominal_stress > 0.0 {
        hi = 2.0;
        while p(hi) < nominal_stress {
            hi *= 2.0;
            if hi > 1e8 {
                return None;
            }
        }
    } else if nominal_stress < 0.0 {
        if material.law == Law::StVenantKirchhoff {
            lo = 1.0 / 3f64.sqrt();
            if p(lo) > nominal_stress {
                return None;
            }
        } else {
            lo = 0.5;
            while p(lo) > nominal_stress {
                lo *= 0.5;
                if lo < 1e-12 {
                    return None;
                }
            }
        }
    }
    let stretch = bisect(|s| p(s) - nominal_stress, lo, hi);
    uniaxial_state(material, order, stretch)
}

/// (t², P) at axial stretch s > 0 (t² ≤ 0 means no lateral state).
fn lateral_and_stress(material: &Material, order: usize, s: f64) -> (f64, f64) {
    let (mu, lambda) = (material.lame.mu, material.lame.lambda);
    let lateral = order.saturating_sub(1) as f64;
    match material.law {
        Law::StVenantKirchhoff => {
            let a = 0.5 * (s * s - 1.0);
            let b = -lambda * a / (2.0 * mu + lateral * lambda);
            let t2 = if order > 1 { 1.0 + 2.0 * b } else { 1.0 };
            (t2, s * (2.0 * mu * a + lambda * (a + lateral * b)))
        }
        Law::NeoHookean => {
            let ln_s = libm::log(s);
            let u = if order > 1 && lambda > 0.0 {
                let g = |u: f64| mu * (u - 1.0) + lambda * (ln_s + 0.5 * lateral * libm::log(u));
                let (mut lo, mut hi) = (1.0, 1.0);
                if g(1.0) > 0.0 {
                    while g(lo) > 0.0 && lo > 0.0 {
                        lo *= 0.5;
                    }
                } else {
                    while g(hi) < 0.0 && hi.is_finite() {
                        hi *= 2.0;
                    }
                }
                bisect(g, lo, hi)
            } else {
                1.0
            };
            let ln_j = ln_s + 0.5 * lateral * libm::log(u);
            (u, (mu * (s * s - 1.0) + lambda * ln_j) / s)
        }
    }
}

/// A root of the increasing `f` on [lo, hi] (f(lo) ≤ 0 ≤ f(hi)), bisected
/// until the interval has no interior point; the end with the smaller |f|.
fn bisect(f: impl Fn(f64) -> f64, mut lo: f64, mut hi: f64) -> f64 {
    loop {
        let mid = 0.5 * (lo + hi);
        if mid <= lo || mid >= hi {
            break;
        }
        if f(mid) < 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    if f(lo).abs() <= f(hi).abs() { lo } else { hi }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stvk_matches_its_closed_form_and_inverts() {
        for k in 1..=4 {
            let m = Material::new(Law::StVenantKirchhoff, k, 3.0, 0.25).expect("valid");
            for s in [0.7, 1.0, 1.1, 1.5] {
                let state = uniaxial_state(&m, k, s).expect("state");
                let closed = 3.0 * s * (s * s - 1.0) / 2.0;
                approx::assert_relative_eq!(state.nominal_stress, closed, epsilon = 1e-14);
                if k > 1 {
                    let t2 = 1.0 - 0.25 * (s * s - 1.0);
                    approx::assert_relative_eq!(state.lateral_stretch, t2.sqrt(), epsilon = 1e-15);
                }
                let back = uniaxial_stretch_under_stress(&m, k, closed).expect("inverse");
                approx::assert_relative_eq!(back.stretch, s, epsilon = 1e-14);
            }
            // Past the lateral collapse s² = 1 + 1/ν = 5, and past the limit point.
            if k > 1 {
                assert!(uniaxial_state(&m, k, 2.3).is_none());
            }
            assert!(uniaxial_stretch_under_stress(&m, k, -3.0 / 27f64.sqrt() * 1.01).is_none());
        }
    }

    #[test]
    fn neo_hookean_small_strain_and_zero_poisson() {
        for k in 1..=4 {
            let m = Material::new(Law::NeoHookean, k, 2.0, 0.2).expect("valid");
            let eps = 1e-6;
            let state = uniaxial_state(&m, k, 1.0 + eps).expect("state");
            approx::assert_relative_eq!(state.nominal_stress / eps, 2.0, max_relative = 1e-5);
            if k > 1 {
                approx::assert_relative_eq!(
                    (1.0 - state.lateral_stretch) / eps,
                    0.2,
                    max_relative = 1e-5
                );
            }
            let back = uniaxial_stretch_under_stress(&m, k, -0.4).expect("inverse");
            approx::assert_relative_eq!(
                uniaxial_state(&m, k, back.stretch)
                    .expect("state")
                    .nominal_stress,
                -0.4,
                epsilon = 1e-14
            );
        }
        // ν = 0: no lateral contraction, P = (E/2)(s − 1/s).
        let m = Material::new(Law::NeoHookean, 3, 2.0, 0.0).expect("valid");
        let state = uniaxial_state(&m, 3, 1.8).expect("state");
        assert_eq!(state.lateral_stretch, 1.0);
        approx::assert_relative_eq!(state.nominal_stress, 1.8 - 1.0 / 1.8, epsilon = 1e-15);
    }
}
