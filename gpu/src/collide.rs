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

use hyperpbd_core::GpuError;
use hyperpbd_core::broadphase::Pair;

use crate::Precision;
use crate::contact::{Block, Bound, ContactBuffers, ContactKernels, ContactPhase, Particles};
use crate::context::GpuContext;
use crate::layout::VectorLayout;
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
    ctx: GpuContext,
    precision: Precision,
    dim: usize,
    kernels: ContactKernels,
}

impl GpuCollide {
    /// Builds the kernels on a new device of `adapter`.
    pub fn with_adapter(
        adapter: &wgpu::Adapter,
        dim: usize,
        precision: Precision,
    ) -> Result<Self, GpuError> {
        let ctx = GpuContext::new(adapter, precision)?;
        let kernels = ContactKernels::new(&ctx, dim, precision)?;
        ctx.check()?;
        Ok(GpuCollide {
            ctx,
            precision,
            dim,
            kernels,
        })
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
        // x and p as the prelude's particle records (inverse mass in the
        // last lane).
        let records = |values: &[f64]| {
            let packed = VectorLayout::Record.pack(self.dim, values, Some(input.inverse_mass));
            let mut out = Vec::with_capacity(packed.len() * real_size(self.precision));
            push_reals(&mut out, &packed, self.precision);
            out
        };
        let ctx = &self.ctx;
        let x = ctx.storage("collide x", &records(input.x))?;
        let p = ctx.storage("collide p", &records(input.p))?;
        let unused = ctx.storage("collide v", &[0; 128])?;
        let force = ctx.storage("collide force", &[0; 128])?;
        let status = ctx.storage(
            "collide status",
            bytemuck::cast_slice(&[u32::MAX, u32::MAX, 0, 0]),
        )?;
        let buffers = ContactBuffers::new(
            ctx,
            &self.kernels,
            Bound {
                x: &x,
                v: &unused,
                p: &p,
                force: &force,
                status: &status,
            },
            &Particles {
                inverse_mass: input.inverse_mass,
                radius: input.radius,
                margin: &[0.0],
                friction: &[input.friction],
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
        let bytes = (n
            * VectorLayout::Record.reals_per_particle(self.dim)
            * real_size(self.precision)) as u64;
        let staging = ctx.staging("collide staging", 16 + bytes)?;
        let mut encoder = ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("collide"),
            });
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            for iteration in 0..iterations as usize {
                buffers.encode(&self.kernels, &mut pass, ContactPhase::Collide, iteration);
            }
        }
        buffers.copy_outcome(&mut encoder);
        encoder.copy_buffer_to_buffer(&status, 0, &staging, 0, 16);
        if bytes > 0 {
            encoder.copy_buffer_to_buffer(&x, 0, &staging, 16, bytes);
        }
        ctx.submit_and_wait(encoder)?;
        let data = ctx.read(&staging, 16 + bytes)?;
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
        Ok(VectorLayout::Record.unpack(self.dim, &read_reals(&data[16..], self.precision)))
    }
}
