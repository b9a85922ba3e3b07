//! The device side of the coupled step (`shaders/coupled.wgsl`): its
//! buffers and bind groups, the element upload, one pass per entry point,
//! the block-tree reductions and the small read-backs the host's Newton
//! loop decides on.
//!
//! ```text
//! vectors     one buffer, region R (R_* of the WGSL) at R · n · N reals
//! tree        channels A, B (n terms), E (elements), T (n particles + pairs);
//!             each channel: its terms, then every level's outputs
//! levels      one Level block {src, dst, len, op} per (reduction, level),
//!             rewritten when the element count changes
//! read        copies the wanted reductions' results and the status words
//!             into one probe, one wait, one map
//! elements    ElementLists (core) + codes + [compliance, rest] per element;
//!             capacities grow by doubling (buffers and bind group rebuilt)
//! ```

use hyperpbd_core::GpuError;
use hyperpbd_core::implicit::{ElementLists, REDUCTION_BLOCK};

use super::entries::{Entry, region};
use crate::Precision;
use crate::barrier::{NONE, STATUS_WORDS, status_words};
use crate::context::GpuContext;
use crate::kernel_set::{BlockWriter, KernelSet};
use crate::params::{push_reals, read_reals, real_size};
use crate::resident::ResidentState;

/// The status block before a read: no flag, no index.
pub(super) const STATUS_RESET: [u32; STATUS_WORDS] = [0, NONE, NONE, NONE, NONE];

/// A reduction: its channel and operation (the `op` of `Level`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Reduction {
    /// Σ over channel A.
    SumA,
    /// max over channel A.
    MaxA,
    /// Σ over channel B.
    SumB,
    /// Σ over channel E.
    SumE,
    /// min over channel T.
    MinT,
}

impl Reduction {
    const ALL: [Reduction; 5] = [
        Reduction::SumA,
        Reduction::MaxA,
        Reduction::SumB,
        Reduction::SumE,
        Reduction::MinT,
    ];

    fn channel(self) -> usize {
        match self {
            Reduction::SumA | Reduction::MaxA => 0,
            Reduction::SumB => 1,
            Reduction::SumE => 2,
            Reduction::MinT => 3,
        }
    }

    fn op(self) -> u32 {
        match self {
            Reduction::MaxA => 1,
            Reduction::MinT => 2,
            _ => 0,
        }
    }

    /// The value of an empty reduction (the block tree's pad).
    fn pad(self) -> f64 {
        match self {
            Reduction::MinT => f64::INFINITY,
            _ => 0.0,
        }
    }
}

/// Levels a block tree over at most 2³² terms can take.
const MAX_LEVELS: usize = 6;

/// Output sizes of the levels of a block tree over `len` terms.
fn level_sizes(len: usize) -> Vec<usize> {
    let mut sizes = Vec::new();
    let mut n = len;
    while n > 0 {
        n = n.div_ceil(REDUCTION_BLOCK);
        sizes.push(n);
        if n == 1 {
            break;
        }
    }
    sizes
}

/// The `CoupledParams` block, host side.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct Params {
    pub elements: u32,
    pub arity_max: u32,
    pub criterion: u32,
    pub diagonal: u32,
    pub first_ball: u32,
    pub channels: [u32; 4],
    pub pairs: u32,
    /// cp_set_x: 0 the warm start, 1 x^t, 2 the trial.
    pub mode: u32,
    /// 1 when some simplex has μ > 0 (its lags are walked at x^t).
    pub mesh_friction: u32,
    pub h: f64,
    pub slip: f64,
    pub step: f64,
}

impl Params {
    pub fn bytes(&self, precision: Precision) -> Vec<u8> {
        let epsilon = match precision {
            Precision::F32 => f64::from(f32::EPSILON),
            Precision::F64 => f64::EPSILON,
        };
        BlockWriter::new(precision)
            .words(&[
                self.elements,
                self.arity_max,
                self.criterion,
                self.diagonal,
                self.first_ball,
            ])
            .words(&self.channels)
            .words(&[self.pairs, self.mode, self.mesh_friction])
            .reals(&[self.h, self.h * self.h, self.slip, self.step, epsilon])
            .finish()
    }
}

