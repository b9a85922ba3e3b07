//! The XPBD step's device program: every buffer, pipeline, bind group
//! and dispatch block of a plan (or of a batch's worlds), built once, and
//! the recording of its dispatches.
//!
//! ```text
//! group 0   particle records (x, v, p, force), gravity scales, elements,
//!           rest, λ, status, report, call blocks, contact slots, residual
//!           partials and chunks, carried values
//! group 1   the dispatch blocks: exact (one dispatch per call), fast (the
//!           step in the chosen mode), alone (each kernel of a substep)
//! record    one command buffer: copies first, then the dispatches in ONE
//!           compute pass (a Host dispatch records the contact stage's
//!           kernels at its call), then the status (and report) copied out
//! ```

use hyperpbd_core::{BackendError, Kernel, Plan, StageName, State, StepError};

use super::contact_step::{ContactStage, collide_particle};
use super::motion_step::Moving;
use super::status::StatusReader;
use super::worlds::{WorldArrays, Worlds};
use crate::Precision;
use crate::context::GpuContext;
use crate::kernel_set::{KernelSet, KernelSetSpec, ParamBlocks};
use crate::layout::VectorLayout;
use crate::origin::SceneOrigin;
use crate::params::{push_reals, real_size};
use crate::resident::ResidentState;
use crate::resident_backend::Resident;
use crate::shader::ShaderFile;
use crate::xpbd::schedule::{Dispatch, Run, Schedule, StepMode};
use crate::xpbd::{Families, Placed, XpbdEntry};

/// Records copies into the encoder before dispatch k
/// ([`Program::record_between`]).
pub(crate) type CopyAt<'a> = &'a dyn Fn(&mut wgpu::CommandEncoder, usize);

/// The XPBD kernels, bind groups and dispatch blocks of one plan.
pub(crate) struct Program {
    pub kernels: KernelSet<XpbdEntry>,
    /// Group 0: the particle records and every kernel buffer.
    group: wgpu::BindGroup,
    /// Group 1: the dispatch blocks.
    blocks: wgpu::BindGroup,
    pub schedule: Schedule,
    /// One dispatch per call (failure diagnosis, contact plans).
    pub exact: Vec<Placed>,
    /// The dispatches of a step in the chosen mode.
    pub fast: Vec<Placed>,
    /// The dispatch of each kernel of a substep run alone (run_kernel).
    pub alone: Vec<Placed>,
    /// Worlds every dispatch runs (1 but in a batch).
    worlds: u32,
    /// The status word and residual report.
    pub status: StatusReader,
    /// λ (cleared by a Predict run alone).
    pub lambda: wgpu::Buffer,
    /// The substep's start positions.
    pub p: wgpu::Buffer,
    /// Buffers only the kernels use.
    _rest: Vec<wgpu::Buffer>,
}

/// What [`Program::build`] makes: the resident state, the program, and
/// the motion and contact stages the plan calls for.
pub(crate) struct Built {
    pub resident: ResidentState,
    pub program: Program,
    pub motion: Option<Moving>,
    pub contacts: Option<ContactStage>,
}

