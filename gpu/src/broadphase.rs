//! `GpuSweep`: the sort-and-sweep broadphase as wgpu compute dispatches.
//!
//! ```text
//! upload boxes (min, max as reals)
//! box_keys                       rec_a = [sortable(key_down(min[axis])), index]
//! 4 × radix pass (8-bit digits)  histogram → scan → scatter      (stable LSD)
//! copy rec_a → order
//! sweep_count → scan → sweep_emit → pairs in rec_a (slots ≥ capacity skipped)
//! read the total; total > capacity: grow the pair buffers, rerun from the top
//! radix passes on j, then on i   (⌈bits(n − 1) / 8⌉ passes each) → canonical
//! read the pairs back
//! ```
//! The rule is the CPU's ([`hyperpbd_core::broadphase::sweep_pairs`]): the
//! same keys, the same stable order, the same scan from each box, the same
//! closed-interval test; the final sort makes the list canonical, so it
//! equals the exhaustive reference exactly — in f64 on the boxes given, in
//! f32 on those boxes rounded outward ([`Aabbs::rounded_outward_to_f32`]),
//! a superset of the f64 pairs (no pair is lost). Everything is integer except
//! the overlap comparisons: no float atomics, nothing depends on
//! scheduling or subgroup size (the radix rank is a loop over shared
//! memory).
//!
//! Device memory: per box 2 reals + 3 records (order, rec_a, rec_b: 8 bytes
//! each) + ~1 scan word; per pair slot 2 records (rec_a, rec_b: 16 bytes)
//! + ~1 scan word (4 bytes) + 8 bytes of readback staging.

use std::sync::{Arc, Mutex};

use hyperpbd_core::GpuError;
use hyperpbd_core::broadphase::{Aabbs, Pair};

use crate::Precision;
use crate::params::{push_reals, real_size};
use crate::shader::{ShaderFile, compose};

const BLOCK: u32 = 256;
const MAX_GROUPS_X: u32 = 65_535;
/// u32 words of one `SweepParams` block.
const PARAM_WORDS: usize = 12;
/// Parameter blocks one submission may use.
const MAX_CALLS: usize = 1024;

/// Device bytes per pair slot of capacity: rec_a + rec_b (2 × 8), the
/// scan word of its radix histogram (4, rounded up per block) and the
/// readback staging (8).
pub const BYTES_PER_PAIR_SLOT: usize = 28;

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum SweepEntry {
    Histogram,
    Scatter,
    ScanBlocks,
    ScanAdd,
    BoxKeys,
    SweepCount,
    SweepEmit,
}

impl SweepEntry {
    const ALL: [SweepEntry; 7] = [
        SweepEntry::Histogram,
        SweepEntry::Scatter,
        SweepEntry::ScanBlocks,
        SweepEntry::ScanAdd,
        SweepEntry::BoxKeys,
        SweepEntry::SweepCount,
        SweepEntry::SweepEmit,
    ];

    fn source(self) -> (ShaderFile, &'static str) {
        match self {
            SweepEntry::Histogram => (ShaderFile::RadixSort, "histogram"),
            SweepEntry::Scatter => (ShaderFile::RadixSort, "scatter"),
            SweepEntry::ScanBlocks => (ShaderFile::RadixSort, "scan_blocks"),
            SweepEntry::ScanAdd => (ShaderFile::RadixSort, "scan_add"),
            SweepEntry::BoxKeys => (ShaderFile::Sweep, "box_keys"),
            SweepEntry::SweepCount => (ShaderFile::Sweep, "sweep_count"),
            SweepEntry::SweepEmit => (ShaderFile::Sweep, "sweep_emit"),
        }
    }
}

/// One `SweepParams` block (see shaders/broadphase.wgsl).
#[derive(Debug, Clone, Copy, Default)]
struct SweepParams {
    count: u32,
    shift: u32,
    word: u32,
    flip: u32,
    blocks: u32,
    base: u32,
    next: u32,
    capacity: u32,
    axis: u32,
}

/// One dispatch: entry, its parameter block, workgroups.
#[derive(Debug, Clone, Copy)]
struct Call {
    entry: SweepEntry,
    params: SweepParams,
    groups: u32,
}

