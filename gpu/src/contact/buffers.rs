//! Buffers of the contact kernel set, bound once (group 0) with the
//! positions and status word they act on, plus one parameter block per
//! kernel call (group 1, dynamic offset).
//!
//! ```text
//! record    ⌊N/4⌋ + 1 vec4: a point and one extra real (R reals, R = 4⌊N/4⌋ + 4)
//! props     vec4 per particle [w, r, pad, 0]
//! boxes     2 records per box      (lower corner, index), (upper corner, w)
//! cands     2 records per box      the same, in bucket order
//! snapshot  2 records per particle (iterate y, r), (substep start p, w)
//! scratch   3N·1024 + 10 + n reals counters  8 + buckets u32
//! ranges    2 u32 per bucket       words     3n + scan blocks u32
//! lists     slots · n u32 (slots a multiple of 4; grown on demand)
//! staging   32 bytes: counters[0..4], deepest overlap
//! ```
//! Device bytes per particle, without the lists: (6R + 5) reals + 7 words
//! (two buckets each); the lists add 4 bytes per slot.

use std::sync::{Arc, Mutex};

use hyperpbd_core::GpuError;

use super::{BOUND_THREADS, ContactKernels, buckets_for, scan_blocks_for};
use crate::Precision;
use crate::params::{push_reals, read_reals, real_size};

const NONE: u32 = u32::MAX;
/// Status counters before the bucket counters (`COUNTERS` in contact.wgsl).
const COUNTERS: usize = 8;
/// u32 words of a parameter block before the friction real.
const PARAM_WORDS: usize = 8;
/// Bytes bound per parameter block: the words and one real (f64 at most).
const PARAMS_BYTES: u64 = (PARAM_WORDS * 4 + 8) as u64;

/// The buffers the kernels act on: the backend's resident positions and
/// status word, or a kernel-level caller's own.
#[derive(Clone, Copy)]
pub(crate) struct Bound<'a> {
    pub(crate) x: &'a wgpu::Buffer,
    pub(crate) p: &'a wgpu::Buffer,
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
        if let Some(i) = self.cut_short {
            return Err(GpuError::Unsupported {
                what: format!(
                    "contact lists this long on this adapter: it ended the loops of invocation {i} early \
                     (llvmpipe stops a shader's loops after 65 535 iterations); use the CPU backend"
                ),
            });
        }
        Ok(())
    }
}