impl Program {
    /// Creates every buffer, pipeline, bind group and dispatch block: of
    /// `plan` with `state`, or of every world of `worlds` (a batch,
    /// batch.rs; `plan` and `state` are world 0's).
    pub fn build(
        ctx: &GpuContext,
        (plan, state, precision): (&Plan, &State, Precision),
        origin: SceneOrigin,
        mode: Option<StepMode>,
        worlds: Option<Worlds<'_>>,
    ) -> Result<Built, BackendError> {
        let device = &ctx.device;
        let dim = plan.dim;
        let workgroup = ShaderFile::Step.workgroup_size();
        let families = Families::new(plan, &origin)?;
        let software = ctx.summary.device_type == "Cpu";
        let schedule = Schedule::new(plan, &families, workgroup, mode, software);
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
            None => WorldArrays::one(plan, state, &families, &schedule),
        };
        // Pipelines for the entry points this plan's schedules use only
        // (lavapipe compiles each one: seconds for the measure kernels).
        let entries = schedule.entries();
        let generated = crate::xpbd::generated(plan, &families, precision);
        let kernels = KernelSet::new(
            ctx,
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
            ctx,
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
        let world_words = if w > 1 { w as u64 } else { 0 };
        let reset = StatusReader::reset_words(world_words);
        let status = make("status", bytemuck::cast_slice(&reset))?;
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
        let staged = 16 + report_bytes + 4 * world_words;
        let report_staging = ctx.staging("report_staging", staged)?;
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
        let dispatch_buffer = blocks.finish(ctx, "dispatches")?;
        // The meshes (mesh_contact.wgsl's bindings 16, 17), where the plan
        // has mesh families.
        let meshes = match &families.meshes {
            Some(layout) => vec![
                make("mesh_reals", &reals(&layout.reals))?,
                make("mesh_words", bytemuck::cast_slice(&layout.words))?,
            ],
            None => Vec::new(),
        };
        let mut bound = vec![
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
        ];
        bound.extend(&meshes);
        let group = kernels.bind(device, 0, &bound, 0)?;
        let blocks_group = kernels.bind(device, 1, &[&dispatch_buffer], block)?;
        let motion = families.motion.clone().map(|layout| Moving {
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
                ctx,
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
        let program = Program {
            kernels,
            group,
            blocks: blocks_group,
            schedule,
            exact,
            fast,
            alone,
            worlds,
            status: StatusReader::new((status, report, report_bytes), report_staging, world_words),
            lambda,
            p,
            _rest: vec![
                gravity_scale,
                elements,
                rest,
                calls,
                contact_slot,
                partials,
                chunks,
                carried,
                dispatch_buffer,
            ]
            .into_iter()
            .chain(meshes)
            .collect(),
        };
        Ok(Built {
            resident,
            program,
            motion,
            contacts,
        })
    }

    /// Records dispatch `d`: a Host dispatch's contact kernels (their own
    /// bind groups) at the call's place, any other the XPBD kernel's.
    pub fn encode(
        &self,
        pass: &mut wgpu::ComputePass<'_>,
        d: &Placed,
        contacts: Option<&ContactStage>,
    ) {
        if let (Run::Host(kernel), Some(stage)) = (d.dispatch.run, contacts) {
            if let Some(call) = self.schedule.calls.get(d.dispatch.first_call as usize) {
                stage.encode(pass, kernel, call.call);
                pass.set_bind_group(0, &self.group, &[]);
            }
            return;
        }
        crate::xpbd::encode(&self.kernels, &self.blocks, pass, d, self.worlds);
    }

    /// Records `dispatches` (`repeats` times) into `pass`, group 0 bound.
    pub fn encode_all(
        &self,
        pass: &mut wgpu::ComputePass<'_>,
        dispatches: &[Placed],
        repeats: u32,
        contacts: Option<&ContactStage>,
    ) {
        pass.set_bind_group(0, &self.group, &[]);
        for _ in 0..repeats {
            for d in dispatches {
                self.encode(pass, d, contacts);
            }
        }
    }

    /// Records `dispatches` into `encoder`, a compute pass for each stretch
    /// between `stops` (dispatch indices, ascending), `copy(encoder, k)`
    /// at each stop k (k = `dispatches.len()`: after the last): the
    /// dispatches of one pass, in the same order.
    pub fn record_between(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        dispatches: &[Placed],
        contacts: Option<&ContactStage>,
        (stops, copy): (&[usize], CopyAt<'_>),
    ) {
        let mut from = 0;
        for &stop in stops {
            if stop > from {
                let mut pass = encoder.begin_compute_pass(&Default::default());
                self.encode_all(&mut pass, &dispatches[from..stop], 1, contacts);
            }
            copy(encoder, stop);
            from = stop;
        }
        if from < dispatches.len() {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            self.encode_all(&mut pass, &dispatches[from..], 1, contacts);
        }
    }

    /// One command buffer: `before` (copies, clears), `dispatches` in one
    /// compute pass (`repeats` times), then the status word (and the report
    /// when `report`) copied to the staging buffer.
    pub fn record(
        &self,
        ctx: &GpuContext,
        before: impl FnOnce(&mut wgpu::CommandEncoder),
        (dispatches, repeats, report): (&[Placed], u32, bool),
        contacts: Option<&ContactStage>,
    ) -> wgpu::CommandEncoder {
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        before(&mut encoder);
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            self.encode_all(&mut pass, dispatches, repeats, contacts);
        }
        self.status.copy_out(&mut encoder, report);
        encoder
    }

    /// Rolls back and reruns the step exactly (one dispatch per call)
    /// through call `through` (`None`: all of it), leaving the state that
    /// call saw (its status block in the staging buffer).
    pub fn rerun_exact(
        &self,
        on: &mut Resident,
        through: Option<u32>,
        contacts: Option<&ContactStage>,
    ) -> Result<(), hyperpbd_core::GpuError> {
        on.state.rollback(&on.ctx)?;
        self.status.reset(&on.ctx);
        let prefix: Vec<Placed> = self
            .exact
            .iter()
            .copied()
            .filter(|d| through.is_none_or(|call| d.dispatch.first_call <= call))
            .collect();
        let encoder = self.record(&on.ctx, |_| {}, (&prefix, 1, false), contacts);
        on.ctx.submit_and_wait(encoder)
    }

    /// The substep of step call `call`.
    pub fn substep_of(&self, call: u32) -> u32 {
        call / self.schedule.kernels_per_substep.max(1) as u32
    }

    /// The error of call `call` failing at `index`: the constraint or
    /// particle the CPU names.
    pub fn step_error(&self, plan: &Plan, call: u32, index: u32) -> BackendError {
        let substep = self.substep_of(call);
        match self.schedule.kernel_of(call) {
            Some(Kernel::Project { family, .. }) => {
                let f = &plan.families[family];
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
                    Some(Kernel::Collide) => collide_particle(index, plan.particle_count()),
                    _ => index as usize,
                },
            }
            .into(),
        }
    }

    /// Device bytes per particle and per constraint slot (buffers that
    /// scale with them), for reports.
    pub fn bytes_per_particle_and_slot(dim: usize, precision: Precision) -> (usize, usize) {
        let r = real_size(precision);
        let record = VectorLayout::Record.reals_per_particle(dim) * r;
        // x, v, p, saved_x, saved_v, force: one record each; gravity scale:
        // one real; a slot per hyperplane family: one u32.
        let per_particle = 6 * record + r;
        // rest, lambda: one real each, plus the particle indices.
        let per_slot = 2 * r;
        (per_particle, per_slot)
    }
}
