//! Dispatch side of the XPBD projection (`shaders/project.wgsl` ↔
//! `cpu/src/project.rs`): the call block of one colour of one family.
//!
//! ```text
//! Δλ = (−C − α~ λ) / (Σ_j w_j |∇_j C|² + α~),  α~ = α / h²
//! x_j += w_j ∇_j C Δλ                       (inequalities clamp λ first)
//! ```
//! Distance, tether and measure colours run one invocation per element;
//! a hyperplane or mesh family (one colour, one element per dynamic
//! particle) runs per particle, so it fuses with the per-particle calls
//! around it.
//! `first` marks the first projection of the family in its substep: λ is
//! read as 0 there (the CPU resets it in predict) and written on every path.
//! `last` marks its last: a λ nothing reads afterwards (not a contact,
//! whose λ friction and the report read) is then not stored.

use hyperpbd_core::{FamilyKind, Kernel, Plan};

use super::Families;
use super::call::{
    Call, FLAG_FIRST, FLAG_MESH, FLAG_PRIMAL, FLAG_TETHER, FLAG_UNREAD, OP_PROJECT_CONTACT,
    OP_PROJECT_DISTANCE, OP_PROJECT_EXPRESSION, OP_PROJECT_MATERIAL, OP_PROJECT_ORIENTED,
    OP_PROJECT_SIMPLEX,
};

/// Projection of colour `color` of family `family`.
pub(crate) fn project(
    plan: &Plan,
    families: &Families,
    (family, color): (usize, usize),
    call: u32,
    (first, last): (bool, bool),
) -> Call {
    let f = &plan.families[family];
    let range = f.color(color);
    let mut c = Call {
        count: range.len() as u32,
        first: range.start as u32,
        flags: if first { FLAG_FIRST } else { 0 } | if last { FLAG_UNREAD } else { 0 },
        alpha_tilde: f.alpha_tilde(plan.h),
        kernel: Some(Kernel::Project { family, color }),
        ..families.family_call(plan, family, call)
    };
    match &f.kind {
        FamilyKind::Distance => c.op = OP_PROJECT_DISTANCE,
        FamilyKind::Tether => {
            c.op = OP_PROJECT_DISTANCE;
            c.flags |= FLAG_TETHER;
        }
        FamilyKind::SimplexMeasure { .. } => c.op = OP_PROJECT_SIMPLEX,
        FamilyKind::OrientedMeasure => c.op = OP_PROJECT_ORIENTED,
        FamilyKind::Expression(_) => {
            c.op = OP_PROJECT_EXPRESSION;
            c.slot_map = super::expression::expression_index(plan, family);
        }
        FamilyKind::Material { .. } => {
            c.op = OP_PROJECT_MATERIAL;
            super::material::set_fields(f, families, family, &mut c);
        }
        FamilyKind::MeshContact { friction, .. } => {
            // Per particle, as a hyperplane (mesh_contact.wgsl).
            c.flags = (c.flags & !FLAG_UNREAD) | FLAG_MESH;
            c.op = OP_PROJECT_CONTACT;
            c.count = plan.particle_count() as u32;
            c.slot_map = families.slot_map[family];
            c.friction = *friction;
            if let Some(layout) = &families.motion {
                let substep = super::motion::substep_of(plan, call);
                layout.mark(plan, family, substep, false, &mut c);
            }
        }
        FamilyKind::HyperplaneContact { normal, friction } => {
            // friction and the report read a contact's λ: always stored.
            c.flags &= !FLAG_UNREAD;
            c.op = OP_PROJECT_CONTACT;
            c.count = plan.particle_count() as u32;
            c.slot_map = families.slot_map[family];
            c.normal = normal.clone();
            c.friction = *friction;
            if let Some(layout) = &families.motion {
                let substep = super::motion::substep_of(plan, call);
                layout.mark(plan, family, substep, false, &mut c);
            }
        }
    }
    if plan.primal_residual {
        // The update of primal.wgsl: λ is a result (always stored), d_e
        // at the family's offset in `carried`; a material element makes
        // its Newton factor at its first update of the substep (FLAG_FIRST).
        let material = matches!(f.kind, FamilyKind::Material { .. });
        let first_flag = if material { 0 } else { FLAG_FIRST };
        c.flags = (c.flags & !(first_flag | FLAG_UNREAD)) | FLAG_PRIMAL;
        c.carried = families.carried_base[family];
        c.factors = families.factor_base[family];
    }
    c
}
