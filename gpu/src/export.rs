//! Positions out to a caller's vertex buffer, on the device: the GPU
//! backends inside a wgpu application (`shaders/export_positions.wgsl`).
//!
//! ```text
//! resident x    one vector per particle in the backend's layout (records
//!               of ⌊N/4⌋ + 1 vec4 words for the XPBD path, N reals dense
//!               for the barrier path), f32 or f64, relative to the scene
//!               origin o (f32-representable; zero in f64 unless chosen)
//! export        out[3i + c] = f32(P[c]·o + Σ_a P[c][a] x[i][a])  (P 3 × N,
//!               default the first three axes, zero rows past N)
//! target        the caller's buffer, usage STORAGE (and VERTEX to draw
//!               it), at least 12 · particles bytes: tightly packed
//!               Float32x3 per particle
//! ```
//! One compute dispatch recorded into the caller's encoder: no host round
//! trip, nothing submitted.

use std::sync::OnceLock;

use hyperpbd_core::GpuError;

use crate::context::GpuContext;
use crate::kernel_set::{BlockWriter, EntryPoint, KernelSet, KernelSetSpec};
/// Where the positions sit (it lives with the resident state it
/// describes; re-exported here, where `position_layout` hands it out).
pub use crate::resident::PositionLayout;
use crate::resident::ResidentState;
use crate::shader::ShaderFile;

/// Bytes per exported particle in the caller's buffer (Float32x3).
pub const EXPORT_BYTES_PER_PARTICLE: u64 = 12;

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct ExportEntry;

impl EntryPoint for ExportEntry {
    fn source(self) -> (ShaderFile, &'static str) {
        (ShaderFile::Export, "export_positions")
    }
}

/// The export pipeline of one backend (built on first use).
#[derive(Default)]
pub(crate) struct Exporter {
    kernels: OnceLock<KernelSet<ExportEntry>>,
}

impl Exporter {
    /// Records the export of `state`'s positions (`layout`) into `target`
    /// with projection `projection` (3 × N row-major; `None`: the first
    /// three axes).
    pub fn encode(
        &self,
        ctx: &GpuContext,
        state: &ResidentState,
        layout: &PositionLayout,
        encoder: &mut wgpu::CommandEncoder,
        target: &wgpu::Buffer,
        projection: Option<&[f64]>,
    ) -> Result<(), GpuError> {
        let n = layout.dim;
        let rows = match projection {
            None => (0..3)
                .flat_map(|c| (0..n).map(move |a| if a == c { 1.0 } else { 0.0 }))
                .collect(),
            Some(p) if p.len() == 3 * n && p.iter().all(|v| v.is_finite()) => p.to_vec(),
            Some(p) => {
                return Err(GpuError::Unsupported {
                    what: format!(
                        "projection: {} values; a 3 × {n} matrix of finite values needs {}",
                        p.len(),
                        3 * n
                    ),
                });
            }
        };
        let needed = EXPORT_BYTES_PER_PARTICLE * layout.count as u64;
        if !target.usage().contains(wgpu::BufferUsages::STORAGE) || target.size() < needed {
            return Err(GpuError::Unsupported {
                what: format!(
                    "target buffer: usage {:?}, {} bytes; the export needs STORAGE and at least \
                     {needed} bytes (12 per particle)",
                    target.usage(),
                    target.size()
                ),
            });
        }
        if layout.count == 0 {
            return Ok(());
        }
        let kernels = match self.kernels.get() {
            Some(k) => k,
            None => {
                let built = KernelSet::new(
                    ctx,
                    &KernelSetSpec {
                        label: "export_positions",
                        modules: &[ShaderFile::Export],
                        dim: n,
                        precision: layout.precision,
                        entries: &[ExportEntry],
                        constants: &[],
                        generated: None,
                    },
                )?;
                self.kernels.get_or_init(|| built)
            }
        };
        // Rows padded to 8 lanes (two vec4 per row), then P · o.
        let mut reals = vec![0.0; 6 * 4 + 4];
        for c in 0..3 {
            for a in 0..n {
                reals[8 * c + a] = rows[c * n + a];
            }
            reals[24 + c] = (0..n).map(|a| rows[c * n + a] * layout.origin[a]).sum();
        }
        let block = BlockWriter::new(layout.precision)
            .words(&[layout.count as u32, layout.stride as u32, 0, 0, 0, 0, 0, 0])
            .reals(&reals)
            .finish();
        // A parameter block per recorded export (128 bytes): a caller may
        // record several exports with different projections before one
        // submit, and a shared block rewritten by queue.write_buffer would
        // give all of them the last one's.
        let params = ctx.buffer("export params", &block, wgpu::BufferUsages::UNIFORM)?;
        let group = kernels.bind(&ctx.device, 0, &[&state.x, &params, target], 0)?;
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("export_positions"),
            timestamp_writes: None,
        });
        pass.set_bind_group(0, &group, &[]);
        kernels.dispatch(&mut pass, ExportEntry, layout.count as u32);
        Ok(())
    }
}

/// What a backend lends the export: its device, resident state, export
/// pipeline and particle count (opaque outside the crate).
pub struct ExportParts<'a> {
    ctx: &'a GpuContext,
    state: &'a ResidentState,
    exporter: &'a Exporter,
    count: usize,
}

impl<'a> ExportParts<'a> {
    pub(crate) fn new(
        ctx: &'a GpuContext,
        state: &'a ResidentState,
        exporter: &'a Exporter,
        count: usize,
    ) -> Self {
        ExportParts {
            ctx,
            state,
            exporter,
            count,
        }
    }
}

/// The GPU backends' resident positions, for a caller's wgpu application
/// (both backends: [`crate::GpuBackend`], [`crate::GpuBarrierBackend`];
/// build them on the caller's device with their `with_device`).
pub trait PositionExport {
    /// The backend's device, state and export pipeline.
    #[doc(hidden)]
    fn export_parts(&self) -> ExportParts<'_>;

    /// The resident position buffer (STORAGE | COPY_SRC | COPY_DST), laid
    /// out as [`PositionExport::position_layout`] says; valid while the
    /// backend lives, rewritten by every step.
    fn position_buffer(&self) -> &wgpu::Buffer {
        &self.export_parts().state.x
    }

    /// How positions sit in [`PositionExport::position_buffer`].
    fn position_layout(&self) -> PositionLayout {
        let parts = self.export_parts();
        parts.state.position_layout(parts.count)
    }

    /// Records into `encoder` the copy of the positions, in world
    /// coordinates as f32, into `target` (usage STORAGE, 12 bytes per
    /// particle: Float32x3): the first three axes (zeros past N), or
    /// `projection` (3 × N, row-major) applied to each position. Nothing is
    /// submitted; the copy sees the last step submitted before the
    /// caller's encoder.
    fn encode_positions(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        target: &wgpu::Buffer,
        projection: Option<&[f64]>,
    ) -> Result<(), hyperpbd_core::BackendError> {
        let parts = self.export_parts();
        let layout = parts.state.position_layout(parts.count);
        parts
            .exporter
            .encode(parts.ctx, parts.state, &layout, encoder, target, projection)
            .map_err(hyperpbd_core::BackendError::from)
    }
}
