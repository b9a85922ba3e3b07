//! The rounding of a material element's computed energy W = V_0 Ψ(F̂):
//! what a change W(y) − W(x) can owe to rounding alone, for the coupled
//! step's rounding floor (docs/implicit.md §7 step 11).
//!
//! ```text
//! C_ij = Σ_a F̂_ai F̂_aj       rounds by ≤ γ Σ_a |F̂_ai F̂_aj| ≤ γ √(C_ii C_jj)    (Cauchy–Schwarz)
//! dΨ   = ½ S : dC            ⇒ through C:  ½ Σ_ij |S_ij| γ (√(C_ii C_jj) + δ_ij)
//!                              (+ δ_ij: E = ½(C − I) and tr C − k cancel against the identity)
//! tr C − k (both laws' leading term, StVK through E)  rounds relative to tr C + k: γ μ (tr C + k)
//! ln J (NH) from k rounded factors: |δ ln J| ≤ k γ  ⇒  k γ (μ + λ |ln J|)
//! the final sums of Ψ: γ |Ψ|
//! δW = 2 V_0 γ [ ½ Σ_ij |S_ij| (√(C_ii C_jj) + δ_ij) + μ (tr C + k) + k (μ + λ |ln J|)_NH + |Ψ| ]
//! ```
//! γ = (N + 4) ε as everywhere on this path, the factor 2 absorbing the
//! bound's own evaluation and second-order terms. Like a spring's C =
//! value − rest, a material's energy near rest is a cancelling difference
//! (tr C − k, ln J): its rounding is relative to the terms, not to W.

use crate::material::{
    Law, LawRefusal, MaterialElement, MaterialScratch, element_energy, ln, measure_ratio,
};

/// W of the element (as `material::element_energy`, ∇W into `grad`) and
/// the bound δW on the rounding of the computed W.
pub fn material_energy_rounding(
    element: MaterialElement<'_>,
    grad: &mut [f64],
    scratch: &mut MaterialScratch,
) -> Result<(f64, f64), LawRefusal> {
    let energy = element_energy(element, grad, scratch)?;
    let (dim, rest, lame) = (element.dim, element.rest, element.material.lame);
    let k = element.order();
    let gamma = (dim as f64 + 4.0) * f64::EPSILON;
    let (mu, lambda) = (lame.mu, lame.lambda);
    let log_term = match element.material.law {
        Law::StVenantKirchhoff => 0.0,
        Law::NeoHookean => {
            let log_ratio = ln(measure_ratio(element.points, dim, rest, scratch));
            k as f64 * (mu + lambda * log_ratio.abs())
        }
    };
    let c = &scratch.cauchy_green;
    let s = &scratch.stress;
    let mut through_c = 0.0;
    let mut trace = 0.0;
    for i in 0..k {
        trace += c[i * k + i];
        for j in 0..k {
            let identity = if i == j { 1.0 } else { 0.0 };
            through_c += s[i * k + j].abs() * ((c[i * k + i] * c[j * k + j]).sqrt() + identity);
        }
    }
    let psi = energy / rest.measure;
    let bound = 0.5 * through_c + mu * (trace + k as f64) + log_term + psi.abs();
    Ok((energy, 2.0 * rest.measure * gamma * bound))
}
