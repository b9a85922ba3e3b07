//! `BarrierStep` ([`crate::GpuBarrierBackend`]): the whole
//! incremental-potential step on the GPU
//! (`shaders/incremental_potential.wgsl`), driven by the host per Newton
//! iteration exactly as cpu/src/incremental_potential.rs runs it.
//!
//! ```text
//! step:   save (x, v) on the device
//!         per substep:  ip_predict
//!                       chunks of { ip_gradient; tree reduction (one dispatch per
//!                              stride); ip_decide: refuse / stalled / converged /
//!                              budget exhausted → stop (on the device);
//!                              ip_newton (filter before every trial, Armijo) },
//!                       ip_velocity (only after a stop that keeps the iterate);
//!                       one read of the decision log per chunk (ip_decision.rs)
//!         on a refusal: restore (x, v) byte for byte, return the typed error
//! probe:  every kernel ends with barrier.wgsl's check_loops; the status
//!         block read with each chunk's log names the first particle whose
//!         loops llvmpipe cut short → the step is refused
//!         (GpuError::Unsupported, state restored), never kept
//! ```
//! The residual's sqrt (packed criterion) is taken on the host in f64, on
//! the logged values; the device compares them with the exact threshold.

use hyperpbd_core::IncrementalPotentialPlan;
use hyperpbd_core::{
    BackendError, Convergence, GpuError, MinimisationReport, MinimisationStatus, Refusal,
};

use crate::Precision;
use crate::barrier::{
    NONE, STATUS_WORDS, barrier_resources, infeasible_start, refuse_cut_loops, status_words,
};
use crate::ip_decision::{Decisions, HEADER_WORDS, LOGGED_WORDS, disagreement};
use crate::kernel_set::{BlockWriter, EntryPoint, KernelSet, KernelSetSpec, ParamBlocks};
use crate::minimising::{Minimiser, Minimising};
use crate::params::{push_reals, real_size};
use crate::resident_backend::{Load, Resident, ResidentBackend};
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
    Decide,
}

impl EntryPoint for IpEntry {
    fn source(self) -> (ShaderFile, &'static str) {
        let name = match self {
            IpEntry::Predict => "ip_predict",
            IpEntry::Gradient => "ip_gradient",
            IpEntry::ReduceSum => "ip_reduce_sum",
            IpEntry::ReduceMax => "ip_reduce_max",
            IpEntry::Newton => "ip_newton",
            IpEntry::Decide => "ip_decide",
            IpEntry::Velocity => "ip_velocity",
        };
        (ShaderFile::IncrementalPotential, name)
    }
}

/// The status block before a pass: nothing moved, no failing particle,
/// no stall, no loop cut short.
const STATUS_RESET: [u32; STATUS_WORDS] = [0, NONE, NONE, 0, NONE];
/// Where the decision words start in the chunk's read-back (after the
/// status words, 8-aligned); the logged values follow them, 8-aligned.
const DECISION_AT: u64 = (4 * STATUS_WORDS as u64).next_multiple_of(8);

/// ip_decide's words for `logged` evaluations.
fn decision_words(logged: usize) -> usize {
    HEADER_WORDS + LOGGED_WORDS * logged
}

/// Bytes of a chunk's read-back for `logged` evaluations.
fn decision_bytes(logged: usize, precision: Precision) -> u64 {
    DECISION_AT
        + (4 * decision_words(logged) as u64).next_multiple_of(8)
        + (logged * real_size(precision)) as u64
}

/// The GPU backend of the incremental-potential path.
pub type GpuBarrierBackend = ResidentBackend<Minimising<BarrierStep>>;

/// The incremental-potential step's kernels and buffers (the resident
/// state: x, v in the dense layout — the barrier kernels index
/// x[i·DIM + a] — saved copies, forces; positions relative to the scene
/// origin).
pub struct BarrierStep {
    ip: IncrementalPotentialPlan,
    kernels: KernelSet<IpEntry>,
    group: wgpu::BindGroup,
    params_group: wgpu::BindGroup,
    /// Dynamic offsets: [base, reduce level 0, level 1, …].
    offsets: Vec<u32>,
    status: wgpu::Buffer,
    /// ip_decide's words and logged values, and their read-back
    /// (ip_decision.rs).
    decision: wgpu::Buffer,
    decided: wgpu::Buffer,
    decision_probe: wgpu::Buffer,
    /// The first chunk's evaluations: the last substep's count.
    chunk: u32,
    /// Buffers only the kernels read or write.
    _rest: Vec<wgpu::Buffer>,
}

