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
//! failed       every failed world: x, v of its start-of-step copy and
//!                its force → a backend of its own plan on this device
//!                (built at its first retry, then kept, with its
//!                subdivided steps); then Backend::step there for all of
//!                them on host threads in lockstep (core's step_adaptive:
//!                attempts s, 2s, 4s, … as its single run; the host's
//!                waits shared: crate::lockstep); x, v back into its place
//!                (device copies, no wait); its report is that run's
//! an error     (not a guard rejection, or rejected at every subdivision)
//!              in the lowest such world: every world rolled back from
//!              the batch's start-of-step copy, the error that world's own
//! ```
//! World k is its own single run, attempt for attempt: accepted, the
//! batch ran its attempt 0 (batch.rs, union.rs) and its single run
//! accepts that attempt; failed, it *is* its single run (the same plan,
//! origin and kernels, from the same bytes). Host waits of a failed batch
//! step: 1 + the most any retried world waits in its single run (one
//! after another they would be 1 + the sum).

use std::sync::Arc;

use hyperpbd_core::{Backend, BackendError, GpuError, Plan, StepReport};

use super::lockstep::step_all;
use crate::backend::{GpuBackend, XpbdStep};
use crate::lockstep::Lockstep;
use crate::resident::ResidentState;
use crate::resident_backend::{Resident, ResidentBackend};
use crate::xpbd::schedule::StepMode;

/// Per world of a batch, a backend of its own plan for its retries, and
/// the lockstep they are stepped in.
pub(crate) struct Retries {
    alone: Vec<Option<GpuBackend>>,
    lockstep: Arc<Lockstep>,
}

impl Retries {
    /// None built yet, for `worlds` worlds.
    pub fn new(worlds: usize) -> Self {
        Retries {
            alone: (0..worlds).map(|_| None).collect(),
            lockstep: Arc::default(),
        }
    }

    /// Worlds `worlds` (ascending; plans `plans[world]`) stepped alone from
    /// their states at the start of the batch's step, in lockstep; on
    /// success each one's x and v written into its place in `batch` (see
    /// the module docs). Their results in `worlds` order, and the host's
    /// waits for them (the lockstep's rounds). On error `batch` is as the
    /// failed batch step left it in that world (the caller rolls every
    /// world back).
    pub fn step_worlds(
        &mut self,
        batch: &mut Resident,
        plans: &[Plan],
        worlds: &[usize],
    ) -> (Vec<Result<StepReport, BackendError>>, u64) {
        let ready: Vec<Result<(), BackendError>> = worlds
            .iter()
            .map(|&world| self.copy_in(batch, plans, world))
            .collect();
        // The backends of the worlds copied in, in world order (a world
        // copied in has its backend).
        let mut copied = worlds
            .iter()
            .zip(&ready)
            .filter(|(_, r)| r.is_ok())
            .map(|(&w, _)| w)
            .peekable();
        let mut backends: Vec<(_, &mut (dyn Backend + Send))> = Vec::new();
        for (k, single) in self.alone.iter_mut().enumerate() {
            if copied.peek() == Some(&k) {
                copied.next();
                if let Some(single) = single.as_mut() {
                    backends.push((single.on.ctx.clone(), single));
                }
            }
        }
        let before = self.lockstep.waits();
        let mut stepped = step_all(&self.lockstep, backends).into_iter();
        let rounds = self.lockstep.waits() - before;
        let mut results = Vec::with_capacity(worlds.len());
        for (&world, prepared) in worlds.iter().zip(ready) {
            let result = prepared.and_then(|()| {
                let report = stepped.next().unwrap_or_else(|| {
                    Err(GpuError::Other {
                        message: format!("world {world}'s retry did not run"),
                    }
                    .into())
                })?;
                self.copy_back(batch, plans, world)?;
                Ok(report)
            });
            results.push(result);
        }
        (results, rounds)
    }

    /// World `world`'s start-of-step x, v and force copied into its own
    /// backend (built at its first retry, on the batch's device, joined to
    /// the lockstep); submitted, no wait.
    fn copy_in(
        &mut self,
        batch: &mut Resident,
        plans: &[Plan],
        world: usize,
    ) -> Result<(), BackendError> {
        let (Some(plan), Some(slot)) = (plans.get(world), self.alone.get_mut(world)) else {
            return Err(GpuError::Other {
                message: format!("a batch step failed in world {world}, which is not in the batch"),
            }
            .into());
        };
        let single = match slot {
            Some(single) => single,
            None => {
                let mut built = alone(batch, plan)?;
                built.on.ctx.join(self.lockstep.clone());
                slot.insert(built)
            }
        };
        let (n, first) = (plan.particle_count(), world * plan.particle_count());
        let mut encoder = batch.encoder();
        let from = (&batch.state, first, true);
        ResidentState::record_copy(&mut encoder, from, (&single.on.state, 0), (n, true));
        single.on.state.forget_snapshot();
        batch.ctx.submit(encoder)?;
        Ok(())
    }

    /// World `world`'s x and v from its own backend back into its place in
    /// `batch` (submitted, no wait).
    fn copy_back(
        &mut self,
        batch: &mut Resident,
        plans: &[Plan],
        world: usize,
    ) -> Result<(), BackendError> {
        let (Some(plan), Some(Some(single))) = (plans.get(world), self.alone.get(world)) else {
            return Err(GpuError::Other {
                message: format!("world {world} has no backend of its own"),
            }
            .into());
        };
        let (n, first) = (plan.particle_count(), world * plan.particle_count());
        let mut encoder = batch.encoder();
        let back = (&single.on.state, 0, false);
        ResidentState::record_copy(&mut encoder, back, (&batch.state, first), (n, false));
        batch.state.forget_snapshot();
        batch.ctx.submit(encoder)?;
        Ok(())
    }
}

/// A backend of `plan` (one world of `batch`) on the batch's device, its
/// origin and schedule mode; its state is copied in before each use.
fn alone(batch: &Resident, plan: &Plan) -> Result<GpuBackend, BackendError> {
    let (on, step) = XpbdStep::build_beside(batch, plan.clone(), StepMode::Fused)?;
    Ok(ResidentBackend::from_parts(on, step))
}
