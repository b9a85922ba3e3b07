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

use hyperpbd_core::{BackendError, GpuError, Kernel, Plan, State, StepReport, check_kernel};

use crate::Precision;
use crate::context::{DeviceSource, GpuContext};
use crate::origin::SceneOrigin;
use crate::params::read_reals;
use crate::resident::ResidentState;
use crate::resident_backend::{Load, Resident, ResidentBackend, ResidentStep};
use crate::xpbd::schedule::StepMode;
use contact_step::{ContactStage, contact_report};
use diagnosis::{diagnosed_error, guard_rejection};
use forces::ForceTape;
use motion_step::{Moving, refuse_alone_with_motion};
use program::Program;
use status::{StatusReader, refuse_cut_loops};

pub(crate) mod contact_step;
mod diagnosis;
mod forces;
mod motion_step;
mod program;
pub(crate) mod status;
pub(crate) mod worlds;

/// The wgpu backend of the XPBD step.
pub type GpuBackend = ResidentBackend<XpbdStep>;

/// The XPBD step on the device: its program (buffers, kernels, dispatch
/// blocks), the contact and motion stages the plan calls for, and the
/// steps of its subdivided plans (adaptive).
pub struct XpbdStep {
    program: Program,
    /// Broadphase and contact kernels, when the plan has collisions.
    contacts: Option<ContactStage>,
    /// Prescribed motion: where each step's values go (motion_step.rs).
    motion: Option<Moving>,
    /// Steps of `plan.subdivided(j)`, j = 1, 2, … (adaptive), each on
    /// its own resident state on this device.
    subdivided: Vec<(Resident, XpbdStep)>,
    /// The contact forces' copies and recorder, when asked (forces.rs).
    forces: Option<ForceTape>,
}

/// How an XPBD step is loaded ([`GpuBackend::with_options`]; the default
/// is what `with_adapter` does).
#[derive(Clone, Debug, Default)]
pub struct XpbdOptions {
    /// Device positions are stored relative to this origin (`None`:
    /// [`SceneOrigin::for_state`]; a plan with expression families keeps
    /// world coordinates and refuses any other).
    pub origin: Option<SceneOrigin>,
    /// The step's dispatches formed as this says (`None`: as the plan's
    /// size suggests). Every mode gives the same results;
    /// [`StepMode::Small`] is refused for plans with particle contact.
    pub mode: Option<StepMode>,
}

impl XpbdOptions {
    /// Positions stored relative to `origin`.
    pub fn origin(origin: SceneOrigin) -> Self {
        XpbdOptions {
            origin: Some(origin),
            mode: None,
        }
    }

    /// The dispatches formed as `mode` says.
    pub fn mode(mode: StepMode) -> Self {
        XpbdOptions {
            origin: None,
            mode: Some(mode),
        }
    }
}

impl ResidentStep for XpbdStep {
    type Options = XpbdOptions;

    fn load(load: Load<'_>, options: XpbdOptions) -> Result<(Resident, Self), BackendError> {
        let (device, plan, state, precision) = load.into_parts();
        let XpbdOptions { origin, mode } = options;
        if mode == Some(StepMode::Small) && plan.contacts.is_some() {
            return Err(BackendError::InvalidCall(
                "step mode small: plans with particle contact run the exact or fused schedule \
                 (the contact kernels are dispatches of their own)"
                    .into(),
            ));
        }
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
        ctx.building(|| Self::build(&ctx, plan, state, (precision, origin, mode), None))
    }

    fn attempt(&mut self, on: &mut Resident, subdivision: u32) -> Result<StepReport, BackendError> {
        let attempt = if subdivision == 0 {
            self.step_once(on)
        } else {
            self.subdivided_attempt(on, subdivision)
        };
        if let (Ok(_), Some(moving)) = (&attempt, &mut self.motion) {
            moving.step_done();
        }
        attempt
    }

