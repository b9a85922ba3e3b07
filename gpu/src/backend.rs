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

use std::sync::{Arc, Mutex};

use hyperpbd_core::{
    Backend, BackendError, FamilyKind, FamilyResidual, GpuError, Kernel, Plan, StageName, State,
    StepError, StepReport, check_forces, check_kernel, check_state,
};

use crate::origin::SceneOrigin;
use crate::params::{Params, params_size, push_reals, read_reals, real_size};

mod contact_step;
use crate::pipelines::{Entry, Pipelines};
use crate::state_transfer::ResidentState;
use crate::{AdapterSummary, Precision};
use contact_step::ContactStage;

const WORKGROUP: u32 = 64;
const MAX_GROUPS_X: u32 = 65_535;
const NONE: u32 = u32::MAX;

/// One dispatch of a step.
#[derive(Debug, Clone, Copy)]
struct Dispatch {
    entry: Entry,
    params_offset: u32,
    groups: (u32, u32),
    stage: Option<StageName>,
}

/// The device buffers.
struct Buffers {
    x: wgpu::Buffer,
    v: wgpu::Buffer,
    /// Positions at the substep start (read by the contact broadphase).
    p: wgpu::Buffer,
    force: wgpu::Buffer,
    status: wgpu::Buffer,
    report: wgpu::Buffer,
    saved_x: wgpu::Buffer,
    saved_v: wgpu::Buffer,
    /// Readback of status (16 bytes) followed by the report.
    report_staging: wgpu::Buffer,
    /// Readback of x then v.
    state_staging: wgpu::Buffer,
    state_bytes: u64,
    report_bytes: u64,
}

/// The wgpu backend.
pub struct GpuBackend {
    plan: Plan,
    precision: Precision,
    summary: AdapterSummary,
    device: wgpu::Device,
    queue: wgpu::Queue,
    buffers: Buffers,
    pipelines: Pipelines,
    state_group: wgpu::BindGroup,
    params_group: wgpu::BindGroup,
    /// Dispatches of a whole step, substeps included.
    step_dispatches: Vec<Dispatch>,
    /// Residual dispatches run after the step.
    residual_dispatches: Vec<Dispatch>,
    /// Kernel calls per substep.
    kernels_per_substep: usize,
    errors: Arc<Mutex<Vec<String>>>,
    lost: Arc<Mutex<Option<String>>>,
    /// Device positions are world positions − origin (f32 only).
    origin: SceneOrigin,
    /// Broadphase and contact kernels, when the plan has collisions.
    contacts: Option<ContactStage>,
}