/// The uploaded element list, host side.
#[derive(Debug, Default)]
pub(super) struct ElementUpload {
    pub lists: ElementLists,
    /// 0 distance, 1 tether, 2 simplex measure, 3 oriented measure, 4 ball,
    /// 5 pair friction lag.
    pub codes: Vec<u32>,
    /// N + 1 per element: [compliance, rest, 0…] (springs), 0s (balls),
    /// [F_max, n] (friction lags).
    pub reals: Vec<f64>,
    /// Index of the first ball element.
    pub first_ball: usize,
}

/// Buffers, bind groups and reductions of the coupled kernels.
pub(super) struct Device {
    pub kernels: KernelSet<Entry>,
    precision: Precision,
    count: usize,
    dim: usize,
    /// Buffers bound at fixed sizes (barrier.wgsl's and the plan's).
    fixed: Vec<wgpu::Buffer>,
    element_words: wgpu::Buffer,
    element_reals: wgpu::Buffer,
    gather: wgpu::Buffer,
    records: wgpu::Buffer,
    slots: wgpu::Buffer,
    pub vectors: wgpu::Buffer,
    pub terms: wgpu::Buffer,
    pub tree: wgpu::Buffer,
    pub params_buffer: wgpu::Buffer,
    /// PCG's scalar state (`CgState`, pcg.rs).
    pub cg: wgpu::Buffer,
    levels: wgpu::Buffer,
    pub status: wgpu::Buffer,
    probe: wgpu::Buffer,
    group: Option<wgpu::BindGroup>,
    levels_group: wgpu::BindGroup,
    level_stride: u32,
    /// Element and pair capacities of the element buffers and the tree.
    capacity: (usize, usize),
    /// Tree offset of each channel's terms and of each level's outputs.
    channels: [(usize, Vec<usize>); 4],
    /// Lengths the level blocks were written for, per reduction.
    lengths: [usize; 5],
    pub params: Params,
    pub record_len: usize,
}

/// Bytes of the probe: four reals, then the status words.
const PROBE_REALS: u64 = 4;

impl Device {
    /// The kernel set's buffers for `count` particles; `fixed` are
    /// barrier.wgsl's bindings 1..=9 followed by mass, gravity_scale,
    /// gravity, obstacle_mu and lag_force, then coupled_material.wgsl's
    /// material_words, material_rest and frames.
    pub fn new(
        ctx: &GpuContext,
        kernels: KernelSet<Entry>,
        precision: Precision,
        (count, dim): (usize, usize),
        fixed: Vec<wgpu::Buffer>,
    ) -> Result<Self, GpuError> {
        let r = real_size(precision);
        let level_stride = ctx.device.limits().min_storage_buffer_offset_alignment;
        let blocks = Reduction::ALL.len() * MAX_LEVELS;
        let levels = ctx.buffer(
            "coupled levels",
            &vec![0u8; blocks * level_stride as usize],
            wgpu::BufferUsages::STORAGE,
        )?;
        let levels_group = kernels.bind(&ctx.device, 1, &[&levels], 16)?;
        let words = |label: &str, len: usize| ctx.storage(label, &vec![0u8; len.max(1) * 4]);
        let reals = |label: &str, len: usize| ctx.storage(label, &vec![0u8; len.max(1) * r]);
        let mut device = Device {
            precision,
            count,
            dim,
            element_words: words("element words", 1)?,
            element_reals: reals("element reals", 1)?,
            gather: words("gather", count + 1)?,
            records: reals("records", 1)?,
            slots: reals("slots", 1)?,
            vectors: reals("vectors", region::COUNT * count * dim)?,
            terms: reals("terms", count * (dim * dim + 2))?,
            tree: reals("tree", 1)?,
            params_buffer: ctx.storage("coupled params", &Params::default().bytes(precision))?,
            cg: ctx.storage(
                "cg state",
                &super::cg_state::CgState::default().bytes(precision),
            )?,
            levels,
            status: ctx.storage("status", bytemuck::cast_slice(&STATUS_RESET))?,
            probe: ctx.staging("probe", PROBE_REALS * 8 + 4 * STATUS_WORDS as u64)?,
            group: None,
            levels_group,
            level_stride,
            capacity: (0, 0),
            channels: Default::default(),
            lengths: [usize::MAX; 5],
            params: Params::default(),
            record_len: 0,
            fixed,
            kernels,
        };
        device.layout_tree(ctx, 0, 0)?;
        Ok(device)
    }