    fn run_kernel(&mut self, on: &mut Resident, kernel: Kernel) -> Result<(), BackendError> {
        refuse_alone_with_motion(self.motion.as_ref(), kernel)?;
        self.run_alone(on, kernel, 1)
    }

    fn prefetch_state(&mut self, on: &mut Resident) {
        on.state.prefetch();
    }

    /// Reported from the device's own states (forces.rs), here and in
    /// every subdivided step built so far or later; a refused request
    /// changes nothing.
    fn request_contact_forces(
        &mut self,
        on: &mut Resident,
        wanted: bool,
    ) -> Result<(), BackendError> {
        let tape = |on: &Resident, step: &XpbdStep| {
            wanted
                .then(|| ForceTape::new(on, &step.program))
                .transpose()
        };
        let own = tape(on, self)?;
        let refined = (self.subdivided.iter())
            .map(|(refined_on, refined)| tape(refined_on, refined))
            .collect::<Result<Vec<_>, _>>()?;
        for ((_, step), tape) in self.subdivided.iter_mut().zip(refined) {
            step.forces = tape;
        }
        self.forces = own;
        Ok(())
    }
}

impl XpbdStep {
    /// The step of `plan` with `state` on `ctx` (or of every world of
    /// `worlds`: a batch, crate::batch; `plan` and `state` are world 0's).
    pub(crate) fn build(
        ctx: &GpuContext,
        plan: Plan,
        state: &State,
        (precision, origin, mode): (Precision, SceneOrigin, Option<StepMode>),
        worlds: Option<worlds::Worlds<'_>>,
    ) -> Result<(Resident, XpbdStep), BackendError> {
        let built = Program::build(ctx, (&plan, state, precision), origin, mode, worlds)?;
        let on = Resident {
            plan,
            precision,
            ctx: ctx.clone(),
            state: built.resident,
        };
        let step = XpbdStep {
            program: built.program,
            contacts: built.contacts,
            motion: built.motion,
            subdivided: Vec::new(),
            forces: None,
        };
        Ok((on, step))
    }

    /// The step of `plan` (`on`'s topology) on `on`'s device, precision
    /// and origin, dispatched as `mode` says, its state zero until one is
    /// copied in (a subdivided plan's step; a batch world's, batch/retry.rs).
    pub(crate) fn build_beside(
        on: &Resident,
        plan: Plan,
        mode: StepMode,
    ) -> Result<(Resident, XpbdStep), BackendError> {
        let n = plan.particle_count() * plan.dim;
        let blank = State {
            dim: plan.dim,
            positions: vec![0.0; n],
            velocities: vec![0.0; n],
        };
        let how = (on.precision, on.state.origin().clone(), Some(mode));
        let ctx = &on.ctx;
        ctx.building(|| Self::build(ctx, plan, &blank, how, None))
    }

    /// One step of the plan's own substeps (attempt 0 of the adaptive
    /// step): one command buffer, one submit, one status readback, which
    /// is the step's one host wait.
    fn step_once(&mut self, on: &mut Resident) -> Result<StepReport, BackendError> {
        if let Some(moving) = &self.motion {
            let p = &mut self.program;
            moving.upload(
                on,
                &mut p.schedule,
                p.exact.iter().chain(&p.fast).chain(&p.alone),
            )?;
        }
        // With forces asked: the exact schedule and the tape's copies
        // (forces.rs); else the chosen schedule.
        let (outcome, block) = if self.forces.is_some() {
            self.submit_recorded(on)?
        } else if self.contacts.is_some() {
            let (outcomes, block) = self.submit_fitting_contact_step(on)?;
            refuse_cut_loops(on, &block)?;
            (Some(first_outcome(&outcomes)), block)
        } else {
            (None, self.submit_step(on)?)
        };
        if let Some(failed) = StatusReader::failure(&block) {
            return Err(self.diagnosed_error(on, failed));
        }
        let report = read_reals(&block[16..], on.precision);
        let mut step = match outcome {
            Some(outcome) => contact_report(&on.plan, &report, &outcome),
            None => crate::xpbd::step_report(&on.plan, &report),
        };
        let clock = self.motion.as_ref().map_or(0, |m| m.step);
        if let Some(tape) = &mut self.forces {
            // A tape that cannot be read fails the step, rolled back.
            match tape.forces(&on.ctx, &on.plan, &on.state, clock) {
                Ok(forces) => step.contact_forces = Some(forces),
                Err(e) => return Err(on.roll_back_after(e.into())),
            }
        }
        Ok(step)
    }

