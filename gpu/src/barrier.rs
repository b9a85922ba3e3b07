//! Kernel-level entry points of the barrier path on the GPU
//! (`shaders/barrier.wgsl`): per-particle barrier evaluation (energy,
//! gradient, PSD-projected Hessian block, smallest distance) and the
//! certified step-filter fraction, one invocation per particle looping over
//! every obstacle; plus the f64 `ln` helper's own check. Results whose
//! loops llvmpipe cut short are refused (below).
//!
//! ```text
//! BarrierKernels::new(adapter, precision, dim, law, obstacles)   pipelines + obstacle upload
//! evaluate(positions, radii)            -> BarrierEvaluation      (one dispatch)
//! filter_fractions(positions, radii, Δ) -> fraction per particle  (one dispatch)
//! ```
//!
//! llvmpipe's loop budget (measured on Mesa 22.3.6, LLVM 15, 256-bit
//! vectors: `tests/gpu/llvmpipe_loop_budget.rs`) and what these kernels do
//! about it:
//!
//! ```text
//! budget     65 535 loop iterations per dispatch and SIMD group of 8
//!            neighbouring invocations (256 bits / 32), all loops of the
//!            kernel together: not per loop, not per invocation; a lane
//!            is cut by its neighbours' loops too
//! cost       a loop with a data-dependent trip count n costs n + 1 (the
//!            group runs it while any lane is in it); a loop with a
//!            constant trip count is unrolled and costs nothing
//! when spent every loop runs its body once and stops, silently
//! probe      every entry point ends with check_loops: two trips, trip
//!            count unknown to the compiler; 1 → status[LOOPS_CUT] =
//!            smallest such particle → GpuError::Unsupported, results
//!            refused (the step: x and v restored)
//! cost here  per pass over the obstacles: 1 per plane, 11 per visited
//!            triangle (measured; 147 before the closest-point solve's
//!            inner loops got constant trip counts: the face loop's 2^k
//!            remains), 1 per hierarchy node visited;
//!            ip_gradient makes one pass, ip_newton one for the filter and
//!            one per Armijo trial (it reuses ip_gradient's terms at x).
//!            Only the simplices whose boxes overlap the particle's
//!            candidate box are visited (core/src/barrier.rs): before the
//!            hierarchy every simplex was, and 7 200 triangles were refused
//!            on llvmpipe (tests/gpu/barrier_loop_budget.rs)
//! ```
//!
//! Obstacle geometry is laid out for the device in one place,
//! [`obstacle_geometry`], after [`local_obstacles`] has moved it into the
//! device coordinates x − o of a [`SceneOrigin`] (f32 far from the world
//! origin: plane offsets shift by n·o, simplex vertices by −o).

use hyperpbd_core::GpuError;
use hyperpbd_core::barrier::{BarrierLaw, BarrierObstacles, FILTER_SAFETY};

use crate::context::GpuContext;
use crate::kernel_set::{BlockWriter, EntryPoint, KernelSet, KernelSetSpec};
use crate::loop_budget::obstacle_loops_cut_short;
use crate::params::{push_reals, read_reals, real_size};
use crate::shader::{MAX_GPU_DIM, ShaderFile};
use crate::{Precision, SceneOrigin};

/// Per-particle barrier terms read back from the device.
#[derive(Debug, Clone, PartialEq)]
pub struct BarrierEvaluation {
    /// Σ b per particle (f64::INFINITY where some d ≤ 0).
    pub energy: Vec<f64>,
    /// Σ b' ∇d, `particles × dim`.
    pub gradient: Vec<f64>,
    /// Σ b'' n nᵀ, `particles × dim × dim`.
    pub hessian: Vec<f64>,
    /// Smallest d per particle.
    pub min_distance: Vec<f64>,
}