impl Minimiser for BarrierStep {
    fn load(load: Load<'_>) -> Result<(Resident, Self), BackendError> {
        let (device, plan, state, precision) = load.into_parts();
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
            &ctx,
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
                    IpEntry::Decide,
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
        let logged = ip.max_iterations as usize + 1;
        let decision = make("decision", &vec![0u8; 4 * decision_words(logged)])?;
        let decided = make("decided", &zeros(logged))?;
        let decision_probe = ctx.staging("decision probe", decision_bytes(logged, precision))?;
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
                &decision,
                &decided,
            ],
            0,
        )?;

        // Parameter blocks: base, then one per reduction stride.
        let criterion = match ip.convergence {
            Convergence::PackedGradient { .. } => 0u32,
            Convergence::MaxAccelerationResidual { .. } => 1,
        };
        let threshold = crate::ip_decision::threshold(ip.convergence, precision);
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
                        .words(&[n as u32, stride, criterion, ip.max_iterations])
                        .reals(&[plan.h, ARMIJO, threshold, 0.0])
                        .finish(),
                )
            })
            .collect();
        let block = blocks.block_size();
        let params = blocks.finish(&ctx, "ip params")?;
        let params_group = kernels.bind(&ctx.device, 1, &[&params], block)?;
        let step = BarrierStep {
            ip,
            kernels,
            group,
            params_group,
            offsets,
            status,
            decision,
            decided,
            decision_probe,
            chunk: 2,
            _rest: barrier
                .into_iter()
                .chain([
                    x_prev,
                    prediction,
                    inverse_mass,
                    gravity_scale,
                    gravity,
                    params,
                    terms,
                ])
                .collect(),
        };
        ctx.check()?;
        let on = Resident {
            plan,
            precision,
            ctx,
            state: resident,
        };
        Ok((on, step))
    }

    /// One minimisation on the resident state (CPU: `minimise`): the
    /// device decides when Newton stops (ip_decide), the host replays its
    /// loop over the device's log for the report.
    fn minimise(&mut self, on: &mut Resident) -> Result<MinimisationReport, BackendError> {
        let logged = self.ip.max_iterations as usize + 1;
        self.reset_status(on);
        let cleared = vec![0u8; 4 * decision_words(logged)];
        on.ctx.queue.write_buffer(&self.decision, 0, &cleared);
        self.run(on, IpEntry::Predict)?;
        let budget = logged as u32;
        let (mut recorded, mut k) = (0, self.chunk.max(2));
        let decisions = loop {
            let k_now = k.min(budget - recorded);
            let decisions = self.chunk(on, k_now)?;
            recorded += k_now;
            if decisions.stopped {
                break decisions;
            }
            if recorded >= budget {
                return Err(disagreement("no stop within max_iterations + 1 evaluations").into());
            }
            k = k.saturating_mul(2);
        };
        self.chunk = decisions.evaluations.len() as u32;
        self.replay(on, &decisions)
    }
}

impl BarrierStep {
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

    fn run(&self, on: &Resident, entry: IpEntry) -> Result<(), GpuError> {
        let n = on.plan.particle_count() as u32;
        let mut encoder = on.ctx.device.create_command_encoder(&Default::default());
        self.pass(&mut encoder, entry, 0, n);
        // No wait: the next submission runs after this one (queue order),
        // and the host needs nothing from it.
        on.ctx.submit(encoder).map(|_| ())
    }

