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
//! ```
//! The residual's sqrt (packed criterion) is taken on the host in f64.

use std::sync::{Arc, Mutex};

use hyperpbd_core::barrier::{FILTER_SAFETY, IncrementalPotentialPlan};
use hyperpbd_core::{
    Backend, BackendError, Convergence, GpuError, Kernel, MinimisationReport, MinimisationStatus,
    Plan, Refusal, State, StepError, StepReport, check_forces, check_kernel, check_state,
};

use crate::backend::{create_buffer, groups_for};
use crate::barrier::{local_obstacles, obstacle_geometry};
use crate::params::{push_reals, read_reals, real_size};
use crate::shader::{MAX_GPU_DIM, ShaderFile, compose};
use crate::state_transfer::ResidentState;
use crate::{Precision, SceneOrigin};

const NONE: u32 = u32::MAX;
/// Armijo constant (same as the CPU's).
const ARMIJO: f64 = 1e-4;

/// Read-only flags of group-0 bindings 0..=18.
const READ_ONLY: [bool; 19] = [
    false, true, true, true, true, false, false, false, false, true, // barrier.wgsl
    false, false, false, true, true, true, false, false, true, // incremental_potential.wgsl
];

/// The GPU backend of the incremental-potential path.
pub struct GpuBarrierBackend {
    plan: Plan,
    ip: IncrementalPotentialPlan,
    precision: Precision,
    device: wgpu::Device,
    queue: wgpu::Queue,
    pipelines: IpPipelines,
    group: wgpu::BindGroup,
    params_group: wgpu::BindGroup,
    /// Dynamic offsets: [base, reduce level 0, level 1, …].
    offsets: Vec<u32>,
    buffers: IpBuffers,
    errors: Arc<Mutex<Vec<String>>>,
    substep: u32,
    reports: Vec<MinimisationReport>,
    summary: crate::AdapterSummary,
    /// Device positions are world positions − origin (f32 far from the
    /// world origin; see `gpu/src/origin.rs`).
    origin: SceneOrigin,
}

struct IpPipelines {
    predict: wgpu::ComputePipeline,
    gradient: wgpu::ComputePipeline,
    reduce_sum: wgpu::ComputePipeline,
    reduce_max: wgpu::ComputePipeline,
    newton: wgpu::ComputePipeline,
    velocity: wgpu::ComputePipeline,
}

struct IpBuffers {
    x: wgpu::Buffer,
    v: wgpu::Buffer,
    saved_x: wgpu::Buffer,
    saved_v: wgpu::Buffer,
    force: wgpu::Buffer,
    terms: wgpu::Buffer,
    status: wgpu::Buffer,
    /// terms[0] then the 4 status words.
    probe: wgpu::Buffer,
    state_staging: wgpu::Buffer,
    state_bytes: u64,
    _rest: Vec<wgpu::Buffer>,
}

impl GpuBarrierBackend {
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

