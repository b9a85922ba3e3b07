//! `GpuBarrierBackend`: the whole incremental-potential step on the GPU
//! (`shaders/incremental_potential.wgsl`), driven by the host per Newton
//! iteration exactly as cpu/src/incremental_potential.rs runs it.
//!
//! ```text
//! step:   save (x, v) on the device
//!         per substep:  ip_predict
//!                       loop { ip_gradient; tree reduction (one dispatch per stride);
//!                              read residual + status (a few bytes)
//!                              refuse / converged / budget exhausted → stop
//!                              ip_newton (filter before every trial, Armijo) }
//!                       ip_velocity
//!         on a refusal: restore (x, v) byte for byte, return the typed error
//! probe:  every kernel ends with barrier.wgsl's check_loops; the status
//!         block read after each gradient pass (and after ip_velocity) names
//!         the first particle whose loops llvmpipe cut short → the step is
//!         refused (GpuError::Unsupported, state restored), never kept
//! ```
//! The residual's sqrt (packed criterion) is taken on the host in f64.

use hyperpbd_core::IncrementalPotentialPlan;
use hyperpbd_core::{
    Backend, BackendError, Convergence, GpuError, Kernel, MinimisationReport, MinimisationStatus,
    Plan, Refusal, State, check_state,
};

use crate::Precision;
use crate::barrier::{
    NONE, STATUS_WORDS, barrier_resources, infeasible_start, refuse_cut_loops, status_words,
};
use crate::context::{DeviceSource, GpuContext};
use crate::export::Exporter;
use crate::kernel_set::{BlockWriter, EntryPoint, KernelSet, KernelSetSpec, ParamBlocks};
use crate::params::{push_reals, read_reals, real_size};
use crate::resident::ResidentState;
use crate::resident_backend::{minimising_backend, resident_backend};
use crate::shader::{MAX_GPU_DIM, ShaderFile};

/// Armijo constant (same as the CPU's).
const ARMIJO: f64 = 1e-4;

/// Entry points of `shaders/incremental_potential.wgsl`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum IpEntry {
    Predict,
    Gradient,
    ReduceSum,
    ReduceMax,
    Newton,
    Velocity,
}

impl EntryPoint for IpEntry {
    fn source(self) -> (ShaderFile, &'static str) {
        let name = match self {
            IpEntry::Predict => "ip_predict",
            IpEntry::Gradient => "ip_gradient",
            IpEntry::ReduceSum => "ip_reduce_sum",
            IpEntry::ReduceMax => "ip_reduce_max",
            IpEntry::Newton => "ip_newton",
            IpEntry::Velocity => "ip_velocity",
        };
        (ShaderFile::IncrementalPotential, name)
    }
}

/// The status block before a pass: nothing moved, no failing particle,
/// no stall, no loop cut short.
const STATUS_RESET: [u32; STATUS_WORDS] = [0, NONE, NONE, 0, NONE];
/// Bytes of the probe read back per Newton iteration: terms[0] (one real,
/// at 0) and the status block at [`STATUS_AT`].
const STATUS_AT: u64 = 16;
const PROBE_BYTES: u64 = STATUS_AT + 4 * STATUS_WORDS as u64;

/// The GPU backend of the incremental-potential path.
pub struct GpuBarrierBackend {
    plan: Plan,
    ip: IncrementalPotentialPlan,
    precision: Precision,
    ctx: GpuContext,
    kernels: KernelSet<IpEntry>,
    group: wgpu::BindGroup,
    params_group: wgpu::BindGroup,
    /// Dynamic offsets: [base, reduce level 0, level 1, …].
    offsets: Vec<u32>,
    /// x, v (dense layout: the barrier kernels index x[i·DIM + a]), saved
    /// copies, forces; positions relative to the scene origin.
    state: ResidentState,
    terms: wgpu::Buffer,
    status: wgpu::Buffer,
    /// terms[0], then the status words at [`STATUS_AT`].
    probe: wgpu::Buffer,
    /// Buffers only the kernels read or write.
    _rest: Vec<wgpu::Buffer>,
    substep: u32,
    reports: Vec<MinimisationReport>,
    /// The position export into a caller's buffer (built on first use).
    exporter: Exporter,
}

