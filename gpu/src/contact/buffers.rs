//! Buffers of the contact kernel set, bound once (group 0) with the
//! particle records and status word they act on, plus one parameter block
//! per kernel call (group 1, dynamic offset).
//!
//! ```text
//! record    VEC = ⌊N/4⌋ + 1 vec4: a point and one extra real in the last lane
//!           (R = 4·VEC reals; the prelude's particle records)
//! props     vec4 per particle [w, r, pad, 0]
//! boxes     2 records per box      (lower corner, index), (upper corner, w)
//! cands     2 records per box      the same, in bucket order
//! snapshot  1 record per particle  (iterate y, r)
//! scratch   3N·1024 + 10 + n reals counters  8 + buckets u32
//! ranges    2 u32 per bucket       words     3n + scan blocks u32
//! lists     slots · n u32 (slots a multiple of 4; grown on demand)
//! staging   32 bytes: counters[0..4], deepest overlap
//! ```
//! Device bytes per particle, without the lists: (5R + 5) reals + 7 words
//! (two buckets each); the lists add 4 bytes per slot.

use hyperpbd_core::GpuError;

use super::{BOUND_THREADS, ContactKernels, buckets_for, scan_blocks_for};
use crate::context::GpuContext;
use crate::kernel_set::{BlockWriter, ParamBlocks};
use crate::layout::{VectorLayout, record_words};
use crate::params::{push_reals, read_reals, real_size};

const NONE: u32 = u32::MAX;
/// Status counters before the bucket counters (`COUNTERS` in contact.wgsl).
const COUNTERS: usize = 8;

/// The buffers the kernels act on: the particle records x v p force
/// (prelude.wgsl) and the step's status word — the backend's resident
/// ones, or a kernel-level caller's own.
#[derive(Clone, Copy)]
pub(crate) struct Bound<'a> {
    pub(crate) x: &'a wgpu::Buffer,
    pub(crate) v: &'a wgpu::Buffer,
    pub(crate) p: &'a wgpu::Buffer,
    pub(crate) force: &'a wgpu::Buffer,
    pub(crate) status: &'a wgpu::Buffer,
}

/// One parameter block: the step call it belongs to (failures are reported
/// against it), its flags and the first grid axis (≥ N: widest spread).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Block {
    pub(crate) call: u32,
    pub(crate) flags: u32,
    pub(crate) axis: u32,
}

/// What one submission found, read back in one 32-byte copy.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Outcome {
    /// Longest contact list of any broadphase since [`ContactBuffers::reset`].
    pub(crate) longest_list: u32,
    /// Active pairs of the last iteration (after a report).
    pub(crate) active: u32,
    /// Deepest overlap over the last lists (after a report).
    pub(crate) deepest: f64,
    /// An invocation whose loops the adapter cut short (llvmpipe's
    /// 65 535-iteration limit): its results are not trusted.
    pub(crate) cut_short: Option<u32>,
}

impl Outcome {
    /// The typed error of results the kernels could not vouch for: loops
    /// the adapter cut short.
    pub(crate) fn trusted(&self) -> Result<(), GpuError> {
        match self.cut_short {
            Some(i) => Err(crate::loop_budget::loops_cut_short(Some(i))),
            None => Ok(()),
        }
    }
}

/// The per-particle constants of a contact stage.
pub(crate) struct Particles<'a> {
    pub(crate) inverse_mass: &'a [f64],
    pub(crate) radius: &'a [f64],
    /// Box margin added to every radius.
    pub(crate) margin: f64,
    /// Coulomb μ between particles.
    pub(crate) friction: f64,
}

/// The buffers, bind groups and parameter blocks of one contact stage.
pub(crate) struct ContactBuffers {
    ctx: GpuContext,
    dim: usize,
    precision: crate::Precision,
    n: usize,
    buckets: usize,
    slots: usize,
    friction: f64,
    blocks: Vec<Block>,
    offsets: Vec<u32>,
    /// x v p force status, then the contact buffers, in binding order.
    bound: [wgpu::Buffer; 5],
    props: wgpu::Buffer,
    boxes: wgpu::Buffer,
    cands: wgpu::Buffer,
    snapshot: wgpu::Buffer,
    scratch: wgpu::Buffer,
    counters: wgpu::Buffer,
    ranges: wgpu::Buffer,
    words: wgpu::Buffer,
    lists: wgpu::Buffer,
    pub(super) group: wgpu::BindGroup,
    pub(super) params_group: wgpu::BindGroup,
    staging: wgpu::Buffer,
}