/// `obstacles` in device coordinates x − o (see [`SceneOrigin`]): plane
/// offsets r − n·o, simplex vertices v − o, and the rounding scale
/// recomputed from the shifted geometry, the hierarchy refitted to the
/// shifted boxes (built first if the set is not indexed). The identity
/// when o = 0 (but for that build).
pub fn local_obstacles(obstacles: &BarrierObstacles, origin: &SceneOrigin) -> BarrierObstacles {
    let dim = origin.as_slice().len();
    let mut local = obstacles.clone();
    if !local.is_indexed() {
        local.reindex(dim);
    }
    if origin.is_zero() {
        return local;
    }
    let mut scale: f64 = 0.0;
    for (offset, normal) in local
        .plane_offsets
        .iter_mut()
        .zip(obstacles.plane_normals.chunks_exact(dim))
    {
        *offset = origin.local_offset(normal, *offset);
        scale = scale.max(offset.abs());
    }
    let slots = hyperpbd_core::barrier::SIMPLEX_SLOTS;
    for (s, &arity) in obstacles.simplex_arity.iter().enumerate() {
        let used = s * slots * dim..(s * slots + arity as usize) * dim;
        let shifted = origin.to_local(&obstacles.simplex_vertices[used.clone()]);
        scale = shifted.iter().fold(scale, |m, c| m.max(c.abs()));
        local.simplex_vertices[used].copy_from_slice(&shifted);
    }
    local.scale = scale;
    local.hierarchy = local.hierarchy.refit(&local.simplex_boxes(dim));
    local
}

/// The obstacle geometry as the kernels read it: reals
/// `[plane normals | plane offsets | simplex vertices (4 slots each) |
/// hierarchy node boxes]` and words `[arity of each simplex | hierarchy
/// node words]` (at least one word, so the buffer is never empty), of an
/// indexed set ([`BarrierObstacles::is_indexed`]). Node
/// boxes rounded to f32 are the boxes of the simplices' f32 vertices
/// (rounding is monotone).
pub fn obstacle_geometry(obstacles: &BarrierObstacles) -> (Vec<f64>, Vec<u32>) {
    let mut reals = obstacles.plane_normals.clone();
    reals.extend(&obstacles.plane_offsets);
    reals.extend(&obstacles.simplex_vertices);
    reals.extend(obstacles.hierarchy.node_boxes());
    let mut arity = obstacles.simplex_arity.clone();
    arity.extend(obstacles.hierarchy.node_words());
    if arity.is_empty() {
        arity.push(0);
    }
    (reals, arity)
}

/// Entry points of `shaders/barrier.wgsl`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum BarrierEntry {
    Evaluate,
    Filter,
    Ln,
}

impl EntryPoint for BarrierEntry {
    fn source(self) -> (ShaderFile, &'static str) {
        let name = match self {
            BarrierEntry::Evaluate => "evaluate",
            BarrierEntry::Filter => "filter_fraction",
            BarrierEntry::Ln => "ln_check",
        };
        (ShaderFile::Barrier, name)
    }
}

/// Words of the status block the barrier and incremental-potential kernels
/// share (binding 10): four of the incremental-potential step, then
/// [`LOOPS_CUT`].
pub(crate) const STATUS_WORDS: usize = 5;
/// Status word: the smallest particle whose loops were cut short (`NONE`:
/// none).
pub(crate) const LOOPS_CUT: usize = 4;
/// An index word that holds no index.
pub(crate) const NONE: u32 = u32::MAX;

/// `Err` naming the first particle whose loops were cut short, if the
/// status words say any were.
pub(crate) fn refuse_cut_loops(status: &[u32; STATUS_WORDS]) -> Result<(), GpuError> {
    match status[LOOPS_CUT] {
        NONE => Ok(()),
        particle => Err(obstacle_loops_cut_short(particle)),
    }
}

/// The status words in `bytes` (little-endian u32s, as the device wrote them).
pub(crate) fn status_words(bytes: &[u8]) -> [u32; STATUS_WORDS] {
    let mut words = [0u32; STATUS_WORDS];
    for (w, b) in words.iter_mut().zip(bytes.chunks_exact(4)) {
        *w = u32::from_le_bytes([b[0], b[1], b[2], b[3]]);
    }
    words
}

