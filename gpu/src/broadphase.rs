//! `GpuSweep`: the device broadphase of the contact step on given boxes,
//! as a kernel-level entry point.
//!
//! ```text
//! upload boxes (f32: rounded outward)
//! boxes_and_bounds → grid_frame → bin_count → scan → bin_fill → neighbours
//! read the lists; a list longer than its slots: grow the slots, rerun
//! canonical pairs = for each i, the partners j > i of its ascending list
//! ```
//! The kernels are the step's (`gpu/src/contact`, `shaders/grid.wgsl`):
//! each box's list is exactly the boxes that overlap it (closed intervals,
//! every axis), in ascending order, so the pairs equal the exhaustive
//! reference [`hyperpbd_core::broadphase::exhaustive_pairs`] — in f64 on the
//! boxes given, in f32 on those boxes rounded outward
//! ([`Aabbs::rounded_outward_to_f32`]), a superset of the f64 pairs.

use hyperpbd_core::GpuError;
use hyperpbd_core::broadphase::{Aabbs, Pair};

use crate::Precision;
use crate::contact::{Block, Bound, ContactBuffers, ContactKernels, ContactPhase, Particles};
use crate::context::GpuContext;

/// Statistics of the last sweep.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct SweepStats {
    /// Pairs found.
    pub pairs: usize,
    /// List slots per box after the sweep (the longest list it holds).
    pub capacity: usize,
    /// Times the lists were grown and the sweep rerun.
    pub regrowths: u32,
}

/// The GPU broadphase on given boxes: the contact step's kernels, with
/// buffers sized for the largest box count seen and grown on demand.
pub struct GpuSweep {
    ctx: GpuContext,
    precision: Precision,
    dim: usize,
    kernels: ContactKernels,
    /// Unused particle records x v p force (one f64 record of the largest
    /// dimension: 96 bytes) and the status (the boxes are given).
    unused: [wgpu::Buffer; 5],
    buffers: Option<ContactBuffers>,
    capacity: usize,
    stats: SweepStats,
}

impl GpuSweep {
    /// Finds an adapter for `precision`, creates a device and builds the
    /// sweep for boxes in R^`dim` with `capacity` initial list slots per
    /// box.
    pub fn new(dim: usize, precision: Precision, capacity: usize) -> Result<Self, GpuError> {
        let (adapter, _) = crate::request_adapter(precision)?;
        Self::with_adapter(&adapter, dim, precision, capacity)
    }

    /// As [`GpuSweep::new`] on a device of `adapter`.
    pub fn with_adapter(
        adapter: &wgpu::Adapter,
        dim: usize,
        precision: Precision,
        capacity: usize,
    ) -> Result<Self, GpuError> {
        let ctx = GpuContext::new(adapter, precision)?;
        let kernels = ContactKernels::new(&ctx, dim, precision)?;
        let unused = [
            ctx.storage("sweep x", &[0; 128])?,
            ctx.storage("sweep v", &[0; 128])?,
            ctx.storage("sweep p", &[0; 128])?,
            ctx.storage("sweep force", &[0; 128])?,
            ctx.storage(
                "sweep status",
                bytemuck::cast_slice(&[u32::MAX, u32::MAX, 0, 0]),
            )?,
        ];
        ctx.check()?;
        Ok(GpuSweep {
            ctx,
            precision,
            dim,
            kernels,
            unused,
            buffers: None,
            capacity: capacity.max(1),
            stats: SweepStats::default(),
        })
    }

    /// Current list slots per box.
    pub fn capacity(&self) -> usize {
        self.capacity
    }

    /// Statistics of the last [`GpuSweep::sweep`].
    pub fn stats(&self) -> SweepStats {
        self.stats
    }

    /// Device bytes per box: its records (box, candidate, snapshot: six
    /// points of ⌊N/4⌋ + 1 vec4), properties, grid and list words and its
    /// share of the scratch, without the list slots (4 bytes each,
    /// [`GpuSweep::capacity`] per box).
    pub fn bytes_per_box(&self) -> usize {
        let r = crate::params::real_size(self.precision);
        (6 * 4 * (self.dim / 4 + 1) + 5) * r + 7 * 4
    }

