//! Dispatch side of dynamic Coulomb friction (`shaders/friction.wgsl` ↔
//! `cpu/src/friction.rs`): its call block.
//!
//! ```text
//! for each contact with λ > 0:  v −= v_t · min(μ w λ / h, |v_t|) / |v_t|
//! ```
//! Run per particle: particle i finds its slot in the family through the
//! family's particle → slot map (fixed particles have none). A mesh
//! family's normal is the mesh's at x (FLAG_MESH, mesh_contact.wgsl).

use hyperpbd_core::{FamilyKind, Kernel, Plan};

use super::Families;
use super::call::{Call, FLAG_MESH, OP_FRICTION};

/// Friction of contact family `family` (a hyperplane or a mesh).
pub(crate) fn friction(plan: &Plan, families: &Families, family: usize, call: u32) -> Call {
    let f = &plan.families[family];
    let (normal, mu, flags) = match &f.kind {
        FamilyKind::HyperplaneContact { normal, friction } => (normal.clone(), *friction, 0),
        // The mesh's normal at x (mesh_contact.wgsl).
        FamilyKind::MeshContact { friction, .. } => (Vec::new(), *friction, FLAG_MESH),
        FamilyKind::Distance
        | FamilyKind::Tether
        | FamilyKind::SimplexMeasure { .. }
        | FamilyKind::OrientedMeasure
        | FamilyKind::Material { .. }
        | FamilyKind::Expression(_) => (Vec::new(), 0.0, 0),
    };
    let mut c = Call {
        op: OP_FRICTION,
        count: plan.particle_count() as u32,
        family: family as u32,
        slot_base: families.slot_base[family],
        slot_map: families.slot_map[family],
        call,
        h: plan.h,
        friction: mu,
        flags,
        normal,
        kernel: Some(Kernel::Friction { family }),
        ..Call::default()
    };
    if let Some(layout) = &families.motion {
        let substep = super::motion::substep_of(plan, call);
        layout.mark(plan, family, substep, false, &mut c);
    }
    c
}