/// Buffers sized for `boxes` boxes and `pairs` pair slots.
struct SweepBuffers {
    boxes: usize,
    pairs: usize,
    box_min: wgpu::Buffer,
    box_max: wgpu::Buffer,
    order: wgpu::Buffer,
    rec_a: wgpu::Buffer,
    rec_b: wgpu::Buffer,
    scan: wgpu::Buffer,
    staging: wgpu::Buffer,
    group: wgpu::BindGroup,
}

/// Statistics of the last sweep.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct SweepStats {
    /// Pairs found.
    pub pairs: usize,
    /// Pair capacity after the sweep.
    pub capacity: usize,
    /// Times the pair buffers were grown and the sweep rerun.
    pub regrowths: u32,
}

/// The GPU broadphase: pipelines and buffers, built once and grown on
/// demand.
pub struct GpuSweep {
    device: wgpu::Device,
    queue: wgpu::Queue,
    precision: Precision,
    dim: usize,
    limits: wgpu::Limits,
    layout: wgpu::BindGroupLayout,
    pipelines: Vec<wgpu::ComputePipeline>,
    params: wgpu::Buffer,
    stride: usize,
    buffers: Option<SweepBuffers>,
    capacity: usize,
    stats: SweepStats,
    errors: Arc<Mutex<Vec<String>>>,
}

/// Levels of an exclusive scan of `len` entries at `base`: (base, len,
/// next) per level, next = where the level's block sums go. Returns the
/// levels and the end of the space they use.
fn scan_levels(base: u32, len: u32) -> (Vec<(u32, u32, u32)>, u32) {
    let mut levels = Vec::new();
    let (mut at, mut n) = (base, len);
    loop {
        let blocks = n.div_ceil(BLOCK).max(1);
        let next = at + n;
        levels.push((at, n, next));
        if blocks == 1 {
            return (levels, next + 1);
        }
        at = next;
        n = blocks;
    }
}

/// Scan words a sweep of `boxes` boxes with `pairs` pair slots needs.
fn scan_words(boxes: usize, pairs: usize) -> u32 {
    let hist = |count: usize| BLOCK * (count as u32).div_ceil(BLOCK).max(1);
    [hist(boxes), boxes as u32 + 1, hist(pairs)]
        .iter()
        .map(|&len| scan_levels(0, len).1)
        .max()
        .unwrap_or(1)
}

/// Radix digits (8 bits) needed for keys up to `max_key`.
fn digits_for(max_key: u32) -> u32 {
    (32 - max_key.leading_zeros()).div_ceil(8).max(1)
}

fn bind(binding: u32, buffer: &wgpu::Buffer) -> wgpu::BindGroupEntry<'_> {
    wgpu::BindGroupEntry {
        binding,
        resource: buffer.as_entire_binding(),
    }
}

impl GpuSweep {
    /// Finds an adapter for `precision`, creates a device and builds the
    /// sweep for boxes in R^`dim` with `pair_capacity` initial pair slots.
    pub fn new(dim: usize, precision: Precision, pair_capacity: usize) -> Result<Self, GpuError> {
        let (adapter, _) = crate::request_adapter(precision)?;
        Self::with_adapter(&adapter, dim, precision, pair_capacity)
    }

    /// As [`GpuSweep::new`] on a device of `adapter`.
    pub fn with_adapter(
        adapter: &wgpu::Adapter,
        dim: usize,
        precision: Precision,
        pair_capacity: usize,
    ) -> Result<Self, GpuError> {
        if dim == 0 || dim > crate::shader::MAX_GPU_DIM {
            return Err(GpuError::Unsupported {
                what: format!(
                    "broadphase dimension {dim} (the GPU kernels support 1..={})",
                    crate::shader::MAX_GPU_DIM
                ),
            });
        }
        let (device, queue) = crate::request_device(adapter, precision)?;
        let errors = crate::device_errors::collect_device_errors(&device);
        Self::with_device(device, queue, errors, dim, precision, pair_capacity)
    }