pub(crate) fn groups_for(invocations: u32) -> (u32, u32) {
    let groups = invocations.div_ceil(WORKGROUP).max(1);
    if groups <= MAX_GROUPS_X {
        (groups, 1)
    } else {
        (MAX_GROUPS_X, groups.div_ceil(MAX_GROUPS_X))
    }
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
    /// x and v as resident on the device, with their read-back staging.
    fn resident_state(&self) -> ResidentState<'_> {
        ResidentState {
            x: &self.buffers.x,
            v: &self.buffers.v,
            staging: &self.buffers.state_staging,
            bytes: self.buffers.state_bytes,
            precision: self.precision,
            origin: &self.origin,
        }
    }

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
        let summary = AdapterSummary::of(adapter);
        let (device, queue) = crate::request_device(adapter, precision)?;
        let errors = crate::device_errors::collect_device_errors(&device);
        let lost: Arc<Mutex<Option<String>>> = Arc::default();
        let lost_sink = lost.clone();
        device.set_device_lost_callback(move |reason, message| {
            if let Ok(mut l) = lost_sink.lock() {
                *l = Some(format!("{reason:?}: {message}"));
            }
        });

        let scope = device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let validation = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let built = Self::build(&device, &queue, &plan, state, precision, &origin);
        let validation_error = pollster::block_on(validation.pop());
        let oom = pollster::block_on(scope.pop());
        if let Some(e) = oom {
            return Err(GpuError::OutOfMemory {
                message: e.to_string(),
            }
            .into());
        }
        if let Some(e) = validation_error {
            return Err(GpuError::Other {
                message: e.to_string(),
            }
            .into());
        }
        let (buffers, pipelines, state_group, params_group, step_dispatches, residual_dispatches) =
            built?;
        let contacts = match plan.contacts {
            Some(_) => Some(ContactStage::new(
                &device,
                &queue,
                errors.clone(),
                (&plan, precision),
                crate::contact::Bound {
                    x: &buffers.x,
                    p: &buffers.p,
                    status: &buffers.status,
                },
            )?),
            None => None,
        };
        Ok(GpuBackend {
            contacts,
            kernels_per_substep: plan.substep_kernels.len(),
            plan,
            precision,
            summary,
            device,
            queue,
            buffers,
            pipelines,
            state_group,
            params_group,
            step_dispatches,
            residual_dispatches,
            errors,
            lost,
            origin,
        })
    }

    #[allow(clippy::type_complexity)]
    fn build(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        plan: &Plan,
        state: &State,
        precision: Precision,
        origin: &SceneOrigin,
    ) -> Result<
        (
            Buffers,
            Pipelines,
            wgpu::BindGroup,
            wgpu::BindGroup,
            Vec<Dispatch>,
            Vec<Dispatch>,
        ),
        BackendError,
    > {
        let limits = device.limits();
        let dim = plan.dim;
        let n = plan.particle_count();
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
        let positions = origin.to_local(&state.positions);
        let slots = rest.len();
        let make = |label: &str, bytes: &[u8], usage: wgpu::BufferUsages| {
            create_buffer(device, queue, &limits, label, bytes, usage)
        };
        let storage = wgpu::BufferUsages::STORAGE
            | wgpu::BufferUsages::COPY_DST
            | wgpu::BufferUsages::COPY_SRC;
        let x = make("x", &reals(&positions), storage)?;
        let v = make("v", &reals(&state.velocities), storage)?;
        let p = make("p", &reals(&positions), storage)?;
        let inv_mass = make("inverse_mass", &reals(&plan.inverse_mass), storage)?;
        let gravity_scale = make("gravity_scale", &reals(&plan.gravity_scale), storage)?;
        let force = make("force", &reals(&plan.force), storage)?;
        let element_buffer = make("elements", bytemuck::cast_slice(&elements), storage)?;
        let rest_buffer = make("rest", &reals(&rest), storage)?;
        let lambda = make("lambda", &reals(&vec![0.0; slots]), storage)?;
        let status = make("status", bytemuck::cast_slice(&[NONE, NONE, 0, 0]), storage)?;
        let resid = make("residuals", &reals(&vec![0.0; slots]), storage)?;
        let report_len = 2 * plan.families.len();
        let report = make("report", &reals(&vec![0.0; report_len]), storage)?;
        let state_bytes = (n * dim * real_size(precision)) as u64;
        let saved_x = make("saved_x", &reals(&positions), storage)?;
        let saved_v = make("saved_v", &reals(&state.velocities), storage)?;
        let report_bytes = (report_len * real_size(precision)) as u64;
        let report_staging = make(
            "report_staging",
            &vec![0u8; 16 + report_bytes as usize],
            wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        )?;
        let state_staging = make(
            "state_staging",
            &vec![0u8; 2 * state_bytes as usize],
            wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        )?;

        // Parameter blocks: one per kernel call of a step, then one per
        // family for the residual.
        let align = limits.min_storage_buffer_offset_alignment as usize;
        let size = params_size(dim, precision);
        let stride = size.div_ceil(align) * align;
        let mut blocks = Vec::new();
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
                        params.count = n as u32;
                        params.flags =
                            u32::from(plan.predict.gravity) | (u32::from(plan.predict.force) << 1);
                        (Entry::Predict, (n as u32).max(lambda_total))
                    }
                    Kernel::Velocity => {
                        params.count = n as u32;
                        (Entry::Velocity, n as u32)
                    }
                    // Run by `contact_step` between these dispatches.
                    Kernel::Broadphase | Kernel::Collide => continue,
                    Kernel::Damping => {
                        params.count = n as u32;
                        params.factor = plan.damping.map_or(1.0, |(_, f)| f);
                        (Entry::Damping, n as u32)
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
                    params_offset: blocks.len() as u32,
                    groups: groups_for(invocations),
                    stage: Some(kernel.stage()),
                });
                params.encode(dim, precision, stride, &mut blocks);
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
            let offset = blocks.len() as u32;
            params.encode(dim, precision, stride, &mut blocks);
            residual_dispatches.push(Dispatch {
                entry: Entry::Residual,
                params_offset: offset,
                groups: groups_for(params.count),
                stage: None,
            });
            residual_dispatches.push(Dispatch {
                entry: Entry::Reduce,
                params_offset: offset,
                groups: (1, 1),
                stage: None,
            });
        }
        if blocks.is_empty() {
            Params::default().encode(dim, precision, stride, &mut blocks);
        }
        let params_buffer = make("params", &blocks, wgpu::BufferUsages::STORAGE)?;

        let pipelines = Pipelines::new(device, dim, precision, &limits)?;
        let state_buffers = [
            &x,
            &v,
            &p,
            &inv_mass,
            &gravity_scale,
            &force,
            &element_buffer,
            &rest_buffer,
            &lambda,
            &status,
            &resid,
            &report,
        ];
        let entries: Vec<wgpu::BindGroupEntry> = state_buffers
            .iter()
            .enumerate()
            .map(|(i, b)| wgpu::BindGroupEntry {
                binding: i as u32,
                resource: b.as_entire_binding(),
            })
            .collect();
        let state_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("hyperpbd state"),
            layout: &pipelines.state_layout,
            entries: &entries,
        });
        let params_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("hyperpbd params"),
            layout: &pipelines.params_layout,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                    buffer: &params_buffer,
                    offset: 0,
                    size: wgpu::BufferSize::new(size as u64),
                }),
            }],
        });
        let buffers = Buffers {
            x,
            v,
            p,
            force,
            status,
            report,
            saved_x,
            saved_v,
            report_staging,
            state_staging,
            state_bytes,
            report_bytes,
        };
        Ok((
            buffers,
            pipelines,
            state_group,
            params_group,
            step_dispatches,
            residual_dispatches,
        ))
    }

    /// The adapter this backend runs on.
    pub fn adapter(&self) -> &AdapterSummary {
        &self.summary
    }

    /// The precision of the kernels.
    pub fn precision(&self) -> Precision {
        self.precision
    }

    /// The origin device positions are relative to.
    pub fn origin(&self) -> &SceneOrigin {
        &self.origin
    }

    /// Destroys the device, as a driver reset or a removed GPU would:
    /// every later call answers [`GpuError::DeviceLost`]. For
    /// fault-injection tests of that path.
    pub fn destroy_device(&self) {
        self.device.destroy();
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
        pass.set_pipeline(self.pipelines.get(d.entry));
        pass.set_bind_group(1, &self.params_group, &[d.params_offset]);
        pass.dispatch_workgroups(d.groups.0, d.groups.1, 1);
    }

    fn check_device(&self) -> Result<(), GpuError> {
        if let Ok(l) = self.lost.lock()
            && let Some(message) = l.clone()
        {
            return Err(GpuError::DeviceLost { message });
        }
        crate::device_errors::take_device_errors(&self.errors)
    }

    /// Submits `encoder` and waits for it.
    fn submit_and_wait(&self, encoder: wgpu::CommandEncoder) -> Result<(), GpuError> {
        let index = self.queue.submit(Some(encoder.finish()));
        self.check_device()?;
        self.device
            .poll(wgpu::PollType::Wait {
                submission_index: Some(index),
                timeout: None,
            })
            .map_err(|e| {
                // The device-lost callback's reason, when it has fired, says
                // more than the failed wait.
                self.check_device().err().unwrap_or(GpuError::DeviceLost {
                    message: e.to_string(),
                })
            })?;
        self.check_device()
    }

    /// Maps `buffer` (already filled and waited for) and copies `len` bytes.
    fn read_mapped(&self, buffer: &wgpu::Buffer, len: u64) -> Result<Vec<u8>, GpuError> {
        crate::readback::read_mapped(&self.device, buffer, len)
    }

    fn reset_status(&self) {
        self.queue.write_buffer(
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
            Kernel::Collide => StepError::NonFiniteParticle {
                stage: StageName::Project,
                substep,
                particle: contact_step::collide_particle(index, self.plan.particle_count()),
            }
            .into(),
            other => StepError::NonFiniteParticle {
                stage: other.stage(),
                substep,
                particle: index as usize,
            }
            .into(),
        }
    }

    fn rollback(&self) -> Result<(), GpuError> {
        let mut encoder = self.device.create_command_encoder(&Default::default());
        let bytes = self.buffers.state_bytes;
        if bytes > 0 {
            encoder.copy_buffer_to_buffer(&self.buffers.saved_x, 0, &self.buffers.x, 0, bytes);
            encoder.copy_buffer_to_buffer(&self.buffers.saved_v, 0, &self.buffers.v, 0, bytes);
        }
        self.submit_and_wait(encoder)
    }
}