impl GpuBarrierBackend {
    /// Loads `plan` with `state` on `device`.
    fn load(
        device: DeviceSource<'_>,
        plan: Plan,
        state: &State,
        precision: Precision,
    ) -> Result<Self, BackendError> {
        check_state(&plan, state)?;
        let Some(ip) = plan.incremental_potential().cloned() else {
            return Err(BackendError::InvalidCall(
                "GpuBarrierBackend runs incremental_potential scenes only".into(),
            ));
        };
        if ip.coupled.is_some() {
            return Err(GpuError::Unsupported {
                what: "the coupled implicit step (constraint springs, ball–ball barriers, \
                       lagged friction or an explicit warm_start under incremental_potential; \
                       docs/implicit.md §7) on GpuBarrierBackend: GpuCoupledBackend runs it \
                       (hyperpbd::load picks it)"
                    .into(),
            }
            .into());
        }
        let dim = plan.dim;
        if dim > MAX_GPU_DIM {
            return Err(GpuError::Unsupported {
                what: format!("dimension {dim} (the GPU kernels support 1..={MAX_GPU_DIM})"),
            }
            .into());
        }
        let ctx = device.context(precision)?;
        let kernels = KernelSet::new(
            &ctx.device,
            &KernelSetSpec {
                label: "hyperpbd incremental potential",
                modules: &[ShaderFile::IncrementalPotential],
                dim,
                precision,
                entries: &[
                    IpEntry::Predict,
                    IpEntry::Gradient,
                    IpEntry::ReduceSum,
                    IpEntry::ReduceMax,
                    IpEntry::Newton,
                    IpEntry::Velocity,
                ],
                constants: &[],
                generated: None,
            },
        )?;
        let n = plan.particle_count();
        let reals = |values: &[f64]| {
            let mut b = Vec::new();
            push_reals(&mut b, values, precision);
            b
        };
        let make = |label: &str, bytes: &[u8]| ctx.storage(label, bytes);
        let zeros = |len: usize| vec![0u8; len * real_size(precision)];
        let (resident, barrier) = barrier_resources(&ctx, &plan, &ip, state, precision)?;
        let x_prev = make("x_prev", &zeros(n * dim))?;
        let prediction = make("prediction", &zeros(n * dim))?;
        let inverse_mass = make("inv_mass", &reals(&plan.inverse_mass))?;
        let gravity_scale = make("gravity_scale", &reals(&plan.gravity_scale))?;
        let terms = make("terms", &zeros(n))?;
        let status = make("status", bytemuck::cast_slice(&STATUS_RESET))?;
        let gravity = make("gravity", &reals(&plan.gravity))?;
        let probe = ctx.staging("probe", PROBE_BYTES)?;
        let group = kernels.bind(
            &ctx.device,
            0,
            &[
                &resident.x,
                &barrier[0],
                &barrier[1],
                &barrier[2],
                &barrier[3],
                &barrier[4],
                &barrier[5],
                &barrier[6],
                &barrier[7],
                &barrier[8],
                &status,
                &resident.v,
                &x_prev,
                &prediction,
                &inverse_mass,
                &gravity_scale,
                &resident.force,
                &terms,
                &gravity,
            ],
            0,
        )?;

        // Parameter blocks: base, then one per reduction stride.
        let criterion = match ip.convergence {
            Convergence::PackedGradient { .. } => 0u32,
            Convergence::MaxAccelerationResidual { .. } => 1,
        };
        let mut strides = vec![0u32];
        let mut s = 1usize;
        while s < n {
            strides.push(s as u32);
            s *= 2;
        }
        let mut blocks = ParamBlocks::new(&ctx.device);
        let offsets: Vec<u32> = strides
            .iter()
            .map(|&stride| {
                blocks.push(
                    &BlockWriter::new(precision)
                        .words(&[n as u32, stride, criterion, 0])
                        .reals(&[plan.h, ARMIJO, 0.0, 0.0])
                        .finish(),
                )
            })
            .collect();
        let block = blocks.block_size();
        let params = blocks.finish(&ctx, "ip params")?;
        let params_group = kernels.bind(&ctx.device, 1, &[&params], block)?;
        let backend = GpuBarrierBackend {
            plan,
            ip,
            precision,
            ctx,
            kernels,
            group,
            params_group,
            offsets,
            state: resident,
            terms,
            status,
            probe,
            _rest: barrier
                .into_iter()
                .chain([
                    x_prev,
                    prediction,
                    inverse_mass,
                    gravity_scale,
                    gravity,
                    params,
                ])
                .collect(),
            substep: 0,
            reports: Vec::new(),
            exporter: Exporter::default(),
        };
        backend.ctx.check()?;
        Ok(backend)
    }

    /// Times the host has waited for this backend's device since it was
    /// loaded (every `device.poll`: `GpuContext::poll`).
    pub fn host_waits(&self) -> u64 {
        self.ctx.host_waits()
    }

    /// Records `entry` over `invocations` with parameter block `block`.
    fn pass(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        entry: IpEntry,
        block: usize,
        invocations: u32,
    ) {
        let mut pass = encoder.begin_compute_pass(&Default::default());
        pass.set_bind_group(0, &self.group, &[]);
        pass.set_bind_group(1, &self.params_group, &[self.offsets[block]]);
        self.kernels.dispatch(&mut pass, entry, invocations);
    }

    fn run(&self, entry: IpEntry) -> Result<(), GpuError> {
        let n = self.plan.particle_count() as u32;
        let mut encoder = self.ctx.device.create_command_encoder(&Default::default());
        self.pass(&mut encoder, entry, 0, n);
        self.ctx.submit_and_wait(encoder)
    }

