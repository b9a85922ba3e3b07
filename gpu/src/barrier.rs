//! Kernel-level entry points of the barrier path on the GPU
//! (`shaders/barrier.wgsl`): per-particle barrier evaluation (energy,
//! gradient, PSD-projected Hessian block, smallest distance) and the
//! certified step-filter fraction, one invocation per particle looping over
//! every obstacle; plus the f64 `ln` helper's own check.
//!
//! ```text
//! BarrierKernels::new(adapter, precision, dim, law, obstacles)   pipelines + obstacle upload
//! evaluate(positions, radii)            -> BarrierEvaluation      (one dispatch)
//! filter_fractions(positions, radii, Δ) -> fraction per particle  (one dispatch)
//! ```
//! Obstacle geometry is laid out for the device in one place,
//! [`obstacle_geometry`], after [`local_obstacles`] has moved it into the
//! device coordinates x − o of a [`SceneOrigin`] (f32 far from the world
//! origin: plane offsets shift by n·o, simplex vertices by −o).

use std::sync::{Arc, Mutex};

use hyperpbd_core::GpuError;
use hyperpbd_core::barrier::{BarrierLaw, BarrierObstacles, FILTER_SAFETY};

use crate::backend::{create_buffer, groups_for};
use crate::params::{push_reals, read_reals, real_size};
use crate::shader::{MAX_GPU_DIM, ShaderFile, compose};
use crate::{Precision, SceneOrigin};

/// Per-particle barrier terms read back from the device.
#[derive(Debug, Clone, PartialEq)]
pub struct BarrierEvaluation {
    /// Σ b per particle (f64::INFINITY where some d ≤ 0).
    pub energy: Vec<f64>,
    /// Σ b' ∇d, `particles × dim`.
    pub gradient: Vec<f64>,
    /// Σ b'' n nᵀ, `particles × dim × dim`.
    pub hessian: Vec<f64>,
    /// Smallest d per particle.
    pub min_distance: Vec<f64>,
}

/// `obstacles` in device coordinates x − o (see [`SceneOrigin`]): plane
/// offsets r − n·o, simplex vertices v − o, and the rounding scale
/// recomputed from the shifted geometry. The identity when o = 0.
pub fn local_obstacles(obstacles: &BarrierObstacles, origin: &SceneOrigin) -> BarrierObstacles {
    if origin.is_zero() {
        return obstacles.clone();
    }
    let dim = origin.as_slice().len();
    let mut local = obstacles.clone();
    let mut scale: f64 = 0.0;
    for (offset, normal) in local
        .plane_offsets
        .iter_mut()
        .zip(obstacles.plane_normals.chunks_exact(dim))
    {
        *offset = origin.local_offset(normal, *offset);
        scale = scale.max(offset.abs());
    }
    let slots = hyperpbd_core::barrier::SIMPLEX_SLOTS;
    for (s, &arity) in obstacles.simplex_arity.iter().enumerate() {
        let used = s * slots * dim..(s * slots + arity as usize) * dim;
        let shifted = origin.to_local(&obstacles.simplex_vertices[used.clone()]);
        scale = shifted.iter().fold(scale, |m, c| m.max(c.abs()));
        local.simplex_vertices[used].copy_from_slice(&shifted);
    }
    local.scale = scale;
    local
}

/// The obstacle geometry as the kernels read it: reals
/// `[plane normals | plane offsets | simplex vertices (4 slots each)]` and
/// the arity of each simplex (at least one word, so the buffer is never
/// empty).
pub fn obstacle_geometry(obstacles: &BarrierObstacles) -> (Vec<f64>, Vec<u32>) {
    let mut reals = obstacles.plane_normals.clone();
    reals.extend(&obstacles.plane_offsets);
    reals.extend(&obstacles.simplex_vertices);
    let mut arity = obstacles.simplex_arity.clone();
    if arity.is_empty() {
        arity.push(0);
    }
    (reals, arity)
}

#[derive(Clone, Copy)]
enum BarrierEntry {
    Evaluate,
    Filter,
    Ln,
}

/// Pipelines and resident obstacle data of the barrier kernels.
pub struct BarrierKernels {
    device: wgpu::Device,
    queue: wgpu::Queue,
    precision: Precision,
    dim: usize,
    layout: wgpu::BindGroupLayout,
    evaluate: wgpu::ComputePipeline,
    filter: wgpu::ComputePipeline,
    ln: wgpu::ComputePipeline,
    geometry: wgpu::Buffer,
    arity: wgpu::Buffer,
    planes: u32,
    simplices: u32,
    law: BarrierLaw,
    scale: f64,
    errors: Arc<Mutex<Vec<String>>>,
}

/// Read-only flags of the bindings 0..=9 of barrier.wgsl.
const READ_ONLY: [bool; 10] = [
    false, true, true, true, true, false, false, false, false, true,
];

