//! Buffers of the contact kernel set, bound once (group 0) with the
//! particle records and status word they act on, plus one parameter block
//! per kernel call (group 1, dynamic offset).
//!
//! ```text
//! record    VEC = ⌊N/4⌋ + 1 vec4: a point and one extra real in the last lane
//!           (R = 4·VEC reals; the prelude's particle records)
//! props     vec4 per particle [w, r, pad, μ]
//! boxes     2 records per box      (lower corner, index), (upper corner, w)
//! cands     2 records per box      the same, in bucket order
//! snapshot  1 record per particle  (iterate y, r)
//! scratch   W + W·(3N·1024 + 10 + n) reals
//! counters  8W + W·buckets u32     ranges    2 u32 per bucket
//! words     3Wn + scan blocks + 2W u32 (the last: each world's list base, slots)
//! lists     Σ_w slots_w · n u32 (slots a multiple of 4; each world's grown
//!           on demand, on its own)
//! staging   32W bytes (each world's counters[0..8]), then W reals (each
//!           world's deepest overlap)
//! ```
//! W worlds of n particles, world-major (W = 1 but in a batch,
//! contact.wgsl). Device bytes per particle, without the lists: (5R + 5)
//! reals + 7 words (two buckets each); the lists add 4 bytes per slot.

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

/// What one submission found in one world, read back with every world's.
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
    /// No list, no pair, nothing cut short.
    pub(crate) const EMPTY: Outcome = Outcome {
        longest_list: 0,
        active: 0,
        deepest: 0.0,
        cut_short: None,
    };

    /// The typed error of results the kernels could not vouch for: loops
    /// the adapter cut short.
    pub(crate) fn trusted(&self) -> Result<(), GpuError> {
        match self.cut_short {
            Some(i) => Err(crate::loop_budget::loops_cut_short(Some(i))),
            None => Ok(()),
        }
    }
}

/// The per-particle constants of a contact stage: W worlds of n
/// particles, world-major (W = `margin.len()`).
pub(crate) struct Particles<'a> {
    /// W·n inverse masses.
    pub(crate) inverse_mass: &'a [f64],
    /// W·n radii.
    pub(crate) radius: &'a [f64],
    /// Per world: the box margin added to every radius.
    pub(crate) margin: &'a [f64],
    /// Per world: Coulomb μ between particles.
    pub(crate) friction: &'a [f64],
}