/// The refusal for a free particle that a kernel found at d ≤ 0, with the
/// obstacle and distance the golden path computes at `position`; where f64
/// finds it feasible (the f32 floor), the nearest obstacle and its f64
/// distance, both measured, rather than an invented 0.
pub(crate) fn infeasible_start(
    plan: &hyperpbd_core::Plan,
    obstacles: &BarrierObstacles,
    position: &[f64],
    particle: usize,
) -> hyperpbd_core::Refusal {
    let mut normal = vec![0.0; plan.dim];
    let mut nearest = (0, f64::INFINITY);
    for o in 0..obstacles.len() {
        let distance = obstacles.distance(o, position, plan.radius[particle], &mut normal);
        if distance.is_nan() || distance <= 0.0 {
            return hyperpbd_core::Refusal::InfeasibleStart {
                particle,
                obstacle: obstacles.source(o) as usize,
                distance,
            };
        }
        if distance < nearest.1 {
            nearest = (o, distance);
        }
    }
    hyperpbd_core::Refusal::InfeasibleStart {
        particle,
        obstacle: obstacles.source(nearest.0) as usize,
        distance: nearest.1,
    }
}

/// What both incremental-potential GPU backends load the same way: the
/// resident state (dense layout, positions relative to the scene origin)
/// and `shaders/barrier.wgsl`'s bindings 1..=9 (radius, obstacle geometry
/// and arities in device coordinates, delta, the per-particle energy,
/// gradient, Hessian block and scalar, the barrier params), in binding order.
pub(crate) fn barrier_resources(
    ctx: &GpuContext,
    plan: &hyperpbd_core::Plan,
    ip: &hyperpbd_core::IncrementalPotentialPlan,
    state: &hyperpbd_core::State,
    precision: Precision,
) -> Result<(crate::resident::ResidentState, Vec<wgpu::Buffer>), hyperpbd_core::BackendError> {
    let (n, dim) = (plan.particle_count(), plan.dim);
    let reals = |values: &[f64]| {
        let mut b = Vec::new();
        push_reals(&mut b, values, precision);
        b
    };
    let zeros = |len: usize| vec![0u8; len * real_size(precision)];
    let origin = SceneOrigin::for_state(dim, &state.positions, precision);
    let obstacles = local_obstacles(&ip.obstacles, &origin);
    let resident = crate::resident::ResidentState::new(
        ctx,
        crate::layout::VectorLayout::Dense,
        precision,
        origin,
        state,
        &plan.inverse_mass,
        &plan.force,
    )?;
    let (geometry, arity) = obstacle_geometry(&obstacles);
    let buffers = vec![
        ctx.storage("radius", &reals(&plan.radius))?,
        ctx.storage("geometry", &reals(&geometry))?,
        ctx.storage("arity", bytemuck::cast_slice(&arity))?,
        ctx.storage("delta", &zeros(1))?,
        ctx.storage("energy", &zeros(n))?,
        ctx.storage("gradient", &zeros(n * dim))?,
        ctx.storage("hessian", &zeros(n * dim * dim))?,
        ctx.storage("scalar", &zeros(n))?,
        ctx.storage(
            "barrier params",
            &barrier_params(precision, n, &obstacles, &ip.law),
        )?,
    ];
    Ok((resident, buffers))
}

/// The `BarrierParams` block of `shaders/barrier.wgsl`.
pub(crate) fn barrier_params(
    precision: Precision,
    particles: usize,
    obstacles: &BarrierObstacles,
    law: &BarrierLaw,
) -> Vec<u8> {
    BlockWriter::new(precision)
        .words(&[
            particles as u32,
            obstacles.plane_count() as u32,
            obstacles.simplex_count() as u32,
            0,
        ])
        .reals(&[
            law.stiffness,
            law.activation_distance,
            FILTER_SAFETY,
            obstacles.scale,
        ])
        .finish()
}

/// Pipelines and resident obstacle data of the barrier kernels.
pub struct BarrierKernels {
    ctx: GpuContext,
    kernels: KernelSet<BarrierEntry>,
    precision: Precision,
    dim: usize,
    geometry: wgpu::Buffer,
    arity: wgpu::Buffer,
    obstacles: BarrierObstacles,
    law: BarrierLaw,
}

