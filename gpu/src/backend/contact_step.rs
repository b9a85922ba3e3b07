//! The GPU step of a plan with particle–particle contact.
//!
//! ```text
//! save (x, v)
//! substeps × plan.substep_kernels:
//!   Broadphase  submit what is recorded; read x and p back; swept boxes
//!               (radius + margin) → GpuSweep on this device (same rule as the
//!               CPU: axis of widest spread, canonical pairs, pairs of two fixed
//!               particles dropped) → contact lists (core::broadphase::
//!               contact_lists) → bind the contact kernels to the resident x, p
//!   Collide     collide_pairs + collide_gather on the resident x, p
//!   other       the plan's dispatch, as in the plain step
//! residuals; status; on failure roll (x, v) back
//! ```
//! The broadphase needs the pair total on the host (to grow the pair buffer
//! and rerun, never dropping a pair), so a contact step synchronises once
//! per substep; the rest is as resident as the plain step.

use hyperpbd_core::broadphase::{Aabbs, contact_lists, sweep_axis};
use hyperpbd_core::geometry::deepest_overlap;
use hyperpbd_core::{
    BackendError, FamilyResidual, GpuError, Kernel, ParticleContacts, StageName, StepReport,
};

use super::GpuBackend;
use crate::collide::{ContactLists, GpuCollide, Resident};
use crate::params::read_reals;
use crate::xpbd::schedule::Run;
use crate::{GpuSweep, Precision};

/// The broadphase and contact kernels of a backend with collisions.
pub(super) struct ContactStage {
    sweep: GpuSweep,
    collide: GpuCollide,
    friction: f64,
    margin: f64,
    /// Pairs and lists of the current substep.
    resident: Option<Resident>,
    pairs: Vec<[u32; 2]>,
}

impl ContactStage {
    /// `contacts` of a plan in R^`dim` with `particles` particles.
    pub(super) fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        errors: std::sync::Arc<std::sync::Mutex<Vec<String>>>,
        (dim, particles, precision): (usize, usize, Precision),
        contacts: ParticleContacts,
    ) -> Result<Self, GpuError> {
        let ParticleContacts { friction, margin } = contacts;
        Ok(ContactStage {
            sweep: GpuSweep::with_device(
                device.clone(),
                queue.clone(),
                errors.clone(),
                dim,
                precision,
                8 * particles.max(1),
            )?,
            collide: GpuCollide::with_device(
                device.clone(),
                queue.clone(),
                errors,
                dim,
                precision,
            )?,
            friction,
            margin,
            resident: None,
            pairs: Vec::new(),
        })
    }
}

impl GpuBackend {
    /// Reads x then p (as f64) after everything submitted so far.
    fn read_x_and_p(&self) -> Result<(Vec<f64>, Vec<f64>), GpuError> {
        let bytes = self.state.bytes();
        if bytes == 0 {
            return Ok((Vec::new(), Vec::new()));
        }
        let staging = &self.buffers.probe_staging;
        let mut encoder = self.ctx.device.create_command_encoder(&Default::default());
        encoder.copy_buffer_to_buffer(&self.state.x, 0, staging, 0, bytes);
        encoder.copy_buffer_to_buffer(&self.buffers.p, 0, staging, bytes, bytes);
        self.submit_and_wait(encoder)?;
        let data = self.read_mapped(staging, 2 * bytes)?;
        let split = bytes as usize;
        Ok((
            self.state.packing.unpack(&data[..split]),
            self.state.packing.unpack(&data[split..]),
        ))
    }

    /// Reads the status word: the failing call, if any.
    fn read_status(&self) -> Result<Option<(u32, u32)>, GpuError> {
        let mut encoder = self.ctx.device.create_command_encoder(&Default::default());
        encoder.copy_buffer_to_buffer(&self.buffers.status, 0, &self.buffers.report_staging, 0, 16);
        self.submit_and_wait(encoder)?;
        let block = self.read_mapped(&self.buffers.report_staging, 16)?;
        Ok(self.failure(&block))
    }

    /// The broadphase of one substep: pairs of the boxes swept from p to x.
    fn contact_broadphase(&mut self) -> Result<(), GpuError> {
        let (x, p) = self.read_x_and_p()?;
        let plan = &self.plan;
        let Some(stage) = self.contacts.as_mut() else {
            return Ok(());
        };
        let boxes = Aabbs::swept_particles(plan.dim, &p, &x, &plan.radius, stage.margin);
        let w = &plan.inverse_mass;
        let mut pairs = stage.sweep.sweep(&boxes, sweep_axis(&boxes))?;
        pairs.retain(|&[i, j]| w[i as usize] + w[j as usize] > 0.0);
        let (offsets, entries) = contact_lists(&pairs, plan.particle_count());
        stage.resident = Some(stage.collide.bind_resident(
            [
                &self.state.x,
                &self.state.v,
                &self.buffers.p,
                &self.state.force,
            ],
            &ContactLists {
                inverse_mass: &plan.inverse_mass,
                radius: &plan.radius,
                pairs: &pairs,
                offsets: &offsets,
                entries: &entries,
                friction: stage.friction,
            },
        ));
        stage.pairs = pairs;
        Ok(())
    }

