//! Buffers of the contact kernel set, bound once (group 0) with the
//! positions and status word they act on, plus one parameter block per
//! kernel call (group 1, dynamic offset).
//!
//! ```text
//! props     vec4 per particle [w, r, pad, 0]     P = 4⌈N/4⌉ reals per point
//! boxes     2P reals per particle    scratch   3N·1024 + 10 + n reals
//! snapshot  2P reals per particle    counters  4 + buckets u32
//! words     4n + scan blocks + buckets u32     lists  slots · n u32 (grown)
//! staging   32 bytes: counters[0..4], deepest overlap
//! ```
//! Device bytes per particle, without the lists: (4P + 5) reals + 8 words
//! (two buckets each); the lists add 4 bytes per slot.

use std::sync::{Arc, Mutex};

use hyperpbd_core::GpuError;

use super::{BOUND_THREADS, ContactKernels, buckets_for, scan_blocks_for};
use crate::Precision;
use crate::params::{push_reals, read_reals, real_size};

const NONE: u32 = u32::MAX;
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
    /// A box spanning more than two grid cells (the grid's precondition
    /// broken: its lists are not trusted).
    pub(crate) grid_broken: Option<u32>,
    /// Active pairs of the last iteration (after a report).
    pub(crate) active: u32,
    /// Deepest overlap over the last lists (after a report).
    pub(crate) deepest: f64,
    /// An invocation whose loops the adapter cut short (llvmpipe's
    /// 65 535-iteration limit): its results are not trusted.
    pub(crate) cut_short: Option<u32>,
}

impl Outcome {
    /// The typed error of results the kernels could not vouch for: a box
    /// spanning more than two grid cells on an axis (the grid's
    /// precondition, shaders/grid.wgsl), or loops the adapter cut short.
    pub(crate) fn trusted(&self) -> Result<(), GpuError> {
        if let Some(i) = self.grid_broken {
            return Err(GpuError::Other {
                message: format!(
                    "broadphase grid: box {i} spans more than two cells on a grid axis (cells too fine for this adapter's rounding)"
                ),
            });
        }
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
    snapshot: wgpu::Buffer,
    scratch: wgpu::Buffer,
    counters: wgpu::Buffer,
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
        let words = 4 * n + scan_blocks_for(buckets) + buckets;
        // vec4-packed points: ⌈N/4⌉ vec4 each.
        let point = 4 * dim.div_ceil(4);
        let align = limits.min_storage_buffer_offset_alignment;
        let stride = (PARAMS_BYTES as u32).div_ceil(align) * align;
        let mut counters = vec![0u32, NONE, 0, NONE];
        counters.resize(4 + buckets, 0);
        let slots = slots.max(1);
        let props = make("contact props", &reals(&props), storage)?;
        let boxes = make("contact boxes", &zeros(2 * point * n * r), storage)?;
        let snapshot = make("contact snapshot", &zeros(2 * point * n * r), storage)?;
        let scratch = make("contact scratch", &zeros(scratch_reals * r), storage)?;
        let counters = make("contact counters", bytemuck::cast_slice(&counters), storage)?;
        let words = make("contact words", &zeros(4 * words), storage)?;
        let lists = empty_storage(device, "contact lists", 4 * (slots * n) as u64)?;
        let params = make(
            "contact params",
            &zeros(stride as usize * blocks.len().max(1)),
            storage,
        )?;
        let staging = make(
            "contact staging",
            &zeros(32),
            wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        )?;
        let (group, params_group) = bind_groups(
            device,
            kernels,
            [
                bound.x,
                bound.p,
                bound.status,
                &props,
                &boxes,
                &snapshot,
                &scratch,
                &counters,
                &words,
                &lists,
            ],
            &params,
        );
        let buffers = ContactBuffers {
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
            props,
            boxes,
            snapshot,
            scratch,
            counters,
            words,
            lists,
            params,
            group,
            params_group,
            staging,
        };
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
        let slots = need.max(2 * self.slots);
        self.lists = empty_storage(&self.device, "contact lists", 4 * (slots * self.n) as u64)?;
        self.slots = slots;
        let (group, params_group) = bind_groups(
            &self.device,
            kernels,
            [
                &self.x,
                &self.p,
                &self.status,
                &self.props,
                &self.boxes,
                &self.snapshot,
                &self.scratch,
                &self.counters,
                &self.words,
                &self.lists,
            ],
            &self.params,
        );
        self.group = group;
        self.params_group = params_group;
        self.write_params();
        crate::device_errors::take_device_errors(&self.errors)
    }

