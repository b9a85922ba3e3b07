//! The GPU step of a plan with particle–particle contact: the plain step
//! (the plan's schedule, fused where the golden order allows) with the
//! contact kernel set ([`crate::contact`]) recorded at the plan's
//! Broadphase and Collide calls, all in one compute pass, one submit.
//!
//! ```text
//! reset status and contact counters; save (x, v)
//! one pass, the schedule's dispatches in order:
//!   Broadphase  boxes from the resident p, x (radius + margin) → hashed grid →
//!               every particle's sorted contact list (pairs of two fixed
//!               particles left out)                          (8 dispatches)
//!   Collide     snapshot + collide on the resident x, p       (2 dispatches)
//!   other       the plan's dispatch, as in the plain step
//! residuals; contact report (deepest overlap, active pairs)  (2 dispatches)
//! ONE wait: status + report (backend) and the 32-byte contact outcome mapped
//!   together, read back with one device poll
//!   a list longer than its slots → roll (x, v) back, grow the lists, rerun
//!   a failed call → roll back, the CPU's error (a contact failure names the
//!   particle the CPU names)
//! ```
//! A batch (batch.rs) records the same dispatches for all its worlds
//! (contact.wgsl's worlds): one outcome per world, and a world whose
//! lists did not fit grows its own lists only; the whole batch reruns the
//! step from its start, so no world loses a step or a pair.
//! No host round trip inside the step: every dispatch size is known when
//! the plan is loaded (particles, buckets), so nothing waits for a count.

use hyperpbd_core::{BackendError, GpuError, Kernel, Plan, StepReport};

use super::GpuBackend;
use crate::Precision;
use crate::contact::{
    BOXES_FROM_STATE, Block, Bound, ContactBuffers, ContactKernels, ContactPhase, Outcome,
    Particles, SKIP_FIXED_PAIRS,
};
use crate::context::GpuContext;
use crate::xpbd::Placed;
use crate::xpbd::schedule::Run;

/// List slots per particle a contact stage starts with (grown on demand).
const INITIAL_SLOTS: usize = 32;
/// Reruns of one step after growing the lists before giving up (each
/// growth at least doubles the slots and fits the longest list seen, and a
/// rerun from the same state finds the same lists, so one is enough).
const MAX_REGROWTHS: usize = 4;

/// The contact kernels and buffers of a backend with collisions.
pub(super) struct ContactStage {
    kernels: ContactKernels,
    buffers: ContactBuffers,
    /// Parameter block of the end-of-step report.
    report_block: usize,
}

impl ContactStage {
    /// The stage of `plans` (one per world, world 0's schedule; each with
    /// collisions), bound to the backend's resident particle records and
    /// status word.
    pub(super) fn new(
        ctx: &GpuContext,
        (plans, precision): (&[Plan], Precision),
        bound: Bound,
    ) -> Result<Self, GpuError> {
        let without = || GpuError::Other {
            message: "a contact stage for a plan without collisions".into(),
        };
        let plan = plans.first().ok_or_else(without)?;
        let mut margin = Vec::with_capacity(plans.len());
        let mut friction = Vec::with_capacity(plans.len());
        for p in plans {
            let contacts = p.contacts.ok_or_else(without)?;
            margin.push(contacts.margin);
            friction.push(contacts.friction);
        }
        let concat = |part: fn(&Plan) -> &[f64]| -> Vec<f64> {
            plans.iter().flat_map(|p| part(p).iter().copied()).collect()
        };
        let k = plan.substep_kernels.len() as u32;
        let mut blocks = Vec::new();
        for substep in 0..plan.substeps {
            for (index, kernel) in plan.substep_kernels.iter().enumerate() {
                if matches!(kernel, Kernel::Broadphase | Kernel::Collide) {
                    blocks.push(Block {
                        call: substep * k + index as u32,
                        flags: SKIP_FIXED_PAIRS | BOXES_FROM_STATE,
                        axis: plan.dim as u32,
                    });
                }
            }
        }
        // The report runs only when no call of the step failed.
        blocks.push(Block {
            call: u32::MAX,
            flags: 0,
            axis: plan.dim as u32,
        });
        let worlds = (plans.len(), plan.particle_count());
        let kernels = ContactKernels::for_worlds(ctx, plan.dim, precision, worlds)?;
        let buffers = ContactBuffers::new(
            ctx,
            &kernels,
            bound,
            &Particles {
                inverse_mass: &concat(|p| &p.inverse_mass),
                radius: &concat(|p| &p.radius),
                margin: &margin,
                friction: &friction,
            },
            INITIAL_SLOTS,
            blocks,
        )?;
        Ok(ContactStage {
            report_block: buffers.block_of(u32::MAX).unwrap_or(0),
            kernels,
            buffers,
        })
    }

