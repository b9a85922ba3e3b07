//! `GpuCollide`: the particle–particle contact iteration
//! (`shaders/collide.wgsl`) as a kernel-level entry point.
//!
//! ```text
//! upload x, p, (w, r) per particle, the pair lists (pairs, offsets, entries)
//! iterations × { collide_pairs (per pair) ; collide_gather (per particle) }
//! read x back
//! ```
//! The same averaged gather-Jacobi iteration as `hyperpbd_cpu::collide`,
//! operation for operation, so it is held to the CPU golden path by a
//! differential test. It is not yet wired into [`crate::GpuBackend`]'s step
//! (that backend refuses plans with collisions).

use std::sync::{Arc, Mutex};

use hyperpbd_core::GpuError;
use hyperpbd_core::broadphase::Pair;

use crate::Precision;
use crate::layout::VectorLayout;
use crate::params::{push_reals, read_reals, real_size};
use crate::shader::{ShaderFile, compose};

const WORKGROUP: u32 = 64;
const MAX_GROUPS_X: u32 = 65_535;

/// Inputs of one contact solve.
pub struct CollideInput<'a> {
    /// Positions (the iterate), flat.
    pub x: &'a [f64],
    /// Positions at the substep start, flat.
    pub p: &'a [f64],
    /// Inverse mass per particle.
    pub inverse_mass: &'a [f64],
    /// Radius per particle.
    pub radius: &'a [f64],
    /// Candidate pairs, canonical order.
    pub pairs: &'a [Pair],
    /// Per-particle list offsets (particles + 1).
    pub offsets: &'a [u32],
    /// List entries 2 e + side.
    pub entries: &'a [u32],
    /// Coulomb μ between particles.
    pub friction: f64,
}

/// The per-particle data and lists of one broadphase (resident mode).
#[derive(Clone, Copy)]
pub(crate) struct ContactLists<'a> {
    pub(crate) inverse_mass: &'a [f64],
    pub(crate) radius: &'a [f64],
    pub(crate) pairs: &'a [Pair],
    pub(crate) offsets: &'a [u32],
    pub(crate) entries: &'a [u32],
    pub(crate) friction: f64,
}

/// Buffers and bind group of one substep's contact lists, bound to a
/// backend's resident positions.
pub(crate) struct Resident {
    group: wgpu::BindGroup,
    /// Corrections and active flags, `pairs × (dim + 1)` reals.
    pub(crate) corr: wgpu::Buffer,
    pub(crate) corr_bytes: u64,
    pairs: usize,
    particles: usize,
}

/// The contact kernels for one dimension and precision.
pub struct GpuCollide {
    device: wgpu::Device,
    queue: wgpu::Queue,
    precision: Precision,
    dim: usize,
    layout: wgpu::BindGroupLayout,
    pairs_pipeline: wgpu::ComputePipeline,
    gather_pipeline: wgpu::ComputePipeline,
    errors: Arc<Mutex<Vec<String>>>,
}

fn groups(invocations: usize) -> (u32, u32) {
    let g = (invocations as u32).div_ceil(WORKGROUP).max(1);
    let x = g.min(MAX_GROUPS_X);
    (x, g.div_ceil(x))
}

impl GpuCollide {
    /// Builds the kernels on a new device of `adapter`.
    pub fn with_adapter(
        adapter: &wgpu::Adapter,
        dim: usize,
        precision: Precision,
    ) -> Result<Self, GpuError> {
        if dim == 0 || dim > crate::shader::MAX_GPU_DIM {
            return Err(GpuError::Unsupported {
                what: format!(
                    "contact dimension {dim} (the GPU kernels support 1..={})",
                    crate::shader::MAX_GPU_DIM
                ),
            });
        }
        let (device, queue) = crate::request_device(adapter, precision)?;
        let errors = crate::device_errors::collect_device_errors(&device);
        Self::with_device(device, queue, errors, dim, precision)
    }