    /// As [`GpuSweep::with_adapter`] on an existing device, whose
    /// uncaptured errors land in `errors`.
    pub(crate) fn with_device(
        device: wgpu::Device,
        queue: wgpu::Queue,
        errors: Arc<Mutex<Vec<String>>>,
        dim: usize,
        precision: Precision,
        pair_capacity: usize,
    ) -> Result<Self, GpuError> {
        let limits = device.limits();
        if limits.max_storage_buffers_per_shader_stage < 7 {
            return Err(GpuError::Unsupported {
                what: "the broadphase needs 7 storage buffers per shader stage".into(),
            });
        }
        let entries: Vec<_> = (0..7u32)
            .map(|b| crate::kernel_set::storage(b, b <= 2, b == 0))
            .collect();
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("hyperpbd broadphase"),
            entries: &entries,
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("hyperpbd broadphase"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let modules: Vec<(ShaderFile, wgpu::ShaderModule)> = ShaderFile::BROADPHASE
            .iter()
            .map(|&file| {
                let source = compose(file, dim, precision);
                let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
                    label: Some(file.file_name()),
                    source: wgpu::ShaderSource::Wgsl(source.into()),
                });
                (file, module)
            })
            .collect();
        let mut pipelines = Vec::new();
        for entry in SweepEntry::ALL {
            let (file, name) = entry.source();
            let Some((_, module)) = modules.iter().find(|(f, _)| *f == file) else {
                return Err(GpuError::Other {
                    message: format!("no module for {file:?}"),
                });
            };
            pipelines.push(
                device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                    label: Some(name),
                    layout: Some(&pipeline_layout),
                    module,
                    entry_point: Some(name),
                    compilation_options: Default::default(),
                    cache: None,
                }),
            );
        }
        let align = limits.min_storage_buffer_offset_alignment as usize;
        let stride = (PARAM_WORDS * 4).div_ceil(align) * align;
        let params = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("broadphase params"),
            size: (stride * MAX_CALLS) as u64,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let sweep = GpuSweep {
            device,
            queue,
            precision,
            dim,
            limits,
            layout,
            pipelines,
            params,
            stride,
            buffers: None,
            capacity: pair_capacity.max(1),
            stats: SweepStats::default(),
            errors,
        };
        sweep.check_device()?;
        Ok(sweep)
    }

    /// Current pair capacity (slots).
    pub fn capacity(&self) -> usize {
        self.capacity
    }

    /// Statistics of the last [`GpuSweep::sweep`].
    pub fn stats(&self) -> SweepStats {
        self.stats
    }

    /// Device bytes per box: min and max (2N reals), three records
    /// (order, rec_a, rec_b) and about one scan word.
    pub fn bytes_per_box(&self) -> usize {
        2 * self.dim * real_size(self.precision) + 3 * 8 + 4
    }

    /// All overlapping pairs (i < j) of `boxes` along `axis`, canonical
    /// (lexicographic) order — equal to the CPU sweeps on the same boxes.
    pub fn sweep(&mut self, boxes: &Aabbs, axis: usize) -> Result<Vec<Pair>, GpuError> {
        if boxes.dim != self.dim || axis >= self.dim {
            return Err(GpuError::Unsupported {
                what: format!(
                    "boxes of dimension {} swept along axis {axis} on a broadphase built for dimension {}",
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
        if n >= (u32::MAX / 2) as usize {
            return Err(GpuError::Unsupported {
                what: format!("{n} boxes (at most 2^31 − 1)"),
            });
        }
        self.ensure_buffers(n)?;
        self.upload(boxes)?;
        let total = loop {
            let total = self.find_pairs(n, axis as u32)?;
            if total <= self.capacity {
                break total;
            }
            self.capacity = total.max(2 * self.capacity);
            self.stats.regrowths += 1;
            self.stats.capacity = self.capacity;
            self.ensure_buffers(n)?;
            self.upload(boxes)?;
        };
        self.stats.pairs = total;
        if total == 0 {
            return Ok(Vec::new());
        }
        let words = self.sort_pairs(n, total)?;
        Ok(words
            .chunks_exact(2)
            .map(|w| [w[0], w[1]])
            .collect::<Vec<Pair>>())
    }

    fn pipeline(&self, entry: SweepEntry) -> &wgpu::ComputePipeline {
        let index = SweepEntry::ALL
            .iter()
            .position(|&e| e == entry)
            .unwrap_or(0);
        &self.pipelines[index]
    }

    fn check_device(&self) -> Result<(), GpuError> {
        crate::device_errors::take_device_errors(&self.errors)
    }

    fn buffer(
        &self,
        label: &str,
        bytes: u64,
        usage: wgpu::BufferUsages,
    ) -> Result<wgpu::Buffer, GpuError> {
        let size = bytes.max(16).next_multiple_of(4);
        let maximum = if usage.contains(wgpu::BufferUsages::STORAGE) {
            self.limits
                .max_storage_buffer_binding_size
                .min(self.limits.max_buffer_size)
        } else {
            self.limits.max_buffer_size
        };
        if size > maximum {
            return Err(GpuError::BufferTooLarge {
                buffer: label.into(),
                requested: size,
                maximum,
            });
        }
        Ok(self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size,
            usage,
            mapped_at_creation: false,
        }))
    }

    /// (Re)allocates the buffers when `n` boxes or the pair capacity do
    /// not fit the current ones.
    fn ensure_buffers(&mut self, n: usize) -> Result<(), GpuError> {
        if let Some(b) = &self.buffers
            && b.boxes >= n
            && b.pairs >= self.capacity
        {
            return Ok(());
        }
        let boxes = n.max(self.buffers.as_ref().map_or(0, |b| b.boxes));
        let pairs = self.capacity;
        let storage = wgpu::BufferUsages::STORAGE
            | wgpu::BufferUsages::COPY_DST
            | wgpu::BufferUsages::COPY_SRC;
        let reals = (boxes * self.dim * real_size(self.precision)) as u64;
        let records = (boxes.max(pairs) * 8) as u64;
        let box_min = self.buffer("box_min", reals, storage)?;
        let box_max = self.buffer("box_max", reals, storage)?;
        let order = self.buffer("order", (boxes * 8) as u64, storage)?;
        let rec_a = self.buffer("pairs_a", records, storage)?;
        let rec_b = self.buffer("pairs_b", records, storage)?;
        let scan = self.buffer("scan", u64::from(scan_words(boxes, pairs)) * 4, storage)?;
        let staging = self.buffer(
            "pairs_staging",
            records,
            wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        )?;
        let group = self.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("broadphase"),
            layout: &self.layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                        buffer: &self.params,
                        offset: 0,
                        size: wgpu::BufferSize::new((PARAM_WORDS * 4) as u64),
                    }),
                },
                bind(1, &box_min),
                bind(2, &box_max),
                bind(3, &order),
                bind(4, &rec_a),
                bind(5, &rec_b),
                bind(6, &scan),
            ],
        });
        self.buffers = Some(SweepBuffers {
            boxes,
            pairs,
            box_min,
            box_max,
            order,
            rec_a,
            rec_b,
            scan,
            staging,
            group,
        });
        self.check_device()
    }

    fn buffers(&self) -> Result<&SweepBuffers, GpuError> {
        self.buffers.as_ref().ok_or_else(|| GpuError::Other {
            message: "broadphase buffers were not allocated".into(),
        })
    }

    /// Uploads `boxes`; in f32 rounded outward, so the device's boxes
    /// contain the f64 ones and the pairs are a superset of theirs (equal
    /// to the exhaustive pairs of [`Aabbs::rounded_outward_to_f32`]).
    fn upload(&self, boxes: &Aabbs) -> Result<(), GpuError> {
        let b = self.buffers()?;
        let rounded;
        let boxes = match self.precision {
            Precision::F32 => {
                rounded = boxes.rounded_outward_to_f32();
                &rounded
            }
            Precision::F64 => boxes,
        };
        for (buffer, values) in [(&b.box_min, &boxes.min), (&b.box_max, &boxes.max)] {
            let mut bytes = Vec::with_capacity(values.len() * real_size(self.precision));
            push_reals(&mut bytes, values, self.precision);
            self.queue.write_buffer(buffer, 0, &bytes);
        }
        Ok(())
    }

    /// The dispatches of an exclusive scan of `len` words at `base`.
    fn scan_calls(calls: &mut Vec<Call>, base: u32, len: u32) {
        let (levels, _) = scan_levels(base, len);
        for &(at, n, next) in &levels {
            calls.push(Call {
                entry: SweepEntry::ScanBlocks,
                params: SweepParams {
                    count: n,
                    base: at,
                    next,
                    ..SweepParams::default()
                },
                groups: n.div_ceil(BLOCK).max(1),
            });
        }
        for &(at, n, next) in levels.iter().rev().skip(1) {
            calls.push(Call {
                entry: SweepEntry::ScanAdd,
                params: SweepParams {
                    count: n,
                    base: at,
                    next,
                    ..SweepParams::default()
                },
                groups: n.div_ceil(BLOCK).max(1),
            });
        }
    }

    /// One stable radix pass over `count` records: digit `shift` of word
    /// `word`, from rec_a (flip 0) or rec_b (flip 1).
    fn radix_pass(calls: &mut Vec<Call>, count: u32, word: u32, shift: u32, flip: u32) {
        let blocks = count.div_ceil(BLOCK).max(1);
        let pass = SweepParams {
            count,
            shift,
            word,
            flip,
            blocks,
            base: 0,
            ..SweepParams::default()
        };
        calls.push(Call {
            entry: SweepEntry::Histogram,
            params: pass,
            groups: blocks,
        });
        Self::scan_calls(calls, 0, 256 * blocks);
        calls.push(Call {
            entry: SweepEntry::Scatter,
            params: pass,
            groups: blocks,
        });
    }

    /// Writes the parameter blocks of `calls` and records them into a pass.
    fn encode(&self, encoder: &mut wgpu::CommandEncoder, calls: &[Call]) -> Result<(), GpuError> {
        if calls.len() > MAX_CALLS {
            return Err(GpuError::Other {
                message: format!("{} broadphase calls exceed {MAX_CALLS}", calls.len()),
            });
        }
        let mut bytes = vec![0u8; calls.len() * self.stride];
        for (c, call) in calls.iter().enumerate() {
            let p = call.params;
            let words = [
                p.count, p.shift, p.word, p.flip, p.blocks, p.base, p.next, p.capacity, p.axis, 0,
                0, 0,
            ];
            let at = c * self.stride;
            bytes[at..at + PARAM_WORDS * 4].copy_from_slice(bytemuck::cast_slice(&words));
        }
        if !bytes.is_empty() {
            self.queue.write_buffer(&self.params, 0, &bytes);
        }
        let group = &self.buffers()?.group;
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("broadphase"),
            timestamp_writes: None,
        });
        for (c, call) in calls.iter().enumerate() {
            pass.set_pipeline(self.pipeline(call.entry));
            pass.set_bind_group(0, group, &[(c * self.stride) as u32]);
            let x = call.groups.min(MAX_GROUPS_X);
            pass.dispatch_workgroups(x, call.groups.div_ceil(x), 1);
        }
        Ok(())
    }

    /// Sorts the boxes, counts, scans and emits the pairs (those within
    /// capacity) into rec_a; returns the total pair count.
    fn find_pairs(&self, n: usize, axis: u32) -> Result<usize, GpuError> {
        let count = n as u32;
        let mut calls = vec![Call {
            entry: SweepEntry::BoxKeys,
            params: SweepParams {
                count,
                axis,
                ..SweepParams::default()
            },
            groups: count.div_ceil(BLOCK),
        }];
        for (pass, shift) in [0u32, 8, 16, 24].into_iter().enumerate() {
            Self::radix_pass(&mut calls, count, 0, shift, pass as u32 % 2);
        }
        let b = self.buffers()?;
        let mut encoder = self
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("broadphase sort boxes"),
            });
        self.encode(&mut encoder, &calls)?;
        // Four passes: the sorted records are back in rec_a.
        encoder.copy_buffer_to_buffer(&b.rec_a, 0, &b.order, 0, u64::from(count) * 8);
        self.submit(encoder)?;

        let sweep = SweepParams {
            count,
            axis,
            base: 0,
            next: 0,
            capacity: self.capacity as u32,
            ..SweepParams::default()
        };
        let mut calls = vec![Call {
            entry: SweepEntry::SweepCount,
            params: sweep,
            groups: (count + 1).div_ceil(BLOCK),
        }];
        Self::scan_calls(&mut calls, 0, count + 1);
        calls.push(Call {
            entry: SweepEntry::SweepEmit,
            params: sweep,
            groups: count.div_ceil(BLOCK),
        });
        let mut encoder = self
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("broadphase sweep"),
            });
        self.encode(&mut encoder, &calls)?;
        if !may_wrap(n) {
            encoder.copy_buffer_to_buffer(&b.scan, u64::from(count) * 4, &b.staging, 0, 4);
            self.submit(encoder)?;
            let bytes = self.read(&b.staging, 4)?;
            return Ok(u32::from_le_bytes([bytes[0], bytes[1], bytes[2], bytes[3]]) as usize);
        }
        // n(n − 1)/2 ≥ 2^32: the u32 running sum may wrap. It rises
        // monotonically by each box's count, so it crossed 2^32 exactly
        // where a prefix is below its predecessor.
        let words = (u64::from(count) + 1) * 4;
        encoder.copy_buffer_to_buffer(&b.scan, 0, &b.staging, 0, words);
        self.submit(encoder)?;
        let bytes = self.read(&b.staging, words)?;
        let prefix: &[u32] = bytemuck::cast_slice(&bytes);
        if prefix.windows(2).any(|w| w[1] < w[0]) {
            return Err(GpuError::BufferTooLarge {
                buffer: "pairs_a".into(),
                requested: (1u64 << 32) * 8,
                maximum: self
                    .limits
                    .max_storage_buffer_binding_size
                    .min(self.limits.max_buffer_size),
            });
        }
        Ok(prefix[count as usize] as usize)
    }

    /// Radix-sorts the `total` pair records in rec_a by j, then by i, and
    /// reads them back.
    fn sort_pairs(&self, n: usize, total: usize) -> Result<Vec<u32>, GpuError> {
        let count = total as u32;
        let digits = digits_for(n.saturating_sub(1) as u32);
        let mut calls = Vec::new();
        let mut flip = 0;
        for word in [1u32, 0] {
            for d in 0..digits {
                Self::radix_pass(&mut calls, count, word, 8 * d, flip);
                flip ^= 1;
            }
        }
        let b = self.buffers()?;
        let mut encoder = self
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("broadphase sort pairs"),
            });
        self.encode(&mut encoder, &calls)?;
        let sorted = if flip == 0 { &b.rec_a } else { &b.rec_b };
        let bytes = u64::from(count) * 8;
        encoder.copy_buffer_to_buffer(sorted, 0, &b.staging, 0, bytes);
        self.submit(encoder)?;
        let data = self.read(&b.staging, bytes)?;
        Ok(bytemuck::cast_slice::<u8, u32>(&data).to_vec())
    }

    fn submit(&self, encoder: wgpu::CommandEncoder) -> Result<(), GpuError> {
        crate::device_errors::submit_and_wait(&self.device, &self.queue, encoder, &self.errors)
    }

    fn read(&self, buffer: &wgpu::Buffer, len: u64) -> Result<Vec<u8>, GpuError> {
        crate::readback::read_mapped(&self.device, buffer, len)
    }
}

/// True when `n` boxes could have 2^32 or more candidate pairs, more than
/// the u32 pair count of the scan can hold.
fn may_wrap(n: usize) -> bool {
    let n = n as u64;
    n * n.saturating_sub(1) / 2 > u64::from(u32::MAX)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_pair_count_can_wrap_from_92_683_boxes() {
        assert!(!may_wrap(92_682));
        assert!(may_wrap(92_683));
    }

    #[test]
    fn scan_levels_nest_until_one_block() {
        assert_eq!(scan_levels(0, 10).0, vec![(0, 10, 10)]);
        assert_eq!(scan_levels(0, 256).0, vec![(0, 256, 256)]);
        assert_eq!(scan_levels(0, 257).0, vec![(0, 257, 257), (257, 2, 259)]);
        let (levels, end) = scan_levels(0, 256 * 256 * 3);
        assert_eq!(levels.len(), 3);
        assert_eq!(end, 256 * 256 * 3 + 768 + 3 + 1);
        assert_eq!(digits_for(0), 1);
        assert_eq!(digits_for(255), 1);
        assert_eq!(digits_for(256), 2);
        assert_eq!(digits_for(u32::MAX), 4);
    }
}