    /// Records kernel `kernel` (Broadphase or Collide) of step call `call`.
    pub(super) fn encode(&self, pass: &mut wgpu::ComputePass<'_>, kernel: Kernel, call: u32) {
        let Some(block) = self.buffers.block_of(call) else {
            return;
        };
        let phase = match kernel {
            Kernel::Broadphase => ContactPhase::Broadphase,
            Kernel::Collide => ContactPhase::Collide,
            _ => return,
        };
        self.buffers.encode(&self.kernels, pass, phase, block);
    }

    /// Whether a list of some world did not fit (that world's lists are
    /// grown then, no other's: rerun), or an outcome's typed error.
    fn regrow(&mut self, outcomes: &[Outcome]) -> Result<bool, GpuError> {
        let mut grown = false;
        for (world, outcome) in outcomes.iter().enumerate() {
            outcome.trusted()?;
            let longest = outcome.longest_list as usize;
            if longest > self.buffers.world_slots()[world] {
                self.buffers.grow(&self.kernels, world, longest)?;
                grown = true;
            }
        }
        Ok(grown)
    }
}

/// The step report of `plan` from its residual `report` values and its
/// contact `outcome` (deepest overlap, active pairs).
pub(super) fn contact_report(plan: &Plan, report: &[f64], outcome: &Outcome) -> StepReport {
    let mut step = crate::xpbd::step_report(plan, report);
    step.residuals.push(hyperpbd_core::FamilyResidual {
        label: "collisions".into(),
        max_violation: outcome.deepest,
    });
    step.active_contacts += outcome.active as usize;
    step
}

/// The particle a failed Collide call names: index i for a non-finite pair
/// (its lower particle), count + k for a non-finite new position of k
/// (shaders/collide.wgsl).
pub(super) fn collide_particle(index: u32, particles: usize) -> usize {
    let index = index as usize;
    index.checked_sub(particles).unwrap_or(index)
}

impl GpuBackend {
    /// List slots per particle of the contact stage (`None` without
    /// particle contact): 32 at load, grown when a step found a longer
    /// list (that step then ran again from its start).
    pub fn contact_list_slots(&self) -> Option<usize> {
        self.contacts.as_ref().map(|stage| stage.buffers.slots())
    }

    /// Every world's list slots per particle (a batch; `None` without
    /// particle contact).
    pub(super) fn world_list_slots(&self) -> Option<Vec<usize>> {
        let stage = self.contacts.as_ref()?;
        Some(stage.buffers.world_slots().to_vec())
    }

    /// Times the host has waited for this backend's device (every device
    /// poll: `GpuContext::poll`) since it was loaded: a step costs one
    /// wait whatever its substeps (with contact: the status/report block
    /// and the contact outcome read together; no round trip per substep).
    pub fn host_waits(&self) -> u64 {
        self.ctx.host_waits()
    }

    /// The contact stage's dispatches per step (0 without one).
    pub(super) fn contact_dispatches_per_step(&self) -> usize {
        crate::contact::contact_dispatches_per_step(&self.plan)
    }

    /// Records a Host dispatch's contact kernels (their own bind groups) at
    /// the call's place in the schedule; false for any other dispatch.
    pub(super) fn encode_contact(&self, pass: &mut wgpu::ComputePass<'_>, d: &Placed) -> bool {
        let (Run::Host(kernel), Some(stage)) = (d.dispatch.run, &self.contacts) else {
            return false;
        };
        if let Some(call) = self.schedule.calls.get(d.dispatch.first_call as usize) {
            stage.encode(pass, kernel, call.call);
            pass.set_bind_group(0, &self.group, &[]);
        }
        true
    }

    /// One step of a plan with collisions (see the module doc).
    pub(super) fn step_with_contacts(&mut self) -> Result<StepReport, BackendError> {
        let (outcomes, block) = self.submit_fitting_contact_step()?;
        let outcome = outcomes.first().copied().unwrap_or(Outcome::EMPTY);
        self.finish_contact_step(&outcome, &block)
    }

    /// Submits the step (every world's) until every list fits, growing
    /// the lists that did not; every world's outcome and the status/report
    /// block of the step that fitted.
    pub(super) fn submit_fitting_contact_step(
        &mut self,
    ) -> Result<(Vec<Outcome>, Vec<u8>), BackendError> {
        for _ in 0..=MAX_REGROWTHS {
            let (outcomes, snapshot, block) = self.submit_contact_step()?;
            let Some(stage) = self.contacts.as_mut() else {
                break;
            };
            match stage.regrow(&outcomes) {
                Ok(false) => return Ok((outcomes, block)),
                Ok(true) => {
                    self.rollback()?;
                    if snapshot {
                        // The state the snapshot showed is gone: take the
                        // rerun's.
                        self.state.forget_snapshot();
                        self.state.prefetch();
                    }
                }
                Err(e) => return Err(self.roll_back_after(e.into())),
            }
        }
        Err(self.roll_back_after(
            GpuError::Other {
                message: "contact lists still too short after growing them".into(),
            }
            .into(),
        ))
    }

