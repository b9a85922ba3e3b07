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

use super::status::StatusReader;
use crate::Precision;
use crate::contact::{
    BOXES_FROM_STATE, Block, Bound, ContactBuffers, ContactKernels, ContactPhase, Outcome,
    Particles, SKIP_FIXED_PAIRS,
};
use crate::context::GpuContext;
use crate::resident_backend::Resident;

/// List slots per particle a contact stage starts with (grown on demand).
const INITIAL_SLOTS: usize = 32;
/// Reruns of one step after growing the lists before giving up (each
/// growth at least doubles the slots and fits the longest list seen, and a
/// rerun from the same state finds the same lists, so one is enough).
const MAX_REGROWTHS: usize = 4;

/// The contact kernels and buffers of a backend with collisions.
pub(crate) struct ContactStage {
    kernels: ContactKernels,
    buffers: ContactBuffers,
    /// Parameter block of the end-of-step report.
    report_block: usize,
}

impl ContactStage {
    /// The stage of `plans` (one per world, world 0's schedule; each with
    /// collisions), bound to the backend's resident particle records and
    /// status word.
    pub(crate) fn new(
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
    pub(crate) fn encode(&self, pass: &mut wgpu::ComputePass<'_>, kernel: Kernel, call: u32) {
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
pub(crate) fn contact_report(plan: &Plan, report: &[f64], outcome: &Outcome) -> StepReport {
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
pub(crate) fn collide_particle(index: u32, particles: usize) -> usize {
    let index = index as usize;
    index.checked_sub(particles).unwrap_or(index)
}

/// Records a step's dispatches (the stage's own at the Host calls) into
/// the encoder, in compute passes of its own.
pub(crate) type RecordStep<'a> = &'a dyn Fn(&mut wgpu::CommandEncoder, &ContactStage);

impl ContactStage {
    /// List slots per particle (world 0's): 32 at load, grown when a step
    /// found a longer list (that step then ran again from its start).
    pub fn slots(&self) -> usize {
        self.buffers.slots()
    }

    /// Every world's list slots per particle.
    pub fn world_slots(&self) -> Vec<usize> {
        self.buffers.world_slots().to_vec()
    }

    /// Submits the step (every world's, recorded by `record`) until every
    /// list fits, growing the lists that did not; every world's outcome
    /// and the status/report block of the step that fitted.
    pub fn submit_fitting(
        &mut self,
        on: &mut Resident,
        status: &StatusReader,
        record: RecordStep<'_>,
    ) -> Result<(Vec<Outcome>, Vec<u8>), BackendError> {
        for _ in 0..=MAX_REGROWTHS {
            let (outcomes, snapshot, block) = self.submit(on, status, record)?;
            match self.regrow(&outcomes) {
                Ok(false) => return Ok((outcomes, block)),
                Ok(true) => {
                    on.state.rollback(&on.ctx)?;
                    if snapshot {
                        // The state the snapshot showed is gone: take the
                        // rerun's.
                        on.state.forget_snapshot();
                        on.state.prefetch();
                    }
                }
                Err(e) => return Err(on.roll_back_after(e.into())),
            }
        }
        Err(on.roll_back_after(
            GpuError::Other {
                message: "contact lists still too short after growing them".into(),
            }
            .into(),
        ))
    }

    /// Records, submits and waits for one step; returns the contact
    /// outcomes, whether a state snapshot was taken and the status/report
    /// block.
    fn submit(
        &self,
        on: &mut Resident,
        status: &StatusReader,
        record: RecordStep<'_>,
    ) -> Result<(Vec<Outcome>, bool, Vec<u8>), BackendError> {
        status.reset(&on.ctx);
        self.buffers.reset();
        let mut encoder = on.ctx.device.create_command_encoder(&Default::default());
        on.state.save(&mut encoder);
        record(&mut encoder, self);
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            let (phase, block) = (ContactPhase::Report, self.report_block);
            self.buffers.encode(&self.kernels, &mut pass, phase, block);
        }
        status.copy_out(&mut encoder, true);
        self.buffers.copy_outcome(&mut encoder);
        let snapshot = on.state.record_snapshot(&mut encoder);
        on.ctx.submit(encoder)?;
        if let Some(slot) = snapshot {
            on.state.map_snapshot(slot);
        }
        // One wait: the outcome and the status/report block mapped together
        // (the snapshot's mapping completes with them).
        let mut read = on
            .ctx
            .read_all(&[self.buffers.outcome_staging(), status.staged()])?;
        on.ctx.check()?;
        let block = read.pop().unwrap_or_default();
        let outcomes = self.buffers.outcomes_of(&read.pop().unwrap_or_default());
        Ok((outcomes, snapshot.is_some(), block))
    }

    /// `run_kernel` of Broadphase or Collide, substep call `call`: the
    /// kernel alone (a broadphase whose lists did not fit is grown and
    /// rerun; it only reads x and p); `Some` failing (call, index) the
    /// caller names. Results the kernels cannot vouch for (loops cut
    /// short) are a typed error with x and v restored.
    pub fn run_kernel(
        &mut self,
        on: &mut Resident,
        status: &StatusReader,
        (kernel, call): (Kernel, u32),
    ) -> Result<Option<(u32, u32)>, BackendError> {
        on.state.forget_snapshot();
        for _ in 0..=MAX_REGROWTHS {
            status.reset(&on.ctx);
            self.buffers.reset();
            let mut encoder = on.ctx.device.create_command_encoder(&Default::default());
            on.state.save(&mut encoder);
            {
                let mut pass = encoder.begin_compute_pass(&Default::default());
                self.encode(&mut pass, kernel, call);
            }
            status.copy_out(&mut encoder, false);
            self.buffers.copy_outcome(&mut encoder);
            on.ctx.submit_and_wait(encoder)?;
            let block = status.read(&on.ctx, false)?;
            let outcome = self.buffers.read_outcome()?;
            if let Some(failed) = StatusReader::failure(&block) {
                return Ok(Some(failed));
            }
            match self.regrow(std::slice::from_ref(&outcome)) {
                Ok(false) => return Ok(None),
                Ok(true) => {}
                // A Collide whose loops were cut short moved x: undo it.
                Err(e) => return Err(on.roll_back_after(e.into())),
            }
        }
        Err(GpuError::Other {
            message: "contact lists still too short after growing them".into(),
        }
        .into())
    }
}
