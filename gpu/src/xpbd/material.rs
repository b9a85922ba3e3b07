//! Dispatch side of the material families (`shaders/material.wgsl` ↔
//! `core/src/material`, projected as `cpu/src/project.rs` does): the rest
//! data the kernel reads and the call fields of a material call.
//!
//! ```text
//! rest data    per element (colour order): R (k × k, row-major), then V_0,
//!              appended to the `rest` buffer after every family's slots
//! call fields  slot_map = offset of the family's rest data in `rest`
//!              friction = Lamé μ,  factor = Lamé λ,  FLAG_NEO_HOOKEAN
//! ```
//! Both are f64 on the host, rounded once to the device precision (in f64
//! the kernel reads the CPU's values bit for bit).

use hyperpbd_core::material::Law;
use hyperpbd_core::{Family, FamilyKind};

use super::Families;
use super::call::{Call, FLAG_NEO_HOOKEAN};

/// Appends the rest data of `family` (nothing for a family that is not a
/// material family).
pub(crate) fn push_rest_data(family: &Family, rest: &mut Vec<f64>) {
    let FamilyKind::Material {
        order,
        frames,
        measures,
        ..
    } = &family.kind
    else {
        return;
    };
    let kk = order * order;
    for (frame, &measure) in frames.chunks_exact(kk).zip(measures) {
        rest.extend_from_slice(frame);
        rest.push(measure);
    }
}

/// Sets the material fields of `call` for family `family` (a material
/// family; other kinds are left as they are).
pub(crate) fn set_fields(family: &Family, families: &Families, index: usize, call: &mut Call) {
    let FamilyKind::Material { material, .. } = &family.kind else {
        return;
    };
    call.slot_map = families.material_base[index];
    call.friction = material.lame.mu;
    call.factor = material.lame.lambda;
    if material.law == Law::NeoHookean {
        call.flags |= FLAG_NEO_HOOKEAN;
    }
}