    /// Reallocates the tree for `elements` and `pairs` terms.
    fn layout_tree(
        &mut self,
        ctx: &GpuContext,
        elements: usize,
        pairs: usize,
    ) -> Result<(), GpuError> {
        let n = self.count;
        let mut at = 0;
        for (c, len) in [n, n, elements, n + pairs].into_iter().enumerate() {
            let start = at;
            at += len;
            let mut outputs = Vec::new();
            for size in level_sizes(len) {
                outputs.push(at);
                at += size;
            }
            self.channels[c] = (start, outputs);
            self.params.channels[c] = start as u32;
        }
        self.tree = ctx.storage("tree", &vec![0u8; at.max(1) * real_size(self.precision)])?;
        self.lengths = [usize::MAX; 5];
        Ok(())
    }

    /// (Re)binds group 0 over the resident `state` and the current buffers.
    pub fn bind(&mut self, ctx: &GpuContext, state: &ResidentState) -> Result<(), GpuError> {
        let f = &self.fixed;
        let group = self.kernels.bind(
            &ctx.device,
            0,
            &[
                &state.x,
                &f[0],
                &f[1],
                &f[2],
                &f[3],
                &f[4],
                &f[5],
                &f[6],
                &f[7],
                &f[8],
                &self.status,
                &state.v,
                &state.force,
                &f[9],
                &f[10],
                &f[11],
                &f[12],
                &f[13],
                &self.element_words,
                &self.element_reals,
                &self.gather,
                &self.records,
                &self.slots,
                &self.vectors,
                &self.terms,
                &self.tree,
                &self.params_buffer,
                &self.cg,
                &f[14],
                &f[15],
                &f[16],
            ],
            0,
        )?;
        self.group = Some(group);
        Ok(())
    }

    /// Uploads `elements` (with `pairs` ball pairs), growing the buffers and
    /// rebinding when they do not fit.
    pub fn upload(
        &mut self,
        ctx: &GpuContext,
        state: &ResidentState,
        elements: &ElementUpload,
        pairs: usize,
    ) -> Result<(), GpuError> {
        let (count, dim, r) = (self.count, self.dim, real_size(self.precision));
        let lists = &elements.lists;
        let len = lists.len();
        let width = lists.arity_max * dim;
        self.record_len = 3 + 2 * width;
        if len > self.capacity.0 || pairs > self.capacity.1 || self.group.is_none() {
            let capacity = (len.next_power_of_two(), pairs.next_power_of_two());
            let words = |label: &str, len: usize| ctx.storage(label, &vec![0u8; len.max(1) * 4]);
            let reals = |label: &str, len: usize| ctx.storage(label, &vec![0u8; len.max(1) * r]);
            self.element_words = words("element words", capacity.0 * (2 + lists.arity_max))?;
            self.element_reals = reals("element reals", capacity.0 * (dim + 1))?;
            self.gather = words("gather", count + 1 + capacity.0 * lists.arity_max)?;
            self.records = reals("records", capacity.0 * self.record_len)?;
            self.slots = reals("slots", capacity.0 * width)?;
            self.layout_tree(ctx, capacity.0, capacity.1)?;
            self.capacity = capacity;
            self.bind(ctx, state)?;
        }
        let mut words = elements.codes.clone();
        words.extend(&lists.arity);
        words.extend(&lists.particles);
        let mut gather = lists.offsets.clone();
        gather.extend(&lists.entries);
        let mut reals = Vec::new();
        push_reals(&mut reals, &elements.reals, self.precision);
        for (buffer, bytes) in [
            (&self.element_words, bytemuck::cast_slice::<u32, u8>(&words)),
            (&self.gather, bytemuck::cast_slice(&gather)),
            (&self.element_reals, &reals[..]),
        ] {
            if !bytes.is_empty() {
                ctx.queue.write_buffer(buffer, 0, bytes);
            }
        }
        self.params.elements = len as u32;
        self.params.arity_max = lists.arity_max as u32;
        self.params.first_ball = elements.first_ball as u32;
        self.params.pairs = pairs as u32;
        self.write_levels(ctx, [count, count, count, len, count + pairs]);
        Ok(())
    }

