//! Compressible Neo-Hookean with a logarithmic volume term: the
//! large-strain reference law.
//!
//! ```text
//! Ψ  = (μ/2)(tr C − k) − μ ln J + (λ/2)(ln J)²
//! S  = 2 ∂Ψ/∂C = μ (I − C⁻¹) + λ ln J · C⁻¹          (∂ ln J/∂C = ½ C⁻¹)
//!
//! J  from deformation::ratio_and_factor (det F̂ for k = N; Π L_jj, C = L Lᵀ, for k < N)
//! refuse:  J < 0 → Inverted;   J = 0, NaN, or C = L Lᵀ failing → Collapsed
//! C⁻¹ = Yᵀ Y,  Y = L⁻¹                                  (cholesky.rs)
//! ln J by material::ln (arithmetic only, the same bits as shaders/ln_f64.wgsl)
//! tr C = Σ_i C_ii (i ascending)
//! Ψ  = 0.5 μ (tr C − k) − μ ln J + 0.5 λ ln J ln J
//! S_ij = μ (δ_ij − C⁻¹_ij) + λ ln J C⁻¹_ij
//! ```
//! Embedded elements (k < N) use their positive intrinsic measure ratio;
//! full-dimensional ones must keep their rest orientation. Ψ ≥ 0 for λ ≥ 0
//! (tr C ≥ k J^{2/k} and k e^{2x/k} − k − 2x ≥ 0), which is why
//! [`super::Material::new`] refuses ν < 0 for this law.

use super::cholesky::{inverse_from_factor_inverse, lower_triangular_inverse};
use super::deformation::ratio_and_factor;
use super::{Lame, LawRefusal, MaterialScratch, ln};
use crate::kinds::ProjectionReal;

/// Ψ of the element [`super::deformation::deform`] left in `s`; S into
/// `s.stress`, or the refusal.
pub(crate) fn neo_hookean(
    lame: Lame,
    k: usize,
    dim: usize,
    s: &mut MaterialScratch,
) -> Result<f64, LawRefusal> {
    let (ratio, factored) = ratio_and_factor(k, dim, s);
    if ratio < 0.0 {
        return Err(LawRefusal::Inverted {
            measure_ratio: ratio,
        });
    }
    if ratio.is_nan() || ratio == 0.0 || !factored {
        return Err(LawRefusal::Collapsed {
            measure_ratio: ratio,
        });
    }
    let Lame { mu, lambda } = lame;
    let MaterialScratch {
        cauchy_green: c,
        factor,
        factor_inverse,
        c_inverse,
        stress,
        ..
    } = s;
    lower_triangular_inverse(factor, k, factor_inverse);
    inverse_from_factor_inverse(factor_inverse, k, c_inverse);
    let log_ratio = ln(ratio);
    Ok(neo_hookean_stress(
        mu, lambda, k, c, c_inverse, log_ratio, stress,
    ))
}

/// Ψ and S (into `stress`) of the k × k `c` given C⁻¹ and ln J, in
/// precision `R` (f64: the golden path; f32: the f32 reference with its
/// own arithmetic ln, as `shaders/material.wgsl`):
/// S = μ(I − C⁻¹) + λ ln J C⁻¹,  Ψ = ½μ(tr C − k) − μ ln J + ½λ (ln J)².
pub fn neo_hookean_stress<R: ProjectionReal>(
    mu: R,
    lambda: R,
    k: usize,
    c: &[R],
    c_inverse: &[R],
    log_ratio: R,
    stress: &mut [R],
) -> R {
    let (zero, one, half) = (R::constant(0.0), R::constant(1.0), R::constant(0.5));
    let mut trace = zero;
    for i in 0..k {
        trace += c[i * k + i];
    }
    for i in 0..k {
        for j in 0..k {
            let delta = if i == j { one } else { zero };
            let inv = c_inverse[i * k + j];
            stress[i * k + j] = mu * (delta - inv) + lambda * log_ratio * inv;
        }
    }
    half * mu * (trace - R::constant(k as f64)) - mu * log_ratio
        + half * lambda * log_ratio * log_ratio
}
