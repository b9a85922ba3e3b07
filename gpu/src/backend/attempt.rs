//! One attempt of the GPU step: the plan's own substeps, or a subdivided
//! plan's (adaptive), and the guard rejection of either.
//!
//! ```text
//! attempt 0       the step: one command buffer, one submit, one status
//!                 readback, which is the step's one host wait (backend.rs's
//!                 module doc)
//! guard kernels   a violation is the status word (guard call, first slot /
//!                 particle); every later call of the step does nothing, so
//!                 the resident state is the rejected substep's end: the
//!                 host reads it once, names the value with the CPU's
//!                 functions (hyperpbd_core::guards), then rolls back
//! attempt j > 0   plan.subdivided(j) built once on this device (its own
//!                 call blocks, schedule and pipelines); x, v, force copied
//!                 in on the device, the step run there, x, v copied back
//!                 on success — no host round trip of the state
//! ```

use hyperpbd_core::adaptive::Subdivided;
use hyperpbd_core::guards::{
    element_ratio_at, element_verdict, measure_rejection, speed_rejection, squared_speed,
};
use hyperpbd_core::{BackendError, GpuError, GuardKind, Kernel, State, StepError, StepReport};

use super::GpuBackend;
use crate::params::read_reals;

impl GpuBackend {
    /// One step of the plan's own substeps (attempt 0 of the adaptive
    /// step).
    pub(super) fn step_once(&mut self) -> Result<StepReport, BackendError> {
        self.upload_motion()?;
        if self.contacts.is_some() {
            return self.step_with_contacts();
        }
        let block = self.submit_step()?;
        if let Some(failed) = self.failure(&block) {
            return Err(self.diagnosed_error(failed));
        }
        let report = read_reals(&block[16..], self.precision);
        Ok(crate::xpbd::step_report(&self.plan, &report))
    }

    /// One submission of the step's dispatches (the chosen schedule, every
    /// world of a batch): the state saved first, a snapshot copied out when
    /// one was asked for, one wait; the status block and the report as
    /// read back. A step whose loops were cut is refused, rolled back.
    pub(super) fn submit_step(&mut self) -> Result<Vec<u8>, BackendError> {
        self.reset_status();
        let mut encoder = self.record(|e| self.state.save(e), &self.fast, 1, true);
        let snapshot = self.state.record_snapshot(&mut encoder);
        self.ctx.submit(encoder)?;
        if let Some(slot) = snapshot {
            self.state.map_snapshot(slot);
        }
        // One wait: mapping the report waits for the step, and completes
        // the snapshot's mapping with it.
        let block =
            self.read_mapped(&self.buffers.report_staging, 16 + self.buffers.report_bytes)?;
        self.ctx.check()?;
        self.refuse_cut_loops(&block)?;
        Ok(block)
    }

    /// The rejection named by a status word whose failing call `call` is
    /// a guard, at `index`, from the state as the failure left it (the
    /// caller rolls back); `None` when `call` is no guard.
    pub(super) fn guard_rejection(
        &mut self,
        (call, index): (u32, u32),
    ) -> Option<Result<BackendError, GpuError>> {
        let kernel = self.schedule.kernel_of(call)?;
        if !matches!(kernel, Kernel::GuardMeasure { .. } | Kernel::GuardSpeed) {
            return None;
        }
        let substep = call / self.schedule.kernels_per_substep.max(1) as u32;
        let state = match self.state.read(&self.ctx) {
            Ok(state) => state,
            Err(e) => return Some(Err(e)),
        };
        let plan = &self.plan;
        let guards = plan.guards.clone().unwrap_or_default();
        let slot = index as usize;
        let rejection = match kernel {
            Kernel::GuardMeasure { family } => {
                let j = element_ratio_at(plan, family, slot, &state.positions);
                // f32 kernels may round J across the limit where the f64
                // evaluation of the same state does not: the device's
                // verdict stands, the value is the host's J.
                let (guard, limit) = element_verdict(&guards, j).unwrap_or(if guards.orientation {
                    (GuardKind::Orientation, 0.0)
                } else {
                    (
                        GuardKind::MinMeasureRatio,
                        guards.min_measure_ratio.unwrap_or(0.0),
                    )
                });
                measure_rejection(plan, family, (slot, guard, j, limit), substep)
            }
            _ => {
                let dim = plan.dim;
                let v = state
                    .velocities
                    .get(slot * dim..(slot + 1) * dim)
                    .unwrap_or(&[]);
                let limit = guards.max_speed.unwrap_or(0.0);
                speed_rejection((slot, squared_speed(v).sqrt(), limit), substep)
            }
        };
        Some(Ok(StepError::GuardRejected(rejection).into()))
    }