    /// Loads an incremental-potential `plan` with `state` on a device of
    /// `adapter`.
    pub fn with_adapter(
        adapter: &wgpu::Adapter,
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
        let dim = plan.dim;
        if dim > MAX_GPU_DIM {
            return Err(GpuError::Unsupported {
                what: format!("dimension {dim} (the GPU kernels support 1..={MAX_GPU_DIM})"),
            }
            .into());
        }
        let summary = crate::AdapterSummary::of(adapter);
        let (device, queue) = crate::request_device(adapter, precision)?;
        let errors = crate::device_errors::collect_device_errors(&device);
        let limits = device.limits();
        if limits.max_storage_buffers_per_shader_stage < READ_ONLY.len() as u32 + 1 {
            return Err(GpuError::Unsupported {
                what: format!(
                    "the adapter allows {} storage buffers per shader stage; the barrier path needs {}",
                    limits.max_storage_buffers_per_shader_stage,
                    READ_ONLY.len() + 1
                ),
            }
            .into());
        }
        let entries: Vec<_> = READ_ONLY
            .iter()
            .enumerate()
            .map(|(i, &ro)| crate::pipelines::storage(i as u32, ro, false))
            .collect();
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("hyperpbd ip state"),
            entries: &entries,
        });
        let params_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("hyperpbd ip params"),
            entries: &[crate::pipelines::storage(0, true, true)],
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("hyperpbd ip"),
            bind_group_layouts: &[Some(&layout), Some(&params_layout)],
            immediate_size: 0,
        });
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("incremental_potential.wgsl"),
            source: wgpu::ShaderSource::Wgsl(
                compose(ShaderFile::IncrementalPotential, dim, precision).into(),
            ),
        });
        let pipeline = |name: &str| {
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(name),
                layout: Some(&pipeline_layout),
                module: &module,
                entry_point: Some(name),
                compilation_options: Default::default(),
                cache: None,
            })
        };
        let pipelines = IpPipelines {
            predict: pipeline("ip_predict"),
            gradient: pipeline("ip_gradient"),
            reduce_sum: pipeline("ip_reduce_sum"),
            reduce_max: pipeline("ip_reduce_max"),
            newton: pipeline("ip_newton"),
            velocity: pipeline("ip_velocity"),
        };

        let n = plan.particle_count();
        let reals = |values: &[f64]| {
            let mut b = Vec::new();
            push_reals(&mut b, values, precision);
            b
        };
        let storage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC;
        let make = |label: &str, bytes: &[u8]| {
            create_buffer(&device, &queue, &limits, label, bytes, storage)
        };
        let zeros = |len: usize| vec![0u8; len * real_size(precision)];
        let origin = SceneOrigin::for_state(dim, &state.positions, precision);
        let local_positions = origin.to_local(&state.positions);
        let obstacles = local_obstacles(&ip.obstacles, &origin);
        let x = make("x", &reals(&local_positions))?;
        let radius = make("radius", &reals(&plan.radius))?;
        let (geometry_reals, arity) = obstacle_geometry(&obstacles);
        let geometry = make("geometry", &reals(&geometry_reals))?;
        let arity = make("arity", bytemuck::cast_slice(&arity))?;
        let delta = make("delta", &zeros(1))?;
        let energy = make("energy", &zeros(1))?;
        let gradient = make("gradient", &zeros(n * dim))?;
        let hessian = make("hessian", &zeros(n * dim * dim))?;
        let scalar = make("scalar", &zeros(1))?;
        let mut barrier_params = Vec::new();
        for word in [
            n as u32,
            obstacles.plane_count() as u32,
            obstacles.simplex_count() as u32,
            0,
        ] {
            barrier_params.extend_from_slice(&word.to_le_bytes());
        }
        push_reals(
            &mut barrier_params,
            &[
                ip.law.stiffness,
                ip.law.activation_distance,
                FILTER_SAFETY,
                obstacles.scale,
            ],
            precision,
        );
        let barrier_params = make("barrier params", &barrier_params)?;
        let v = make("v", &reals(&state.velocities))?;
        let x_prev = make("x_prev", &zeros(n * dim))?;
        let prediction = make("prediction", &zeros(n * dim))?;
        let inverse_mass = make("inv_mass", &reals(&plan.inverse_mass))?;
        let gravity_scale = make("gravity_scale", &reals(&plan.gravity_scale))?;
        let force = make("force", &reals(&plan.force))?;
        let terms = make("terms", &zeros(n))?;
        let status = make("status", bytemuck::cast_slice(&[0u32, NONE, NONE, 0]))?;
        let gravity = make("gravity", &reals(&plan.gravity))?;
        let saved_x = make("saved_x", &reals(&local_positions))?;
        let saved_v = make("saved_v", &reals(&state.velocities))?;
        let r = real_size(precision) as u64;
        let state_bytes = (n * dim) as u64 * r;
        let read_usage = wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST;
        let probe = create_buffer(&device, &queue, &limits, "probe", &[0u8; 32], read_usage)?;
        let state_staging = create_buffer(
            &device,
            &queue,
            &limits,
            "state staging",
            &vec![0u8; 2 * state_bytes as usize],
            read_usage,
        )?;
        let group_buffers = [
            &x,
            &radius,
            &geometry,
            &arity,
            &delta,
            &energy,
            &gradient,
            &hessian,
            &scalar,
            &barrier_params,
            &v,
            &x_prev,
            &prediction,
            &inverse_mass,
            &gravity_scale,
            &force,
            &terms,
            &status,
            &gravity,
        ];
        let entries: Vec<_> = group_buffers
            .iter()
            .enumerate()
            .map(|(i, b)| wgpu::BindGroupEntry {
                binding: i as u32,
                resource: b.as_entire_binding(),
            })
            .collect();
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("hyperpbd ip state"),
            layout: &layout,
            entries: &entries,
        });

        // Parameter blocks: base, then one per reduction stride.
        let criterion = match ip.convergence {
            Convergence::PackedGradient { .. } => 0u32,
            Convergence::MaxAccelerationResidual { .. } => 1,
        };
        let align = limits.min_storage_buffer_offset_alignment as usize;
        let block = 16 + 4 * real_size(precision);
        let stride_bytes = block.div_ceil(align) * align;
        let mut strides = vec![0u32];
        let mut s = 1usize;
        while s < n {
            strides.push(s as u32);
            s *= 2;
        }
        let mut blocks = Vec::new();
        let mut offsets = Vec::new();
        for &stride in &strides {
            blocks.resize(offsets.len() * stride_bytes, 0);
            offsets.push(blocks.len() as u32);
            for word in [n as u32, stride, criterion, 0] {
                blocks.extend_from_slice(&word.to_le_bytes());
            }
            push_reals(&mut blocks, &[plan.h, ARMIJO, 0.0, 0.0], precision);
        }
        blocks.resize(offsets.len() * stride_bytes, 0);
        let params = create_buffer(
            &device,
            &queue,
            &limits,
            "ip params",
            &blocks,
            wgpu::BufferUsages::STORAGE,
        )?;
        let params_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("hyperpbd ip params"),
            layout: &params_layout,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                    buffer: &params,
                    offset: 0,
                    size: wgpu::BufferSize::new(block as u64),
                }),
            }],
        });
        let backend = GpuBarrierBackend {
            plan,
            ip,
            precision,
            device,
            queue,
            pipelines,
            group,
            params_group,
            offsets,
            buffers: IpBuffers {
                x,
                v,
                saved_x,
                saved_v,
                force,
                terms,
                status,
                probe,
                state_staging,
                state_bytes,
                _rest: vec![
                    radius,
                    geometry,
                    arity,
                    delta,
                    energy,
                    gradient,
                    hessian,
                    scalar,
                    barrier_params,
                    x_prev,
                    prediction,
                    inverse_mass,
                    gravity_scale,
                    gravity,
                    params,
                ],
            },
            errors,
            substep: 0,
            reports: Vec::new(),
            summary,
            origin,
        };
        backend.check()?;
        Ok(backend)
    }

    /// Finds an adapter for `precision` and loads `plan` with `state`.
    pub fn new(plan: Plan, state: &State, precision: Precision) -> Result<Self, BackendError> {
        let (adapter, _) = crate::request_adapter(precision)?;
        Self::with_adapter(&adapter, plan, state, precision)
    }

    /// The adapter this backend runs on.
    pub fn adapter(&self) -> &crate::AdapterSummary {
        &self.summary
    }

    fn check(&self) -> Result<(), GpuError> {
        crate::device_errors::take_device_errors(&self.errors)
    }

    fn pass(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        pipeline: &wgpu::ComputePipeline,
        block: usize,
        invocations: u32,
    ) {
        let (gx, gy) = groups_for(invocations);
        let mut pass = encoder.begin_compute_pass(&Default::default());
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, &self.group, &[]);
        pass.set_bind_group(1, &self.params_group, &[self.offsets[block]]);
        pass.dispatch_workgroups(gx, gy, 1);
    }

    fn submit(&self, encoder: wgpu::CommandEncoder) -> Result<(), GpuError> {
        crate::device_errors::submit_and_wait(&self.device, &self.queue, encoder, &self.errors)
    }

    fn read(&self, buffer: &wgpu::Buffer, len: u64) -> Result<Vec<u8>, GpuError> {
        crate::readback::read_mapped(&self.device, buffer, len)
    }

    /// Gradient pass, reduction, and the probe: (residual, status words).
    fn evaluate_residual(&self) -> Result<(f64, [u32; 4]), GpuError> {
        let n = self.plan.particle_count() as u32;
        let mut encoder = self.device.create_command_encoder(&Default::default());
        self.pass(&mut encoder, &self.pipelines.gradient, 0, n);
        let reduce = match self.ip.convergence {
            Convergence::PackedGradient { .. } => &self.pipelines.reduce_sum,
            Convergence::MaxAccelerationResidual { .. } => &self.pipelines.reduce_max,
        };
        for level in 1..self.offsets.len() {
            let stride = 1u32 << (level - 1);
            let invocations = (n - stride).div_ceil(2 * stride);
            self.pass(&mut encoder, reduce, level, invocations);
        }
        let r = real_size(self.precision) as u64;
        encoder.copy_buffer_to_buffer(&self.buffers.terms, 0, &self.buffers.probe, 0, r);
        encoder.copy_buffer_to_buffer(&self.buffers.status, 0, &self.buffers.probe, 16, 16);
        self.submit(encoder)?;
        let bytes = self.read(&self.buffers.probe, 32)?;
        let value = read_reals(&bytes[..r as usize], self.precision)[0];
        let mut words = [0u32; 4];
        for (k, w) in words.iter_mut().enumerate() {
            let at = 16 + 4 * k;
            *w = u32::from_le_bytes([bytes[at], bytes[at + 1], bytes[at + 2], bytes[at + 3]]);
        }
        let residual = match self.ip.convergence {
            Convergence::PackedGradient { .. } => value.sqrt(),
            Convergence::MaxAccelerationResidual { .. } => value,
        };
        Ok((residual, words))
    }

    fn reset_status(&self) {
        self.queue.write_buffer(
            &self.buffers.status,
            0,
            bytemuck::cast_slice(&[0u32, NONE, NONE, 0]),
        );
    }

    /// One minimisation on the resident state (CPU: `minimise`).
    fn minimise(&mut self) -> Result<MinimisationReport, BackendError> {
        let n = self.plan.particle_count() as u32;
        let mut report = MinimisationReport {
            criterion: self.ip.convergence,
            initial_residual: None,
            final_residual: None,
            iterations: 0,
            status: MinimisationStatus::Converged,
        };
        self.reset_status();
        let mut encoder = self.device.create_command_encoder(&Default::default());
        self.pass(&mut encoder, &self.pipelines.predict, 0, n);
        self.submit(encoder)?;
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
            if report.initial_residual.is_none() {
                report.initial_residual = Some(residual);
            }
            report.final_residual = Some(residual);
            report.iterations = iteration;
            if residual <= self.ip.convergence.tolerance() {
                report.status = MinimisationStatus::Converged;
                break;
            }
            if iteration == self.ip.max_iterations {
                report.status = MinimisationStatus::BudgetExhausted;
                break;
            }
            iteration += 1;
            report.iterations = iteration;
            self.reset_status();
            let mut encoder = self.device.create_command_encoder(&Default::default());
            self.pass(&mut encoder, &self.pipelines.newton, 0, n);
            self.submit(encoder)?;
        }
        let mut encoder = self.device.create_command_encoder(&Default::default());
        self.pass(&mut encoder, &self.pipelines.velocity, 0, n);
        self.submit(encoder)?;
        Ok(report)
    }

    /// The refusal for an infeasible start of `particle`, with the obstacle
    /// and distance computed by the golden path on the device's positions.
    fn infeasible(&mut self, particle: u32) -> Result<Refusal, BackendError> {
        let state = self.read_state()?;
        let i = particle as usize;
        let mut normal = vec![0.0; self.plan.dim];
        let obstacles = &self.ip.obstacles;
        for o in 0..obstacles.len() {
            let distance =
                obstacles.distance(o, state.position(i), self.plan.radius[i], &mut normal);
            if distance.is_nan() || distance <= 0.0 {
                return Ok(Refusal::InfeasibleStart {
                    particle: i,
                    obstacle: obstacles.source(o) as usize,
                    distance,
                });
            }
        }
        // Feasible in f64 but not as the kernel computes it (the f32
        // floor): name the nearest obstacle and its f64 distance, both
        // measured, rather than an invented 0.
        let mut nearest = (0, f64::INFINITY);
        for o in 0..obstacles.len() {
            let distance =
                obstacles.distance(o, state.position(i), self.plan.radius[i], &mut normal);
            if distance < nearest.1 {
                nearest = (o, distance);
            }
        }
        Ok(Refusal::InfeasibleStart {
            particle: i,
            obstacle: obstacles.source(nearest.0) as usize,
            distance: nearest.1,
        })
    }

    fn run_minimise(&mut self) -> Result<(), BackendError> {
        let report = self.minimise()?;
        let refused = StepError::refused(self.substep, &report);
        self.reports.push(report);
        refused.map_or(Ok(()), |e| Err(e.into()))
    }

    fn rollback(&self) -> Result<(), GpuError> {
        let bytes = self.buffers.state_bytes;
        if bytes == 0 {
            return Ok(());
        }
        let mut encoder = self.device.create_command_encoder(&Default::default());
        encoder.copy_buffer_to_buffer(&self.buffers.saved_x, 0, &self.buffers.x, 0, bytes);
        encoder.copy_buffer_to_buffer(&self.buffers.saved_v, 0, &self.buffers.v, 0, bytes);
        self.submit(encoder)
    }
}

