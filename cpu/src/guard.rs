//! The state guards' kernels on the CPU (`shaders/guard.wgsl` ↔
//! `gpu/src/xpbd/guard.rs`): read-only checks at the end of a substep,
//! through the arithmetic of `hyperpbd_core::guards`, which the GPU's guard
//! kernel mirrors.
//!
//! ```text
//! GuardMeasure(f)  the first element of family f (slot order) whose measure
//!                  ratio J breaks the orientation or the ratio guard
//! GuardSpeed       the first dynamic particle (index order) faster than the
//!                  speed guard
//! ```
//! A violation is the step's `GuardRejected` error: the backend rolls the
//! step back (and an adaptive step retries it subdivided).

use hyperpbd_core::{Plan, StepError, guards};

/// GuardMeasure of family `family` at positions `x` in substep `substep`.
pub fn measure(plan: &Plan, family: usize, x: &[f64], substep: u32) -> Result<(), StepError> {
    match guards::measure_violation(plan, family, x) {
        None => Ok(()),
        Some(found) => Err(StepError::GuardRejected(guards::measure_rejection(
            plan, family, found, substep,
        ))),
    }
}

/// GuardSpeed at velocities `v` in substep `substep`.
pub fn speed(plan: &Plan, v: &[f64], substep: u32) -> Result<(), StepError> {
    match guards::speed_violation(plan, v) {
        None => Ok(()),
        Some(found) => Err(StepError::GuardRejected(guards::speed_rejection(
            found, substep,
        ))),
    }
}