impl BarrierKernels {
    /// Creates a device on `adapter`, builds the pipelines for `dim` and
    /// `precision`, and uploads the obstacles.
    pub fn new(
        adapter: &wgpu::Adapter,
        precision: Precision,
        dim: usize,
        law: BarrierLaw,
        obstacles: &BarrierObstacles,
    ) -> Result<Self, GpuError> {
        if dim == 0 || dim > MAX_GPU_DIM {
            return Err(GpuError::Unsupported {
                what: format!("dimension {dim} (the GPU kernels support 1..={MAX_GPU_DIM})"),
            });
        }
        let (device, queue) = crate::request_device(adapter, precision)?;
        let errors = crate::device_errors::collect_device_errors(&device);
        let limits = device.limits();
        if limits.max_storage_buffers_per_shader_stage < READ_ONLY.len() as u32 {
            return Err(GpuError::Unsupported {
                what: format!(
                    "the adapter allows {} storage buffers per shader stage; the barrier kernels need {}",
                    limits.max_storage_buffers_per_shader_stage,
                    READ_ONLY.len()
                ),
            });
        }
        let entries: Vec<_> = READ_ONLY
            .iter()
            .enumerate()
            .map(|(i, &ro)| crate::pipelines::storage(i as u32, ro, false))
            .collect();
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("hyperpbd barrier"),
            entries: &entries,
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("hyperpbd barrier"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("barrier.wgsl"),
            source: wgpu::ShaderSource::Wgsl(compose(ShaderFile::Barrier, dim, precision).into()),
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
        let evaluate = pipeline("evaluate");
        let filter = pipeline("filter_fraction");
        let ln = pipeline("ln_check");
        let (reals, arity) = obstacle_geometry(obstacles);
        let mut bytes = Vec::new();
        push_reals(&mut bytes, &reals, precision);
        let storage = wgpu::BufferUsages::STORAGE;
        let geometry = create_buffer(&device, &queue, &limits, "geometry", &bytes, storage)?;
        let arity = create_buffer(
            &device,
            &queue,
            &limits,
            "arity",
            bytemuck::cast_slice(&arity),
            storage,
        )?;
        let kernels = BarrierKernels {
            device,
            queue,
            precision,
            dim,
            layout,
            evaluate,
            filter,
            ln,
            geometry,
            arity,
            planes: obstacles.plane_count() as u32,
            simplices: obstacles.simplex_count() as u32,
            law,
            scale: obstacles.scale,
            errors,
        };
        kernels.check()?;
        Ok(kernels)
    }

    fn check(&self) -> Result<(), GpuError> {
        crate::device_errors::take_device_errors(&self.errors)
    }

    /// Barrier energy, gradient, Hessian block and smallest distance of
    /// every particle (`positions` flat, `radii` one per particle).
    pub fn evaluate(
        &self,
        positions: &[f64],
        radii: &[f64],
    ) -> Result<BarrierEvaluation, GpuError> {
        let n = radii.len();
        let out = self.run(BarrierEntry::Evaluate, positions, radii, &[], n)?;
        let infinite = |e: f64| {
            let max = match self.precision {
                Precision::F32 => f64::from(f32::MAX),
                Precision::F64 => f64::MAX,
            };
            if e >= max { f64::INFINITY } else { e }
        };
        Ok(BarrierEvaluation {
            energy: out[0].iter().map(|&e| infinite(e)).collect(),
            gradient: out[1].clone(),
            hessian: out[2].clone(),
            min_distance: out[3].clone(),
        })
    }

    /// Certified admissible fraction of the step `deltas` (flat) of every
    /// particle.
    pub fn filter_fractions(
        &self,
        positions: &[f64],
        radii: &[f64],
        deltas: &[f64],
    ) -> Result<Vec<f64>, GpuError> {
        let n = radii.len();
        let mut out = self.run(BarrierEntry::Filter, positions, radii, deltas, n)?;
        Ok(std::mem::take(&mut out[3]))
    }

    /// `ln` of every value as the kernels compute it (the built-in log in
    /// f32; the arithmetic-only ln of `ln_f64.wgsl` in f64).
    pub fn ln(&self, values: &[f64]) -> Result<Vec<f64>, GpuError> {
        let mut out = self.run(BarrierEntry::Ln, &[], &[], values, values.len())?;
        Ok(std::mem::take(&mut out[3]))
    }

    /// Uploads inputs, dispatches `which` over `count` invocations, reads
    /// back [energy, gradient, hessian, scalar].
    fn run(
        &self,
        which: BarrierEntry,
        positions: &[f64],
        radii: &[f64],
        deltas: &[f64],
        count: usize,
    ) -> Result<[Vec<f64>; 4], GpuError> {
        if count == 0 {
            return Ok([Vec::new(), Vec::new(), Vec::new(), Vec::new()]);
        }
        let prepared = self.prepare(positions, radii, deltas, count)?;
        self.dispatch(&prepared, which, 1)?;
        self.read(&prepared)
    }

    /// Inputs and outputs of one batch on the device (for benchmarks that
    /// time the dispatch alone).
    pub fn prepare(
        &self,
        positions: &[f64],
        radii: &[f64],
        deltas: &[f64],
        count: usize,
    ) -> Result<PreparedBatch, GpuError> {
        let dim = self.dim;
        let limits = self.device.limits();
        let storage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC;
        let reals = |values: &[f64]| {
            let mut b = Vec::new();
            push_reals(&mut b, values, self.precision);
            b
        };
        let zeros = |len: usize| vec![0u8; len * real_size(self.precision)];
        let make = |label: &str, bytes: &[u8]| {
            create_buffer(&self.device, &self.queue, &limits, label, bytes, storage)
        };
        let x = make("x", &reals(positions))?;
        let radius = make("radius", &reals(radii))?;
        let delta = make("delta", &reals(deltas))?;
        let energy = make("energy", &zeros(count))?;
        let gradient = make("gradient", &zeros(count * dim))?;
        let hessian = make("hessian", &zeros(count * dim * dim))?;
        let scalar = make("scalar", &zeros(count))?;
        let mut params = Vec::new();
        params.extend_from_slice(&(count as u32).to_le_bytes());
        params.extend_from_slice(&self.planes.to_le_bytes());
        params.extend_from_slice(&self.simplices.to_le_bytes());
        params.extend_from_slice(&0u32.to_le_bytes());
        push_reals(
            &mut params,
            &[
                self.law.stiffness,
                self.law.activation_distance,
                FILTER_SAFETY,
                self.scale,
            ],
            self.precision,
        );
        let params = make("barrier params", &params)?;
        let buffers = [
            &x,
            &radius,
            &self.geometry,
            &self.arity,
            &delta,
            &energy,
            &gradient,
            &hessian,
            &scalar,
            &params,
        ];
        let entries: Vec<_> = buffers
            .iter()
            .enumerate()
            .map(|(i, b)| wgpu::BindGroupEntry {
                binding: i as u32,
                resource: b.as_entire_binding(),
            })
            .collect();
        let group = self.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("hyperpbd barrier"),
            layout: &self.layout,
            entries: &entries,
        });
        let r = real_size(self.precision) as u64;
        let sizes = [
            count as u64 * r,
            (count * dim) as u64 * r,
            (count * dim * dim) as u64 * r,
            count as u64 * r,
        ];
        let staging = create_buffer(
            &self.device,
            &self.queue,
            &limits,
            "barrier staging",
            &vec![0u8; sizes.iter().sum::<u64>() as usize],
            wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        )?;
        self.check()?;
        Ok(PreparedBatch {
            count: count as u32,
            group,
            outputs: [energy, gradient, hessian, scalar],
            sizes,
            staging,
            _inputs: [x, radius, delta, params],
        })
    }

    /// Dispatches the evaluation kernel `repeats` times on a prepared batch
    /// and waits (benchmarks).
    pub fn dispatch_evaluate(&self, batch: &PreparedBatch, repeats: u32) -> Result<(), GpuError> {
        self.dispatch(batch, BarrierEntry::Evaluate, repeats)
    }

    fn dispatch(
        &self,
        batch: &PreparedBatch,
        which: BarrierEntry,
        repeats: u32,
    ) -> Result<(), GpuError> {
        let pipeline = match which {
            BarrierEntry::Evaluate => &self.evaluate,
            BarrierEntry::Filter => &self.filter,
            BarrierEntry::Ln => &self.ln,
        };
        let (gx, gy) = groups_for(batch.count);
        let mut encoder = self.device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, &batch.group, &[]);
            for _ in 0..repeats {
                pass.dispatch_workgroups(gx, gy, 1);
            }
        }
        crate::device_errors::submit_and_wait(&self.device, &self.queue, encoder, &self.errors)
    }

    /// Reads back [energy, gradient, hessian, scalar] of a batch.
    pub fn read(&self, batch: &PreparedBatch) -> Result<[Vec<f64>; 4], GpuError> {
        let mut encoder = self.device.create_command_encoder(&Default::default());
        let mut offset = 0;
        for (buffer, &size) in batch.outputs.iter().zip(&batch.sizes) {
            if size > 0 {
                encoder.copy_buffer_to_buffer(buffer, 0, &batch.staging, offset, size);
            }
            offset += size;
        }
        self.queue.submit(Some(encoder.finish()));
        let total = offset;
        let bytes = crate::readback::read_mapped(&self.device, &batch.staging, total)?;
        self.check()?;
        let mut out: [Vec<f64>; 4] = Default::default();
        let mut start = 0usize;
        for (k, &size) in batch.sizes.iter().enumerate() {
            out[k] = read_reals(&bytes[start..start + size as usize], self.precision);
            start += size as usize;
        }
        Ok(out)
    }
}

/// Device buffers of one batch of particles.
pub struct PreparedBatch {
    count: u32,
    group: wgpu::BindGroup,
    outputs: [wgpu::Buffer; 4],
    sizes: [u64; 4],
    staging: wgpu::Buffer,
    _inputs: [wgpu::Buffer; 4],
}