    /// One submission of the step's dispatches (the chosen schedule, every
    /// world of a batch): the state saved first, a snapshot copied out when
    /// one was asked for, one wait; the status block and the report as
    /// read back. A step whose loops were cut is refused, rolled back.
    pub(crate) fn submit_step(&mut self, on: &mut Resident) -> Result<Vec<u8>, BackendError> {
        let program = &self.program;
        program.status.reset(&on.ctx);
        let fast = (&program.fast[..], 1, true);
        let save = |e: &mut wgpu::CommandEncoder| on.state.save(e);
        let encoder = program.record(&on.ctx, save, fast, self.contacts.as_ref());
        submit_for_status(on, &program.status, encoder)
    }

    /// With particle contact: the step (every world's) submitted until
    /// every list fits (contact_step.rs); every world's outcome and the
    /// status/report block.
    pub(crate) fn submit_fitting_contact_step(
        &mut self,
        on: &mut Resident,
    ) -> Result<(Vec<crate::contact::Outcome>, Vec<u8>), BackendError> {
        let Some(stage) = self.contacts.as_mut() else {
            return Err(GpuError::Other {
                message: "contact step without a contact stage".into(),
            }
            .into());
        };
        let program = &self.program;
        let record = |encoder: &mut wgpu::CommandEncoder, stage: &ContactStage| {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            program.encode_all(&mut pass, &program.fast, 1, Some(stage));
        };
        stage.submit_fitting(on, &program.status, &record)
    }

