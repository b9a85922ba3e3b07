//! The step's status word and report, and their one read-back: failures
//! and loops a software adapter cut short.
//!
//! ```text
//! status    [first failing call (NONE), its smallest index (NONE), cut flag,
//!           lowest failing world] and, in a batch of W worlds, W words
//!           (nonzero: that world failed); reset before every submission,
//!           copied with the report (2 reals per family and world) to the
//!           staging buffer: status (16 bytes), the report, the W words
//! llvmpipe: one counter per group of 8 neighbouring invocations (its SIMD
//!           width), 65 535 loop iterations in all loops together; past it
//!           every loop runs its body once and stops, silently (measured:
//!           gpu/src/barrier.rs)
//! kernels:  a two-trip probe loop at the end (trip count unknown to the
//!           compiler) counts 1 instead of 2 once the budget is spent →
//!           status[2] (step.wgsl) or the contact outcome (contact.wgsl)
//! host:     any cut → x and v restored from the step's saved copy, then
//!           GpuError::Unsupported; never a silently shortened step
//! ```

use hyperpbd_core::{BackendError, GpuError};

use crate::context::GpuContext;
use crate::loop_budget::loops_cut_short;
use crate::resident_backend::Resident;
use crate::xpbd::NONE;

/// The status word, the residual report and their staging buffer.
pub(crate) struct StatusReader {
    pub status: wgpu::Buffer,
    pub report: wgpu::Buffer,
    /// Read-back of status (16 bytes) followed by the report and the
    /// worlds' words.
    staging: wgpu::Buffer,
    report_bytes: u64,
    /// Worlds with a word of their own (0 for one world).
    worlds: u64,
}

impl StatusReader {
    /// The status word as a step starts it.
    pub const RESET: [u32; 4] = [NONE, NONE, 0, NONE];

    /// Over `status` (reset), `report` (`report_bytes` of it read back)
    /// and their `staging` buffer (16 + `report_bytes` + 4 per world);
    /// `worlds` words of the worlds' own (0 for one world).
    pub fn new(
        (status, report, report_bytes): (wgpu::Buffer, wgpu::Buffer, u64),
        staging: wgpu::Buffer,
        worlds: u64,
    ) -> Self {
        StatusReader {
            status,
            report,
            staging,
            report_bytes,
            worlds,
        }
    }

    /// The status words as a step starts them: [`Self::RESET`], then a
    /// zero per world of a batch (`worlds`, 0 for one world).
    pub fn reset_words(worlds: u64) -> Vec<u32> {
        let mut words = Self::RESET.to_vec();
        words.resize(4 + worlds as usize, 0);
        words
    }

    /// Clears the status words before a submission.
    pub fn reset(&self, ctx: &GpuContext) {
        let words = Self::reset_words(self.worlds);
        ctx.queue
            .write_buffer(&self.status, 0, bytemuck::cast_slice(&words));
    }

    /// Copies the status word (and the report and the worlds' words when
    /// `report`) to staging.
    pub fn copy_out(&self, encoder: &mut wgpu::CommandEncoder, report: bool) {
        encoder.copy_buffer_to_buffer(&self.status, 0, &self.staging, 0, 16);
        if report && self.report_bytes > 0 {
            let bytes = self.report_bytes;
            encoder.copy_buffer_to_buffer(&self.report, 0, &self.staging, 16, bytes);
        }
        if report && self.worlds > 0 {
            let at = 16 + self.report_bytes;
            encoder.copy_buffer_to_buffer(&self.status, 16, &self.staging, at, 4 * self.worlds);
        }
    }

    /// The staging buffer and its length with the report (for a read of
    /// several buffers with one wait).
    pub fn staged(&self) -> (&wgpu::Buffer, u64) {
        (&self.staging, 16 + self.report_bytes + 4 * self.worlds)
    }

    /// Maps the staging buffer (its submission already made) and copies
    /// the status block (and the report and worlds' words when `report`)
    /// out.
    pub fn read(&self, ctx: &GpuContext, report: bool) -> Result<Vec<u8>, GpuError> {
        let len = if report { self.staged().1 } else { 16 };
        ctx.read(&self.staging, len)
    }

    /// The report of a block read with it (after the 16 status bytes).
    pub fn report_of<'a>(&self, block: &'a [u8]) -> &'a [u8] {
        let end = (16 + self.report_bytes as usize).min(block.len());
        &block[16.min(end)..end]
    }

    /// The worlds that failed, by the words of a block read with the
    /// report (a batch's; empty for one world).
    pub fn failed_worlds(&self, block: &[u8]) -> Vec<bool> {
        let from = 16 + self.report_bytes as usize;
        let words = block
            .get(from..from + 4 * self.worlds as usize)
            .unwrap_or(&[]);
        words.chunks_exact(4).map(|w| w != [0; 4]).collect()
    }

    /// The failing call and index a status block names, if any.
    pub fn failure(block: &[u8]) -> Option<(u32, u32)> {
        let words: &[u32] = bytemuck::cast_slice(&block[..8]);
        (words[0] != NONE).then_some((words[0], words[1]))
    }
}

/// Refuses a submitted step whose status block (16 bytes: failing call,
/// index, cut flag, world) says a step kernel's loops were cut short,
/// restoring x and v first.
pub(crate) fn refuse_cut_loops(on: &mut Resident, block: &[u8]) -> Result<(), BackendError> {
    let words: &[u32] = bytemuck::cast_slice(&block[..16]);
    if words[2] == 0 {
        return Ok(());
    }
    Err(on.roll_back_after(loops_cut_short(None).into()))
}
