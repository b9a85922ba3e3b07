//! Dispatch side of simplex-mesh contact on the XPBD step
//! (`shaders/mesh_contact.wgsl` ↔ `cpu/src/project.rs` `mesh_contact_in`
//! and `cpu/src/mesh_contact.rs`): the plan's meshes laid out for the
//! device, in device coordinates x − o (`barrier::local_obstacles`: the
//! vertices shifted, the rounding scale recomputed, the hierarchy refitted;
//! the identity in f64, where o = 0).
//!
//! ```text
//! words  [per family: its mesh's header (NONE: not a mesh family)]
//!        per mesh: header (reals base b, words base k, simplices S, frame F),
//!                  F: where its values of the last substep start in `rest`
//!                  (a moving mesh's residual: motion.rs; NONE when static),
//!                  at k: arity of each simplex, then node words (right, first, last)
//! reals  per mesh: at b the scale, then the vertices (4 slots each), then the node boxes
//! ```
//! A mesh family's contact and friction calls carry FLAG_MESH and run per
//! particle (project.rs, friction.rs); its residual call RESIDUAL_MESH.

use hyperpbd_core::{FamilyKind, Plan};

use super::NONE;
use super::motion::MotionLayout;
use crate::barrier::{local_obstacles, obstacle_geometry};
use crate::origin::SceneOrigin;

/// The meshes of a plan's mesh contact families as the kernels read them
/// (`mesh_reals`, `mesh_words` of mesh_contact.wgsl).
#[derive(Debug, Clone)]
pub(crate) struct MeshLayout {
    pub reals: Vec<f64>,
    pub words: Vec<u32>,
}

impl MeshLayout {
    /// The layout of `plan`'s meshes relative to `origin` (`motion`: the
    /// plan's motion values, if it has any); `None` when no family is a
    /// mesh contact (the module then has no mesh bindings).
    pub fn new(plan: &Plan, origin: &SceneOrigin, motion: Option<&MotionLayout>) -> Option<Self> {
        let is_mesh = |kind: &FamilyKind| matches!(kind, FamilyKind::MeshContact { .. });
        if !plan.families.iter().any(|f| is_mesh(&f.kind)) {
            return None;
        }
        let mut words = vec![NONE; plan.families.len()];
        let mut reals = Vec::new();
        let mut headers = Vec::with_capacity(plan.meshes.len());
        for (m, mesh) in plan.meshes.iter().enumerate() {
            let local = local_obstacles(mesh, origin);
            let (geometry, arity) = obstacle_geometry(&local);
            headers.push(words.len() as u32);
            let base = words.len() + 4;
            let family = plan
                .families
                .iter()
                .position(|f| matches!(f.kind, FamilyKind::MeshContact { mesh, .. } if mesh == m));
            let frame = motion
                .zip(family)
                .and_then(|(l, f)| l.last_mesh_block(plan, f));
            words.extend([
                reals.len() as u32,
                base as u32,
                local.simplex_count() as u32,
                frame.unwrap_or(NONE),
            ]);
            reals.push(local.scale);
            reals.extend(geometry);
            words.extend(arity);
        }
        for (slot, f) in words.iter_mut().zip(&plan.families) {
            if let FamilyKind::MeshContact { mesh, .. } = f.kind {
                *slot = headers[mesh];
            }
        }
        Some(MeshLayout { reals, words })
    }
}

#[cfg(test)]
mod tests {
    use crate::Precision;
    use crate::shader::{ShaderFile, compose_with, mesh_source, validate};

    #[test]
    fn the_step_module_with_meshes_validates_in_every_dimension_and_precision() {
        for dim in 1..=hyperpbd_core::MAX_DIM {
            for precision in [Precision::F32, Precision::F64] {
                let mut generated =
                    crate::xpbd::expression::generated_for(&[], dim, precision, false);
                generated.push_str(&crate::shader::primal_source(false, false));
                generated.push_str(&mesh_source(true));
                let source = compose_with(ShaderFile::Step, dim, precision, Some(&generated));
                let (module, _) = validate(&source, precision)
                    .unwrap_or_else(|e| panic!("dim {dim} {precision}: {e}"));
                let bound: Vec<u32> = (module.global_variables.iter())
                    .filter_map(|(_, v)| v.binding.as_ref().filter(|b| b.group == 0))
                    .map(|b| b.binding)
                    .collect();
                assert!(
                    bound.contains(&16) && bound.contains(&17),
                    "dim {dim}: {bound:?}"
                );
            }
        }
    }
}
