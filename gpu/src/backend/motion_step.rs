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

use hyperpbd_core::{BackendError, Kernel, StepError};

use crate::params::push_reals;
use crate::resident_backend::Resident;
use crate::xpbd::Placed;
use crate::xpbd::motion::MotionLayout;
use crate::xpbd::schedule::Schedule;

/// The buffers a step's motion values go to, and the clock.
pub(crate) struct Moving {
    pub layout: MotionLayout,
    pub rest: wgpu::Buffer,
    pub calls: wgpu::Buffer,
    pub dispatches: wgpu::Buffer,
    /// Steps accepted (t = step·dt at the start of the next one).
    pub step: u64,
}

impl Moving {
    /// Writes step `self.step`'s values: into `schedule`'s call blocks
    /// and onto the device (`rest`, the call blocks, every dispatch block
    /// of `placed`); a moving mesh's reach rejection writes nothing.
    pub fn upload<'a>(
        &self,
        on: &Resident,
        schedule: &mut Schedule,
        placed: impl Iterator<Item = &'a Placed>,
    ) -> Result<(), BackendError> {
        let (dim, precision) = (on.plan.dim, on.precision);
        let origin = on.state.origin();
        let (base, blocks) = self
            .layout
            .step(
                &on.plan,
                origin,
                self.step,
                &mut schedule.calls,
                schedule.run_base,
            )
            .map_err(|rejection| BackendError::from(StepError::GuardRejected(rejection)))?;
        let queue = &on.ctx.queue;
        let mut bytes = Vec::new();
        push_reals(&mut bytes, &blocks, precision);
        let at = (base * crate::params::real_size(precision)) as u64;
        queue.write_buffer(&self.rest, at, &bytes);
        let mut calls = Vec::new();
        for call in &schedule.calls {
            calls.extend(call.encode(dim, precision));
        }
        queue.write_buffer(&self.calls, 0, &calls);
        let mut blocks = vec![0u8; self.dispatches.size() as usize];
        for placed in placed {
            let block = placed.dispatch.block(&schedule.calls, dim, precision);
            let at = placed.offset as usize;
            blocks[at..at + block.len()].copy_from_slice(&block);
        }
        queue.write_buffer(&self.dispatches, 0, &blocks);
        Ok(())
    }

    /// The clock after an accepted step.
    pub fn step_done(&mut self) {
        self.step += 1;
    }
}

/// A kernel alone reads values no step has written: refused for a plan
/// with motion (its kernels run inside whole steps).
pub(crate) fn refuse_alone_with_motion(
    motion: Option<&Moving>,
    kernel: Kernel,
) -> Result<(), BackendError> {
    if motion.is_some() {
        return Err(BackendError::InvalidCall(format!(
            "run_kernel({kernel:?}): a plan with prescribed motion runs its kernels inside \
             whole steps on the GPU (the motion values are written per step)"
        )));
    }
    Ok(())
}
