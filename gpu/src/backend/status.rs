//! The step's status word: failures and loops a software adapter cut short.
//!
//! ```text
//! status    [first failing call (NONE), its smallest index (NONE), cut flag, 0]
//!           reset before every submission, copied to the report staging
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

use hyperpbd_core::guards::material_refusal_error;
use hyperpbd_core::{Backend, BackendError, FamilyKind, GpuError, Kernel, element_refusal};

use super::GpuBackend;
use crate::loop_budget::loops_cut_short;
use crate::xpbd::schedule::StepMode;
use crate::xpbd::{NONE, Placed};

impl GpuBackend {
    pub(super) fn reset_status(&self) {
        self.ctx.queue.write_buffer(
            &self.buffers.status,
            0,
            bytemuck::cast_slice(&[NONE, NONE, 0u32, NONE]),
        );
    }

    /// Reads the status block: the failing call and index, if any.
    pub(super) fn failure(&self, status: &[u8]) -> Option<(u32, u32)> {
        let words: &[u32] = bytemuck::cast_slice(&status[..8]);
        (words[0] != NONE).then_some((words[0], words[1]))
    }

    /// Refuses a submitted step whose status block (16 bytes: failing call,
    /// index, cut flag, unused) says a step kernel's loops were cut short,
    /// restoring x and v first.
    pub(super) fn refuse_cut_loops(&mut self, status: &[u8]) -> Result<(), BackendError> {
        let words: &[u32] = bytemuck::cast_slice(&status[..16]);
        if words[2] == 0 {
            return Ok(());
        }
        Err(self.roll_back_after(loops_cut_short(None).into()))
    }

    /// `error` after rolling the state back to the step's start: a rollback
    /// that fails itself keeps `error` as its source.
    pub(super) fn roll_back_after(&mut self, error: BackendError) -> BackendError {
        let rollback = self.rollback();
        error.after_rollback(rollback)
    }
}

/// Naming a failed step's error: the failing call, and for a guard the
/// state it saw.
impl GpuBackend {
    /// The error of a step whose status names `failed` (call, index), with
    /// the state rolled back. The fused schedule finds the failing call by
    /// rerunning the step exactly; a rollback or rerun that fails keeps the
    /// step's error as its source.
    pub(super) fn diagnosed_error(&mut self, failed: (u32, u32)) -> BackendError {
        if let Some(rejected) = self.guard_error(failed) {
            return rejected;
        }
        let diagnosed = if self.schedule.mode == StepMode::Fused {
            self.diagnose(failed)
        } else {
            self.rollback().map(|()| failed)
        };
        match diagnosed {
            Ok((call, index)) => self
                .material_error(call, index)
                .unwrap_or_else(|| self.step_error(call, index)),
            Err(e) => self.step_error(failed.0, failed.1).after_rollback(Err(e)),
        }
    }

    fn diagnose(&mut self, fallback: (u32, u32)) -> Result<(u32, u32), GpuError> {
        self.rollback()?;
        self.reset_status();
        let encoder = self.record(|_| {}, &self.exact, 1, false);
        self.submit_and_wait(encoder)?;
        let block = self.read_mapped(&self.buffers.report_staging, 16)?;
        let found = self.failure(&block).unwrap_or(fallback);
        self.rollback()?;
        Ok(found)
    }

    /// The error of a failed material projection (call `call`, slot
    /// `index`; the state rolled back): the law's refusal — or, under
    /// element guards, the guard's rejection — named as the CPU names it
    /// (`guards::material_refusal_error`), from the positions that
    /// projection saw (the step rerun exactly through it: the failing
    /// element wrote nothing and no other element of its colour moves its
    /// particles). `None` for any
    /// other call, or when the element evaluates there (a non-finite
    /// value or update: the caller's `NonFiniteConstraint`).
    fn material_error(&mut self, call: u32, index: u32) -> Option<BackendError> {
        let Some(Kernel::Project { family, .. }) = self.schedule.kernel_of(call) else {
            return None;
        };
        if !matches!(self.plan.families[family].kind, FamilyKind::Material { .. }) {
            return None;
        }
        let seen = self
            .rerun_through(call)
            .map_err(BackendError::from)
            .and_then(|()| self.read_state());
        let rolled_back = self.rollback();
        let positions = match seen {
            Ok(state) => state.positions,
            Err(e) => return Some(e.after_rollback(rolled_back)),
        };
        let f = &self.plan.families[family];
        let refusal = element_refusal(self.plan.dim, f, index as usize, &positions)?;
        let k = self.schedule.kernels_per_substep.max(1) as u32;
        let error = material_refusal_error(&self.plan, family, index as usize, refusal, call / k);
        Some(BackendError::from(error).after_rollback(rolled_back))
    }

    /// Rolls back and reruns the step exactly (one dispatch per call)
    /// through call `call`, leaving the state that call saw.
    pub(super) fn rerun_through(&mut self, call: u32) -> Result<(), GpuError> {
        self.rollback()?;
        self.reset_status();
        let prefix: Vec<Placed> = self
            .exact
            .iter()
            .copied()
            .filter(|d| d.dispatch.first_call <= call)
            .collect();
        let encoder = self.record(|_| {}, &prefix, 1, false);
        self.submit_and_wait(encoder)
    }
}
