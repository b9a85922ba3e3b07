//! `GpuBackend`: the plan's kernels as wgpu compute dispatches.
//!
//! ```text
//! load   particle records, families, call blocks, the schedules and every
//!        dispatch block, pipelines and both bind groups, once
//! step   one command buffer: save (x, v); ONE compute pass with every
//!        dispatch of the step (the chosen schedule, residual included);
//!        copy the status/report block (and a prefetched state) out; ONE
//!        submit, one wait, one small readback.
//!        A failed call → (x, v) restored byte for byte; a fused schedule
//!        replays the step one call per dispatch first, so the error names
//!        the kernel and element the CPU names.
//! ```
//! The schedule is the plan's (xpbd/schedule.rs): the GPU runs the
//! algorithm of the CPU golden path, kernel for kernel, in the same order
//! per particle and per colour.

use hyperpbd_core::{
    BackendError, GpuError, Kernel, Plan, StageName, State, StepError, check_kernel, check_state,
};

use crate::Precision;
use crate::context::GpuContext;
use crate::export::Exporter;
use crate::kernel_set::{KernelSet, KernelSetSpec, ParamBlocks};
use crate::layout::VectorLayout;
use crate::origin::SceneOrigin;
use crate::params::{push_reals, real_size};
use crate::resident::ResidentState;
use crate::resident_backend::resident_backend;
use crate::shader::ShaderFile;
use crate::xpbd::schedule::{Dispatch, Schedule, StepMode};
use crate::xpbd::{Families, NONE, Placed, XpbdEntry};

mod attempt;
pub(crate) mod batch;
mod contact_step;
mod motion_step;
use crate::context::DeviceSource;
pub(crate) mod status;
mod union;
use batch::{WorldArrays, Worlds};
use contact_step::ContactStage;

/// The device buffers besides the resident state.
struct Buffers {
    lambda: wgpu::Buffer,
    status: wgpu::Buffer,
    report: wgpu::Buffer,
    /// Readback of status (16 bytes) followed by the report.
    report_staging: wgpu::Buffer,
    report_bytes: u64,
    /// Buffers only the kernels use.
    _rest: Vec<wgpu::Buffer>,
}

/// The wgpu backend.
pub struct GpuBackend {
    plan: Plan,
    precision: Precision,
    ctx: GpuContext,
    state: ResidentState,
    buffers: Buffers,
    kernels: KernelSet<XpbdEntry>,
    /// Group 0: the particle records and every kernel buffer.
    group: wgpu::BindGroup,
    /// Group 1: the dispatch blocks.
    blocks: wgpu::BindGroup,
    schedule: Schedule,
    /// One dispatch per call (failure diagnosis, contact plans).
    exact: Vec<Placed>,
    /// The dispatches of a step in the chosen mode.
    fast: Vec<Placed>,
    /// The dispatch of each kernel of a substep run alone (run_kernel).
    alone: Vec<Placed>,
    /// Broadphase and contact kernels, when the plan has collisions.
    contacts: Option<ContactStage>,
    /// Backends of `plan.subdivided(j)`, j = 1, 2, … (adaptive; attempt.rs).
    subdivided: Vec<GpuBackend>,
    /// The position export into a caller's buffer (built on first use).
    exporter: Exporter,
    /// Worlds every dispatch runs (1 but in a batch, batch.rs).
    worlds: u32,
    /// Prescribed motion: where each step's values go (motion_step.rs).
    motion: Option<motion_step::Moving>,
}

impl GpuBackend {
    /// Loads `plan` with `state`, storing positions relative to `origin`
    /// (see [`SceneOrigin`]; [`GpuBackend::with_adapter`] picks it).
    pub fn with_origin(
        adapter: &wgpu::Adapter,
        plan: Plan,
        state: &State,
        precision: Precision,
        origin: SceneOrigin,
    ) -> Result<Self, BackendError> {
        let own = DeviceSource::Own(adapter);
        Self::load(own, plan, state, precision, Some(origin), None)
    }

