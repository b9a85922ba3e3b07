//! The XPBD energy constraint of one material element: the scalar C whose
//! XPBD energy C²/(2α) with compliance α = 1 is the element energy W, so
//! the converged XPBD step is backward Euler with the law's force −∇W.
//!
//! ```text
//! W > 0:  C = √(2W),   ∇_j C = ∇_j W / C         (divided component by component)
//! W ≤ 0:  C = 0,       ∇_j C = 0                  (the law's minimum, to rounding:
//!                                                 no response, like a coincident distance)
//! XPBD (α = 1, α~ = 1/h²):  Δλ = (−C − α~ λ) / (Σ_j w_j |∇_j C|² + α~),  x_j += w_j ∇_j C Δλ
//! converged:  C + α~ λ = 0  ⇒  w_j⁻¹ Δx_j = ∇_j C λ = −h² C ∇_j C = −h² ∇_j W
//! ```
//! |∇C|² = |∇W|²/(2W) stays bounded as W → 0 (W is locally quadratic
//! about its minimum), and the first change of an iteration,
//! Δx_j = −w_j C ∇_j C / (Σ w|∇C|² + α~) = −w_j ∇_j W / (Σ w|∇C|² + α~),
//! has the exact ∇W in its numerator: rounding in a tiny W changes only
//! the denominator, never blows the step up. A NaN W passes through as a
//! NaN C for the kernel's finiteness check.
//! A Neo-Hookean refusal (J ≤ 0) is returned unchanged: the kernel stops
//! the step with it (docs/materials.md).

use super::energy::element_energy;
use super::{LawRefusal, MaterialElement, MaterialScratch};

/// C of the element (see the module docs); ∇C into `grad` ((k + 1) ×
/// `dim`, the layout of its points). A refusal leaves `grad` unspecified.
pub fn energy_constraint(
    element: MaterialElement<'_>,
    grad: &mut [f64],
    scratch: &mut MaterialScratch,
) -> Result<f64, LawRefusal> {
    let energy = element_energy(element, grad, scratch)?;
    let count = element.points.len();
    if energy <= 0.0 {
        grad[..count].fill(0.0);
        return Ok(0.0);
    }
    let c = (2.0 * energy).sqrt();
    for g in &mut grad[..count] {
        *g /= c;
    }
    Ok(c)
}