    /// Gradient pass, reduction, and the probe: (residual, status words),
    /// refused when some kernel's loops were cut short since the last reset.
    fn evaluate_residual(&self) -> Result<(f64, [u32; STATUS_WORDS]), GpuError> {
        let n = self.plan.particle_count() as u32;
        let mut encoder = self.ctx.device.create_command_encoder(&Default::default());
        self.pass(&mut encoder, IpEntry::Gradient, 0, n);
        let reduce = match self.ip.convergence {
            Convergence::PackedGradient { .. } => IpEntry::ReduceSum,
            Convergence::MaxAccelerationResidual { .. } => IpEntry::ReduceMax,
        };
        for level in 1..self.offsets.len() {
            let stride = 1u32 << (level - 1);
            let invocations = (n - stride).div_ceil(2 * stride);
            self.pass(&mut encoder, reduce, level, invocations);
        }
        let r = real_size(self.precision) as u64;
        encoder.copy_buffer_to_buffer(&self.terms, 0, &self.probe, 0, r);
        let bytes = self.read_status(encoder)?;
        let value = read_reals(&bytes[..r as usize], self.precision)[0];
        let words = status_words(&bytes[STATUS_AT as usize..]);
        let residual = match self.ip.convergence {
            Convergence::PackedGradient { .. } => value.sqrt(),
            Convergence::MaxAccelerationResidual { .. } => value,
        };
        Ok((residual, words))
    }

    /// Submits `encoder` with a copy of the status block into the probe,
    /// reads the probe back, and refuses it when some kernel's loops were
    /// cut short since the last reset.
    fn read_status(&self, mut encoder: wgpu::CommandEncoder) -> Result<Vec<u8>, GpuError> {
        let words = 4 * STATUS_WORDS as u64;
        encoder.copy_buffer_to_buffer(&self.status, 0, &self.probe, STATUS_AT, words);
        self.ctx.submit_and_wait(encoder)?;
        let bytes = self.ctx.read(&self.probe, PROBE_BYTES)?;
        refuse_cut_loops(&status_words(&bytes[STATUS_AT as usize..]))?;
        Ok(bytes)
    }

    fn reset_status(&self) {
        self.ctx
            .queue
            .write_buffer(&self.status, 0, bytemuck::cast_slice(&STATUS_RESET));
    }

    /// One minimisation on the resident state (CPU: `minimise`).
    fn minimise(&mut self) -> Result<MinimisationReport, BackendError> {
        let mut report = MinimisationReport::before_first_iteration(self.ip.convergence);
        self.reset_status();
        self.run(IpEntry::Predict)?;
        let mut iteration = 0;
        loop {
            let (residual, status) = self.evaluate_residual()?;
            if status[2] != NONE {
                if report.initial_residual.is_none() {
                    report.status = MinimisationStatus::Refused(self.infeasible(status[2])?);
                } else {
                    report.status = MinimisationStatus::Refused(Refusal::NonFinite {
                        particle: status[2] as usize,
                    });
                }
                report.initial_residual = None;
                report.final_residual = None;
                return Ok(report);
            }
            if status[1] != NONE {
                report.status = MinimisationStatus::Refused(Refusal::NonFinite {
                    particle: status[1] as usize,
                });
                return Ok(report);
            }
            if iteration > 0 && status[0] == 0 && status[3] == 0 {
                report.status = MinimisationStatus::RoundingFloor;
                break;
            }
            if iteration > 0 && status[0] == 0 {
                report.status = MinimisationStatus::Refused(Refusal::NoDescent {
                    residual: report.final_residual.unwrap_or(residual),
                });
                return Ok(report);
            }
            if report.record_residual(residual, iteration, self.ip.max_iterations) {
                break;
            }
            iteration += 1;
            report.iterations = iteration;
            self.reset_status();
            self.run(IpEntry::Newton)?;
        }
        let n = self.plan.particle_count() as u32;
        let mut encoder = self.ctx.device.create_command_encoder(&Default::default());
        self.pass(&mut encoder, IpEntry::Velocity, 0, n);
        self.read_status(encoder)?;
        Ok(report)
    }

    /// The refusal for an infeasible start of `particle`
    /// ([`infeasible_start`] on the device's positions).
    fn infeasible(&mut self, particle: u32) -> Result<Refusal, BackendError> {
        let state = self.read_state()?;
        Ok(infeasible_start(
            &self.plan,
            &self.ip.obstacles,
            state.position(particle as usize),
            particle as usize,
        ))
    }
}

minimising_backend!(GpuBarrierBackend);

resident_backend! {
    GpuBarrierBackend, load() {
        fn run_kernel(&mut self, kernel: Kernel) -> Result<(), BackendError> {
            self.minimise_kernel(kernel)
        }
    }
}

/// The refusal of an incremental-potential plan by the XPBD backend.
pub(crate) fn incremental_potential_unsupported() -> GpuError {
    GpuError::Unsupported {
        what: "the incremental_potential solver on GpuBackend (use GpuBarrierBackend)".into(),
    }
}
