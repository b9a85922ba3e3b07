//! `GpuBackend`: the plan's kernels as wgpu compute dispatches.
//!
//! ```text
//! load   buffers (structure of arrays), pipelines, both bind groups and
//!        every parameter block, once
//! step   one command buffer: save (x, v); substeps × plan.substep_kernels
//!        as dispatches; residual + reduction per family; copy the small
//!        status/report block out. One wait, one 16-byte + report readback.
//!        A failed call (status) → copy (x, v) back: state byte-identical.
//! ```
//! The schedule is the plan's: the GPU runs the algorithm of the CPU golden
//! path, kernel for kernel, in the same order.

use hyperpbd_core::{
    Backend, BackendError, FamilyKind, FamilyResidual, GpuError, Kernel, Plan, StageName, State,
    StepError, StepReport, check_forces, check_kernel, check_state,
};

use crate::context::GpuContext;
use crate::kernel_set::{KernelSet, KernelSetSpec, ParamBlocks};
use crate::layout::VectorLayout;
use crate::origin::SceneOrigin;
use crate::params::{Params, params_size, push_reals, read_reals, real_size};
use crate::resident::ResidentState;

mod contact_step;
use crate::pipelines::{Entry, STATE_BINDINGS};
use crate::{AdapterSummary, Precision};
use contact_step::ContactStage;

const NONE: u32 = u32::MAX;

/// One dispatch of a step.
#[derive(Debug, Clone, Copy)]
struct Dispatch {
    entry: Entry,
    params_offset: u32,
    invocations: u32,
    stage: Option<StageName>,
}

/// The device buffers besides the resident state.
struct Buffers {
    /// Positions at the substep start (read by the contact broadphase).
    p: wgpu::Buffer,
    status: wgpu::Buffer,
    report: wgpu::Buffer,
    /// Readback of status (16 bytes) followed by the report.
    report_staging: wgpu::Buffer,
    /// Readback of x then p (the contact broadphase).
    probe_staging: wgpu::Buffer,
    report_bytes: u64,
}

/// The wgpu backend.
pub struct GpuBackend {
    plan: Plan,
    precision: Precision,
    ctx: GpuContext,
    state: ResidentState,
    buffers: Buffers,
    kernels: KernelSet<Entry>,
    state_group: wgpu::BindGroup,
    params_group: wgpu::BindGroup,
    /// Dispatches of a whole step, substeps included.
    step_dispatches: Vec<Dispatch>,
    /// Residual dispatches run after the step.
    residual_dispatches: Vec<Dispatch>,
    /// Kernel calls per substep.
    kernels_per_substep: usize,
    /// Broadphase and contact kernels, when the plan has collisions.
    contacts: Option<ContactStage>,
}

fn kind_code(kind: &FamilyKind) -> u32 {
    match kind {
        FamilyKind::Distance => 0,
        FamilyKind::SimplexMeasure { .. } => 1,
        FamilyKind::OrientedMeasure => 2,
        FamilyKind::HyperplaneContact { .. } => 3,
        FamilyKind::Tether => 4,
    }
}

impl GpuBackend {
    /// Finds an adapter for `precision`, creates a device and loads `plan`
    /// with `state`.
    pub fn new(plan: Plan, state: &State, precision: Precision) -> Result<Self, BackendError> {
        let (adapter, _) = crate::request_adapter(precision)?;
        Self::with_adapter(&adapter, plan, state, precision)
    }

    /// Loads `plan` with `state` on a device of `adapter`.
    pub fn with_adapter(
        adapter: &wgpu::Adapter,
        plan: Plan,
        state: &State,
        precision: Precision,
    ) -> Result<Self, BackendError> {
        let origin = SceneOrigin::for_state(plan.dim, &state.positions, precision);
        Self::with_origin(adapter, plan, state, precision, origin)
    }