    /// The rejection of a step whose status names a guard call, with the
    /// state rolled back; `None` when the failing call is no guard.
    pub(super) fn guard_error(&mut self, failed: (u32, u32)) -> Option<BackendError> {
        let kernel = self.schedule.kernel_of(failed.0)?;
        if !matches!(kernel, Kernel::GuardMeasure { .. } | Kernel::GuardSpeed) {
            return None;
        }
        // The calls after a failing one still run (the step is refused
        // anyway), so the state the step left lies past the rejected
        // substep: rerun the step exactly through the guard call, then
        // name the value from that state, as the CPU does.
        if let Err(e) = self.rerun_through(failed.0) {
            return Some(self.roll_back_after(e.into()));
        }
        let found = self.guard_rejection(failed)?;
        Some(self.roll_back_after(found.unwrap_or_else(BackendError::from)))
    }

    /// One attempt on `plan.subdivided(subdivision)`, run by a backend of
    /// that plan on this device (built on first use) from this state.
    fn subdivided_attempt(&mut self, subdivision: u32) -> Result<StepReport, BackendError> {
        let j = subdivision as usize;
        while self.subdivided.len() < j {
            let plan = self.plan.subdivided(self.subdivided.len() as u32 + 1);
            let n = plan.particle_count() * plan.dim;
            let blank = State {
                dim: plan.dim,
                positions: vec![0.0; n],
                velocities: vec![0.0; n],
            };
            let (ctx, origin) = (self.ctx.clone(), self.origin().clone());
            let mode = Some(self.schedule.mode);
            let built = self.ctx.building(|| {
                Self::build(
                    ctx.clone(),
                    plan,
                    &blank,
                    self.precision,
                    origin,
                    mode,
                    None,
                )
            })?;
            self.subdivided.push(built);
        }
        let clock = self.motion.as_ref().map(|m| m.step);
        let refined = &mut self.subdivided[j - 1];
        if let (Some(step), Some(moving)) = (clock, refined.motion.as_mut()) {
            moving.step = step;
        }
        copy_state(&self.ctx, &self.state, &refined.state, true)?;
        let report = refined.step_once()?;
        let refined = &self.subdivided[j - 1];
        self.state.forget_snapshot();
        copy_state(&self.ctx, &refined.state, &self.state, false)?;
        Ok(report)
    }
}

/// x and v (and the forces when `forces`) of `from` into `to`, on the
/// device, byte for byte (same plan topology, same layout).
fn copy_state(
    ctx: &crate::context::GpuContext,
    from: &crate::resident::ResidentState,
    to: &crate::resident::ResidentState,
    forces: bool,
) -> Result<(), hyperpbd_core::GpuError> {
    let mut encoder = ctx.device.create_command_encoder(&Default::default());
    let mut pairs = vec![(&from.x, &to.x), (&from.v, &to.v)];
    if forces {
        pairs.push((&from.force, &to.force));
    }
    for (a, b) in pairs {
        encoder.copy_buffer_to_buffer(a, 0, b, 0, a.size().min(b.size()));
    }
    ctx.submit_and_wait(encoder)
}

impl Subdivided for GpuBackend {
    fn attempt(&mut self, subdivision: u32) -> Result<StepReport, BackendError> {
        let attempt = if subdivision == 0 {
            self.step_once()
        } else {
            self.subdivided_attempt(subdivision)
        };
        if attempt.is_ok() {
            self.motion_step_done();
        }
        attempt
    }
}