    /// Writes the Level blocks for the reductions' lengths (in
    /// [`Reduction::ALL`] order) when they changed.
    fn write_levels(&mut self, ctx: &GpuContext, lengths: [usize; 5]) {
        if lengths == self.lengths {
            return;
        }
        let stride = self.level_stride as usize;
        let mut bytes = vec![0u8; Reduction::ALL.len() * MAX_LEVELS * stride];
        for (k, reduction) in Reduction::ALL.into_iter().enumerate() {
            let (start, outputs) = &self.channels[reduction.channel()];
            let mut src = *start;
            let mut len = lengths[k];
            for (level, &dst) in outputs
                .iter()
                .enumerate()
                .take(level_sizes(lengths[k]).len())
            {
                let block = BlockWriter::new(self.precision)
                    .words(&[src as u32, dst as u32, len as u32, reduction.op()])
                    .finish();
                let at = (k * MAX_LEVELS + level) * stride;
                bytes[at..at + block.len()].copy_from_slice(&block);
                src = dst;
                len = len.div_ceil(REDUCTION_BLOCK);
            }
        }
        ctx.queue.write_buffer(&self.levels, 0, &bytes);
        self.lengths = lengths;
    }

    /// Writes the params block (before the next submission).
    pub fn write_params(&self, ctx: &GpuContext) {
        ctx.queue
            .write_buffer(&self.params_buffer, 0, &self.params.bytes(self.precision));
    }

    /// Clears the status words (before the next submission).
    pub fn reset_status(&self, ctx: &GpuContext) {
        ctx.queue
            .write_buffer(&self.status, 0, bytemuck::cast_slice(&STATUS_RESET));
    }

    /// Records `entry` over `invocations` in a compute pass of its own.
    pub fn pass(&self, encoder: &mut wgpu::CommandEncoder, entry: Entry, invocations: usize) {
        if invocations == 0 || self.group.is_none() {
            return;
        }
        let mut pass = self.begin(encoder);
        self.dispatch(&mut pass, entry, invocations);
    }

