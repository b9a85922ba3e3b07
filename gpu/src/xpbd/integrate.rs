//! Dispatch side of prediction, velocity reconstruction and damping
//! (`shaders/integrate.wgsl` ↔ `cpu/src/integrate.rs`): their call blocks.
//!
//! ```text
//! predict   p = x;  for dynamic i: v += h (s g + w f);  x += h v
//!           (FLAG_UNIT_SCALE: every dynamic s is 1, not loaded)
//! velocity  for dynamic i: v = (x − p) / h
//! damping   for dynamic i: v *= exp(−rate h)      (the plan's factor)
//! ```
//! All three run per particle (`particles` in step.wgsl). Prediction does
//! not reset the multipliers: the first projection of each family in the
//! substep reads λ as 0 (project.rs). With the primal residual
//! (FLAG_PRIMAL) it ends with the warm start x += Σ_e d_e (primal.wgsl).

use hyperpbd_core::{Kernel, Plan};

use super::Families;
use super::call::{
    Call, FLAG_FORCE, FLAG_GRAVITY, FLAG_PRIMAL, FLAG_UNIT_SCALE, OP_DAMPING, OP_PREDICT,
    OP_VELOCITY,
};

/// Prediction of every particle.
pub(crate) fn predict(plan: &Plan, families: &Families, call: u32) -> Call {
    let mut flags = 0;
    if plan.predict.gravity {
        flags |= FLAG_GRAVITY;
    }
    if plan.predict.force {
        flags |= FLAG_FORCE;
    }
    // Every dynamic particle's scale is 1: the kernel skips the load.
    let dynamic = plan.gravity_scale.iter().zip(&plan.inverse_mass);
    if dynamic.filter(|(_, w)| **w != 0.0).all(|(s, _)| *s == 1.0) {
        flags |= FLAG_UNIT_SCALE;
    }
    let mut slot_map = 0;
    if plan.primal_residual {
        flags |= FLAG_PRIMAL;
        slot_map = families.warm_start;
    }
    Call {
        op: OP_PREDICT,
        count: plan.particle_count() as u32,
        call,
        flags,
        h: plan.h,
        gravity: plan.gravity.clone(),
        slot_map,
        kernel: Some(Kernel::Predict),
        ..Call::default()
    }
}

/// v = (x − p) / h of every dynamic particle.
pub(crate) fn velocity(plan: &Plan, call: u32) -> Call {
    Call {
        op: OP_VELOCITY,
        count: plan.particle_count() as u32,
        call,
        h: plan.h,
        kernel: Some(Kernel::Velocity),
        ..Call::default()
    }
}

/// v *= exp(−rate h) of every dynamic particle.
pub(crate) fn damping(plan: &Plan, call: u32) -> Call {
    Call {
        op: OP_DAMPING,
        count: plan.particle_count() as u32,
        call,
        factor: plan.damping.map_or(1.0, |(_, factor)| factor),
        kernel: Some(Kernel::Damping),
        ..Call::default()
    }
}