    /// Clears the counters the outcome reads (before a submission).
    pub(crate) fn reset(&self) {
        self.queue
            .write_buffer(&self.counters, 0, bytemuck::cast_slice(&[0u32, NONE, 0, NONE]));
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
            grid_broken: (words[1] != NONE).then_some(words[1]),
            active: words[2],
            deepest: deepest.first().copied().unwrap_or(0.0),
            cut_short: (words[3] != NONE).then_some(words[3]),
        })
    }

    /// Writes boxes (flat corners, `dim` per box) for a sweep of given
    /// boxes, vec4-packed as the kernels hold them.
    pub(crate) fn write_boxes(&self, min: &[f64], max: &[f64]) {
        let d = self.dim;
        let point = 4 * d.div_ceil(4);
        let mut values = Vec::with_capacity(2 * point * self.n);
        for (lo, hi) in min.chunks_exact(d).zip(max.chunks_exact(d)) {
            for corner in [lo, hi] {
                values.extend_from_slice(corner);
                values.resize(values.len() + point - d, 0.0);
            }
        }
        let mut bytes = Vec::new();
        push_reals(&mut bytes, &values, self.precision);
        if !bytes.is_empty() {
            self.queue.write_buffer(&self.boxes, 0, &bytes);
        }
    }

    /// Writes the substep starts p (flat, `dim` per particle) where the
    /// broadphase keeps them for the contact iterations (vec4-packed).
    pub(crate) fn write_starts(&self, p: &[f64]) {
        let d = self.dim;
        let point = 4 * d.div_ceil(4);
        let mut values = Vec::with_capacity(point * self.n);
        for start in p.chunks_exact(d) {
            values.extend_from_slice(start);
            values.resize(values.len() + point - d, 0.0);
        }
        let mut bytes = Vec::new();
        push_reals(&mut bytes, &values, self.precision);
        if !bytes.is_empty() {
            let at = (point * self.n * real_size(self.precision)) as u64;
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
        encoder.copy_buffer_to_buffer(&self.words, 8 * n, staging, 0, 4 * n);
        encoder.copy_buffer_to_buffer(&self.lists, 0, staging, 4 * n, 4 * n * self.slots as u64);
    }

    /// Bytes [`ContactBuffers::copy_lists`] writes.
    pub(crate) fn lists_bytes(&self) -> u64 {
        4 * self.n as u64 * (1 + self.slots as u64)
    }

    /// Writes per-particle lists (`lists[k]` ascending) for a contact
    /// iteration on given lists; they must fit the slots.
    pub(crate) fn write_lists(&self, lists: &[Vec<u32>]) {
        let n = self.n;
        let mut lengths = vec![0u32; n];
        let mut slots = vec![0u32; n * self.slots];
        for (k, list) in lists.iter().enumerate() {
            lengths[k] = list.len() as u32;
            for (t, &m) in list.iter().enumerate() {
                slots[t * n + k] = m;
            }
        }
        if n > 0 {
            self.queue
                .write_buffer(&self.words, 8 * n as u64, bytemuck::cast_slice(&lengths));
            self.queue
                .write_buffer(&self.lists, 0, bytemuck::cast_slice(&slots));
        }
    }
}

/// Group 0 over `resources` (binding order of contact.wgsl) and group 1
/// over one parameter block of `params`.
fn bind_groups(
    device: &wgpu::Device,
    kernels: &ContactKernels,
    resources: [&wgpu::Buffer; 10],
    params: &wgpu::Buffer,
) -> (wgpu::BindGroup, wgpu::BindGroup) {
    let entries: Vec<_> = resources
        .iter()
        .enumerate()
        .map(|(b, buffer)| wgpu::BindGroupEntry {
            binding: b as u32,
            resource: buffer.as_entire_binding(),
        })
        .collect();
    let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("hyperpbd contact"),
        layout: &kernels.layout,
        entries: &entries,
    });
    let params_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("hyperpbd contact params"),
        layout: &kernels.params_layout,
        entries: &[wgpu::BindGroupEntry {
            binding: 0,
            resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                buffer: params,
                offset: 0,
                size: wgpu::BufferSize::new(PARAMS_BYTES),
            }),
        }],
    });
    (group, params_group)
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