/// The buffers, bind groups and parameter blocks of one contact stage.
pub(crate) struct ContactBuffers {
    device: wgpu::Device,
    queue: wgpu::Queue,
    errors: Arc<Mutex<Vec<String>>>,
    dim: usize,
    precision: Precision,
    n: usize,
    buckets: usize,
    slots: usize,
    friction: f64,
    blocks: Vec<Block>,
    stride: u32,
    x: wgpu::Buffer,
    p: wgpu::Buffer,
    status: wgpu::Buffer,
    props: wgpu::Buffer,
    boxes: wgpu::Buffer,
    cands: wgpu::Buffer,
    snapshot: wgpu::Buffer,
    scratch: wgpu::Buffer,
    counters: wgpu::Buffer,
    ranges: wgpu::Buffer,
    words: wgpu::Buffer,
    lists: wgpu::Buffer,
    params: wgpu::Buffer,
    pub(super) group: wgpu::BindGroup,
    pub(super) params_group: wgpu::BindGroup,
    staging: wgpu::Buffer,
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

impl ContactBuffers {
    /// Buffers for `particles` with `slots` list entries per particle,
    /// bound to `bound`, with the parameter blocks `blocks`.
    pub(crate) fn new(
        (device, queue, errors): (&wgpu::Device, &wgpu::Queue, Arc<Mutex<Vec<String>>>),
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
                    Precision::F64 => r + particles.margin,
                    Precision::F32 => {
                        f64::from(hyperpbd_core::broadphase::key_up(r + particles.margin))
                    }
                };
                [w, r, pad, 0.0]
            })
            .collect();
        let buckets = buckets_for(n);
        let r = real_size(precision);
        let limits = device.limits();
        let storage = wgpu::BufferUsages::STORAGE
            | wgpu::BufferUsages::COPY_DST
            | wgpu::BufferUsages::COPY_SRC;
        let make = |label: &str, bytes: &[u8], usage| {
            crate::backend::create_buffer(device, queue, &limits, label, bytes, usage)
        };
        let zeros = |count: usize| vec![0u8; count];
        let reals = |values: &[f64]| {
            let mut out = Vec::with_capacity(values.len() * r);
            push_reals(&mut out, values, precision);
            out
        };
        let scratch_reals = 3 * dim * BOUND_THREADS as usize + 10 + n;
        let record = record_reals(dim);
        let align = limits.min_storage_buffer_offset_alignment;
        let stride = (PARAMS_BYTES as u32).div_ceil(align) * align;
        let mut counters = vec![0u32, NONE, 0, 0];
        counters.resize(COUNTERS + buckets, 0);
        let slots = slots_for(slots);
        let params = make(
            "contact params",
            &zeros(stride as usize * blocks.len().max(1)),
            storage,
        )?;
        let mut buffers = ContactBuffers {
            props: make("contact props", &reals(&props), storage)?,
            boxes: make("contact boxes", &zeros(2 * record * n * r), storage)?,
            cands: make("contact candidates", &zeros(2 * record * n * r), storage)?,
            snapshot: make("contact snapshot", &zeros(2 * record * n * r), storage)?,
            scratch: make("contact scratch", &zeros(scratch_reals * r), storage)?,
            counters: make("contact counters", bytemuck::cast_slice(&counters), storage)?,
            ranges: make("contact ranges", &zeros(8 * buckets), storage)?,
            words: make(
                "contact words",
                &zeros(4 * (3 * n + scan_blocks_for(buckets))),
                storage,
            )?,
            lists: empty_storage(device, "contact lists", 4 * (slots * n) as u64)?,
            staging: make(
                "contact staging",
                &zeros(32),
                wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            )?,
            group: placeholder(device, &kernels.params_layout, &params),
            params_group: placeholder(device, &kernels.params_layout, &params),
            params,
            device: device.clone(),
            queue: queue.clone(),
            errors,
            dim,
            precision,
            n,
            buckets,
            slots,
            friction: particles.friction,
            blocks,
            stride,
            x: bound.x.clone(),
            p: bound.p.clone(),
            status: bound.status.clone(),
        };
        buffers.rebind(kernels);
        buffers.write_params();
        crate::device_errors::take_device_errors(&buffers.errors)?;
        Ok(buffers)
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
        block as u32 * self.stride
    }

    /// Writes the parameter blocks (at load and after a growth).
    fn write_params(&self) {
        let mut bytes = Vec::with_capacity(self.stride as usize * self.blocks.len());
        for block in &self.blocks {
            let start = bytes.len();
            let words = [
                block.call,
                self.n as u32,
                self.buckets as u32,
                self.slots as u32,
                self.scan_blocks() as u32,
                block.flags,
                block.axis,
                0,
            ];
            bytes.extend_from_slice(bytemuck::cast_slice(&words));
            push_reals(&mut bytes, &[self.friction], self.precision);
            bytes.resize(start + self.stride as usize, 0);
        }
        if !bytes.is_empty() {
            self.queue.write_buffer(&self.params, 0, &bytes);
        }
    }

    /// Grows the lists to at least `need` slots per particle (doubling at
    /// least), keeping everything else.
    pub(crate) fn grow(&mut self, kernels: &ContactKernels, need: usize) -> Result<(), GpuError> {
        let slots = slots_for(need.max(2 * self.slots));
        self.lists = empty_storage(&self.device, "contact lists", 4 * (slots * self.n) as u64)?;
        self.slots = slots;
        self.rebind(kernels);
        self.write_params();
        crate::device_errors::take_device_errors(&self.errors)
    }

    /// Both bind groups over the current buffers (at load, after a growth).
    fn rebind(&mut self, kernels: &ContactKernels) {
        let resources = [
            &self.x,
            &self.p,
            &self.status,
            &self.props,
            &self.boxes,
            &self.cands,
            &self.snapshot,
            &self.scratch,
            &self.counters,
            &self.ranges,
            &self.words,
            &self.lists,
        ];
        let entries: Vec<_> = resources
            .iter()
            .enumerate()
            .map(|(b, buffer)| wgpu::BindGroupEntry {
                binding: b as u32,
                resource: buffer.as_entire_binding(),
            })
            .collect();
        self.group = self.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("hyperpbd contact"),
            layout: &kernels.layout,
            entries: &entries,
        });
        self.params_group = placeholder(&self.device, &kernels.params_layout, &self.params);
    }

    /// Clears the counters the outcome reads (before a submission).
    pub(crate) fn reset(&self) {
        self.queue
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
        let bytes = crate::readback::read_mapped(&self.device, &self.staging, 32)?;
        let words: &[u32] = bytemuck::cast_slice(&bytes[..16]);
        let deepest = read_reals(&bytes[16..16 + real_size(self.precision)], self.precision);
        Ok(Outcome {
            longest_list: words[0],
            active: words[2],
            deepest: deepest.first().copied().unwrap_or(0.0),
            cut_short: (words[1] != NONE).then_some(words[1]),
        })
    }

    /// Flat points (`dim` per point) with one extra each, as records.
    fn records(&self, points: &[f64], extra: impl Fn(usize) -> f64) -> Vec<u8> {
        let d = self.dim;
        let record = record_reals(d);
        let mut values = Vec::with_capacity(record * points.len() / d.max(1));
        for (i, point) in points.chunks_exact(d).enumerate() {
            let at = values.len();
            values.extend_from_slice(point);
            values.push(extra(i));
            values.resize(at + record, 0.0);
        }
        let mut bytes = Vec::new();
        push_reals(&mut bytes, &values, self.precision);
        bytes
    }

    /// Writes given boxes (flat corners, `dim` per box) as the kernels
    /// hold them: (lower corner, index), (upper corner, 0).
    pub(crate) fn write_boxes(&self, min: &[f64], max: &[f64]) {
        let lower = self.records(min, |i| i as f64);
        let upper = self.records(max, |_| 0.0);
        let half = lower.len() / self.n.max(1);
        let mut bytes = Vec::with_capacity(2 * lower.len());
        for (lo, hi) in lower
            .chunks_exact(half.max(1))
            .zip(upper.chunks_exact(half.max(1)))
        {
            bytes.extend_from_slice(lo);
            bytes.extend_from_slice(hi);
        }
        if !bytes.is_empty() {
            self.queue.write_buffer(&self.boxes, 0, &bytes);
        }
    }

    /// Writes the substep starts p (flat) and inverse masses where the
    /// broadphase keeps them for the contact iterations.
    pub(crate) fn write_starts(&self, p: &[f64], inverse_mass: &[f64]) {
        let bytes = self.records(p, |i| inverse_mass[i]);
        if !bytes.is_empty() {
            let at = (record_reals(self.dim) * self.n * real_size(self.precision)) as u64;
            self.queue.write_buffer(&self.snapshot, at, &bytes);
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
            self.queue
                .write_buffer(&self.words, 4 * n as u64, bytemuck::cast_slice(&lengths));
            self.queue
                .write_buffer(&self.lists, 0, bytemuck::cast_slice(&entries));
        }
    }
}

