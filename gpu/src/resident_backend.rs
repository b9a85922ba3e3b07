//! [`ResidentBackend`]: one GPU backend, generic over the step it runs
//! ([`crate::GpuBackend`] the XPBD step, [`crate::GpuBarrierBackend`] the
//! incremental-potential step, [`crate::GpuCoupledBackend`] the coupled
//! implicit step). What they do the same way is written here once:
//!
//! ```text
//! Resident     plan, precision, ctx (the device), state (ResidentState):
//!              what every step works on, owned by the backend
//! step S       the step's own data and kernels (ResidentStep):
//!              S::load(Load { source, plan, state, precision }, S::Options)
//!              → (Resident, S) after the state is checked against the
//!              plan; attempt, run_kernel, prefetch_state
//! new          on the shared device of an adapter found for precision
//! with_adapter on the shared device of the given adapter
//! with_private_device  on a device of its own
//! with_device  on the caller's device and queue (DeviceSource::Given)
//! export       PositionExport: the resident positions into a caller's
//!              vertex buffer, one dispatch recorded into the caller's
//!              encoder (crate::export)
//! Backend      name "gpu-<precision>", plan, step = step_adaptive over
//!              S's attempts (its report's host_waits: the context's polls
//!              during the step), read/write state and set forces through
//!              the ResidentState; run_kernel and prefetch_state are S's
//! ```

use hyperpbd_core::adaptive::{Subdivided, step_adaptive};
use hyperpbd_core::{
    Backend, BackendError, GpuError, Kernel, Plan, State, StepReport, check_state,
};

use crate::context::{DeviceSource, GpuContext};
use crate::export::{ExportParts, Exporter};
use crate::resident::ResidentState;
use crate::{AdapterSummary, PositionExport, Precision};

/// What every resident step works on: the plan, the kernels' precision,
/// the device and the state kept on it.
pub struct Resident {
    pub(crate) plan: Plan,
    pub(crate) precision: Precision,
    pub(crate) ctx: GpuContext,
    pub(crate) state: ResidentState,
}

impl Resident {
    /// A command encoder on the device.
    pub(crate) fn encoder(&self) -> wgpu::CommandEncoder {
        self.ctx.device.create_command_encoder(&Default::default())
    }

    /// `error` after rolling the state back to the step's start: a
    /// rollback that fails itself keeps `error` as its source.
    pub(crate) fn roll_back_after(&mut self, error: BackendError) -> BackendError {
        let rollback = self.state.rollback(&self.ctx);
        error.after_rollback(rollback)
    }
}

/// What a step is loaded from: the device, the plan and the state it will
/// work on (checked against each other before a step sees them) and the
/// kernels' precision.
pub struct Load<'a> {
    pub(crate) source: DeviceSource<'a>,
    pub(crate) plan: Plan,
    pub(crate) state: &'a State,
    pub(crate) precision: Precision,
}

impl<'a> Load<'a> {
    /// The device source, plan, state and precision, in that order.
    pub(crate) fn into_parts(self) -> (DeviceSource<'a>, Plan, &'a State, Precision) {
        (self.source, self.plan, self.state, self.precision)
    }
}

/// A step a [`ResidentBackend`] runs: its own data and kernels, loaded on
/// a device with the plan and state it then works on. Implemented by the
/// crate's three steps ([`crate::XpbdStep`], [`crate::Minimising`] over
/// [`crate::BarrierStep`] and [`crate::CoupledStep`]); `load` takes the
/// crate's own device source, so the trait is not for implementing outside
/// it (it is public because the backend types name it).
pub trait ResidentStep: Sized {
    /// What loading takes besides the plan, state and precision.
    type Options: Default;

    /// Checks what `load`'s plan asks of the step and loads the plan and
    /// state on its device (the state already fits the plan).
    fn load(load: Load<'_>, options: Self::Options) -> Result<(Resident, Self), BackendError>;

    /// One attempt over the plan's dt with `substeps << subdivision`
    /// substeps (core's `Subdivided`); on error the state is exactly as
    /// before the call.
    fn attempt(&mut self, on: &mut Resident, subdivision: u32) -> Result<StepReport, BackendError>;

    /// `Backend::run_kernel`.
    fn run_kernel(&mut self, on: &mut Resident, kernel: Kernel) -> Result<(), BackendError>;

    /// `Backend::prefetch_state` (nothing unless the step copies a
    /// snapshot out with its own submission).
    fn prefetch_state(&mut self, _on: &mut Resident) {}

    /// `Backend::request_contact_forces` (every step here reports them,
    /// or refuses with its reason).
    fn request_contact_forces(
        &mut self,
        on: &mut Resident,
        wanted: bool,
    ) -> Result<(), BackendError>;
}

/// A GPU backend keeping the whole state on the device, running step `S`
/// (see the module docs).
pub struct ResidentBackend<S> {
    pub(crate) on: Resident,
    pub(crate) step: S,
    /// The position export into a caller's buffer (built on first use).
    exporter: Exporter,
}

impl<S: ResidentStep> ResidentBackend<S> {
    /// Loads `plan` with `state` on `source` (`options`: the step's own),
    /// the state checked against the plan first.
    pub(crate) fn load(
        source: DeviceSource<'_>,
        plan: Plan,
        state: &State,
        precision: Precision,
        options: S::Options,
    ) -> Result<Self, BackendError> {
        check_state(&plan, state)?;
        let load = Load {
            source,
            plan,
            state,
            precision,
        };
        let (on, step) = S::load(load, options)?;
        Ok(Self::from_parts(on, step))
    }