    /// Loads `plan` with `state`, forming the step's dispatches as `mode`
    /// says rather than as the plan's size suggests (every mode gives the
    /// same results; [`StepMode::Small`] is refused for plans with particle
    /// contact).
    pub fn with_step_mode(
        adapter: &wgpu::Adapter,
        plan: Plan,
        state: &State,
        precision: Precision,
        mode: StepMode,
    ) -> Result<Self, BackendError> {
        if mode == StepMode::Small && plan.contacts.is_some() {
            return Err(BackendError::InvalidCall(
                "step mode small: plans with particle contact run the exact or fused schedule \
                 (the contact kernels are dispatches of their own)"
                    .into(),
            ));
        }
        let own = DeviceSource::Own(adapter);
        Self::load(own, plan, state, precision, None, Some(mode))
    }

    /// Loads `plan` with `state` on `device`: positions relative to
    /// `origin` (`None`: [`SceneOrigin::for_state`]), the step's
    /// dispatches formed as `mode` says (`None`: as the plan's size
    /// suggests).
    fn load(
        device: DeviceSource<'_>,
        plan: Plan,
        state: &State,
        precision: Precision,
        origin: Option<SceneOrigin>,
        mode: Option<StepMode>,
    ) -> Result<Self, BackendError> {
        // An expression need not be translation-invariant (a param may be a
        // point): a plan with one keeps world coordinates.
        let expressions = plan.families.iter().any(|f| f.kind.is_expression());
        let origin = origin.unwrap_or_else(|| match expressions {
            true => SceneOrigin::zero(plan.dim),
            false => SceneOrigin::for_state(plan.dim, &state.positions, precision),
        });
        if expressions && origin.as_slice().iter().any(|&o| o != 0.0) {
            return Err(BackendError::InvalidCall(
                "a plan with expression families runs in world coordinates: its scene origin \
                 must be zero"
                    .into(),
            ));
        }
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
        if plan.primal_residual {
            primal_supported(&plan)?;
        }
        if plan.incremental_potential().is_some() {
            return Err(crate::incremental_potential::incremental_potential_unsupported().into());
        }
        let ctx = device.context(precision)?;
        ctx.building(|| Self::build(ctx.clone(), plan, state, precision, origin, mode, None))
    }