    /// Loads `plan` with `state`, storing positions relative to `origin`
    /// (see [`SceneOrigin`]; [`GpuBackend::with_adapter`] picks it).
    pub fn with_origin(
        adapter: &wgpu::Adapter,
        plan: Plan,
        state: &State,
        precision: Precision,
        origin: SceneOrigin,
    ) -> Result<Self, BackendError> {
        check_state(&plan, state)?;
        if origin.as_slice().len() != plan.dim {
            return Err(BackendError::InvalidCall(format!(
                "scene origin has {} components; the plan has dim {}",
                origin.as_slice().len(),
                plan.dim
            )));
        }
        if plan.dim > crate::shader::MAX_GPU_DIM {
            return Err(GpuError::Unsupported {
                what: format!(
                    "dimension {} (the GPU kernels support 1..={}; use the CPU backend)",
                    plan.dim,
                    crate::shader::MAX_GPU_DIM
                ),
            }
            .into());
        }
        if plan.incremental_potential.is_some() {
            return Err(incremental_potential_unsupported().into());
        }
        let ctx = GpuContext::new(adapter, precision)?;
        let (
            state,
            buffers,
            kernels,
            state_group,
            params_group,
            step_dispatches,
            residual_dispatches,
        ) = ctx.building(|| Self::build(&ctx, &plan, state, precision, origin))?;
        let contacts = match plan.contacts {
            Some(c) => Some(ContactStage::new(
                &ctx.device,
                &ctx.queue,
                ctx.errors(),
                (plan.dim, plan.particle_count(), precision),
                c,
            )?),
            None => None,
        };
        Ok(GpuBackend {
            contacts,
            kernels_per_substep: plan.substep_kernels.len(),
            plan,
            precision,
            ctx,
            state,
            buffers,
            kernels,
            state_group,
            params_group,
            step_dispatches,
            residual_dispatches,
        })
    }