impl BarrierKernels {
    /// Creates a device on `adapter`, builds the pipelines for `dim` and
    /// `precision`, and uploads the obstacles.
    pub fn new(
        adapter: &wgpu::Adapter,
        precision: Precision,
        dim: usize,
        law: BarrierLaw,
        obstacles: &BarrierObstacles,
    ) -> Result<Self, GpuError> {
        if dim == 0 || dim > MAX_GPU_DIM {
            return Err(GpuError::Unsupported {
                what: format!("dimension {dim} (the GPU kernels support 1..={MAX_GPU_DIM})"),
            });
        }
        let ctx = GpuContext::new(adapter, precision)?;
        let kernels = KernelSet::new(
            &ctx,
            &KernelSetSpec {
                label: "hyperpbd barrier",
                modules: &[ShaderFile::Barrier],
                dim,
                precision,
                entries: &[
                    BarrierEntry::Evaluate,
                    BarrierEntry::Filter,
                    BarrierEntry::Ln,
                ],
                constants: &[],
                generated: None,
            },
        )?;
        let mut obstacles = obstacles.clone();
        if !obstacles.is_indexed() {
            obstacles.reindex(dim);
        }
        let (reals, arity) = obstacle_geometry(&obstacles);
        let mut bytes = Vec::new();
        push_reals(&mut bytes, &reals, precision);
        let storage = wgpu::BufferUsages::STORAGE;
        let geometry = ctx.buffer("geometry", &bytes, storage)?;
        let arity = ctx.buffer("arity", bytemuck::cast_slice(&arity), storage)?;
        ctx.check()?;
        Ok(BarrierKernels {
            ctx,
            kernels,
            precision,
            dim,
            geometry,
            arity,
            obstacles,
            law,
        })
    }

    /// Barrier energy, gradient, Hessian block and smallest distance of
    /// every particle (`positions` flat, `radii` one per particle).
    pub fn evaluate(
        &self,
        positions: &[f64],
        radii: &[f64],
    ) -> Result<BarrierEvaluation, GpuError> {
        let n = radii.len();
        let out = self.run(BarrierEntry::Evaluate, positions, radii, &[], n)?;
        let infinite = |e: f64| {
            let max = match self.precision {
                Precision::F32 => f64::from(f32::MAX),
                Precision::F64 => f64::MAX,
            };
            if e >= max { f64::INFINITY } else { e }
        };
        Ok(BarrierEvaluation {
            energy: out[0].iter().map(|&e| infinite(e)).collect(),
            gradient: out[1].clone(),
            hessian: out[2].clone(),
            min_distance: out[3].clone(),
        })
    }

    /// Certified admissible fraction of the step `deltas` (flat) of every
    /// particle.
    pub fn filter_fractions(
        &self,
        positions: &[f64],
        radii: &[f64],
        deltas: &[f64],
    ) -> Result<Vec<f64>, GpuError> {
        let n = radii.len();
        let mut out = self.run(BarrierEntry::Filter, positions, radii, deltas, n)?;
        Ok(std::mem::take(&mut out[3]))
    }

    /// `ln` of every value as the kernels compute it (the arithmetic-only
    /// ln of `ln_f32.wgsl` / `ln_f64.wgsl`).
    pub fn ln(&self, values: &[f64]) -> Result<Vec<f64>, GpuError> {
        let mut out = self.run(BarrierEntry::Ln, &[], &[], values, values.len())?;
        Ok(std::mem::take(&mut out[3]))
    }

    /// Uploads inputs, dispatches `which` over `count` invocations, reads
    /// back [energy, gradient, hessian, scalar].
    fn run(
        &self,
        which: BarrierEntry,
        positions: &[f64],
        radii: &[f64],
        deltas: &[f64],
        count: usize,
    ) -> Result<[Vec<f64>; 4], GpuError> {
        if count == 0 {
            return Ok([Vec::new(), Vec::new(), Vec::new(), Vec::new()]);
        }
        let prepared = self.prepare(positions, radii, deltas, count)?;
        self.dispatch(&prepared, which, 1)?;
        self.read(&prepared)
    }

