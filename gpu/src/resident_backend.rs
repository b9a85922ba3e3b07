//! What the two GPU backends ([`crate::GpuBackend`], the XPBD step, and
//! [`crate::GpuBarrierBackend`], the incremental-potential step) do the
//! same way, because both keep the whole state on the device in the same
//! fields and build themselves on a device source the same way:
//!
//! ```text
//! fields       plan: Plan, precision: Precision, ctx: GpuContext,
//!              state: ResidentState, exporter: Exporter
//! load         T::load(DeviceSource, plan, state, precision, extra…): the
//!              type's loader, its own further arguments given per type
//! new          on a device of its own, on an adapter found for precision
//! with_adapter on a device of its own, on the given adapter
//! with_device  on the caller's device and queue (DeviceSource::Given)
//! adapter      the summary of the adapter it runs on
//! export       PositionExport: the resident positions into a caller's
//!              vertex buffer, one dispatch recorded into the caller's
//!              encoder (crate::export)
//! Backend      name "gpu-<precision>", plan, step = step_adaptive over the
//!              type's Subdivided attempts (its report's host_waits: the
//!              context's polls during the step), read/write state and set forces
//!              through the ResidentState; the rest given per type
//! ```
//! The orphan rule keeps a blanket `impl Backend` out of this crate, so one
//! macro writes these items for each backend.

/// Writes, for the resident GPU backend `$backend` (fields as the module
/// doc says) loaded by `Self::$load(source, plan, state, precision,
/// $extra…)`: `new`, `with_adapter`, `with_device`, `adapter`,
/// [`crate::PositionExport`], and [`hyperpbd_core::Backend`] with the
/// shared methods and `$own`, the type's own ones (`run_kernel`,
/// optionally `prefetch_state`).
macro_rules! resident_backend {
    ($backend:ty, $load:ident($($extra:expr),*) { $($own:tt)* }) => {
        impl $backend {
            /// Finds an adapter for `precision`, creates a device and loads
            /// `plan` with `state`.
            pub fn new(
                plan: ::hyperpbd_core::Plan,
                state: &::hyperpbd_core::State,
                precision: $crate::Precision,
            ) -> Result<Self, ::hyperpbd_core::BackendError> {
                let (adapter, _) = $crate::request_adapter(precision)?;
                Self::with_adapter(&adapter, plan, state, precision)
            }

            /// Loads `plan` with `state` on a device of `adapter`.
            pub fn with_adapter(
                adapter: &wgpu::Adapter,
                plan: ::hyperpbd_core::Plan,
                state: &::hyperpbd_core::State,
                precision: $crate::Precision,
            ) -> Result<Self, ::hyperpbd_core::BackendError> {
                let source = $crate::context::DeviceSource::Own(adapter);
                Self::$load(source, plan, state, precision $(, $extra)*)
            }

            /// As `with_adapter`, on a device of its own: the backend
            /// shares neither the device nor its compiled kernels with
            /// other backends (the one way to a backend that may
            /// `destroy_device`).
            pub fn with_private_device(
                adapter: &wgpu::Adapter,
                plan: ::hyperpbd_core::Plan,
                state: &::hyperpbd_core::State,
                precision: $crate::Precision,
            ) -> Result<Self, ::hyperpbd_core::BackendError> {
                let source = $crate::context::DeviceSource::Private(adapter);
                Self::$load(source, plan, state, precision $(, $extra)*)
            }

            /// Loads `plan` with `state` on the caller's `device` and
            /// `queue` (created on `adapter` with the features `precision`
            /// needs: [`crate::required_features`]), so the simulation
            /// lives in the caller's application:
            /// [`crate::PositionExport::encode_positions`] then fills a
            /// vertex buffer of the caller's without a host round trip. The
            /// caller's error handler and device-lost callback stay in place.
            pub fn with_device(
                adapter: &wgpu::Adapter,
                device: wgpu::Device,
                queue: wgpu::Queue,
                plan: ::hyperpbd_core::Plan,
                state: &::hyperpbd_core::State,
                precision: $crate::Precision,
            ) -> Result<Self, ::hyperpbd_core::BackendError> {
                let source = $crate::context::DeviceSource::Given {
                    adapter,
                    device,
                    queue,
                };
                Self::$load(source, plan, state, precision $(, $extra)*)
            }

            /// The adapter this backend runs on.
            pub fn adapter(&self) -> &$crate::AdapterSummary {
                &self.ctx.summary
            }
        }

        impl $crate::PositionExport for $backend {
            fn export_parts(&self) -> $crate::export::ExportParts<'_> {
                $crate::export::ExportParts::new(
                    &self.ctx,
                    &self.state,
                    &self.exporter,
                    self.plan.particle_count(),
                )
            }
        }

        impl ::hyperpbd_core::Backend for $backend {
            fn name(&self) -> String {
                format!("gpu-{}", self.precision)
            }

            fn plan(&self) -> &::hyperpbd_core::Plan {
                &self.plan
            }

            fn step(
                &mut self,
            ) -> Result<::hyperpbd_core::StepReport, ::hyperpbd_core::BackendError> {
                let before = self.ctx.host_waits();
                let mut report = ::hyperpbd_core::adaptive::step_adaptive(
                    self.plan.substeps,
                    self.plan.adaptive,
                    self,
                )?;
                report.host_waits = self.ctx.host_waits() - before;
                Ok(report)
            }

            fn read_state(
                &mut self,
            ) -> Result<::hyperpbd_core::State, ::hyperpbd_core::BackendError> {
                Ok(self.state.read(&self.ctx)?)
            }

            fn write_state(
                &mut self,
                state: &::hyperpbd_core::State,
            ) -> Result<(), ::hyperpbd_core::BackendError> {
                self.state.write(&self.ctx, &self.plan, state)
            }

            fn set_forces(&mut self, forces: &[f64]) -> Result<(), ::hyperpbd_core::BackendError> {
                self.state.set_forces(&self.ctx, &self.plan, forces)
            }

            /// Refused: the kernels keep their contact multipliers on the
            /// device and do not read them back (the CPU golden path
            /// reports contact forces).
            fn request_contact_forces(
                &mut self,
                on: bool,
            ) -> Result<(), ::hyperpbd_core::BackendError> {
                if !on {
                    return Ok(());
                }
                Err(::hyperpbd_core::GpuError::Unsupported {
                    what: format!(
                        "contact forces on {}: the kernels do not read their contact multipliers back yet; the CPU golden path reports them (--backend cpu)",
                        ::hyperpbd_core::Backend::name(self)
                    ),
                }
                .into())
            }

            $($own)*
        }
    };
}