    #[allow(clippy::type_complexity)]
    fn build(
        ctx: &GpuContext,
        plan: &Plan,
        state: &State,
        precision: Precision,
        origin: SceneOrigin,
    ) -> Result<
        (
            ResidentState,
            Buffers,
            KernelSet<Entry>,
            wgpu::BindGroup,
            wgpu::BindGroup,
            Vec<Dispatch>,
            Vec<Dispatch>,
        ),
        BackendError,
    > {
        let device = &ctx.device;
        let dim = plan.dim;
        let reals = |values: &[f64]| {
            let mut out = Vec::with_capacity(values.len() * real_size(precision));
            push_reals(&mut out, values, precision);
            out
        };
        // Family layout in the shared element / slot arrays.
        let mut elements: Vec<u32> = Vec::new();
        let mut rest: Vec<f64> = Vec::new();
        let mut bases = Vec::new();
        for f in &plan.families {
            bases.push((elements.len() as u32, rest.len() as u32));
            elements.extend_from_slice(&f.elements);
            match &f.kind {
                FamilyKind::HyperplaneContact { normal, .. } => {
                    rest.extend(f.rest.iter().map(|&r| origin.local_offset(normal, r)))
                }
                _ => rest.extend_from_slice(&f.rest),
            }
        }
        let resident = ResidentState::new(
            ctx,
            VectorLayout::Dense,
            precision,
            origin,
            state,
            &plan.inverse_mass,
            &plan.force,
        )?;
        let slots = rest.len();
        let make = |label: &str, bytes: &[u8]| ctx.storage(label, bytes);
        let p = make("p", &resident.packing.positions(&state.positions))?;
        let inv_mass = make("inverse_mass", &reals(&plan.inverse_mass))?;
        let gravity_scale = make("gravity_scale", &reals(&plan.gravity_scale))?;
        let element_buffer = make("elements", bytemuck::cast_slice(&elements))?;
        let rest_buffer = make("rest", &reals(&rest))?;
        let lambda = make("lambda", &reals(&vec![0.0; slots]))?;
        let status = make("status", bytemuck::cast_slice(&[NONE, NONE, 0, 0]))?;
        let resid = make("residuals", &reals(&vec![0.0; slots]))?;
        let report_len = 2 * plan.families.len();
        let report = make("report", &reals(&vec![0.0; report_len]))?;
        let report_bytes = (report_len * real_size(precision)) as u64;
        let report_staging = ctx.staging("report_staging", 16 + report_bytes)?;
        let probe_staging = ctx.staging("probe_staging", 2 * resident.bytes())?;

        // Parameter blocks: one per kernel call of a step, then one per
        // family for the residual.
        let size = params_size(dim, precision);
        let mut blocks = ParamBlocks::new(device);
        let mut step_dispatches = Vec::new();
        let k = plan.substep_kernels.len();
        let lambda_total = slots as u32;
        for substep in 0..plan.substeps as usize {
            for (index, kernel) in plan.substep_kernels.iter().enumerate() {
                let call = (substep * k + index) as u32;
                let mut params = Params {
                    call,
                    h: plan.h,
                    gravity: plan.gravity.clone(),
                    ..Params::default()
                };
                let (entry, invocations) = match *kernel {
                    Kernel::Predict => {
                        params.count = plan.particle_count() as u32;
                        params.flags =
                            u32::from(plan.predict.gravity) | (u32::from(plan.predict.force) << 1);
                        (Entry::Predict, params.count.max(lambda_total))
                    }
                    Kernel::Velocity => {
                        params.count = plan.particle_count() as u32;
                        (Entry::Velocity, params.count)
                    }
                    // Run by `contact_step` between these dispatches.
                    Kernel::Broadphase | Kernel::Collide => continue,
                    Kernel::Damping => {
                        params.count = plan.particle_count() as u32;
                        params.factor = plan.damping.map_or(1.0, |(_, f)| f);
                        (Entry::Damping, params.count)
                    }
                    Kernel::Project { family, color } => {
                        let f = &plan.families[family];
                        let range = f.color(color);
                        params.count = range.len() as u32;
                        params.first = range.start as u32;
                        params.elem_base = bases[family].0;
                        params.slot_base = bases[family].1;
                        params.arity = f.arity as u32;
                        params.family = family as u32;
                        params.alpha_tilde = f.compliance / (plan.h * plan.h);
                        let entry = match &f.kind {
                            FamilyKind::Distance => Entry::ProjectDistance,
                            FamilyKind::Tether => {
                                // project_distance with the one-sided clamp.
                                params.flags = 1;
                                Entry::ProjectDistance
                            }
                            FamilyKind::SimplexMeasure { .. } => Entry::ProjectSimplexMeasure,
                            FamilyKind::OrientedMeasure => Entry::ProjectOrientedMeasure,
                            FamilyKind::HyperplaneContact { normal, friction } => {
                                params.normal = normal.clone();
                                params.friction = *friction;
                                Entry::ProjectContact
                            }
                        };
                        (entry, params.count)
                    }
                    Kernel::Minimise => return Err(incremental_potential_unsupported().into()),
                    Kernel::Friction { family } => {
                        let f = &plan.families[family];
                        params.count = f.len() as u32;
                        params.elem_base = bases[family].0;
                        params.slot_base = bases[family].1;
                        params.family = family as u32;
                        if let FamilyKind::HyperplaneContact { normal, friction } = &f.kind {
                            params.normal = normal.clone();
                            params.friction = *friction;
                        }
                        (Entry::Friction, params.count)
                    }
                };
                step_dispatches.push(Dispatch {
                    entry,
                    params_offset: blocks.push(&params.encode(dim, precision)),
                    invocations,
                    stage: Some(kernel.stage()),
                });
            }
        }
        let mut residual_dispatches = Vec::new();
        for (family, f) in plan.families.iter().enumerate() {
            let mut params = Params {
                count: f.len() as u32,
                elem_base: bases[family].0,
                slot_base: bases[family].1,
                arity: f.arity as u32,
                flags: kind_code(&f.kind),
                family: family as u32,
                ..Params::default()
            };
            if let FamilyKind::HyperplaneContact { normal, .. } = &f.kind {
                params.normal = normal.clone();
            }
            let offset = blocks.push(&params.encode(dim, precision));
            residual_dispatches.push(Dispatch {
                entry: Entry::Residual,
                params_offset: offset,
                invocations: params.count,
                stage: None,
            });
            residual_dispatches.push(Dispatch {
                entry: Entry::Reduce,
                params_offset: offset,
                invocations: 1,
                stage: None,
            });
        }
        blocks.push(&Params::default().encode(dim, precision));
        let block = (size as u64).max(blocks.block_size());
        let params_buffer = blocks.finish(ctx, "params")?;

        let kernels = KernelSet::new(
            device,
            &KernelSetSpec {
                label: "hyperpbd xpbd",
                dim,
                precision,
                groups: &[&STATE_BINDINGS, &[crate::kernel_set::Binding::BLOCK]],
                entries: &Entry::ALL,
            },
        )?;
        let state_group = kernels.bind(
            device,
            0,
            &[
                &resident.x,
                &resident.v,
                &p,
                &inv_mass,
                &gravity_scale,
                &resident.force,
                &element_buffer,
                &rest_buffer,
                &lambda,
                &status,
                &resid,
                &report,
            ],
            0,
        )?;
        let params_group = kernels.bind(device, 1, &[&params_buffer], block)?;
        let buffers = Buffers {
            p,
            status,
            report,
            report_staging,
            probe_staging,
            report_bytes,
        };
        Ok((
            resident,
            buffers,
            kernels,
            state_group,
            params_group,
            step_dispatches,
            residual_dispatches,
        ))
    }

