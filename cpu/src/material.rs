//! The material families' element evaluation on the golden path: the XPBD
//! energy constraint of one St. Venant–Kirchhoff or Neo-Hookean simplex,
//! from the law code in `hyperpbd_core::material` (no second copy of the
//! math), and the diagnosis of a refused element.
//!
//! ```text
//! C = √(2W),  ∇C = ∇W / C       (W = V_0 Ψ(C), material::energy_constraint;
//!                                 C = 0, ∇C = 0 at the law's minimum)
//! α = 1, α~ = 1/h²               (the family's compliance is 1)
//! Δλ = (−C − α~ λ) / (Σ_j w_j |∇_j C|² + α~),  x_j += w_j ∇_j C Δλ
//! ```
//! The update is the generic one of `project.rs` (`measure`), which calls
//! [`energy_constraint`] for the value and gradient: the material families
//! share the colour-parallel schedule and the update arithmetic of every
//! gradient-based family, so their results are the same bytes for any
//! thread count.
//!
//! **Refusal.** A Neo-Hookean element whose current iterate has J ≤ 0 is
//! reported by `measure` as a failed slot, like a non-finite update, and
//! the step rolls back. `hyperpbd_core::element_refusal` (shared with the
//! GPU backend) then names the reason: it re-evaluates
//! the failed element at the positions the kernel left. Those are the
//! positions the element was refused at, because the element failed
//! before writing, the other elements of its colour write none of its
//! dynamic particles (the colouring), fixed particles are never written,
//! and the chunk holding it stopped at that element.
//!
//! **Residual.** A material family's violation is max_e C_e = √(2 W_e),
//! the square root of twice the largest element energy (0 at rest; under
//! load, the energy the law stores); a refused element counts as +∞ (its
//! Neo-Hookean energy is unbounded as J → 0⁺).

use hyperpbd_core::Family;
use hyperpbd_core::material::{LawRefusal, MaterialScratch};

/// C of element `e` (colour-ordered slot) of the material family `family`
/// at the gathered `points`; ∇C into `grad`. A family of another kind has
/// no energy constraint: C = NaN (the caller's finiteness check fails).
pub fn energy_constraint(
    family: &Family,
    e: usize,
    points: &[f64],
    dim: usize,
    grad: &mut [f64],
    scratch: &mut MaterialScratch,
) -> Result<f64, LawRefusal> {
    match family.kind.material_element(e, points, dim) {
        Some(element) => hyperpbd_core::material::energy_constraint(element, grad, scratch),
        None => Ok(f64::NAN),
    }
}