impl ContactBuffers {
    /// Buffers for `particles` with `slots` list entries per particle,
    /// bound to `bound`, with the parameter blocks `blocks`.
    pub(crate) fn new(
        ctx: &GpuContext,
        kernels: &ContactKernels,
        bound: Bound,
        particles: &Particles,
        slots: usize,
        blocks: Vec<Block>,
    ) -> Result<Self, GpuError> {
        let (dim, precision) = (kernels.dim, kernels.precision);
        let n = particles.inverse_mass.len();
        if n > super::MAX_PARTICLES {
            return Err(GpuError::Unsupported {
                what: format!(
                    "{n} particles with contact (the GPU broadphase takes at most {})",
                    super::MAX_PARTICLES
                ),
            });
        }
        let props: Vec<f64> = (0..n)
            .flat_map(|i| {
                let (w, r) = (particles.inverse_mass[i], particles.radius[i]);
                // The golden path's pad r + m; in f32 rounded up so the
                // device box holds the f64 one.
                let pad = match precision {
                    crate::Precision::F64 => r + particles.margin,
                    crate::Precision::F32 => {
                        f64::from(hyperpbd_core::broadphase::key_up(r + particles.margin))
                    }
                };
                [w, r, pad, 0.0]
            })
            .collect();
        let buckets = buckets_for(n);
        let r = real_size(precision);
        let record = 4 * record_words(dim);
        let zeros = |count: usize| vec![0u8; count];
        let mut props_bytes = Vec::with_capacity(props.len() * r);
        push_reals(&mut props_bytes, &props, precision);
        let mut counters = vec![0u32, NONE, 0, 0];
        counters.resize(COUNTERS + buckets, 0);
        let slots = slots_for(slots);
        let scratch_reals = 3 * dim * BOUND_THREADS as usize + 10 + n;
        let props = ctx.storage("contact props", &props_bytes)?;
        let boxes = ctx.storage("contact boxes", &zeros(2 * record * n * r))?;
        let cands = ctx.storage("contact candidates", &zeros(2 * record * n * r))?;
        let snapshot = ctx.storage("contact snapshot", &zeros(record * n * r))?;
        let scratch = ctx.storage("contact scratch", &zeros(scratch_reals * r))?;
        let counters = ctx.storage("contact counters", bytemuck::cast_slice(&counters))?;
        let ranges = ctx.storage("contact ranges", &zeros(8 * buckets))?;
        let words = ctx.storage(
            "contact words",
            &zeros(4 * (3 * n + scan_blocks_for(buckets))),
        )?;
        let lists = empty_storage(ctx, "contact lists", 4 * (slots * n) as u64)?;
        let staging = ctx.staging("contact staging", 32)?;
        let bound = [
            bound.x.clone(),
            bound.v.clone(),
            bound.p.clone(),
            bound.force.clone(),
            bound.status.clone(),
        ];
        let (group, params_group, offsets) = bind(
            ctx,
            kernels,
            [
                &bound[0], &bound[1], &bound[2], &bound[3], &bound[4], &props, &boxes, &cands,
                &snapshot, &scratch, &counters, &ranges, &words, &lists,
            ],
            &ParamsOf {
                blocks: &blocks,
                n,
                buckets,
                slots,
                friction: particles.friction,
                precision,
            },
        )?;
        Ok(ContactBuffers {
            ctx: ctx.clone(),
            dim,
            precision,
            n,
            buckets,
            slots,
            friction: particles.friction,
            blocks,
            offsets,
            bound,
            props,
            boxes,
            cands,
            snapshot,
            scratch,
            counters,
            ranges,
            words,
            lists,
            group,
            params_group,
            staging,
        })
    }

    pub(crate) fn particles(&self) -> usize {
        self.n
    }

    pub(super) fn scan_blocks(&self) -> usize {
        scan_blocks_for(self.buckets)
    }

    /// List slots per particle.
    pub(crate) fn slots(&self) -> usize {
        self.slots
    }

    /// The parameter block of step call `call`, if the set has one.
    pub(crate) fn block_of(&self, call: u32) -> Option<usize> {
        self.blocks.iter().position(|b| b.call == call)
    }

    pub(super) fn block_offset(&self, block: usize) -> u32 {
        self.offsets.get(block).copied().unwrap_or(0)
    }

