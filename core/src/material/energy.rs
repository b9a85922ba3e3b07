//! Element energy W = V_0 Ψ and its gradient with respect to the k + 1
//! vertices, for either law.
//!
//! ```text
//! deform      D, F̂ = D R, C = F̂ᵀF̂                     (deformation.rs)
//! law         Ψ and S = 2 ∂Ψ/∂C                        (stvk.rs | neo_hookean.rs)
//! W           = V_0 · Ψ
//! pull back   ∇_{j+1} W = V_0 (F̂ S Rᵀ)[:, j],  ∇_0 W = −Σ_j ∇_{j+1} W   (deformation.rs)
//! ```
//! Σ_j ∇_j W = 0 (translation invariance) holds by construction, to the
//! rounding of the last sum.

use super::deformation::{deform, pull_back};
use super::neo_hookean::neo_hookean;
use super::stvk::stvk;
use super::{Law, LawRefusal, MaterialElement, MaterialScratch};

/// W of the element; ∇W into `grad` (the layout of its points). A refusal
/// leaves `grad` unspecified.
pub fn element_energy(
    element: MaterialElement<'_>,
    grad: &mut [f64],
    scratch: &mut MaterialScratch,
) -> Result<f64, LawRefusal> {
    let (dim, rest, lame) = (element.dim, element.rest, element.material.lame);
    let k = deform(element.points, dim, rest.frame, scratch);
    let psi = match element.material.law {
        Law::StVenantKirchhoff => stvk(lame, k, scratch),
        Law::NeoHookean => neo_hookean(lame, k, dim, scratch)?,
    };
    pull_back(k, dim, rest, scratch, grad);
    Ok(rest.measure * psi)
}