/// Group 1 over one parameter block of `params` (the dynamic offset picks
/// the block).
fn placeholder(
    device: &wgpu::Device,
    layout: &wgpu::BindGroupLayout,
    params: &wgpu::Buffer,
) -> wgpu::BindGroup {
    device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("hyperpbd contact params"),
        layout,
        entries: &[wgpu::BindGroupEntry {
            binding: 0,
            resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                buffer: params,
                offset: 0,
                size: wgpu::BufferSize::new(PARAMS_BYTES),
            }),
        }],
    })
}

/// Reals of one record (contact.wgsl): ⌊N/4⌋ + 1 vec4.
fn record_reals(dim: usize) -> usize {
    4 * (dim / 4 + 1)
}

/// List slots for at least `slots` entries: a multiple of 4 (one vec4 of
/// entries per access), at least 4.
fn slots_for(slots: usize) -> usize {
    slots.max(1).next_multiple_of(4)
}

/// An uninitialised storage buffer of `bytes` (at least 16), refused with
/// a typed error beyond the device's limits.
fn empty_storage(device: &wgpu::Device, label: &str, bytes: u64) -> Result<wgpu::Buffer, GpuError> {
    let limits = device.limits();
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
    Ok(device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size,
        usage: wgpu::BufferUsages::STORAGE
            | wgpu::BufferUsages::COPY_SRC
            | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    }))
}
