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

/// Ψ of the C in `s.cauchy_green`; S into `s.stress`.
pub(crate) fn stvk(lame: Lame, k: usize, s: &mut MaterialScratch) -> f64 {
    let Lame { mu, lambda } = lame;
    let MaterialScratch {
        cauchy_green: c,
        stress,
        ..
    } = s;
    let mut trace = 0.0;
    let mut square = 0.0;
    for i in 0..k {
        for j in 0..k {
            let delta = if i == j { 1.0 } else { 0.0 };
            let e = 0.5 * (c[i * k + j] - delta);
            square += e * e;
            stress[i * k + j] = 2.0 * mu * e;
        }
        trace += 0.5 * (c[i * k + i] - 1.0);
    }
    for i in 0..k {
        stress[i * k + i] += lambda * trace;
    }
    mu * square + 0.5 * lambda * trace * trace
}
