//! The GPU step of a plan with particle–particle contact: the plain step
//! with the contact kernel set ([`crate::contact`]) recorded at the plan's
//! Broadphase and Collide positions, all in one compute pass, one submit.
//!
//! ```text
//! reset status and contact counters; save (x, v)
//! substeps × plan.substep_kernels, one pass:
//!   Broadphase  boxes from the resident p, x (radius + margin) → hashed grid →
//!               every particle's sorted contact list (pairs of two fixed
//!               particles left out)                          (8 dispatches)
//!   Collide     snapshot + collide on the resident x, p       (2 dispatches)
//!   other       the plan's dispatch, as in the plain step
//! residuals; contact report (deepest overlap, active pairs)
//! one wait; read status + report (backend) and the 32-byte contact outcome
//!   a list longer than its slots → roll (x, v) back, grow the lists, rerun
//!   a failed call → roll back, the CPU's error (a contact failure names the
//!   particle the CPU names)
//! ```
//! No host round trip inside the step: every dispatch size is known when
//! the plan is loaded (particles, buckets), so nothing waits for a count.

use hyperpbd_core::{BackendError, FamilyResidual, GpuError, Kernel, Plan, StageName, StepReport};

use super::GpuBackend;
use crate::Precision;
use crate::contact::{
    BOXES_FROM_STATE, Block, Bound, ContactBuffers, ContactKernels, Outcome, Particles,
    SKIP_FIXED_PAIRS,
};

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
    /// The stage of `plan` (which has collisions), bound to the backend's
    /// resident buffers.
    pub(super) fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        errors: std::sync::Arc<std::sync::Mutex<Vec<String>>>,
        (plan, precision): (&Plan, Precision),
        bound: Bound,
    ) -> Result<Self, GpuError> {
        let contacts = plan.contacts.ok_or_else(|| GpuError::Other {
            message: "a contact stage for a plan without collisions".into(),
        })?;
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
        let kernels = ContactKernels::new(device, plan.dim, precision)?;
        let buffers = ContactBuffers::new(
            (device, queue, errors),
            &kernels,
            bound,
            &Particles {
                inverse_mass: &plan.inverse_mass,
                radius: &plan.radius,
                margin: contacts.margin,
                friction: contacts.friction,
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
    fn encode(&self, pass: &mut wgpu::ComputePass<'_>, kernel: Kernel, call: u32) {
        let Some(block) = self.buffers.block_of(call) else {
            return;
        };
        match kernel {
            Kernel::Broadphase => self.buffers.encode_broadphase(&self.kernels, pass, block),
            Kernel::Collide => self.buffers.encode_collide(&self.kernels, pass, block),
            _ => {}
        }
    }

    /// `Some(slots)` when a list did not fit: grow to that and rerun.
    fn regrow(&mut self, outcome: &Outcome) -> Result<bool, GpuError> {
        outcome.trusted()?;
        let longest = outcome.longest_list as usize;
        if longest <= self.buffers.slots() {
            return Ok(false);
        }
        self.buffers.grow(&self.kernels, longest)?;
        Ok(true)
    }
}

/// The particle a failed Collide call names: index i for a non-finite pair
/// (its lower particle), count + k for a non-finite new position of k
/// (shaders/collide.wgsl).
pub(super) fn collide_particle(index: u32, particles: usize) -> usize {
    let index = index as usize;
    index.checked_sub(particles).unwrap_or(index)
}

impl GpuBackend {
    /// One step of a plan with collisions (see the module doc).
    pub(super) fn step_with_contacts(&mut self) -> Result<StepReport, BackendError> {
        for _ in 0..=MAX_REGROWTHS {
            let outcome = self.submit_contact_step()?;
            let Some(stage) = self.contacts.as_mut() else {
                break;
            };
            match stage.regrow(&outcome) {
                Ok(false) => return self.finish_contact_step(&outcome),
                Ok(true) => self.rollback()?,
                Err(e) => {
                    self.rollback()?;
                    return Err(e.into());
                }
            }
        }
        Err(GpuError::Other {
            message: "contact lists still too short after growing them".into(),
        }
        .into())
    }

    /// Records, submits and waits for one step; returns the contact outcome
    /// (the status and report block are in `report_staging`).
    fn submit_contact_step(&mut self) -> Result<Outcome, BackendError> {
        let Some(stage) = &self.contacts else {
            return Err(GpuError::Other {
                message: "contact step without a contact stage".into(),
            }
            .into());
        };
        self.reset_status();
        stage.buffers.reset();
        let bytes = self.buffers.state_bytes;
        let mut encoder = self.device.create_command_encoder(&Default::default());
        if bytes > 0 {
            encoder.copy_buffer_to_buffer(&self.buffers.x, 0, &self.buffers.saved_x, 0, bytes);
            encoder.copy_buffer_to_buffer(&self.buffers.v, 0, &self.buffers.saved_v, 0, bytes);
        }
        let kernels = &self.plan.substep_kernels;
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            pass.set_bind_group(0, &self.state_group, &[]);
            let mut dispatches = self.step_dispatches.iter();
            for substep in 0..self.plan.substeps {
                for (index, &kernel) in kernels.iter().enumerate() {
                    if matches!(kernel, Kernel::Broadphase | Kernel::Collide) {
                        let call = substep * kernels.len() as u32 + index as u32;
                        stage.encode(&mut pass, kernel, call);
                        pass.set_bind_group(0, &self.state_group, &[]);
                        continue;
                    }
                    let Some(d) = dispatches.next() else {
                        return Err(GpuError::Other {
                            message: "contact step: dispatch list shorter than the plan".into(),
                        }
                        .into());
                    };
                    self.encode(&mut pass, d);
                }
            }
            for d in &self.residual_dispatches {
                self.encode(&mut pass, d);
            }
            stage
                .buffers
                .encode_report(&stage.kernels, &mut pass, stage.report_block);
        }
        encoder.copy_buffer_to_buffer(&self.buffers.status, 0, &self.buffers.report_staging, 0, 16);
        if self.buffers.report_bytes > 0 {
            encoder.copy_buffer_to_buffer(
                &self.buffers.report,
                0,
                &self.buffers.report_staging,
                16,
                self.buffers.report_bytes,
            );
        }
        stage.buffers.copy_outcome(&mut encoder);
        self.submit_and_wait(encoder)?;
        Ok(stage.buffers.read_outcome()?)
    }

    /// The report of a submitted step whose lists fitted, or its error
    /// (state rolled back).
    fn finish_contact_step(&self, outcome: &Outcome) -> Result<StepReport, BackendError> {
        let block =
            self.read_mapped(&self.buffers.report_staging, 16 + self.buffers.report_bytes)?;
        if let Some((call, index)) = self.failure(&block) {
            self.rollback()?;
            return Err(self.step_error(call, index));
        }
        let report = crate::params::read_reals(&block[16..], self.precision);
        let mut residuals = Vec::with_capacity(self.plan.families.len() + 1);
        let mut active_contacts = outcome.active as usize;
        for (family, f) in self.plan.families.iter().enumerate() {
            residuals.push(FamilyResidual {
                label: f.label.clone(),
                max_violation: report[2 * family],
            });
            if f.kind.is_inequality() {
                active_contacts += report[2 * family + 1] as usize;
            }
        }
        residuals.push(FamilyResidual {
            label: "collisions".into(),
            max_violation: outcome.deepest,
        });
        let mut kernel_calls: Vec<(StageName, u64)> =
            self.plan.stages.iter().map(|&s| (s, 0)).collect();
        for kernel in &self.plan.substep_kernels {
            if let Some(entry) = kernel_calls.iter_mut().find(|(s, _)| *s == kernel.stage()) {
                entry.1 += u64::from(self.plan.substeps);
            }
        }
        Ok(StepReport {
            kernel_calls,
            residuals,
            active_contacts,
            minimisation: Vec::new(),
        })
    }

    /// `run_kernel` of Broadphase or Collide: the kernel of the first
    /// substep's call, alone (a broadphase whose lists did not fit is grown
    /// and rerun; it only reads x and p).
    pub(super) fn run_contact_kernel(&mut self, kernel: Kernel) -> Result<(), BackendError> {
        let Some(index) = self.plan.substep_kernels.iter().position(|&k| k == kernel) else {
            return Err(BackendError::InvalidCall(format!(
                "{kernel:?} is not in this plan's schedule"
            )));
        };
        let call = index as u32;
        for _ in 0..=MAX_REGROWTHS {
            let Some(stage) = &self.contacts else {
                break;
            };
            self.reset_status();
            stage.buffers.reset();
            let mut encoder = self.device.create_command_encoder(&Default::default());
            {
                let mut pass = encoder.begin_compute_pass(&Default::default());
                stage.encode(&mut pass, kernel, call);
            }
            encoder.copy_buffer_to_buffer(
                &self.buffers.status,
                0,
                &self.buffers.report_staging,
                0,
                16,
            );
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
            if !stage.regrow(&outcome)? {
                return Ok(());
            }
        }
        Err(GpuError::Other {
            message: "contact lists still too short after growing them".into(),
        }
        .into())
    }
}