    /// Begins a compute pass with group 0 bound (for [`Device::dispatch`]
    /// and [`Device::reduce_in`]): a submission's dispatches share one pass,
    /// since on lavapipe a pass of its own per dispatch costs more than a
    /// small dispatch (WebGPU orders the dispatches of a pass and makes each
    /// one's writes visible to the next).
    pub fn begin<'e>(&self, encoder: &'e mut wgpu::CommandEncoder) -> wgpu::ComputePass<'e> {
        let mut pass = encoder.begin_compute_pass(&Default::default());
        if let Some(group) = &self.group {
            pass.set_bind_group(0, group, &[]);
        }
        pass
    }

    /// Records `entry` over `invocations` into `pass` (from [`Device::begin`]).
    pub fn dispatch(&self, pass: &mut wgpu::ComputePass<'_>, entry: Entry, invocations: usize) {
        if invocations == 0 {
            return;
        }
        pass.set_bind_group(1, &self.levels_group, &[0]);
        self.kernels.dispatch(pass, entry, invocations as u32);
    }

    /// Records `reduction` level by level into `pass` (from
    /// [`Device::begin`]); where its result will be (a tree offset), or its
    /// pad when it has no terms.
    pub fn reduce_in(
        &self,
        pass: &mut wgpu::ComputePass<'_>,
        reduction: Reduction,
    ) -> Result<usize, f64> {
        let k = Reduction::ALL
            .iter()
            .position(|&r| r == reduction)
            .unwrap_or(0);
        let sizes = level_sizes(self.lengths[k]);
        if self.group.is_none() || sizes.is_empty() {
            return Err(reduction.pad());
        }
        let outputs = &self.channels[reduction.channel()].1;
        for (level, &groups) in sizes.iter().enumerate() {
            let offset = ((k * MAX_LEVELS + level) as u32) * self.level_stride;
            pass.set_bind_group(1, &self.levels_group, &[offset]);
            self.kernels
                .dispatch_workgroups(pass, Entry::Reduce, groups as u32);
        }
        Ok(outputs[sizes.len() - 1])
    }

    /// Records copying region `region` of the vectors into the point buffer.
    pub fn load_point(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        state: &ResidentState,
        region: usize,
    ) {
        let size = (self.count * self.dim * real_size(self.precision)) as u64;
        if size > 0 {
            encoder.copy_buffer_to_buffer(&self.vectors, region as u64 * size, &state.x, 0, size);
        }
    }

    /// Submits `encoder` after recording the copies of `results` (from
    /// [`Device::reduce`]) and the status words into the probe; waits and
    /// returns the values (REAL_MAX read as +∞) and the status words,
    /// refused when some kernel's loops were cut short.
    pub fn read(
        &self,
        ctx: &GpuContext,
        mut encoder: wgpu::CommandEncoder,
        results: &[Result<usize, f64>],
    ) -> Result<(Vec<f64>, [u32; STATUS_WORDS]), GpuError> {
        for (k, &result) in results.iter().enumerate() {
            self.copy_result(&mut encoder, result, k);
        }
        self.read_copied(ctx, encoder, results)
    }

    /// Records copying a reduction's result into probe slot `slot` (now,
    /// before a later reduction on its channel overwrites it).
    pub fn copy_result(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        result: Result<usize, f64>,
        slot: usize,
    ) {
        let r = real_size(self.precision) as u64;
        if let Ok(at) = result {
            let (from, to) = (at as u64 * r, slot as u64 * 8);
            encoder.copy_buffer_to_buffer(&self.tree, from, &self.probe, to, r);
        }
    }

    /// [`Device::read`] of `results` whose copies into the probe (slot k
    /// for results[k]) are already recorded.
    pub fn read_copied(
        &self,
        ctx: &GpuContext,
        mut encoder: wgpu::CommandEncoder,
        results: &[Result<usize, f64>],
    ) -> Result<(Vec<f64>, [u32; STATUS_WORDS]), GpuError> {
        let r = real_size(self.precision) as u64;
        let (status_at, words) = (PROBE_REALS * 8, 4 * STATUS_WORDS as u64);
        encoder.copy_buffer_to_buffer(&self.status, 0, &self.probe, status_at, words);
        let bytes = ctx.submit_and_read(encoder, &self.probe, status_at + words)?;
        let status = status_words(&bytes[status_at as usize..]);
        super::material::refuse_cut_loops_of(&status)?;
        let values = results
            .iter()
            .enumerate()
            .map(|(k, result)| match result {
                Err(pad) => *pad,
                Ok(_) => match read_reals(&bytes[k * 8..k * 8 + r as usize], self.precision)[0] {
                    value if value >= f64::MAX => f64::INFINITY,
                    value => value,
                },
            })
            .collect();
        Ok((values, status))
    }

    /// Reads vector regions back (in `regions` order).
    pub fn read_regions(
        &self,
        ctx: &GpuContext,
        regions: &[usize],
    ) -> Result<Vec<Vec<f64>>, GpuError> {
        let size = (self.count * self.dim * real_size(self.precision)) as u64;
        let copies: Vec<(&wgpu::Buffer, u64, u64)> = regions
            .iter()
            .map(|&region| (&self.vectors, region as u64 * size, size))
            .collect();
        self.read_spans(ctx, &copies)
    }

    /// Reads the per-particle terms and the element records back.
    pub fn read_terms_and_records(
        &self,
        ctx: &GpuContext,
    ) -> Result<(Vec<f64>, Vec<f64>), GpuError> {
        let r = real_size(self.precision) as u64;
        let terms = (self.count * (self.dim * self.dim + 2)) as u64 * r;
        let records = (self.params.elements as usize * self.record_len) as u64 * r;
        let mut out =
            self.read_spans(ctx, &[(&self.terms, 0, terms), (&self.records, 0, records)])?;
        let records = out.pop().unwrap_or_default();
        Ok((out.pop().unwrap_or_default(), records))
    }

    /// Copies spans (buffer, offset, bytes) through one staging buffer.
    fn read_spans(
        &self,
        ctx: &GpuContext,
        spans: &[(&wgpu::Buffer, u64, u64)],
    ) -> Result<Vec<Vec<f64>>, GpuError> {
        let total: u64 = spans.iter().map(|s| s.2).sum();
        let staging = ctx.staging("coupled read-back", total.max(4))?;
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        let mut at = 0;
        for &(buffer, offset, len) in spans {
            if len > 0 {
                encoder.copy_buffer_to_buffer(buffer, offset, &staging, at, len);
            }
            at += len;
        }
        let bytes = ctx.submit_and_read(encoder, &staging, total.max(4))?;
        let mut out = Vec::new();
        let mut at = 0;
        for &(_, _, len) in spans {
            out.push(read_reals(
                &bytes[at as usize..(at + len) as usize],
                self.precision,
            ));
            at += len;
        }
        Ok(out)
    }
}
