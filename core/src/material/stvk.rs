//! St. Venant–Kirchhoff: the polynomial small-strain reference law.
//!
//! ```text
//! E   = ½ (C − I)                       E_ij = 0.5 (C_ij − δ_ij)
//! Ψ   = μ tr(E²) + (λ/2)(tr E)²         tr(E²) = Σ_i Σ_j E_ij²  (i, then j ascending)
//! S   = ∂Ψ/∂E = 2μ E + λ tr(E) I        (= 2 ∂Ψ/∂C)
//! ```
//! Defined for every deformation (it does not refuse collapse or
//! inversion, and famously softens under strong compression). Ψ ≥ 0 for
//! admissible parameters: Ψ ≥ (μ/k + λ/2)(tr E)² = (K_k/2)(tr E)² with
//! K_k = λ + 2μ/k > 0 (Cauchy–Schwarz: tr(E²) ≥ (tr E)²/k).

use super::{Lame, MaterialScratch};
use crate::kinds::ProjectionReal;

/// Ψ of the C in `s.cauchy_green`; S into `s.stress`.
pub(crate) fn stvk(lame: Lame, k: usize, s: &mut MaterialScratch) -> f64 {
    let Lame { mu, lambda } = lame;
    stvk_stress(mu, lambda, k, &s.cauchy_green, &mut s.stress)
}

/// Ψ of the k × k `c` and S into `stress`, in precision `R` (f64: the
/// golden path; f32: the f32 reference, as `shaders/material.wgsl`).
pub fn stvk_stress<R: ProjectionReal>(mu: R, lambda: R, k: usize, c: &[R], stress: &mut [R]) -> R {
    let (zero, one, half, two) = (
        R::constant(0.0),
        R::constant(1.0),
        R::constant(0.5),
        R::constant(2.0),
    );
    let mut trace = zero;
    let mut square = zero;
    for i in 0..k {
        for j in 0..k {
            let delta = if i == j { one } else { zero };
            let e = half * (c[i * k + j] - delta);
            square += e * e;
            stress[i * k + j] = two * mu * e;
        }
        trace += half * (c[i * k + i] - one);
    }
    for i in 0..k {
        stress[i * k + i] += lambda * trace;
    }
    mu * square + half * lambda * trace * trace
}