pub(crate) use resident_backend;

/// Writes, for an incremental-potential GPU backend `$backend` (fields
/// plan, ctx, state, substep: u32, reports: Vec<MinimisationReport>; a
/// method `minimise(&mut self) -> Result<MinimisationReport,
/// BackendError>` for one minimisation on the resident state), what the
/// barrier and coupled backends do the same way:
///
/// ```text
/// run_minimise      one minimisation, its report kept, a refusal as StepError
/// minimise_kernel   Backend::run_kernel's body: save, run_minimise; results the
///                   device could not finish (GpuError) are rolled back
/// Subdivided        one attempt = every Minimise kernel of every substep, the
///                   state restored byte for byte on any error (no adaptive steps);
///                   its report carries the families' residuals (core's violation)
/// ```
macro_rules! minimising_backend {
    ($backend:ty) => {
        impl $backend {
            fn run_minimise(&mut self) -> Result<(), ::hyperpbd_core::BackendError> {
                let report = self.minimise()?;
                let refused = ::hyperpbd_core::StepError::refused(self.substep, &report);
                self.reports.push(report);
                refused.map_or(Ok(()), |e| Err(e.into()))
            }

            fn minimise_kernel(
                &mut self,
                kernel: ::hyperpbd_core::Kernel,
            ) -> Result<(), ::hyperpbd_core::BackendError> {
                ::hyperpbd_core::check_kernel(&self.plan, kernel)?;
                let mut encoder = self.ctx.device.create_command_encoder(&Default::default());
                self.state.save(&mut encoder);
                // No wait: the steps' submissions follow it in queue order.
                self.ctx.submit(encoder)?;
                match self.run_minimise() {
                    // Results the device could not finish (loops cut short, a
                    // lost device) are not kept: the state goes back to the
                    // call's start.
                    Err(e @ ::hyperpbd_core::BackendError::Gpu(_)) => {
                        Err(e.after_rollback(self.state.rollback(&self.ctx)))
                    }
                    other => other,
                }
            }
        }

        /// The incremental-potential path runs no guards (validation refuses
        /// them there), so its one attempt is the step itself.
        impl ::hyperpbd_core::adaptive::Subdivided for $backend {
            fn attempt(
                &mut self,
                subdivision: u32,
            ) -> Result<::hyperpbd_core::StepReport, ::hyperpbd_core::BackendError> {
                if subdivision > 0 {
                    return Err(::hyperpbd_core::BackendError::InvalidCall(
                        "the incremental-potential path has no adaptive steps".into(),
                    ));
                }
                let mut encoder = self.ctx.device.create_command_encoder(&Default::default());
                self.state.save(&mut encoder);
                // No wait: the steps' submissions follow it in queue order.
                self.ctx.submit(encoder)?;
                self.reports.clear();
                for substep in 0..self.plan.substeps {
                    self.substep = substep;
                    for k in 0..self.plan.substep_kernels.len() {
                        if self.plan.substep_kernels[k] != ::hyperpbd_core::Kernel::Minimise {
                            continue;
                        }
                        if let Err(e) = self.run_minimise() {
                            return Err(e.after_rollback(self.state.rollback(&self.ctx)));
                        }
                    }
                }
                // The families' and the balls' residuals at the accepted
                // state, as the CPU reports them (one read-back, only with
                // families or collisions).
                let residuals = if self.plan.families.is_empty() && self.plan.contacts.is_none() {
                    Vec::new()
                } else {
                    let x = self.state.read(&self.ctx)?.positions;
                    let (plan, violation) =
                        (&self.plan, ::hyperpbd_core::violation::family_residuals);
                    let mut residuals = violation(&plan.families, plan.dim, &x);
                    if plan.contacts.is_some() {
                        residuals.push(::hyperpbd_core::violation::ball_overlap_residual(plan, &x));
                    }
                    residuals
                };
                Ok(::hyperpbd_core::StepReport {
                    kernel_calls: self.plan.kernel_counts(),
                    minimisation: std::mem::take(&mut self.reports),
                    residuals,
                    ..::hyperpbd_core::StepReport::default()
                })
            }
        }
    };
}

pub(crate) use minimising_backend;