    /// As [`GpuCollide::with_adapter`] on an existing device.
    pub(crate) fn with_device(
        device: wgpu::Device,
        queue: wgpu::Queue,
        errors: Arc<Mutex<Vec<String>>>,
        dim: usize,
        precision: Precision,
    ) -> Result<Self, GpuError> {
        // x v p force (particle records, prelude.wgsl), then cparams props
        // lists corr.
        let read_only = [false, false, false, true, true, true, true, false];
        let entries: Vec<_> = read_only
            .iter()
            .enumerate()
            .map(|(b, &ro)| crate::kernel_set::storage(b as u32, ro, false))
            .collect();
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("hyperpbd collide"),
            entries: &entries,
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("hyperpbd collide"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let source = compose(ShaderFile::Collide, dim, precision);
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("collide.wgsl"),
            source: wgpu::ShaderSource::Wgsl(source.into()),
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
        let pairs_pipeline = pipeline("collide_pairs");
        let gather_pipeline = pipeline("collide_gather");
        let collide = GpuCollide {
            device,
            queue,
            precision,
            dim,
            layout,
            pairs_pipeline,
            gather_pipeline,
            errors,
        };
        collide.check_device()?;
        Ok(collide)
    }

    /// Binds the kernels to a backend's resident particle records
    /// `[x, v, p, force]` (of this device) with the lists of one
    /// broadphase, for [`GpuCollide::encode`].
    pub(crate) fn bind_resident(
        &self,
        records: [&wgpu::Buffer; 4],
        lists: &ContactLists,
    ) -> Resident {
        let ContactLists {
            inverse_mass,
            radius,
            pairs,
            offsets,
            entries,
            friction,
        } = *lists;
        let n = inverse_mass.len();
        let mut params = Vec::new();
        let offsets_at = 2 * pairs.len() as u32;
        let entries_at = offsets_at + n as u32 + 1;
        for word in [pairs.len() as u32, n as u32, offsets_at, entries_at] {
            params.extend_from_slice(&word.to_le_bytes());
        }
        push_reals(&mut params, &[friction], self.precision);
        params.resize(params.len().next_multiple_of(16), 0);
        let props: Vec<f64> = inverse_mass
            .iter()
            .zip(radius)
            .flat_map(|(&w, &r)| [w, r])
            .collect();
        let mut props_bytes = Vec::new();
        push_reals(&mut props_bytes, &props, self.precision);
        let mut lists: Vec<u32> = pairs.iter().flatten().copied().collect();
        lists.extend_from_slice(offsets);
        lists.extend_from_slice(entries);
        let params = self.storage("collide params", &params);
        let props = self.storage("props", &props_bytes);
        let lists = self.storage("lists", bytemuck::cast_slice(&lists));
        let corr_bytes = pairs.len() * (self.dim + 1) * real_size(self.precision);
        let corr = self.storage("corrections", &vec![0u8; corr_bytes]);
        let group = self.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("collide resident"),
            layout: &self.layout,
            entries: &[
                records[0], records[1], records[2], records[3], &params, &props, &lists, &corr,
            ]
            .iter()
            .enumerate()
            .map(|(b, buffer)| wgpu::BindGroupEntry {
                binding: b as u32,
                resource: buffer.as_entire_binding(),
            })
            .collect::<Vec<_>>(),
        });
        Resident {
            group,
            corr,
            corr_bytes: corr_bytes as u64,
            pairs: pairs.len(),
            particles: n,
        }
    }

    /// Records one iteration (pair kernel, gather kernel) on `resident`
    /// into `pass`; the caller restores its own bind group 0 afterwards.
    pub(crate) fn encode(&self, pass: &mut wgpu::ComputePass<'_>, resident: &Resident) {
        pass.set_bind_group(0, &resident.group, &[]);
        let (gx, gy) = groups(resident.pairs);
        pass.set_pipeline(&self.pairs_pipeline);
        pass.dispatch_workgroups(gx, gy, 1);
        let (gx, gy) = groups(resident.particles);
        pass.set_pipeline(&self.gather_pipeline);
        pass.dispatch_workgroups(gx, gy, 1);
    }

    fn check_device(&self) -> Result<(), GpuError> {
        crate::device_errors::take_device_errors(&self.errors)
    }

    fn storage(&self, label: &str, bytes: &[u8]) -> wgpu::Buffer {
        let size = (bytes.len() as u64).max(16).next_multiple_of(4);
        let buffer = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size,
            usage: wgpu::BufferUsages::STORAGE
                | wgpu::BufferUsages::COPY_DST
                | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        if !bytes.is_empty() {
            let mut padded = bytes.to_vec();
            padded.resize(padded.len().next_multiple_of(4), 0);
            self.queue.write_buffer(&buffer, 0, &padded);
        }
        buffer
    }

    /// Runs `iterations` contact iterations on `input` and returns the new
    /// positions (as f64). Fails with a typed error on a non-finite result.
    pub fn iterate(&self, input: &CollideInput, iterations: u32) -> Result<Vec<f64>, GpuError> {
        let n = input.inverse_mass.len();
        let pairs = input.pairs.len();
        if input.x.len() != n * self.dim
            || input.p.len() != n * self.dim
            || input.radius.len() != n
            || input.offsets.len() != n + 1
            || input.entries.len() != 2 * pairs
        {
            return Err(GpuError::Unsupported {
                what: "collide input arrays of inconsistent lengths".into(),
            });
        }
        let reals = |values: &[f64]| {
            let mut out = Vec::with_capacity(values.len() * real_size(self.precision));
            push_reals(&mut out, values, self.precision);
            out
        };
        let mut params = Vec::new();
        let offsets_at = 2 * pairs as u32;
        let entries_at = offsets_at + n as u32 + 1;
        for word in [pairs as u32, n as u32, offsets_at, entries_at] {
            params.extend_from_slice(&word.to_le_bytes());
        }
        push_reals(&mut params, &[input.friction], self.precision);
        params.resize(params.len().next_multiple_of(16), 0);
        let props: Vec<f64> = input
            .inverse_mass
            .iter()
            .zip(input.radius)
            .flat_map(|(&w, &r)| [w, r])
            .collect();
        let mut lists: Vec<u32> = input.pairs.iter().flatten().copied().collect();
        lists.extend_from_slice(input.offsets);
        lists.extend_from_slice(input.entries);
        let params = self.storage("collide params", &params);
        let layout = VectorLayout::Record;
        let pack = |values: &[f64]| reals(&layout.pack(self.dim, values, Some(input.inverse_mass)));
        let x = self.storage("x", &pack(input.x));
        let p = self.storage("p", &pack(input.p));
        let unused_v = self.storage("v (unused)", &[]);
        let unused_force = self.storage("force (unused)", &[]);
        let props = self.storage("props", &reals(&props));
        let lists = self.storage("lists", bytemuck::cast_slice(&lists));
        let corr = self.storage("corrections", &reals(&vec![0.0; pairs * (self.dim + 1)]));
        let group = self.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("collide"),
            layout: &self.layout,
            entries: &[
                x.clone(),
                unused_v,
                p,
                unused_force,
                params,
                props,
                lists,
                corr,
            ]
            .iter()
            .enumerate()
            .map(|(b, buffer)| wgpu::BindGroupEntry {
                binding: b as u32,
                resource: buffer.as_entire_binding(),
            })
            .collect::<Vec<_>>(),
        });
        let bytes = (n * layout.reals_per_particle(self.dim) * real_size(self.precision)) as u64;
        let staging = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("collide staging"),
            size: bytes.max(16),
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut encoder = self
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("collide"),
            });
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("collide"),
                timestamp_writes: None,
            });
            pass.set_bind_group(0, &group, &[]);
            for _ in 0..iterations {
                let (gx, gy) = groups(pairs);
                pass.set_pipeline(&self.pairs_pipeline);
                pass.dispatch_workgroups(gx, gy, 1);
                let (gx, gy) = groups(n);
                pass.set_pipeline(&self.gather_pipeline);
                pass.dispatch_workgroups(gx, gy, 1);
            }
        }
        if bytes > 0 {
            encoder.copy_buffer_to_buffer(&x, 0, &staging, 0, bytes);
        }
        crate::device_errors::submit_and_wait(&self.device, &self.queue, encoder, &self.errors)?;
        if bytes == 0 {
            return Ok(Vec::new());
        }
        let data = layout.unpack(
            self.dim,
            &read_reals(
                &crate::readback::read_mapped(&self.device, &staging, bytes)?,
                self.precision,
            ),
        );
        if let Some(bad) = data.iter().position(|v| !v.is_finite()) {
            return Err(GpuError::Other {
                message: format!(
                    "particle {} became non-finite in the contact solve",
                    bad / self.dim
                ),
            });
        }
        Ok(data)
    }
}