    /// Inputs and outputs of one batch on the device (for benchmarks that
    /// time the dispatch alone).
    pub fn prepare(
        &self,
        positions: &[f64],
        radii: &[f64],
        deltas: &[f64],
        count: usize,
    ) -> Result<PreparedBatch, GpuError> {
        let dim = self.dim;
        let reals = |values: &[f64]| {
            let mut b = Vec::new();
            push_reals(&mut b, values, self.precision);
            b
        };
        let zeros = |len: usize| vec![0u8; len * real_size(self.precision)];
        let make = |label: &str, bytes: &[u8]| self.ctx.storage(label, bytes);
        let x = make("x", &reals(positions))?;
        let radius = make("radius", &reals(radii))?;
        let delta = make("delta", &reals(deltas))?;
        let energy = make("energy", &zeros(count))?;
        let gradient = make("gradient", &zeros(count * dim))?;
        let hessian = make("hessian", &zeros(count * dim * dim))?;
        let scalar = make("scalar", &zeros(count))?;
        let params = make(
            "barrier params",
            &barrier_params(self.precision, count, &self.obstacles, &self.law),
        )?;
        let status = make("status", bytemuck::cast_slice(&[NONE; STATUS_WORDS]))?;
        let buffers = [
            &x,
            &radius,
            &self.geometry,
            &self.arity,
            &delta,
            &energy,
            &gradient,
            &hessian,
            &scalar,
            &params,
            &status,
        ];
        let group = self.kernels.bind(&self.ctx.device, 0, &buffers, 0)?;
        let r = real_size(self.precision) as u64;
        let sizes = [
            count as u64 * r,
            (count * dim) as u64 * r,
            (count * dim * dim) as u64 * r,
            count as u64 * r,
            (4 * STATUS_WORDS) as u64,
        ];
        let staging = self
            .ctx
            .staging("barrier staging", sizes.iter().sum::<u64>())?;
        self.ctx.check()?;
        Ok(PreparedBatch {
            count: count as u32,
            group,
            outputs: [energy, gradient, hessian, scalar, status],
            sizes,
            staging,
            _inputs: [x, radius, delta, params],
        })
    }

    /// Dispatches the evaluation kernel `repeats` times on a prepared batch
    /// and waits (benchmarks).
    pub fn dispatch_evaluate(&self, batch: &PreparedBatch, repeats: u32) -> Result<(), GpuError> {
        self.dispatch(batch, BarrierEntry::Evaluate, repeats)
    }

    fn dispatch(
        &self,
        batch: &PreparedBatch,
        which: BarrierEntry,
        repeats: u32,
    ) -> Result<(), GpuError> {
        let mut encoder = self.ctx.device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            pass.set_bind_group(0, &batch.group, &[]);
            for _ in 0..repeats {
                self.kernels.dispatch(&mut pass, which, batch.count);
            }
        }
        self.ctx.submit_and_wait(encoder)
    }

    /// Reads back [energy, gradient, hessian, scalar] of a batch, refusing
    /// them when the status block says a particle's loops were cut short.
    pub fn read(&self, batch: &PreparedBatch) -> Result<[Vec<f64>; 4], GpuError> {
        let mut encoder = self.ctx.device.create_command_encoder(&Default::default());
        let mut offset = 0;
        for (buffer, &size) in batch.outputs.iter().zip(&batch.sizes) {
            if size > 0 {
                encoder.copy_buffer_to_buffer(buffer, 0, &batch.staging, offset, size);
            }
            offset += size;
        }
        self.ctx.submit_and_wait(encoder)?;
        let bytes = self.ctx.read(&batch.staging, offset)?;
        let mut out: [Vec<f64>; 4] = Default::default();
        let mut start = 0usize;
        for (k, &size) in batch.sizes[..4].iter().enumerate() {
            out[k] = read_reals(&bytes[start..start + size as usize], self.precision);
            start += size as usize;
        }
        refuse_cut_loops(&status_words(&bytes[start..]))?;
        Ok(out)
    }
}

/// Device buffers of one batch of particles.
pub struct PreparedBatch {
    count: u32,
    group: wgpu::BindGroup,
    /// energy, gradient, hessian, scalar, status.
    outputs: [wgpu::Buffer; 5],
    sizes: [u64; 5],
    staging: wgpu::Buffer,
    _inputs: [wgpu::Buffer; 4],
}