    /// The adapter this backend runs on.
    pub fn adapter(&self) -> &AdapterSummary {
        &self.ctx.summary
    }

    /// The precision of the kernels.
    pub fn precision(&self) -> Precision {
        self.precision
    }

    /// The origin device positions are relative to.
    pub fn origin(&self) -> &SceneOrigin {
        self.state.origin()
    }

    /// Destroys the device, as a driver reset or a removed GPU would:
    /// every later call answers [`GpuError::DeviceLost`]. For
    /// fault-injection tests of that path.
    pub fn destroy_device(&self) {
        self.ctx.device.destroy();
    }

    /// Device bytes per particle and per constraint slot (buffers that
    /// scale with them), for reports.
    pub fn bytes_per_particle_and_slot(&self) -> (usize, usize) {
        let r = real_size(self.precision);
        // x, v, p, saved_x, saved_v, force: DIM reals each; inverse mass,
        // gravity scale: one real each.
        let per_particle = 6 * self.plan.dim * r + 2 * r;
        // rest, lambda, residual: one real each, plus the particle indices.
        let per_slot = 3 * r;
        (per_particle, per_slot)
    }

    fn encode(&self, pass: &mut wgpu::ComputePass<'_>, d: &Dispatch) {
        pass.set_bind_group(1, &self.params_group, &[d.params_offset]);
        self.kernels.dispatch(pass, d.entry, d.invocations);
    }

    /// Submits `encoder` and waits for it.
    fn submit_and_wait(&self, encoder: wgpu::CommandEncoder) -> Result<(), GpuError> {
        self.ctx.submit_and_wait(encoder)
    }

    /// Maps `buffer` (already filled and waited for) and copies `len` bytes.
    fn read_mapped(&self, buffer: &wgpu::Buffer, len: u64) -> Result<Vec<u8>, GpuError> {
        self.ctx.read(buffer, len)
    }

    fn reset_status(&self) {
        self.ctx.queue.write_buffer(
            &self.buffers.status,
            0,
            bytemuck::cast_slice(&[NONE, NONE, 0u32, 0u32]),
        );
    }

    /// Reads the status block: the failing call and index, if any.
    fn failure(&self, status: &[u8]) -> Option<(u32, u32)> {
        let words: &[u32] = bytemuck::cast_slice(&status[..8]);
        (words[0] != NONE).then_some((words[0], words[1]))
    }

    fn step_error(&self, call: u32, index: u32) -> BackendError {
        let k = self.kernels_per_substep.max(1);
        let substep = call / k as u32;
        let kernel = self.plan.substep_kernels[call as usize % k];
        match kernel {
            Kernel::Project { family, .. } => {
                let f = &self.plan.families[family];
                StepError::NonFiniteConstraint {
                    stage: StageName::Project,
                    substep,
                    family,
                    family_label: f.label.clone(),
                    element: f
                        .source
                        .get(index as usize)
                        .map_or(index as usize, |&s| s as usize),
                }
                .into()
            }
            other => StepError::NonFiniteParticle {
                stage: other.stage(),
                substep,
                particle: index as usize,
            }
            .into(),
        }
    }

    fn rollback(&mut self) -> Result<(), GpuError> {
        self.state.rollback(&self.ctx)
    }
}

/// The incremental-potential step has its own GPU backend
/// ([`crate::GpuBarrierBackend`]); this one runs XPBD plans only.
fn incremental_potential_unsupported() -> GpuError {
    GpuError::Unsupported {
        what: "the incremental_potential solver on GpuBackend (use GpuBarrierBackend)".into(),
    }
}