    /// Creates every buffer, pipeline, bind group and dispatch block: of
    /// `plan` with `state`, or of every world of `worlds` (a batch,
    /// batch.rs; `plan` and `state` are world 0's).
    fn build(
        ctx: GpuContext,
        plan: Plan,
        state: &State,
        precision: Precision,
        origin: SceneOrigin,
        mode: Option<StepMode>,
        worlds: Option<Worlds<'_>>,
    ) -> Result<Self, BackendError> {
        let device = &ctx.device;
        let dim = plan.dim;
        let workgroup = ShaderFile::Step.workgroup_size();
        let families = Families::new(&plan, &origin)?;
        let software = ctx.summary.device_type == "Cpu";
        let schedule = Schedule::new(&plan, &families, workgroup, mode, software);
        if schedule.mode == StepMode::Small
            && !crate::xpbd::schedule::small_supported(&schedule.calls[..schedule.step_calls])
        {
            return Err(BackendError::InvalidCall(
                "step mode small: the plan has measure families or guards (they run one dispatch per call or colour)"
                    .into(),
            ));
        }
        let world = match worlds {
            Some(worlds) => WorldArrays::batch(worlds, &families, &schedule)?,
            None => WorldArrays::one(&plan, state, &families, &schedule),
        };
        // Pipelines for the entry points this plan's schedules use only
        // (lavapipe compiles each one: seconds for the measure kernels).
        let entries = schedule.entries();
        let generated = crate::xpbd::generated(&plan, &families, precision);
        let kernels = KernelSet::new(
            &ctx,
            &KernelSetSpec {
                label: "hyperpbd xpbd",
                modules: &[crate::shader::ShaderFile::Step],
                dim,
                precision,
                entries: &entries,
                constants: &world.constants,
                generated: Some(&generated),
            },
        )?;
        // The call blocks first: the largest buffer of a long step, named
        // `params` in a BufferTooLarge refusal.
        let mut call_bytes = Vec::new();
        for call in world.calls {
            call_bytes.extend(call.encode(dim, precision));
        }
        if call_bytes.is_empty() {
            // The binding holds at least one block.
            call_bytes = crate::xpbd::call::Call::default().encode(dim, precision);
        }
        let calls = ctx.storage("params", &call_bytes)?;
        let reals = |values: &[f64]| {
            let mut out = Vec::with_capacity(values.len() * real_size(precision));
            push_reals(&mut out, values, precision);
            out
        };
        let resident = ResidentState::new(
            &ctx,
            VectorLayout::Record,
            precision,
            origin,
            &world.state,
            &world.inverse_mass,
            &world.force,
        )?;
        let make = |label: &str, bytes: &[u8]| ctx.storage(label, bytes);
        let w = world.count as usize;
        let slots = families.slots * w;
        let p = make("p", &resident.packing.positions(&world.state.positions))?;
        let gravity_scale = make("gravity_scale", &reals(&world.gravity_scale))?;
        let elements = make("elements", bytemuck::cast_slice(&families.elements))?;
        let rest = make("rest", &reals(world.rest))?;
        let lambda = make("lambda", &reals(&vec![0.0; slots]))?;
        let status = make("status", bytemuck::cast_slice(&[NONE, NONE, 0, NONE]))?;
        let report_len = 2 * plan.families.len() * w;
        let report = make("report", &reals(&vec![0.0; report_len]))?;
        let contact_slot = make("contact_slot", bytemuck::cast_slice(&families.slot_maps))?;
        let partials = make(
            "partials",
            &reals(&vec![0.0; 2 * schedule.chunks.len() * w]),
        )?;
        let chunk_words: Vec<u32> = schedule.chunks.iter().flatten().copied().collect();
        let chunks = make("chunks", bytemuck::cast_slice(&chunk_words))?;
        // One real at least: the binding exists in every plan.
        let carried = make(
            "carried",
            &reals(&vec![0.0; families.carried_len.max(1) * w]),
        )?;
        let report_bytes = (report_len * real_size(precision)) as u64;
        let report_staging = ctx.staging("report_staging", 16 + report_bytes)?;
        let mut resident = resident;
        if plan.primal_residual {
            // λ and d carry over from step to step: saved and rolled back
            // with x and v, cleared by a written state.
            for (buffer, label) in [(&lambda, "saved_lambda"), (&carried, "saved_carried")] {
                let saved = make(label, &vec![0u8; buffer.size() as usize])?;
                resident.carry(buffer.clone(), saved);
            }
        }

        let mut blocks = ParamBlocks::uniform(device);
        let mut place = |dispatches: &[Dispatch]| -> Vec<Placed> {
            dispatches
                .iter()
                .map(|&dispatch| Placed {
                    dispatch,
                    offset: blocks.push(&dispatch.block(&schedule.calls, dim, precision)),
                })
                .collect()
        };
        let exact = place(&schedule.exact);
        let fast = place(&schedule.fast);
        let alone_dispatches: Vec<Dispatch> = plan
            .substep_kernels
            .iter()
            .filter_map(|&k| schedule.run_kernel(k))
            .collect();
        let alone = place(&alone_dispatches);
        let block = blocks.block_size();
        let dispatch_buffer = blocks.finish(&ctx, "dispatches")?;
        let group = kernels.bind(
            device,
            0,
            &[
                &resident.x,
                &resident.v,
                &p,
                &resident.force,
                &gravity_scale,
                &elements,
                &rest,
                &lambda,
                &status,
                &report,
                &calls,
                &contact_slot,
                &partials,
                &chunks,
                &elements,
                &carried,
            ],
            0,
        )?;
        let blocks_group = kernels.bind(device, 1, &[&dispatch_buffer], block)?;
        let motion = families.motion.clone().map(|layout| motion_step::Moving {
            layout,
            rest: rest.clone(),
            calls: calls.clone(),
            dispatches: dispatch_buffer.clone(),
            step: 0,
        });
        let (worlds, world_plans) = (world.count, world.plans);
        drop(world);
        let contacts = match plan.contacts {
            Some(_) => Some(ContactStage::new(
                &ctx,
                (world_plans, precision),
                crate::contact::Bound {
                    x: &resident.x,
                    v: &resident.v,
                    p: &p,
                    force: &resident.force,
                    status: &status,
                },
            )?),
            None => None,
        };
        Ok(GpuBackend {
            plan,
            precision,
            ctx,
            state: resident,
            buffers: Buffers {
                lambda,
                status,
                report,
                report_staging,
                report_bytes,
                _rest: vec![
                    p,
                    gravity_scale,
                    elements,
                    rest,
                    calls,
                    contact_slot,
                    partials,
                    chunks,
                    carried,
                    dispatch_buffer,
                ],
            },
            kernels,
            group,
            blocks: blocks_group,
            schedule,
            exact,
            fast,
            alone,
            contacts,
            subdivided: Vec::new(),
            exporter: Exporter::default(),
            worlds,
            motion,
        })
    }