    /// One chunk of `k` evaluations (module docs), ip_velocity after it,
    /// submitted with one read of the status words and the decision log;
    /// refused when some kernel's loops were cut short since the reset.
    fn chunk(&self, on: &Resident, k: u32) -> Result<Decisions, GpuError> {
        let n = on.plan.particle_count() as u32;
        let mut encoder = on.ctx.device.create_command_encoder(&Default::default());
        let reduce = match self.ip.convergence {
            Convergence::PackedGradient { .. } => IpEntry::ReduceSum,
            Convergence::MaxAccelerationResidual { .. } => IpEntry::ReduceMax,
        };
        for _ in 0..k {
            self.pass(&mut encoder, IpEntry::Gradient, 0, n);
            for level in 1..self.offsets.len() {
                let stride = 1u32 << (level - 1);
                let invocations = (n - stride).div_ceil(2 * stride);
                self.pass(&mut encoder, reduce, level, invocations);
            }
            self.pass(&mut encoder, IpEntry::Decide, 0, 1);
            self.pass(&mut encoder, IpEntry::Newton, 0, n);
        }
        self.pass(&mut encoder, IpEntry::Velocity, 0, n);
        let logged = self.ip.max_iterations as usize + 1;
        let words = 4 * decision_words(logged) as u64;
        let at = DECISION_AT + words.next_multiple_of(8);
        let status = 4 * STATUS_WORDS as u64;
        let probe = &self.decision_probe;
        encoder.copy_buffer_to_buffer(&self.status, 0, probe, 0, status);
        encoder.copy_buffer_to_buffer(&self.decision, 0, probe, DECISION_AT, words);
        let values = logged as u64 * real_size(on.precision) as u64;
        encoder.copy_buffer_to_buffer(&self.decided, 0, probe, at, values);
        let bytes = on.ctx.submit_and_read(encoder, probe, at + values)?;
        refuse_cut_loops(&status_words(&bytes))?;
        let words = &bytes[DECISION_AT as usize..(DECISION_AT + words) as usize];
        let values = &bytes[at as usize..(at + values) as usize];
        Ok(crate::ip_decision::parse(words, values, on.precision))
    }

    fn reset_status(&self, on: &Resident) {
        on.ctx
            .queue
            .write_buffer(&self.status, 0, bytemuck::cast_slice(&STATUS_RESET));
    }

    /// The host's loop over the device's evaluations (the branches of the
    /// host-decided loop, core's `record_residual`): the report, checked
    /// to stop exactly at the device's last evaluation with its code.
    fn replay(
        &mut self,
        on: &mut Resident,
        decisions: &Decisions,
    ) -> Result<MinimisationReport, BackendError> {
        let mut report = MinimisationReport::before_first_iteration(self.ip.convergence);
        let count = decisions.evaluations.len();
        let mut iteration = 0;
        for (j, e) in decisions.evaluations.iter().enumerate() {
            let (status, value) = (e.status, e.value);
            let residual = match self.ip.convergence {
                Convergence::PackedGradient { .. } => value.sqrt(),
                Convergence::MaxAccelerationResidual { .. } => value,
            };
            let code = if status[2] != NONE {
                if report.initial_residual.is_none() {
                    report.status = MinimisationStatus::Refused(self.infeasible(on, status[2])?);
                } else {
                    report.status = MinimisationStatus::Refused(Refusal::NonFinite {
                        particle: status[2] as usize,
                    });
                }
                report.initial_residual = None;
                report.final_residual = None;
                4
            } else if status[1] != NONE {
                report.status = MinimisationStatus::Refused(Refusal::NonFinite {
                    particle: status[1] as usize,
                });
                4
            } else if iteration > 0 && status[0] == 0 && status[3] == 0 {
                report.status = MinimisationStatus::RoundingFloor;
                3
            } else if iteration > 0 && status[0] == 0 {
                report.status = MinimisationStatus::Refused(Refusal::NoDescent {
                    residual: report.final_residual.unwrap_or(residual),
                });
                4
            } else if report.record_residual(residual, iteration, self.ip.max_iterations) {
                if matches!(report.status, MinimisationStatus::Converged) {
                    1
                } else {
                    2
                }
            } else {
                0
            };
            if code != 0 {
                let last = j + 1 == count;
                if !last || code != decisions.code {
                    return Err(disagreement(&format!(
                        "the host stops at evaluation {j} (code {code}), the device at {} (code {})",
                        count - 1,
                        decisions.code
                    ))
                    .into());
                }
                return Ok(report);
            }
            iteration += 1;
            report.iterations = iteration;
        }
        Err(disagreement(&format!(
            "the host does not stop within the device's {count} evaluations"
        ))
        .into())
    }

    /// The refusal for an infeasible start of `particle`
    /// ([`infeasible_start`] on the device's positions).
    fn infeasible(&self, on: &mut Resident, particle: u32) -> Result<Refusal, BackendError> {
        let state = on.state.read(&on.ctx)?;
        Ok(infeasible_start(
            &on.plan,
            &self.ip.obstacles,
            state.position(particle as usize),
            particle as usize,
        ))
    }
}

/// The refusal of an incremental-potential plan by the XPBD backend.
pub(crate) fn incremental_potential_unsupported() -> GpuError {
    GpuError::Unsupported {
        what: "the incremental_potential solver on GpuBackend (use GpuBarrierBackend)".into(),
    }
}