    /// The backend of a step already loaded.
    pub(crate) fn from_parts(on: Resident, step: S) -> Self {
        ResidentBackend {
            on,
            step,
            exporter: Exporter::default(),
        }
    }

    /// Finds an adapter for `precision` and loads `plan` with `state` on
    /// its device.
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
        let source = DeviceSource::Own(adapter);
        Self::load(source, plan, state, precision, S::Options::default())
    }

    /// As `with_adapter`, on a device of its own: the backend shares
    /// neither the device nor its compiled kernels with other backends
    /// (the one way to a backend that may `destroy_device`).
    pub fn with_private_device(
        adapter: &wgpu::Adapter,
        plan: Plan,
        state: &State,
        precision: Precision,
    ) -> Result<Self, BackendError> {
        let source = DeviceSource::Private(adapter);
        Self::load(source, plan, state, precision, S::Options::default())
    }

    /// Loads `plan` with `state` on the caller's `device` and `queue`
    /// (created on `adapter` with the features `precision` needs:
    /// [`crate::required_features`]), so the simulation lives in the
    /// caller's application: [`PositionExport::encode_positions`] then
    /// fills a vertex buffer of the caller's without a host round trip.
    /// The caller's error handler and device-lost callback stay in place.
    pub fn with_device(
        adapter: &wgpu::Adapter,
        device: wgpu::Device,
        queue: wgpu::Queue,
        plan: Plan,
        state: &State,
        precision: Precision,
    ) -> Result<Self, BackendError> {
        let source = DeviceSource::Given {
            adapter,
            device,
            queue,
        };
        Self::load(source, plan, state, precision, S::Options::default())
    }

    /// The adapter this backend runs on.
    pub fn adapter(&self) -> &AdapterSummary {
        &self.on.ctx.summary
    }

    /// The precision of the kernels.
    pub fn precision(&self) -> Precision {
        self.on.precision
    }

    /// Times the host has waited for this backend's device (every device
    /// poll: `GpuContext::poll`) since it was loaded.
    pub fn host_waits(&self) -> u64 {
        self.on.ctx.host_waits()
    }

    /// Destroys the device as a driver reset would (later calls answer
    /// [`GpuError::DeviceLost`]), for fault-injection tests; only a device
    /// of the backend's own (`with_private_device`, `with_device`).
    pub fn destroy_device(&self) -> Result<(), GpuError> {
        self.on.ctx.destroy()
    }
}

impl<S: ResidentStep> PositionExport for ResidentBackend<S> {
    fn export_parts(&self) -> ExportParts<'_> {
        let on = &self.on;
        ExportParts::new(&on.ctx, &on.state, &self.exporter, on.plan.particle_count())
    }
}

/// The step's attempts with what they work on, for core's adaptive step.
struct Attempts<'a, S> {
    on: &'a mut Resident,
    step: &'a mut S,
}

impl<S: ResidentStep> Subdivided for Attempts<'_, S> {
    fn attempt(&mut self, subdivision: u32) -> Result<StepReport, BackendError> {
        self.step.attempt(self.on, subdivision)
    }
}

impl<S: ResidentStep> Backend for ResidentBackend<S> {
    fn name(&self) -> String {
        format!("gpu-{}", self.on.precision)
    }

    fn plan(&self) -> &Plan {
        &self.on.plan
    }

    fn step(&mut self) -> Result<StepReport, BackendError> {
        let before = self.on.ctx.host_waits();
        let (substeps, adaptive) = (self.on.plan.substeps, self.on.plan.adaptive);
        let mut attempts = Attempts {
            on: &mut self.on,
            step: &mut self.step,
        };
        let mut report = step_adaptive(substeps, adaptive, &mut attempts)?;
        report.host_waits = self.on.ctx.host_waits() - before;
        Ok(report)
    }

    fn read_state(&mut self) -> Result<State, BackendError> {
        Ok(self.on.state.read(&self.on.ctx)?)
    }

    fn write_state(&mut self, state: &State) -> Result<(), BackendError> {
        self.on.state.write(&self.on.ctx, &self.on.plan, state)
    }

    fn set_forces(&mut self, forces: &[f64]) -> Result<(), BackendError> {
        self.on
            .state
            .set_forces(&self.on.ctx, &self.on.plan, forces)
    }

    fn run_kernel(&mut self, kernel: Kernel) -> Result<(), BackendError> {
        self.step.run_kernel(&mut self.on, kernel)
    }

    fn prefetch_state(&mut self) {
        self.step.prefetch_state(&mut self.on);
    }

    fn request_contact_forces(&mut self, on: bool) -> Result<(), BackendError> {
        self.step.request_contact_forces(&mut self.on, on)
    }
}