    /// All overlapping pairs (i < j) of `boxes` in canonical
    /// (lexicographic) order — equal to the CPU sweeps on the same boxes.
    /// `axis` is the first axis of the grid (the others: widest spread
    /// first); the pairs do not depend on it.
    pub fn sweep(&mut self, boxes: &Aabbs, axis: usize) -> Result<Vec<Pair>, GpuError> {
        if boxes.dim != self.dim || axis >= self.dim {
            return Err(GpuError::Unsupported {
                what: format!(
                    "boxes of dimension {} on grid axis {axis} on a broadphase built for dimension {}",
                    boxes.dim, self.dim
                ),
            });
        }
        let n = boxes.len();
        self.stats = SweepStats {
            capacity: self.capacity,
            ..SweepStats::default()
        };
        if n == 0 {
            return Ok(Vec::new());
        }
        self.ensure_buffers(n)?;
        let rounded;
        let boxes = match self.precision {
            Precision::F32 => {
                rounded = boxes.rounded_outward_to_f32();
                &rounded
            }
            Precision::F64 => boxes,
        };
        let lists = loop {
            let Some(buffers) = &self.buffers else {
                return Err(GpuError::Other {
                    message: "broadphase buffers were not allocated".into(),
                });
            };
            buffers.write_boxes(&boxes.min, &boxes.max);
            let (outcome, data) = self.run(buffers, axis as u32)?;
            outcome.trusted()?;
            let longest = outcome.longest_list as usize;
            if longest <= buffers.slots() {
                break data;
            }
            self.stats.regrowths += 1;
            if let Some(buffers) = &mut self.buffers {
                buffers.grow(&self.kernels, 0, longest)?;
                self.capacity = buffers.slots();
                self.stats.capacity = self.capacity;
            }
        };
        let mut pairs = Vec::new();
        for (i, list) in lists.iter().enumerate() {
            pairs.extend(
                list.iter()
                    .filter(|&&j| j as usize > i)
                    .map(|&j| [i as u32, j]),
            );
        }
        self.stats.pairs = pairs.len();
        Ok(pairs)
    }

    /// Buffers for exactly `n` boxes (the grid's bucket count follows n).
    fn ensure_buffers(&mut self, n: usize) -> Result<(), GpuError> {
        if let Some(b) = &self.buffers
            && b.particles() == n
        {
            return Ok(());
        }
        let zeros = vec![0.0; n];
        let [x, v, p, force, status] = &self.unused;
        self.buffers = Some(ContactBuffers::new(
            &self.ctx,
            &self.kernels,
            Bound {
                x,
                v,
                p,
                force,
                status,
            },
            &Particles {
                inverse_mass: &zeros,
                radius: &zeros,
                margin: &[0.0],
                friction: &[0.0],
            },
            self.capacity,
            (0..self.dim as u32)
                .map(|axis| Block {
                    call: 0,
                    flags: 0,
                    axis,
                })
                .collect(),
        )?);
        Ok(())
    }

    /// One broadphase on the uploaded boxes; returns the outcome and every
    /// box's list.
    fn run(
        &self,
        buffers: &ContactBuffers,
        axis: u32,
    ) -> Result<(crate::contact::Outcome, Vec<Vec<u32>>), GpuError> {
        let staging = self
            .ctx
            .staging("sweep lists staging", buffers.lists_bytes())?;
        buffers.reset();
        let mut encoder = self
            .ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("broadphase"),
            });
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            let (kernels, block) = (&self.kernels, axis as usize);
            buffers.encode(kernels, &mut pass, ContactPhase::Broadphase, block);
        }
        buffers.copy_outcome(&mut encoder);
        buffers.copy_lists(&mut encoder, &staging);
        self.ctx.submit_and_wait(encoder)?;
        let outcome = buffers.read_outcome()?;
        let data = self.ctx.read(&staging, buffers.lists_bytes())?;
        Ok((outcome, buffers.decode_lists(bytemuck::cast_slice(&data))))
    }
}