    fn fail_and_roll_back(&mut self, call: u32, index: u32) -> BackendError {
        let rollback = self.rollback();
        self.step_error(call, index).after_rollback(rollback)
    }

    /// One step of a plan with collisions (see the module doc).
    pub(super) fn step_with_contacts(&mut self) -> Result<StepReport, BackendError> {
        self.reset_status();
        let mut encoder = self.ctx.device.create_command_encoder(&Default::default());
        self.state.save(&mut encoder);
        let mut kernel_calls: Vec<(StageName, u64)> =
            self.plan.stages.iter().map(|&s| (s, 0)).collect();
        let mut count = |stage: StageName| {
            if let Some(entry) = kernel_calls.iter_mut().find(|(s, _)| *s == stage) {
                entry.1 += 1;
            }
        };
        // The exact schedule, in passes split at each broadphase (which
        // runs on the host); particle contact is encoded in place.
        let dispatches = self.exact.clone();
        let mut start = 0;
        while start < dispatches.len() {
            let end = dispatches[start..]
                .iter()
                .position(|d| d.dispatch.run == Run::Host(Kernel::Broadphase))
                .map_or(dispatches.len(), |at| start + at);
            {
                let mut pass = encoder.begin_compute_pass(&Default::default());
                pass.set_bind_group(0, &self.group, &[]);
                for d in &dispatches[start..end] {
                    // One call per dispatch here; residual calls have no kernel.
                    if let Some(kernel) = self.schedule.kernel_of(d.dispatch.first_call) {
                        count(kernel.stage());
                    }
                    if d.dispatch.run == Run::Host(Kernel::Collide) {
                        if let Some(stage) = &self.contacts
                            && let Some(resident) = &stage.resident
                        {
                            stage.collide.encode(&mut pass, resident);
                            pass.set_bind_group(0, &self.group, &[]);
                        }
                        continue;
                    }
                    self.encode(&mut pass, d);
                }
            }
            if end < dispatches.len() {
                count(StageName::Broadphase);
                self.submit_and_wait(encoder)?;
                if let Some((call, index)) = self.read_status()? {
                    return Err(self.fail_and_roll_back(call, index));
                }
                self.contact_broadphase()?;
                encoder = self.ctx.device.create_command_encoder(&Default::default());
            }
            start = end + 1;
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
        self.submit_and_wait(encoder)?;
        let block =
            self.read_mapped(&self.buffers.report_staging, 16 + self.buffers.report_bytes)?;
        if let Some((call, index)) = self.failure(&block) {
            return Err(self.fail_and_roll_back(call, index));
        }
        let (x, _) = self.read_x_and_p()?;
        if let Some(i) = x.iter().position(|c| !c.is_finite()) {
            let error: BackendError = hyperpbd_core::StepError::NonFiniteParticle {
                stage: StageName::Project,
                substep: self.plan.substeps.saturating_sub(1),
                particle: i / self.plan.dim.max(1),
            }
            .into();
            return Err(error.after_rollback(self.rollback()));
        }
        let report = read_reals(&block[16..], self.precision);
        let mut residuals = Vec::with_capacity(self.plan.families.len() + 1);
        let mut active_contacts = 0;
        for (family, f) in self.plan.families.iter().enumerate() {
            residuals.push(FamilyResidual {
                label: f.label.clone(),
                max_violation: report[2 * family],
            });
            if f.kind.is_inequality() {
                active_contacts += report[2 * family + 1] as usize;
            }
        }
        let (deepest, active) = self.contact_report(&x)?;
        residuals.push(FamilyResidual {
            label: "collisions".into(),
            max_violation: deepest,
        });
        Ok(StepReport {
            kernel_calls,
            residuals,
            active_contacts: active_contacts + active,
            minimisation: Vec::new(),
            threads: 0,
        })
    }

    /// Deepest overlap over the last candidate pairs (the CPU's formula on
    /// the read-back positions) and the pairs active in the last iteration.
    fn contact_report(&self, x: &[f64]) -> Result<(f64, usize), GpuError> {
        let Some(stage) = &self.contacts else {
            return Ok((0.0, 0));
        };
        let dim = self.plan.dim;
        let deepest = deepest_overlap(dim, &self.plan.radius, &stage.pairs, x);
        let mut active = 0;
        if let Some(resident) = &stage.resident
            && resident.corr_bytes > 0
        {
            let staging = self.ctx.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("corrections staging"),
                size: resident.corr_bytes,
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            let mut encoder = self.ctx.device.create_command_encoder(&Default::default());
            encoder.copy_buffer_to_buffer(&resident.corr, 0, &staging, 0, resident.corr_bytes);
            self.submit_and_wait(encoder)?;
            let corr = read_reals(
                &self.read_mapped(&staging, resident.corr_bytes)?,
                self.precision,
            );
            active = corr.chunks_exact(dim + 1).filter(|c| c[dim] != 0.0).count();
        }
        Ok((deepest, active))
    }
}