    /// Grows the lists to at least `need` slots per particle (doubling at
    /// least), keeping everything else.
    pub(crate) fn grow(&mut self, kernels: &ContactKernels, need: usize) -> Result<(), GpuError> {
        let slots = slots_for(need.max(2 * self.slots));
        self.lists = empty_storage(&self.ctx, "contact lists", 4 * (slots * self.n) as u64)?;
        self.slots = slots;
        let b = &self.bound;
        let (group, params_group, offsets) = bind(
            &self.ctx,
            kernels,
            [
                &b[0],
                &b[1],
                &b[2],
                &b[3],
                &b[4],
                &self.props,
                &self.boxes,
                &self.cands,
                &self.snapshot,
                &self.scratch,
                &self.counters,
                &self.ranges,
                &self.words,
                &self.lists,
            ],
            &ParamsOf {
                blocks: &self.blocks,
                n: self.n,
                buckets: self.buckets,
                slots,
                friction: self.friction,
                precision: self.precision,
            },
        )?;
        (self.group, self.params_group, self.offsets) = (group, params_group, offsets);
        self.ctx.check()
    }

    /// Clears the counters the outcome reads (before a submission).
    pub(crate) fn reset(&self) {
        self.ctx
            .queue
            .write_buffer(&self.counters, 0, bytemuck::cast_slice(&[0u32, NONE, 0, 0]));
    }

    /// Copies the outcome into the staging buffer (end of a submission).
    pub(crate) fn copy_outcome(&self, encoder: &mut wgpu::CommandEncoder) {
        let r = real_size(self.precision) as u64;
        let report = (3 * self.dim as u64 * u64::from(BOUND_THREADS) + 9) * r;
        encoder.copy_buffer_to_buffer(&self.counters, 0, &self.staging, 0, 16);
        encoder.copy_buffer_to_buffer(&self.scratch, report, &self.staging, 16, r);
    }

    /// Reads the outcome copied by the last waited-for submission.
    pub(crate) fn read_outcome(&self) -> Result<Outcome, GpuError> {
        let bytes = self.ctx.read(&self.staging, 32)?;
        Ok(self.outcome_of(&bytes))
    }

    /// The outcome's staging buffer and its length, for a caller that
    /// reads it together with its own buffers (one wait).
    pub(crate) fn outcome_staging(&self) -> (&wgpu::Buffer, u64) {
        (&self.staging, 32)
    }

    /// The outcome from the 32 bytes of [`Self::outcome_staging`].
    pub(crate) fn outcome_of(&self, bytes: &[u8]) -> Outcome {
        let words: &[u32] = bytemuck::cast_slice(&bytes[..16]);
        let deepest = read_reals(&bytes[16..16 + real_size(self.precision)], self.precision);
        Outcome {
            longest_list: words[0],
            active: words[2],
            deepest: deepest.first().copied().unwrap_or(0.0),
            cut_short: (words[1] != NONE).then_some(words[1]),
        }
    }

    /// Writes given boxes (flat corners, `dim` per box) as the kernels
    /// hold them: (lower corner, index), (upper corner, 0).
    pub(crate) fn write_boxes(&self, min: &[f64], max: &[f64]) {
        let (d, n) = (self.dim, self.n);
        let index: Vec<f64> = (0..n).map(|i| i as f64).collect();
        let lower = VectorLayout::Record.pack(d, min, Some(&index));
        let upper = VectorLayout::Record.pack(d, max, None);
        let record = 4 * record_words(d);
        let mut values = Vec::with_capacity(2 * lower.len());
        for (lo, hi) in lower.chunks_exact(record).zip(upper.chunks_exact(record)) {
            values.extend_from_slice(lo);
            values.extend_from_slice(hi);
        }
        let mut bytes = Vec::new();
        push_reals(&mut bytes, &values, self.precision);
        if !bytes.is_empty() {
            self.ctx.queue.write_buffer(&self.boxes, 0, &bytes);
        }
    }

    /// Copies the list lengths and the lists into `staging` (at least
    /// [`ContactBuffers::lists_bytes`] bytes) for a read-back.
    pub(crate) fn copy_lists(&self, encoder: &mut wgpu::CommandEncoder, staging: &wgpu::Buffer) {
        let n = self.n as u64;
        if n == 0 {
            return;
        }
        encoder.copy_buffer_to_buffer(&self.words, 4 * n, staging, 0, 4 * n);
        encoder.copy_buffer_to_buffer(&self.lists, 0, staging, 4 * n, 4 * n * self.slots as u64);
    }