/// The buffers, bind groups and parameter blocks of one contact stage.
pub(crate) struct ContactBuffers {
    ctx: GpuContext,
    dim: usize,
    precision: crate::Precision,
    /// Particles per world.
    n: usize,
    /// Worlds.
    worlds: usize,
    /// Buckets per world.
    buckets: usize,
    /// List slots per particle, per world.
    slots: Vec<usize>,
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
    /// Buffers for `particles` (W worlds: the kernels') with `slots` list
    /// entries per particle, bound to `bound`, with the parameter blocks
    /// `blocks`.
    pub(crate) fn new(
        ctx: &GpuContext,
        kernels: &ContactKernels,
        bound: Bound,
        particles: &Particles,
        slots: usize,
        blocks: Vec<Block>,
    ) -> Result<Self, GpuError> {
        let (dim, precision) = (kernels.dim, kernels.precision);
        let worlds = kernels.worlds;
        let n = particles.inverse_mass.len() / worlds.max(1);
        if particles.margin.len() != worlds
            || particles.friction.len() != worlds
            || particles.radius.len() != n * worlds
            || particles.inverse_mass.len() != n * worlds
        {
            return Err(GpuError::Other {
                message: format!("contact constants laid out for other than {worlds} worlds"),
            });
        }
        if n > super::MAX_PARTICLES || worlds * buckets_for(n) > 2 * super::MAX_PARTICLES {
            return Err(GpuError::Unsupported {
                what: format!(
                    "{worlds} world(s) of {n} particles with contact: {} hash buckets (the GPU \
                     broadphase's scan takes at most {}, at least two per particle, of all \
                     worlds together)",
                    worlds * buckets_for(n),
                    2 * super::MAX_PARTICLES
                ),
            });
        }
        let props: Vec<f64> = (0..worlds * n)
            .flat_map(|i| {
                let (w, r) = (particles.inverse_mass[i], particles.radius[i]);
                let (margin, mu) = (particles.margin[i / n], particles.friction[i / n]);
                // The golden path's pad r + m; in f32 rounded up so the
                // device box holds the f64 one.
                let pad = match precision {
                    crate::Precision::F64 => r + margin,
                    crate::Precision::F32 => {
                        f64::from(hyperpbd_core::broadphase::key_up(r + margin))
                    }
                };
                [w, r, pad, mu]
            })
            .collect();
        let buckets = buckets_for(n);
        let r = real_size(precision);
        let record = 4 * record_words(dim);
        let zeros = |count: usize| vec![0u8; count];
        let mut props_bytes = Vec::with_capacity(props.len() * r);
        push_reals(&mut props_bytes, &props, precision);
        let mut counters = header(worlds);
        counters.resize((COUNTERS + buckets) * worlds, 0);
        let slots = vec![slots_for(slots); worlds];
        let scratch_reals = worlds * (1 + 3 * dim * BOUND_THREADS as usize + 10 + n);
        let all = worlds * n;
        let props = ctx.storage("contact props", &props_bytes)?;
        let boxes = ctx.storage("contact boxes", &zeros(2 * record * all * r))?;
        let cands = ctx.storage("contact candidates", &zeros(2 * record * all * r))?;
        let snapshot = ctx.storage("contact snapshot", &zeros(record * all * r))?;
        let scratch = ctx.storage("contact scratch", &zeros(scratch_reals * r))?;
        let counters = ctx.storage("contact counters", bytemuck::cast_slice(&counters))?;
        let ranges = ctx.storage("contact ranges", &zeros(8 * buckets * worlds))?;
        let table = list_table(n, &slots);
        let words = ctx.storage(
            "contact words",
            &zeros(4 * (3 * all + scan_blocks_for(buckets * worlds) + table.len())),
        )?;
        ctx.queue.write_buffer(
            &words,
            4 * (3 * all + scan_blocks_for(buckets * worlds)) as u64,
            bytemuck::cast_slice(&table),
        );
        let lists = empty_storage(ctx, "contact lists", lists_bytes(n, &slots))?;
        let staging = ctx.staging("contact staging", ((32 + r) * worlds) as u64)?;
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
                worlds,
            },
        )?;
        Ok(ContactBuffers {
            ctx: ctx.clone(),
            dim,
            precision,
            n,
            worlds,
            buckets,
            slots,
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

    /// Particles per world.
    pub(crate) fn particles(&self) -> usize {
        self.n
    }

    /// Worlds.
    pub(crate) fn worlds(&self) -> usize {
        self.worlds
    }

    pub(super) fn scan_blocks(&self) -> usize {
        scan_blocks_for(self.buckets * self.worlds)
    }

    /// List slots per particle (world 0's).
    pub(crate) fn slots(&self) -> usize {
        self.slots[0]
    }

    /// List slots per particle of every world.
    pub(crate) fn world_slots(&self) -> &[usize] {
        &self.slots
    }

    /// The parameter block of step call `call`, if the set has one.
    pub(crate) fn block_of(&self, call: u32) -> Option<usize> {
        self.blocks.iter().position(|b| b.call == call)
    }

    pub(super) fn block_offset(&self, block: usize) -> u32 {
        self.offsets.get(block).copied().unwrap_or(0)
    }

    /// Grows world `world`'s lists to at least `need` slots per particle
    /// (doubling at least), keeping every other world's slots and
    /// everything else (the lists' contents are the next broadphase's).
    pub(crate) fn grow(
        &mut self,
        kernels: &ContactKernels,
        world: usize,
        need: usize,
    ) -> Result<(), GpuError> {
        let mut slots = self.slots.clone();
        slots[world] = slots_for(need.max(2 * slots[world]));
        let bytes = lists_bytes(self.n, &slots);
        self.lists = empty_storage(&self.ctx, "contact lists", bytes)?;
        self.slots = slots;
        let table = list_table(self.n, &self.slots);
        let at = 4 * (3 * self.worlds * self.n + self.scan_blocks()) as u64;
        self.ctx
            .queue
            .write_buffer(&self.words, at, bytemuck::cast_slice(&table));
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
                worlds: self.worlds,
            },
        )?;
        (self.group, self.params_group, self.offsets) = (group, params_group, offsets);
        self.ctx.check()
    }

    /// Clears every world's counters the outcome reads (before a
    /// submission; the spans are the next broadphase's).
    pub(crate) fn reset(&self) {
        let header = header(self.worlds);
        self.ctx
            .queue
            .write_buffer(&self.counters, 0, bytemuck::cast_slice(&header));
    }

    /// Bytes of the outcome staging: every world's header, then every
    /// world's deepest overlap.
    fn outcome_bytes(&self) -> u64 {
        ((4 * COUNTERS + real_size(self.precision)) * self.worlds) as u64
    }

    /// Copies the outcome into the staging buffer (end of a submission).
    pub(crate) fn copy_outcome(&self, encoder: &mut wgpu::CommandEncoder) {
        let (headers, r) = (
            4 * (COUNTERS * self.worlds) as u64,
            real_size(self.precision),
        );
        let reports = (r * self.worlds) as u64;
        encoder.copy_buffer_to_buffer(&self.counters, 0, &self.staging, 0, headers);
        encoder.copy_buffer_to_buffer(&self.scratch, 0, &self.staging, headers, reports);
    }

    /// Reads world 0's outcome copied by the last waited-for submission.
    pub(crate) fn read_outcome(&self) -> Result<Outcome, GpuError> {
        let bytes = self.ctx.read(&self.staging, self.outcome_bytes())?;
        Ok(self.outcome_of(&bytes))
    }

    /// The outcome's staging buffer and its length, for a caller that
    /// reads it together with its own buffers (one wait).
    pub(crate) fn outcome_staging(&self) -> (&wgpu::Buffer, u64) {
        (&self.staging, self.outcome_bytes())
    }

    /// World 0's outcome from the bytes of [`Self::outcome_staging`].
    pub(crate) fn outcome_of(&self, bytes: &[u8]) -> Outcome {
        self.outcomes_of(bytes)
            .first()
            .copied()
            .unwrap_or(Outcome::EMPTY)
    }

    /// Every world's outcome from the bytes of [`Self::outcome_staging`].
    pub(crate) fn outcomes_of(&self, bytes: &[u8]) -> Vec<Outcome> {
        let headers = 4 * COUNTERS * self.worlds;
        if bytes.len() < headers {
            return Vec::new();
        }
        let words: &[u32] = bytemuck::cast_slice(&bytes[..headers]);
        let deepest = read_reals(&bytes[headers..], self.precision);
        words
            .chunks_exact(COUNTERS)
            .enumerate()
            .map(|(w, words)| Outcome {
                longest_list: words[0],
                active: words[2],
                deepest: deepest.get(w).copied().unwrap_or(0.0),
                cut_short: (words[1] != NONE).then_some(words[1]),
            })
            .collect()
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
        let slots = self.slots() as u64;
        encoder.copy_buffer_to_buffer(&self.words, 4 * n, staging, 0, 4 * n);
        encoder.copy_buffer_to_buffer(&self.lists, 0, staging, 4 * n, 4 * n * slots);
    }

    /// Bytes [`ContactBuffers::copy_lists`] writes.
    pub(crate) fn lists_bytes(&self) -> u64 {
        4 * self.n as u64 * (1 + self.slots() as u64)
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
                (0..(len as usize).min(self.slots()))
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
        let mut entries = vec![0u32; n * self.slots()];
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
    /// Particles and buckets per world.
    n: usize,
    buckets: usize,
    worlds: usize,
}

/// Every world's counter header as a submission starts: longest list 0,
/// no cut loop, no active pair.
fn header(worlds: usize) -> Vec<u32> {
    let mut one = [0u32; COUNTERS];
    one[1] = NONE;
    one.repeat(worlds)
}

/// Each world's list region (base in vec4 of entries, slots) for `n`
/// particles per world: world after world.
fn list_table(n: usize, slots: &[usize]) -> Vec<u32> {
    let mut base = 0;
    let mut table = Vec::with_capacity(2 * slots.len());
    for &s in slots {
        table.extend([base as u32, s as u32]);
        base += s / 4 * n;
    }
    table
}

/// Bytes of every world's list region.
fn lists_bytes(n: usize, slots: &[usize]) -> u64 {
    4 * (slots.iter().sum::<usize>() * n) as u64
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
                0,
                scan_blocks_for(params.buckets * params.worlds) as u32,
                b.flags,
                b.axis,
                0,
            ];
            blocks.push(&BlockWriter::new(kernels.precision).words(&words).finish())
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
