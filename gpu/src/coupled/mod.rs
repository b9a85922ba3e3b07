//! `CoupledStep` ([`crate::GpuCoupledBackend`]): the coupled implicit step (docs/implicit.md §7) on
//! the GPU, the golden path's schedule (`cpu/src/coupled/`) kernel for
//! kernel: every per-element and per-particle pass, PCG whole (its vectors
//! and its scalar recurrence, pcg.rs), the line search's vectors, and every
//! sum on the block tree run in `shaders/coupled.wgsl` and
//! `coupled_solve.wgsl`, the material elements' passes (StVK, Neo-Hookean:
//! W, ∇W, the frame Hessian H_F projected by cyclic Jacobi, its products)
//! in `coupled_material.wgsl`; the host runs the Newton loop's other
//! decisions on the few reduced scalars it reads back, through the same
//! core functions as the CPU (`pcg_start`, `armijo`, `MinimisationReport`,
//! `change_resolution`).
//!
//! ```text
//! per substep:  cp_start (x^t, x~, load, lags, d ≤ 0) → pairs at x^t (collisions) → warm start
//!               loop { x_k → point; cp_elements + cp_material_elements; cp_gradient;
//!                      Σ|max → residual (one read; without materials PCG's start
//!                      rides in it)
//!                      PCG on the device (pcg.rs: cp_material_frames (H_F⁺ at x_k, only
//!                      with materials), the diagonal and start, one read; then
//!                      chunks of iterations, one read each; cp_material_slots after
//!                      every cp_slots)
//!                      pairs over [x_k, x_k + Δ]; filter and, at x_k, elements and
//!                      slope (one read); trials in batches of 1, 2, 4, … (one read
//!                      per batch, trials.rs); accept (no read) }
//!               cp_finish: x = x_k, v = (x − x^t)/h (no read)
//! host waits    per Newton iteration: the residual, PCG's chunks, filter + slope, the
//!               trial batches (plus the swept pairs with collisions); per substep the start
//!               (with the warm start's filter when there are no collisions)
//! pairs         the broadphase over the swept boxes runs on the host over x_k and Δ read
//!               back (only with `collisions`); the element list (springs, balls, pair
//!               friction lags frozen at x^t) is re-uploaded when the pair set changes
//! materials     refusals (a law refusal at x_k, a non-finite H_F) and the rounding δW
//!               of the floor are core's functions on the host, on x_k read back
//!               (only when needed), as the golden path names and sums them
//! loops         a material element whose Jacobi sweeps llvmpipe cuts short is a typed
//!               refusal naming it (R^5 simplices on lavapipe; material.rs)
//! f32           the same passes at ε₃₂ (f32.rs): the certified filter counts ε₃₂ on the
//!               stored device coordinates (relative to the scene origin), radii stored
//!               rounded outward, the rounding floor at ε₃₂ with its second-order terms;
//!               the authored criterion, ending mostly at RoundingFloor
//! refused       material families in f32 (their δW and frame Hessians are outside the
//!               f32 bound)
//! ```
//! In f64 on lavapipe every state is bit-identical to the CPU golden path
//! (`tests/gpu/coupled/`). In f32 nothing the device reports is taken as
//! evidence: the host recomputes ∇F in f64 at the returned iterate
//! (`hyperpbd_cpu::coupled_gradient`) and bounds its distance to the CPU's
//! iterate with a per-particle modulus (`hyperpbd_verify::compare_coupled`,
//! `tests/gpu/coupled_f32.rs`).

mod cg_state;
mod device;
mod entries;
pub(crate) mod expression;
mod f32;
mod material;
mod newton;
mod pcg;
mod step;
mod trials;

use hyperpbd_core::{BackendError, MinimisationReport};

use crate::minimising::{Minimiser, Minimising};
use crate::resident_backend::{Load, Resident, ResidentBackend};
use newton::Newton;
pub use step::CoupledStep;

/// The GPU backend of the coupled implicit step.
pub type GpuCoupledBackend = ResidentBackend<Minimising<CoupledStep>>;

/// The coupled step minimises by Newton's loop (newton.rs) on its own
/// data (step.rs). Implemented here, not in step.rs: newton.rs reads
/// step.rs, and no two files may import each other (tests/house).
impl Minimiser for CoupledStep {
    fn load(load: Load<'_>) -> Result<(Resident, Self), BackendError> {
        CoupledStep::load(load)
    }

    fn minimise(&mut self, on: &mut Resident) -> Result<MinimisationReport, BackendError> {
        Newton { on, step: self }.minimise()
    }
}