impl GpuBackend {
    /// Runs `kernel` `repeats` times in one compute pass and one submit
    /// (benchmarks: the per-element cost of a kernel without a round trip
    /// per call). The state changes as `repeats` calls would change it.
    pub fn repeat_kernel(&mut self, kernel: Kernel, repeats: u32) -> Result<(), BackendError> {
        check_kernel(&self.plan, kernel)?;
        let Some(index) = self.plan.substep_kernels.iter().position(|&k| k == kernel) else {
            return Err(BackendError::InvalidCall(format!(
                "{kernel:?} is not in this plan's schedule"
            )));
        };
        self.reset_status();
        self.state.forget_snapshot();
        let mut encoder = self.ctx.device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            pass.set_bind_group(0, &self.state_group, &[]);
            for _ in 0..repeats {
                self.encode(&mut pass, &self.step_dispatches[index]);
            }
        }
        Ok(self.submit_and_wait(encoder)?)
    }
}

impl Backend for GpuBackend {
    fn name(&self) -> String {
        format!("gpu-{}", self.precision)
    }

    fn plan(&self) -> &Plan {
        &self.plan
    }

    fn step(&mut self) -> Result<StepReport, BackendError> {
        if self.contacts.is_some() {
            return self.step_with_contacts();
        }
        self.reset_status();
        let mut encoder = self.ctx.device.create_command_encoder(&Default::default());
        self.state.save(&mut encoder);
        let mut kernel_calls: Vec<(StageName, u64)> =
            self.plan.stages.iter().map(|&s| (s, 0)).collect();
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            pass.set_bind_group(0, &self.state_group, &[]);
            for d in &self.step_dispatches {
                self.encode(&mut pass, d);
                if let Some(stage) = d.stage
                    && let Some(entry) = kernel_calls.iter_mut().find(|(s, _)| *s == stage)
                {
                    entry.1 += 1;
                }
            }
            for d in &self.residual_dispatches {
                self.encode(&mut pass, d);
            }
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
        let snapshot = self.state.record_snapshot(&mut encoder);
        let index = self.ctx.submit(encoder)?;
        if let Some(slot) = snapshot {
            self.state.map_snapshot(slot);
        }
        self.ctx.wait(index)?;
        let block =
            self.read_mapped(&self.buffers.report_staging, 16 + self.buffers.report_bytes)?;
        if let Some((call, index)) = self.failure(&block) {
            self.rollback()?;
            return Err(self.step_error(call, index));
        }
        let report = read_reals(&block[16..], self.precision);
        let mut residuals = Vec::with_capacity(self.plan.families.len());
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
        Ok(StepReport {
            kernel_calls,
            residuals,
            active_contacts,
            ..StepReport::default()
        })
    }

    fn read_state(&mut self) -> Result<State, BackendError> {
        Ok(self.state.read(&self.ctx)?)
    }

    fn prefetch_state(&mut self) {
        self.state.prefetch();
    }

    fn write_state(&mut self, state: &State) -> Result<(), BackendError> {
        check_state(&self.plan, state)?;
        self.state.write(&self.ctx, state);
        Ok(())
    }

    fn set_forces(&mut self, forces: &[f64]) -> Result<(), BackendError> {
        check_forces(&self.plan, forces)?;
        self.state.set_forces(&self.ctx, forces);
        Ok(())
    }

    fn run_kernel(&mut self, kernel: Kernel) -> Result<(), BackendError> {
        check_kernel(&self.plan, kernel)?;
        if self.contacts.is_some() {
            return Err(BackendError::InvalidCall(
                "single kernel calls on a plan with collisions are not offered on the GPU; \
                 the contact kernels are checked alone through GpuSweep and GpuCollide"
                    .into(),
            ));
        }
        let Some(index) = self.plan.substep_kernels.iter().position(|&k| k == kernel) else {
            return Err(BackendError::InvalidCall(format!(
                "{kernel:?} is not in this plan's schedule"
            )));
        };
        self.reset_status();
        self.state.forget_snapshot();
        let mut encoder = self.ctx.device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            pass.set_bind_group(0, &self.state_group, &[]);
            self.encode(&mut pass, &self.step_dispatches[index]);
        }
        encoder.copy_buffer_to_buffer(&self.buffers.status, 0, &self.buffers.report_staging, 0, 16);
        self.submit_and_wait(encoder)?;
        let block = self.read_mapped(&self.buffers.report_staging, 16)?;
        match self.failure(&block) {
            Some((call, index)) => Err(self.step_error(call, index)),
            None => Ok(()),
        }
    }
}
