//! Guards and adaptive steps in a GPU batch: a world whose step failed is
//! stepped again alone, as its own single run steps it, and put back in
//! its place; the other worlds' results are not touched.
//!
//! ```text
//! batch step   every world at its plan's substeps (attempt 0): one
//!              submit, one wait. A failing call does not stop the calls
//!              after it (step.wgsl, "Failure"), and no kernel reads
//!              another world's records, so a world that did not fail
//!              holds exactly its own attempt 0, whatever another did
//! status       status[4 + w] ≠ 0: world w failed (batch.rs,
//!              `failed_worlds`; with particle contact, whose kernels
//!              stop every world's later calls after a failure: all)
//! accepted     kept, report attempts = [s]
//! failed       in world order: x, v of its start-of-step copy and its
//!                force → a backend of its own plan on this device (built
//!                at its first retry, then kept, with its subdivided
//!                steps); Backend::step there (core's step_adaptive:
//!                attempts s, 2s, 4s, … as its single run); x, v back
//!                into its place (device copies, no wait); its report is
//!                that run's
//! an error     (not a guard rejection, or rejected at every subdivision)
//!              in the lowest such world: every world rolled back from
//!              the batch's start-of-step copy, the error that world's own
//! ```
//! World k is its own single run, attempt for attempt: accepted, the
//! batch ran its attempt 0 (batch.rs, union.rs) and its single run
//! accepts that attempt; failed, it *is* its single run (the same plan,
//! origin and kernels, from the same bytes). Host waits of a failed batch
//! step: 1 + Σ over the retried worlds of their single run's.

use hyperpbd_core::{Backend, BackendError, GpuError, Plan, StepReport};

use crate::backend::{GpuBackend, XpbdStep};
use crate::resident::ResidentState;
use crate::resident_backend::{Resident, ResidentBackend};
use crate::xpbd::schedule::StepMode;

/// Per world of a batch, a backend of its own plan for its retries.
pub(crate) struct Retries {
    alone: Vec<Option<GpuBackend>>,
}

impl Retries {
    /// None built yet, for `worlds` worlds.
    pub fn new(worlds: usize) -> Self {
        Retries {
            alone: (0..worlds).map(|_| None).collect(),
        }
    }

    /// World `world` (plan `plans[world]`) stepped alone from its state at
    /// the start of the batch's step; on success its x and v written into
    /// its place in `batch` (see the module docs). On error `batch` is as
    /// the failed batch step left it (the caller rolls every world back).
    pub fn step_world(
        &mut self,
        batch: &mut Resident,
        plans: &[Plan],
        world: usize,
    ) -> Result<StepReport, BackendError> {
        let (Some(plan), Some(slot)) = (plans.get(world), self.alone.get_mut(world)) else {
            return Err(GpuError::Other {
                message: format!("a batch step failed in world {world}, which is not in the batch"),
            }
            .into());
        };
        let single = match slot {
            Some(single) => single,
            None => slot.insert(alone(batch, plan)?),
        };
        let (n, first) = (plan.particle_count(), world * plan.particle_count());
        let mut encoder = batch.encoder();
        let from = (&batch.state, first, true);
        ResidentState::record_copy(&mut encoder, from, (&single.on.state, 0), (n, true));
        single.on.state.forget_snapshot();
        batch.ctx.submit(encoder)?;
        let report = single.step()?;
        let mut encoder = batch.encoder();
        let back = (&single.on.state, 0, false);
        ResidentState::record_copy(&mut encoder, back, (&batch.state, first), (n, false));
        batch.state.forget_snapshot();
        batch.ctx.submit(encoder)?;
        Ok(report)
    }
}

/// A backend of `plan` (one world of `batch`) on the batch's device, its
/// origin and schedule mode; its state is copied in before each use.
fn alone(batch: &Resident, plan: &Plan) -> Result<GpuBackend, BackendError> {
    let (on, step) = XpbdStep::build_beside(batch, plan.clone(), StepMode::Fused)?;
    Ok(ResidentBackend::from_parts(on, step))
}