    /// The precision of the kernels.
    pub fn precision(&self) -> Precision {
        self.precision
    }

    /// The origin device positions are relative to.
    pub fn origin(&self) -> &SceneOrigin {
        self.state.origin()
    }

    /// How the dispatches of a step are formed.
    pub fn step_mode(&self) -> StepMode {
        self.schedule.mode
    }

    /// Compute dispatches per step (residual and contact stage included).
    pub fn dispatches_per_step(&self) -> usize {
        self.schedule.dispatches_per_step() + self.contact_dispatches_per_step()
    }

    /// Compute pipelines of the XPBD kernels: one per entry point and set
    /// of its constants (ops, flags, io) the plan's schedules use.
    pub fn pipeline_count(&self) -> usize {
        self.kernels.pipeline_count()
    }

    /// Destroys the device as a driver reset would (later calls answer
    /// [`GpuError::DeviceLost`]), for fault-injection tests; only a device
    /// of the backend's own (`with_private_device`, `with_device`).
    pub fn destroy_device(&self) -> Result<(), GpuError> {
        self.ctx.destroy()
    }

    /// Device bytes per particle and per constraint slot (buffers that
    /// scale with them), for reports.
    pub fn bytes_per_particle_and_slot(&self) -> (usize, usize) {
        let r = real_size(self.precision);
        let record = VectorLayout::Record.reals_per_particle(self.plan.dim) * r;
        // x, v, p, saved_x, saved_v, force: one record each; gravity scale:
        // one real; a slot per hyperplane family: one u32.
        let per_particle = 6 * record + r;
        // rest, lambda: one real each, plus the particle indices.
        let per_slot = 2 * r;
        (per_particle, per_slot)
    }

    fn encode(&self, pass: &mut wgpu::ComputePass<'_>, d: &Placed) {
        if !self.encode_contact(pass, d) {
            crate::xpbd::encode(&self.kernels, &self.blocks, pass, d, self.worlds);
        }
    }

    /// Submits `encoder` and waits for it.
    fn submit_and_wait(&self, encoder: wgpu::CommandEncoder) -> Result<(), GpuError> {
        self.ctx.submit_and_wait(encoder)
    }

    /// Maps `buffer` (already filled and waited for) and copies `len` bytes.
    fn read_mapped(&self, buffer: &wgpu::Buffer, len: u64) -> Result<Vec<u8>, GpuError> {
        self.ctx.read(buffer, len)
    }

    fn step_error(&self, call: u32, index: u32) -> BackendError {
        let k = self.schedule.kernels_per_substep.max(1) as u32;
        let substep = call / k;
        match self.schedule.kernel_of(call) {
            Some(Kernel::Project { family, .. }) => {
                let f = &self.plan.families[family];
                StepError::NonFiniteConstraint {
                    stage: StageName::Project,
                    substep,
                    family,
                    family_label: f.label.clone(),
                    element: f.authored_element(index as usize),
                }
                .into()
            }
            other => StepError::NonFiniteParticle {
                stage: other.map_or(StageName::Project, |k| k.stage()),
                substep,
                particle: match other {
                    Some(Kernel::Collide) => {
                        contact_step::collide_particle(index, self.plan.particle_count())
                    }
                    _ => index as usize,
                },
            }
            .into(),
        }
    }

    fn rollback(&mut self) -> Result<(), GpuError> {
        self.state.rollback(&self.ctx)
    }