    /// Bytes [`ContactBuffers::copy_lists`] writes.
    pub(crate) fn lists_bytes(&self) -> u64 {
        4 * self.n as u64 * (1 + self.slots as u64)
    }

    /// The lists from the words [`ContactBuffers::copy_lists`] copied (a
    /// list longer than the slots, which the outcome reports, is cut at
    /// the slots).
    pub(crate) fn decode_lists(&self, words: &[u32]) -> Vec<Vec<u32>> {
        let n = self.n;
        let (lengths, lists) = words.split_at(n.min(words.len()));
        lengths
            .iter()
            .enumerate()
            .map(|(k, &len)| {
                (0..(len as usize).min(self.slots))
                    .filter_map(|t| lists.get(4 * ((t / 4) * n + k) + t % 4).copied())
                    .collect()
            })
            .collect()
    }

    /// Writes per-particle lists (`lists[k]` ascending) for a contact
    /// iteration on given lists; they must fit the slots.
    pub(crate) fn write_lists(&self, lists: &[Vec<u32>]) {
        let n = self.n;
        let mut lengths = vec![0u32; n];
        let mut entries = vec![0u32; n * self.slots];
        for (k, list) in lists.iter().enumerate() {
            lengths[k] = list.len() as u32;
            for (t, &m) in list.iter().enumerate() {
                entries[4 * ((t / 4) * n + k) + t % 4] = m;
            }
        }
        if n > 0 {
            let queue = &self.ctx.queue;
            queue.write_buffer(&self.words, 4 * n as u64, bytemuck::cast_slice(&lengths));
            queue.write_buffer(&self.lists, 0, bytemuck::cast_slice(&entries));
        }
    }
}

/// What the parameter blocks hold.
struct ParamsOf<'a> {
    blocks: &'a [Block],
    n: usize,
    buckets: usize,
    slots: usize,
    friction: f64,
    precision: crate::Precision,
}

/// Group 0 over `buffers` (binding order of contact.wgsl), the parameter
/// blocks (`ContactParams`) and group 1 over them; returns both groups and
/// each block's dynamic offset.
fn bind(
    ctx: &GpuContext,
    kernels: &ContactKernels,
    buffers: [&wgpu::Buffer; 14],
    params: &ParamsOf,
) -> Result<(wgpu::BindGroup, wgpu::BindGroup, Vec<u32>), GpuError> {
    let mut blocks = ParamBlocks::new(&ctx.device);
    let offsets = params
        .blocks
        .iter()
        .map(|b| {
            let words = [
                b.call,
                params.n as u32,
                params.buckets as u32,
                params.slots as u32,
                scan_blocks_for(params.buckets) as u32,
                b.flags,
                b.axis,
                0,
            ];
            blocks.push(
                &BlockWriter::new(params.precision)
                    .words(&words)
                    .reals(&[params.friction])
                    .finish(),
            )
        })
        .collect();
    let size = blocks.block_size();
    let buffer = blocks.finish(ctx, "contact params")?;
    let group = kernels.set.bind(&ctx.device, 0, &buffers, 0)?;
    let params_group = kernels.set.bind(&ctx.device, 1, &[&buffer], size)?;
    Ok((group, params_group, offsets))
}

/// List slots for at least `slots` entries: a multiple of 4 (one vec4 of
/// entries per access), at least 4.
fn slots_for(slots: usize) -> usize {
    slots.max(1).next_multiple_of(4)
}

/// An uninitialised storage buffer of `bytes` (at least 16), refused with
/// a typed error beyond the device's limits.
fn empty_storage(ctx: &GpuContext, label: &str, bytes: u64) -> Result<wgpu::Buffer, GpuError> {
    let limits = ctx.device.limits();
    let size = bytes.max(16).next_multiple_of(4);
    let maximum = limits
        .max_storage_buffer_binding_size
        .min(limits.max_buffer_size);
    if size > maximum {
        return Err(GpuError::BufferTooLarge {
            buffer: label.into(),
            requested: size,
            maximum,
        });
    }
    Ok(ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size,
        usage: wgpu::BufferUsages::STORAGE
            | wgpu::BufferUsages::COPY_SRC
            | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    }))
}