    /// Records, submits and waits for one step in the schedule's mode;
    /// returns the contact outcome, whether a state snapshot was taken and
    /// the status/report block.
    fn submit_contact_step(&mut self) -> Result<(Vec<Outcome>, bool, Vec<u8>), BackendError> {
        let Some(stage) = &self.contacts else {
            return Err(GpuError::Other {
                message: "contact step without a contact stage".into(),
            }
            .into());
        };
        self.reset_status();
        stage.buffers.reset();
        let mut encoder = self.ctx.device.create_command_encoder(&Default::default());
        self.state.save(&mut encoder);
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            pass.set_bind_group(0, &self.group, &[]);
            for d in &self.fast {
                self.encode(&mut pass, d);
            }
            let (phase, block) = (ContactPhase::Report, stage.report_block);
            stage
                .buffers
                .encode(&stage.kernels, &mut pass, phase, block);
        }
        let staging = &self.buffers.report_staging;
        encoder.copy_buffer_to_buffer(&self.buffers.status, 0, staging, 0, 16);
        if self.buffers.report_bytes > 0 {
            let bytes = self.buffers.report_bytes;
            encoder.copy_buffer_to_buffer(&self.buffers.report, 0, staging, 16, bytes);
        }
        stage.buffers.copy_outcome(&mut encoder);
        let snapshot = self.state.record_snapshot(&mut encoder);
        self.ctx.submit(encoder)?;
        if let Some(slot) = snapshot {
            self.state.map_snapshot(slot);
        }
        let Some(stage) = &self.contacts else {
            return Ok(unreachable_stage()?);
        };
        // One wait: the outcome and the status/report block mapped together
        // (the snapshot's mapping completes with them).
        let report = (&self.buffers.report_staging, 16 + self.buffers.report_bytes);
        let mut read = self
            .ctx
            .read_all(&[stage.buffers.outcome_staging(), report])?;
        self.ctx.check()?;
        let block = read.pop().unwrap_or_default();
        let outcomes = stage.buffers.outcomes_of(&read.pop().unwrap_or_default());
        Ok((outcomes, snapshot.is_some(), block))
    }

    /// The report of a submitted step whose lists fitted (its status/report
    /// `block`), or its error (state rolled back).
    fn finish_contact_step(
        &mut self,
        outcome: &Outcome,
        block: &[u8],
    ) -> Result<StepReport, BackendError> {
        self.refuse_cut_loops(block)?;
        if let Some(failed) = self.failure(block) {
            return Err(self.diagnosed_error(failed));
        }
        let report = crate::params::read_reals(&block[16..], self.precision);
        Ok(contact_report(&self.plan, &report, outcome))
    }

    /// `run_kernel` of Broadphase or Collide: the kernel of the first
    /// substep's call, alone (a broadphase whose lists did not fit is grown
    /// and rerun; it only reads x and p). Results the kernels cannot vouch
    /// for (loops cut short) are a typed error with x and v restored.
    pub(super) fn run_contact_kernel(&mut self, kernel: Kernel) -> Result<(), BackendError> {
        let Some(index) = self.plan.substep_kernels.iter().position(|&k| k == kernel) else {
            return Err(BackendError::InvalidCall(format!(
                "{kernel:?} is not in this plan's schedule"
            )));
        };
        let call = index as u32;
        self.state.forget_snapshot();
        for _ in 0..=MAX_REGROWTHS {
            let Some(stage) = &self.contacts else {
                break;
            };
            self.reset_status();
            stage.buffers.reset();
            let mut encoder = self.ctx.device.create_command_encoder(&Default::default());
            self.state.save(&mut encoder);
            {
                let mut pass = encoder.begin_compute_pass(&Default::default());
                stage.encode(&mut pass, kernel, call);
            }
            let staging = &self.buffers.report_staging;
            encoder.copy_buffer_to_buffer(&self.buffers.status, 0, staging, 0, 16);
            stage.buffers.copy_outcome(&mut encoder);
            self.submit_and_wait(encoder)?;
            let block = self.read_mapped(&self.buffers.report_staging, 16)?;
            let outcome = stage.buffers.read_outcome()?;
            if let Some((call, index)) = self.failure(&block) {
                return Err(self.step_error(call, index));
            }
            let Some(stage) = self.contacts.as_mut() else {
                break;
            };
            match stage.regrow(std::slice::from_ref(&outcome)) {
                Ok(false) => return Ok(()),
                Ok(true) => {}
                // A Collide whose loops were cut short moved x: undo it.
                Err(e) => return Err(self.roll_back_after(e.into())),
            }
        }
        Err(GpuError::Other {
            message: "contact lists still too short after growing them".into(),
        }
        .into())
    }
}

fn unreachable_stage<T>() -> Result<T, GpuError> {
    Err(GpuError::Other {
        message: "contact step without a contact stage".into(),
    })
}