    /// One command buffer: `before` (copies, clears), `dispatches` in one
    /// compute pass (`repeats` times), then the status word (and the report
    /// when `report`) copied to the staging buffer.
    fn record(
        &self,
        before: impl FnOnce(&mut wgpu::CommandEncoder),
        dispatches: &[Placed],
        repeats: u32,
        report: bool,
    ) -> wgpu::CommandEncoder {
        let mut encoder = self.ctx.device.create_command_encoder(&Default::default());
        before(&mut encoder);
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            pass.set_bind_group(0, &self.group, &[]);
            for _ in 0..repeats {
                for d in dispatches {
                    self.encode(&mut pass, d);
                }
            }
        }
        let staging = &self.buffers.report_staging;
        encoder.copy_buffer_to_buffer(&self.buffers.status, 0, staging, 0, 16);
        if report && self.buffers.report_bytes > 0 {
            let bytes = self.buffers.report_bytes;
            encoder.copy_buffer_to_buffer(&self.buffers.report, 0, staging, 16, bytes);
        }
        encoder
    }

    /// Runs `kernel` alone `repeats` times in one compute pass and one
    /// submit, the CPU's way (`Predict` resets the multipliers).
    fn run_alone(&mut self, kernel: Kernel, repeats: u32) -> Result<(), BackendError> {
        check_kernel(&self.plan, kernel)?;
        if matches!(kernel, Kernel::Broadphase | Kernel::Collide) {
            return self.run_contact_kernel(kernel);
        }
        let Some(index) = self.plan.substep_kernels.iter().position(|&k| k == kernel) else {
            return Err(BackendError::InvalidCall(format!(
                "{kernel:?} is not in this plan's schedule"
            )));
        };
        let Some(d) = self.alone.iter().find(|d| {
            self.schedule.kernel_of(d.dispatch.first_call) == Some(kernel)
                && d.dispatch.first_call as usize >= self.schedule.run_base
        }) else {
            return Err(BackendError::InvalidCall(format!(
                "{kernel:?} (call {index}) has no dispatch"
            )));
        };
        self.reset_status();
        self.state.forget_snapshot();
        let lambda = &self.buffers.lambda;
        let primal = self.plan.primal_residual;
        let encoder = self.record(
            |encoder| {
                // With the primal residual λ carries over (as on the CPU).
                if kernel == Kernel::Predict && !primal {
                    encoder.clear_buffer(lambda, 0, None);
                }
            },
            std::slice::from_ref(d),
            repeats,
            false,
        );
        self.submit_and_wait(encoder)?;
        let block = self.read_mapped(&self.buffers.report_staging, 16)?;
        match self.failure(&block) {
            Some(failed) => Err(match self.guard_rejection(failed) {
                Some(found) => found.unwrap_or_else(BackendError::from),
                None => self.step_error(failed.0, failed.1),
            }),
            None => Ok(()),
        }
    }

    /// Runs `kernel` `repeats` times in one compute pass and one submit
    /// (benchmarks: the per-element cost of a kernel without a round trip
    /// per call). The state changes as `repeats` calls would change it.
    pub fn repeat_kernel(&mut self, kernel: Kernel, repeats: u32) -> Result<(), BackendError> {
        self.refuse_alone_with_motion(kernel)?;
        self.run_alone(kernel, repeats)
    }
}

resident_backend! {
    GpuBackend, load(None, None) {
        fn prefetch_state(&mut self) {
            self.state.prefetch();
        }

        fn run_kernel(&mut self, kernel: Kernel) -> Result<(), BackendError> {
            self.refuse_alone_with_motion(kernel)?;
            self.run_alone(kernel, 1)
        }
    }
}

/// What the GPU runs of XPBD with the primal residual so far: everything
/// but adaptive steps (a retry's subdivided backend would start without
/// the carried forces) and batches (batch.rs); refused by name, with the
/// backend that runs it.
fn primal_supported(plan: &Plan) -> Result<(), GpuError> {
    if plan.adaptive.is_some() {
        return Err(GpuError::Unsupported {
            what: "XPBD with \"primal_residual\": true with adaptive steps (--backend cpu runs \
                   it)"
            .into(),
        });
    }
    Ok(())
}
