//! Lamé parameters of a k-dimensional isotropic material from its Young's
//! modulus E and Poisson's ratio ν.
//!
//! ```text
//! linear isotropic law in k dimensions:  σ = λ tr(ε) I + 2μ ε
//! uniaxial stress (σ_11 only, lateral σ_ll = 0, l = 2..k):
//!   ε_ll = −ν ε_11,   σ_11 = E ε_11
//!   ⇒  ν = λ / ((k − 1) λ + 2μ),   E = 2μ (1 + ν)
//!   ⇒  μ = E / (2 (1 + ν)),        λ = E ν / ((1 + ν)(1 − (k − 1) ν))
//!
//! k = 3:  λ = E ν / ((1 + ν)(1 − 2ν))     (the usual 3D formulas)
//! k = 2:  λ = E ν / (1 − ν²)              (plane stress: a 2D world, a membrane)
//! k = 1:  λ = E ν / (1 + ν),  λ + 2μ = E  (a string: ν drops out)
//!
//! admissible: E > 0, μ > 0 and bulk modulus K_k = λ + 2μ/k > 0, i.e.
//!   −1 < ν < 1/(k − 1)     (k ≥ 2;  k = 3: ν < 1/2,  k = 2: ν < 1,  k = 4: ν < 1/3)
//!   −1 < ν                 (k = 1)
//! ```
//! So E and ν always mean what a uniaxial test of the k-dimensional
//! material measures, in every dimension, and the small-strain uniaxial
//! response is σ = E ε for every k (docs/materials.md derives the
//! large-strain closed forms from the same parameters).

use super::MaterialError;

/// μ (shear modulus) and λ of a k-dimensional material.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Lame {
    /// μ = E / (2 (1 + ν)) > 0.
    pub mu: f64,
    /// λ = E ν / ((1 + ν)(1 − (k − 1) ν)).
    pub lambda: f64,
}

/// The open interval (lower, upper) of admissible ν for k-simplices
/// (upper = +∞ for k = 1).
pub fn poisson_ratio_range(order: usize) -> (f64, f64) {
    let upper = if order <= 1 {
        f64::INFINITY
    } else {
        1.0 / (order - 1) as f64
    };
    (-1.0, upper)
}

impl Lame {
    /// Lamé parameters of a material of `order` k from E and ν, validated.
    pub fn from_young_poisson(
        youngs_modulus: f64,
        poisson_ratio: f64,
        order: usize,
    ) -> Result<Lame, MaterialError> {
        if !(youngs_modulus.is_finite() && youngs_modulus > 0.0) {
            return Err(MaterialError::YoungsModulus {
                value: youngs_modulus,
            });
        }
        let (lower, upper) = poisson_ratio_range(order);
        if !(poisson_ratio.is_finite() && poisson_ratio > lower && poisson_ratio < upper) {
            return Err(MaterialError::PoissonRatio {
                value: poisson_ratio,
                lower,
                upper,
                order,
            });
        }
        let nu = poisson_ratio;
        let lateral = order.saturating_sub(1) as f64;
        let mu = youngs_modulus / (2.0 * (1.0 + nu));
        let lambda = youngs_modulus * nu / ((1.0 + nu) * (1.0 - lateral * nu));
        if !(mu.is_finite() && lambda.is_finite() && mu > 0.0) {
            return Err(MaterialError::LameOverflow {
                youngs_modulus,
                poisson_ratio,
            });
        }
        Ok(Lame { mu, lambda })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn three_dimensional_formulas_and_plane_stress() {
        let (e, nu) = (1.0e6, 0.3);
        let l3 = Lame::from_young_poisson(e, nu, 3).expect("valid");
        approx::assert_relative_eq!(l3.mu, e / (2.0 * 1.3), max_relative = 1e-15);
        approx::assert_relative_eq!(l3.lambda, e * nu / (1.3 * 0.4), max_relative = 1e-15);
        let l2 = Lame::from_young_poisson(e, nu, 2).expect("valid");
        approx::assert_relative_eq!(l2.lambda, e * nu / (1.0 - nu * nu), max_relative = 1e-15);
        let l1 = Lame::from_young_poisson(e, nu, 1).expect("valid");
        approx::assert_relative_eq!(l1.lambda + 2.0 * l1.mu, e, max_relative = 1e-15);
    }

    #[test]
    fn the_uniaxial_modulus_and_ratio_come_back_in_every_order() {
        for k in 1..=8 {
            let (_, upper) = poisson_ratio_range(k);
            let top = upper.min(1.0);
            for nu in [-0.9, -0.2, 0.0, 0.1 * top, 0.5 * top, 0.95 * top] {
                let l = Lame::from_young_poisson(2.5, nu, k).expect("valid");
                let lateral = (k - 1) as f64;
                let e = 2.0 * l.mu * (k as f64 * l.lambda + 2.0 * l.mu)
                    / (lateral * l.lambda + 2.0 * l.mu);
                // The check's own rounding grows near both ends of the ν
                // range: like λ/μ ∝ 1/(1 − (k − 1)ν) at the top, and like
                // μ/K_k (bulk modulus K_k = λ + 2μ/k → 0) as ν → −1.
                let bulk = l.lambda + 2.0 * l.mu / k as f64;
                let bound = 16.0 * f64::EPSILON * (1.0 + l.lambda.abs() / l.mu + l.mu / bulk);
                approx::assert_relative_eq!(e, 2.5, max_relative = bound);
                if k > 1 {
                    let back = l.lambda / (lateral * l.lambda + 2.0 * l.mu);
                    approx::assert_abs_diff_eq!(back, nu, epsilon = bound);
                }
                assert!(
                    l.lambda + 2.0 * l.mu / k as f64 > 0.0,
                    "bulk modulus, k = {k}"
                );
            }
        }
    }

    #[test]
    fn bad_parameters_are_typed_errors() {
        for e in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            assert!(
                matches!(
                    Lame::from_young_poisson(e, 0.3, 3),
                    Err(MaterialError::YoungsModulus { .. })
                ),
                "E = {e}"
            );
        }
        for (nu, k) in [(0.5, 3), (-1.0, 3), (1.0, 2), (1.0 / 3.0, 4), (f64::NAN, 2)] {
            assert!(
                matches!(
                    Lame::from_young_poisson(1.0, nu, k),
                    Err(MaterialError::PoissonRatio { order, .. }) if order == k
                ),
                "ν = {nu}, k = {k}"
            );
        }
        assert!(Lame::from_young_poisson(1.0, 0.9, 1).is_ok());
        assert!(matches!(
            Lame::from_young_poisson(1.7e308, 0.49999, 3),
            Err(MaterialError::LameOverflow { .. })
        ));
    }
}
