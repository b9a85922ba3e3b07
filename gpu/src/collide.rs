//! `GpuCollide`: the particle–particle contact iteration
//! (`shaders/collide.wgsl`) on given lists, as a kernel-level entry point.
//!
//! ```text
//! upload x, p, (w, r) per particle; each particle's list from the CSR lists
//! iterations × { contact_snapshot ; collide }
//! read x back
//! ```
//! The same averaged gather-Jacobi iteration as `hyperpbd_cpu::collide`,
//! operation for operation, and the same kernels as the contact step of
//! [`crate::GpuBackend`], so it is held to the CPU golden path by a
//! differential test.

use std::sync::{Arc, Mutex};

use hyperpbd_core::GpuError;
use hyperpbd_core::broadphase::Pair;

use crate::Precision;
use crate::contact::{Block, Bound, ContactBuffers, ContactKernels, Particles};
use crate::params::{push_reals, read_reals, real_size};

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

/// The contact kernels for one dimension and precision.
pub struct GpuCollide {
    device: wgpu::Device,
    queue: wgpu::Queue,
    precision: Precision,
    dim: usize,
    kernels: ContactKernels,
    errors: Arc<Mutex<Vec<String>>>,
}

impl GpuCollide {
    /// Builds the kernels on a new device of `adapter`.
    pub fn with_adapter(
        adapter: &wgpu::Adapter,
        dim: usize,
        precision: Precision,
    ) -> Result<Self, GpuError> {
        let (device, queue) = crate::request_device(adapter, precision)?;
        let errors = crate::device_errors::collect_device_errors(&device);
        let kernels = ContactKernels::new(&device, dim, precision)?;
        crate::device_errors::take_device_errors(&errors)?;
        Ok(GpuCollide {
            device,
            queue,
            precision,
            dim,
            kernels,
            errors,
        })
    }

    fn storage(&self, label: &str, bytes: &[u8]) -> Result<wgpu::Buffer, GpuError> {
        crate::backend::create_buffer(
            &self.device,
            &self.queue,
            &self.device.limits(),
            label,
            bytes,
            wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        )
    }

    /// Runs `iterations` contact iterations on `input` and returns the new
    /// positions (as f64). Fails with a typed error on a non-finite result,
    /// naming the particle the CPU names.
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
        // Particle k's partners in the order of its CSR list.
        let mut lists = Vec::with_capacity(n);
        for k in 0..n {
            let range = input.offsets[k] as usize..input.offsets[k + 1] as usize;
            let list: Option<Vec<u32>> = input.entries.get(range).map(|entries| {
                entries
                    .iter()
                    .map(|&entry| input.pairs[entry as usize / 2][1 - entry as usize % 2])
                    .collect()
            });
            lists.push(list.ok_or_else(|| GpuError::Unsupported {
                what: format!("collide input: offsets of particle {k} out of range"),
            })?);
        }
        let reals = |values: &[f64]| {
            let mut out = Vec::with_capacity(values.len() * real_size(self.precision));
            push_reals(&mut out, values, self.precision);
            out
        };
        let x = self.storage("collide x", &reals(input.x))?;
        let p = self.storage("collide p", &reals(input.p))?;
        let status = self.storage(
            "collide status",
            bytemuck::cast_slice(&[u32::MAX, u32::MAX, 0, 0]),
        )?;
        let buffers = ContactBuffers::new(
            (&self.device, &self.queue, self.errors.clone()),
            &self.kernels,
            Bound {
                x: &x,
                p: &p,
                status: &status,
            },
            &Particles {
                inverse_mass: input.inverse_mass,
                radius: input.radius,
                margin: 0.0,
                friction: input.friction,
            },
            lists.iter().map(Vec::len).max().unwrap_or(1),
            // One block per iteration: after a failure, later iterations
            // see an earlier failed call and do nothing.
            (0..iterations.max(1))
                .map(|call| Block {
                    call,
                    flags: 0,
                    axis: 0,
                })
                .collect(),
        )?;
        buffers.write_lists(&lists);
        buffers.write_starts(input.p, input.inverse_mass);
        let bytes = (n * self.dim * real_size(self.precision)) as u64;
        let staging = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("collide staging"),
            size: bytes.max(16) + 16,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut encoder = self
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("collide"),
            });
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            for iteration in 0..iterations as usize {
                buffers.encode_collide(&self.kernels, &mut pass, iteration);
            }
        }
        buffers.copy_outcome(&mut encoder);
        encoder.copy_buffer_to_buffer(&status, 0, &staging, 0, 16);
        if bytes > 0 {
            encoder.copy_buffer_to_buffer(&x, 0, &staging, 16, bytes);
        }
        crate::device_errors::submit_and_wait(&self.device, &self.queue, encoder, &self.errors)?;
        let data = crate::readback::read_mapped(&self.device, &staging, 16 + bytes)?;
        buffers.read_outcome()?.trusted()?;
        let words: &[u32] = bytemuck::cast_slice(&data[..16]);
        if words[0] != u32::MAX {
            let index = words[1] as usize;
            return Err(GpuError::Other {
                message: format!(
                    "particle {} became non-finite in the contact solve",
                    index.checked_sub(n).unwrap_or(index)
                ),
            });
        }
        Ok(read_reals(&data[16..], self.precision))
    }
}