    /// The submission of a recorded step (every list fitted, with particle
    /// contact): its contact outcome, if any, and its status block; a step
    /// whose loops were cut is refused, rolled back.
    fn submit_recorded(
        &mut self,
        on: &mut Resident,
    ) -> Result<(Option<crate::contact::Outcome>, Vec<u8>), BackendError> {
        let (program, Some(tape)) = (&self.program, self.forces.as_ref()) else {
            return Err(GpuError::Other {
                message: "a recorded step without its tape".into(),
            }
            .into());
        };
        let copy = |encoder: &mut wgpu::CommandEncoder, at: usize| tape.copy(encoder, at);
        let between = (tape.stops(), &copy as program::CopyAt<'_>);
        if let Some(stage) = self.contacts.as_mut() {
            let record = |encoder: &mut wgpu::CommandEncoder, stage: &ContactStage| {
                program.record_between(encoder, &program.exact, Some(stage), between);
            };
            let (outcomes, block) = stage.submit_fitting(on, &program.status, &record)?;
            refuse_cut_loops(on, &block)?;
            return Ok((Some(first_outcome(&outcomes)), block));
        }
        program.status.reset(&on.ctx);
        let mut encoder = on.encoder();
        on.state.save(&mut encoder);
        program.record_between(&mut encoder, &program.exact, None, between);
        program.status.copy_out(&mut encoder, true);
        Ok((None, submit_for_status(on, &program.status, encoder)?))
    }

    /// The status words and report of the step (every world's).
    pub(crate) fn status(&self) -> &StatusReader {
        &self.program.status
    }

    /// Whether the plan has particle contact (a contact stage).
    pub(crate) fn has_contacts(&self) -> bool {
        self.contacts.is_some()
    }

    /// The error of a step whose status names `failed`, state rolled back.
    pub(crate) fn diagnosed_error(&self, on: &mut Resident, failed: (u32, u32)) -> BackendError {
        diagnosed_error(on, (&self.program, self.contacts.as_ref()), failed)
    }

    /// One attempt on `plan.subdivided(subdivision)`, run by a step of
    /// that plan on this device (built on first use) from this state: x,
    /// v, force copied in on the device, the step run there, x, v copied
    /// back on success — no host round trip of the state.
    fn subdivided_attempt(
        &mut self,
        on: &mut Resident,
        subdivision: u32,
    ) -> Result<StepReport, BackendError> {
        let j = subdivision as usize;
        while self.subdivided.len() < j {
            let plan = on.plan.subdivided(self.subdivided.len() as u32 + 1);
            let (mut refined_on, mut refined) =
                Self::build_beside(on, plan, self.program.schedule.mode)?;
            if self.forces.is_some() {
                refined.request_contact_forces(&mut refined_on, true)?;
            }
            self.subdivided.push((refined_on, refined));
        }
        let clock = self.motion.as_ref().map(|m| m.step);
        let (refined_on, refined) = &mut self.subdivided[j - 1];
        if let (Some(step), Some(moving)) = (clock, refined.motion.as_mut()) {
            moving.step = step;
        }
        copy_state(&on.ctx, &on.state, &refined_on.state, true)?;
        let report = refined.step_once(refined_on)?;
        on.state.forget_snapshot();
        copy_state(&on.ctx, &refined_on.state, &on.state, false)?;
        Ok(report)
    }

    /// Runs `kernel` alone `repeats` times in one compute pass and one
    /// submit, the CPU's way (`Predict` resets the multipliers).
    fn run_alone(
        &mut self,
        on: &mut Resident,
        kernel: Kernel,
        repeats: u32,
    ) -> Result<(), BackendError> {
        check_kernel(&on.plan, kernel)?;
        let Some(index) = on.plan.substep_kernels.iter().position(|&k| k == kernel) else {
            return Err(BackendError::InvalidCall(format!(
                "{kernel:?} is not in this plan's schedule"
            )));
        };
        let program = &self.program;
        if matches!(kernel, Kernel::Broadphase | Kernel::Collide) {
            let Some(stage) = self.contacts.as_mut() else {
                on.state.forget_snapshot();
                return Err(GpuError::Other {
                    message: "contact lists still too short after growing them".into(),
                }
                .into());
            };
            return match stage.run_kernel(on, &program.status, (kernel, index as u32))? {
                Some((call, index)) => Err(program.step_error(&on.plan, call, index)),
                None => Ok(()),
            };
        }
        let schedule = &program.schedule;
        let Some(d) = program.alone.iter().find(|d| {
            schedule.kernel_of(d.dispatch.first_call) == Some(kernel)
                && d.dispatch.first_call as usize >= schedule.run_base
        }) else {
            return Err(BackendError::InvalidCall(format!(
                "{kernel:?} (call {index}) has no dispatch"
            )));
        };
        program.status.reset(&on.ctx);
        on.state.forget_snapshot();
        let lambda = &program.lambda;
        let primal = on.plan.primal_residual;
        let clear = |encoder: &mut wgpu::CommandEncoder| {
            // With the primal residual λ carries over (as on the CPU).
            if kernel == Kernel::Predict && !primal {
                encoder.clear_buffer(lambda, 0, None);
            }
        };
        let alone = (std::slice::from_ref(d), repeats, false);
        let encoder = program.record(&on.ctx, clear, alone, self.contacts.as_ref());
        on.ctx.submit_and_wait(encoder)?;
        let block = program.status.read(&on.ctx, false)?;
        match StatusReader::failure(&block) {
            Some(failed) => Err(match guard_rejection(on, program, failed) {
                Some(found) => found.unwrap_or_else(BackendError::from),
                None => program.step_error(&on.plan, failed.0, failed.1),
            }),
            None => Ok(()),
        }
    }
}

/// World 0's contact outcome (a single world's).
fn first_outcome(outcomes: &[crate::contact::Outcome]) -> crate::contact::Outcome {
    outcomes
        .first()
        .copied()
        .unwrap_or(crate::contact::Outcome::EMPTY)
}

/// Submits a recorded step (`encoder`, its status copied out), a state
/// snapshot copied out with it when one was asked for; one wait: mapping
/// the report waits for the step and completes the snapshot's mapping
/// with it. The status block as read back; a step whose loops were cut is
/// refused, rolled back.
fn submit_for_status(
    on: &mut Resident,
    status: &StatusReader,
    mut encoder: wgpu::CommandEncoder,
) -> Result<Vec<u8>, BackendError> {
    let snapshot = on.state.record_snapshot(&mut encoder);
    on.ctx.submit(encoder)?;
    if let Some(slot) = snapshot {
        on.state.map_snapshot(slot);
    }
    let block = status.read(&on.ctx, true)?;
    on.ctx.check()?;
    refuse_cut_loops(on, &block)?;
    Ok(block)
}

/// What [`GpuBackend`] offers besides the resident backend's API.
impl GpuBackend {
    /// Loads `plan` with `state` on the shared device of `adapter` as
    /// `options` say: the scene origin (see [`SceneOrigin`];
    /// [`GpuBackend::with_adapter`] picks it) and the step mode.
    pub fn with_options(
        adapter: &wgpu::Adapter,
        plan: Plan,
        state: &State,
        precision: Precision,
        options: XpbdOptions,
    ) -> Result<Self, BackendError> {
        Self::load(DeviceSource::Own(adapter), plan, state, precision, options)
    }

