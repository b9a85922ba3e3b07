//! The prescribed motion of a step, handed to the device before the
//! step's one submit (xpbd/motion.rs has the layout):
//!
//! ```text
//! step k   MotionLayout::step(k): every substep's values (f64, the golden
//!          path's) → `rest`'s motion blocks, the call blocks and every
//!          dispatch block rewritten (queue writes, ordered before the
//!          step's submit); the clock k advances when the step is accepted
//! ```
//! A plan without motion has none of this: nothing is written.

use hyperpbd_core::{BackendError, GpuError, Kernel};

use super::GpuBackend;
use crate::params::push_reals;
use crate::xpbd::motion::MotionLayout;

/// The buffers a step's motion values go to, and the clock.
pub(crate) struct Moving {
    pub layout: MotionLayout,
    pub rest: wgpu::Buffer,
    pub calls: wgpu::Buffer,
    pub dispatches: wgpu::Buffer,
    /// Steps accepted (t = step·dt at the start of the next one).
    pub step: u64,
}

impl GpuBackend {
    /// Writes step `self.motion.step`'s values (nothing without motion).
    pub(super) fn upload_motion(&mut self) -> Result<(), GpuError> {
        let Some(moving) = &self.motion else {
            return Ok(());
        };
        let (dim, precision) = (self.plan.dim, self.precision);
        let origin = self.state.origin().clone();
        let (base, blocks) = moving.layout.step(
            &self.plan,
            &origin,
            moving.step,
            &mut self.schedule.calls,
            self.schedule.run_base,
        );
        let queue = &self.ctx.queue;
        let mut bytes = Vec::new();
        push_reals(&mut bytes, &blocks, precision);
        let at = (base * crate::params::real_size(precision)) as u64;
        queue.write_buffer(&moving.rest, at, &bytes);
        let mut calls = Vec::new();
        for call in &self.schedule.calls {
            calls.extend(call.encode(dim, precision));
        }
        queue.write_buffer(&moving.calls, 0, &calls);
        let mut blocks = vec![0u8; moving.dispatches.size() as usize];
        for placed in self.exact.iter().chain(&self.fast).chain(&self.alone) {
            let block = placed.dispatch.block(&self.schedule.calls, dim, precision);
            let at = placed.offset as usize;
            blocks[at..at + block.len()].copy_from_slice(&block);
        }
        queue.write_buffer(&moving.dispatches, 0, &blocks);
        Ok(())
    }

    /// The clock after an accepted step.
    pub(super) fn motion_step_done(&mut self) {
        if let Some(moving) = &mut self.motion {
            moving.step += 1;
        }
    }

    /// A kernel alone reads values no step has written: refused for a
    /// plan with motion (its kernels run inside whole steps).
    pub(super) fn refuse_alone_with_motion(&self, kernel: Kernel) -> Result<(), BackendError> {
        if self.motion.is_some() {
            return Err(BackendError::InvalidCall(format!(
                "run_kernel({kernel:?}): a plan with prescribed motion runs its kernels inside \
                 whole steps on the GPU (the motion values are written per step)"
            )));
        }
        Ok(())
    }
}