/// The incremental-potential step has its own GPU backend
/// ([`crate::GpuBarrierBackend`]); this one runs XPBD plans only.
fn incremental_potential_unsupported() -> GpuError {
    GpuError::Unsupported {
        what: "the incremental_potential solver on GpuBackend (use GpuBarrierBackend)".into(),
    }
}

/// Creates a buffer with `bytes` (at least 16 bytes), refusing sizes over
/// the device limits with a typed error.
pub(crate) fn create_buffer(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    limits: &wgpu::Limits,
    label: &str,
    bytes: &[u8],
    usage: wgpu::BufferUsages,
) -> Result<wgpu::Buffer, GpuError> {
    let size = (bytes.len() as u64).max(16).next_multiple_of(4);
    let maximum = if usage.contains(wgpu::BufferUsages::STORAGE) {
        limits
            .max_storage_buffer_binding_size
            .min(limits.max_buffer_size)
    } else {
        limits.max_buffer_size
    };
    if size > maximum {
        return Err(GpuError::BufferTooLarge {
            buffer: label.into(),
            requested: size,
            maximum,
        });
    }
    let buffer = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size,
        usage: usage | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    if !bytes.is_empty() && !usage.contains(wgpu::BufferUsages::MAP_READ) {
        let mut padded = bytes.to_vec();
        padded.resize(padded.len().next_multiple_of(4), 0);
        queue.write_buffer(&buffer, 0, &padded);
    }
    Ok(buffer)
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
        let bytes = self.buffers.state_bytes;
        let mut encoder = self.device.create_command_encoder(&Default::default());
        if bytes > 0 {
            encoder.copy_buffer_to_buffer(&self.buffers.x, 0, &self.buffers.saved_x, 0, bytes);
            encoder.copy_buffer_to_buffer(&self.buffers.v, 0, &self.buffers.saved_v, 0, bytes);
        }
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
        self.submit_and_wait(encoder)?;
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
        Ok(self
            .resident_state()
            .read(&self.device, self.plan.dim, |e| self.submit_and_wait(e))?)
    }

    fn write_state(&mut self, state: &State) -> Result<(), BackendError> {
        check_state(&self.plan, state)?;
        self.resident_state().write(&self.queue, state);
        Ok(())
    }

    fn set_forces(&mut self, forces: &[f64]) -> Result<(), BackendError> {
        check_forces(&self.plan, forces)?;
        let mut f = Vec::new();
        push_reals(&mut f, forces, self.precision);
        if !f.is_empty() {
            self.queue.write_buffer(&self.buffers.force, 0, &f);
        }
        Ok(())
    }

    fn run_kernel(&mut self, kernel: Kernel) -> Result<(), BackendError> {
        check_kernel(&self.plan, kernel)?;
        if matches!(kernel, Kernel::Broadphase | Kernel::Collide) {
            return self.run_contact_kernel(kernel);
        }
        let Some(at) = self.plan.substep_kernels.iter().position(|&k| k == kernel) else {
            return Err(BackendError::InvalidCall(format!(
                "{kernel:?} is not in this plan's schedule"
            )));
        };
        // The contact kernels have no entry in the dispatch list.
        let index = self.plan.substep_kernels[..at]
            .iter()
            .filter(|k| !matches!(k, Kernel::Broadphase | Kernel::Collide))
            .count();
        self.reset_status();
        let mut encoder = self.device.create_command_encoder(&Default::default());
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