    /// The origin device positions are relative to.
    pub fn origin(&self) -> &SceneOrigin {
        self.on.state.origin()
    }

    /// Bytes a step copies out for its contact forces (`None` unless
    /// they were asked for: `Backend::request_contact_forces`).
    pub fn contact_force_tape_bytes(&self) -> Option<u64> {
        self.step.forces.as_ref().map(|tape| tape.bytes())
    }

    /// How the dispatches of a step are formed.
    pub fn step_mode(&self) -> StepMode {
        self.step.program.schedule.mode
    }

    /// Compute dispatches per step (residual and contact stage included).
    pub fn dispatches_per_step(&self) -> usize {
        let contact = crate::contact::contact_dispatches_per_step(&self.on.plan);
        self.step.program.schedule.dispatches_per_step() + contact
    }

    /// Compute pipelines of the XPBD kernels: one per entry point and set
    /// of its constants (ops, flags, io) the plan's schedules use.
    pub fn pipeline_count(&self) -> usize {
        self.step.program.kernels.pipeline_count()
    }

    /// Device bytes per particle and per constraint slot (buffers that
    /// scale with them), for reports.
    pub fn bytes_per_particle_and_slot(&self) -> (usize, usize) {
        Program::bytes_per_particle_and_slot(self.on.plan.dim, self.on.precision)
    }

    /// List slots per particle of the contact stage (`None` without
    /// particle contact): 32 at load, grown when a step found a longer
    /// list (that step then ran again from its start).
    pub fn contact_list_slots(&self) -> Option<usize> {
        self.step.contacts.as_ref().map(ContactStage::slots)
    }

    /// Every world's list slots per particle (a batch; `None` without
    /// particle contact).
    pub(crate) fn world_list_slots(&self) -> Option<Vec<usize>> {
        self.step.contacts.as_ref().map(ContactStage::world_slots)
    }

    /// Runs `kernel` `repeats` times in one compute pass and one submit
    /// (benchmarks: the per-element cost of a kernel without a round trip
    /// per call). The state changes as `repeats` calls would change it.
    pub fn repeat_kernel(&mut self, kernel: Kernel, repeats: u32) -> Result<(), BackendError> {
        refuse_alone_with_motion(self.step.motion.as_ref(), kernel)?;
        self.step.run_alone(&mut self.on, kernel, repeats)
    }
}

/// x and v (and the forces when `forces`) of `from` into `to`, on the
/// device, byte for byte (same plan topology, same layout).
fn copy_state(
    ctx: &GpuContext,
    from: &ResidentState,
    to: &ResidentState,
    forces: bool,
) -> Result<(), GpuError> {
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
