//! Dispatch side of the guards (`shaders/guard.wgsl` ↔
//! `hyperpbd_core::guards`, which the CPU runs): their call blocks.
//!
//! ```text
//! guard measure   one invocation per slot of a guarded family:
//!                 J = V(x)/V_rest (material families: their measure ratio,
//!                 FLAG_MATERIAL, slot_map = their rest data); orientation
//!                 J ≤ 0, ratio J < r → fail
//! guard speed     one invocation per particle (dynamic only):
//!                 Σ_a v_a² > v² → fail
//! block           alpha_tilde = r, factor = v² (host f64, then the
//!                 kernels' precision); FLAG_ORIENTATION, FLAG_RATIO
//! ```
//! A failure is the step's status word (call, smallest slot / particle),
//! read back with the step's one status readback; the host then names
//! the value from the state at the failure (`backend/guard.rs`).

use hyperpbd_core::{FamilyKind, Kernel, Plan};

use super::Families;
use super::call::{
    Call, FLAG_MATERIAL, FLAG_ORIENTATION, FLAG_RATIO, OP_GUARD_MEASURE, OP_GUARD_SPEED,
};

/// The measure guards over family `family`.
pub(crate) fn measure(plan: &Plan, families: &Families, family: usize, call: u32) -> Call {
    let fam = &plan.families[family];
    let guards = plan.guards.clone().unwrap_or_default();
    let mut flags = 0;
    if guards.orientation {
        flags |= FLAG_ORIENTATION;
    }
    if guards.min_measure_ratio.is_some() {
        flags |= FLAG_RATIO;
    }
    // A material family's J is its own measure ratio, from its rest data.
    let material = matches!(fam.kind, FamilyKind::Material { .. });
    if material {
        flags |= FLAG_MATERIAL;
    }
    Call {
        op: OP_GUARD_MEASURE,
        flags,
        alpha_tilde: guards.min_measure_ratio.unwrap_or(0.0),
        slot_map: if material {
            families.material_base[family]
        } else {
            0
        },
        kernel: Some(Kernel::GuardMeasure { family }),
        ..families.family_call(plan, family, call)
    }
}

/// The speed guard over every particle.
pub(crate) fn speed(plan: &Plan, call: u32) -> Call {
    let limit = plan
        .guards
        .as_ref()
        .and_then(|g| g.max_speed)
        .unwrap_or(0.0);
    Call {
        op: OP_GUARD_SPEED,
        count: plan.particle_count() as u32,
        call,
        factor: limit * limit,
        kernel: Some(Kernel::GuardSpeed),
        ..Call::default()
    }
}