impl Backend for GpuBarrierBackend {
    fn name(&self) -> String {
        format!("gpu-{}", self.precision)
    }

    fn plan(&self) -> &Plan {
        &self.plan
    }

    fn step(&mut self) -> Result<StepReport, BackendError> {
        let bytes = self.buffers.state_bytes;
        if bytes > 0 {
            let mut encoder = self.device.create_command_encoder(&Default::default());
            encoder.copy_buffer_to_buffer(&self.buffers.x, 0, &self.buffers.saved_x, 0, bytes);
            encoder.copy_buffer_to_buffer(&self.buffers.v, 0, &self.buffers.saved_v, 0, bytes);
            self.submit(encoder)?;
        }
        self.reports.clear();
        for substep in 0..self.plan.substeps {
            self.substep = substep;
            for k in 0..self.plan.substep_kernels.len() {
                if self.plan.substep_kernels[k] != Kernel::Minimise {
                    continue;
                }
                if let Err(e) = self.run_minimise() {
                    return Err(e.after_rollback(self.rollback()));
                }
            }
        }
        Ok(StepReport {
            kernel_calls: self.plan.kernel_counts(),
            minimisation: std::mem::take(&mut self.reports),
            ..StepReport::default()
        })
    }

    fn read_state(&mut self) -> Result<State, BackendError> {
        Ok(self
            .resident_state()
            .read(&self.device, self.plan.dim, |e| self.submit(e))?)
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
        self.run_minimise()
    }
}
