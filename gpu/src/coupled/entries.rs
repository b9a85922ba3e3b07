//! The coupled step's kernel set: its entry points in
//! `shaders/coupled.wgsl`, `shaders/coupled_solve.wgsl` and
//! `shaders/coupled_material.wgsl` (their bindings
//! are the WGSL's own, read by the kernel-set builder), and the vector
//! regions and status words they share with the host.

use crate::kernel_set::EntryPoint;
use crate::shader::ShaderFile;

/// Entry points of `shaders/coupled.wgsl` and `coupled_particles.wgsl`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Entry {
    Elements,
    ElementChanges,
    Slots,
    Start,
    Gradient,
    ParticleCurvature,
    CgResidual,
    CgTurn,
    CgAlpha,
    CgBeta,
    Slope,
    Trial,
    ParticleChanges,
    FilterParticles,
    FilterPairs,
    SetX,
    Finish,
    Reduce,
    MaterialElements,
    MaterialChanges,
    MaterialFrames,
    MaterialSlots,
}

impl Entry {
    /// The entries of a plan without material families (the material
    /// passes are compiled only for a plan that has some).
    pub const SPRINGS: [Entry; 18] = [
        Entry::Elements,
        Entry::ElementChanges,
        Entry::Slots,
        Entry::Start,
        Entry::Gradient,
        Entry::ParticleCurvature,
        Entry::CgResidual,
        Entry::CgTurn,
        Entry::CgAlpha,
        Entry::CgBeta,
        Entry::Slope,
        Entry::Trial,
        Entry::ParticleChanges,
        Entry::FilterParticles,
        Entry::FilterPairs,
        Entry::SetX,
        Entry::Finish,
        Entry::Reduce,
    ];

    /// The material passes (`coupled_material.wgsl`).
    pub const MATERIAL: [Entry; 4] = [
        Entry::MaterialElements,
        Entry::MaterialChanges,
        Entry::MaterialFrames,
        Entry::MaterialSlots,
    ];

    /// The entries a plan needs: every spring pass, and the material passes
    /// when it has material elements.
    pub fn needed(materials: bool) -> Vec<Entry> {
        let mut entries = Entry::SPRINGS.to_vec();
        if materials {
            entries.extend(Entry::MATERIAL);
        }
        entries
    }
}

impl EntryPoint for Entry {
    fn source(self) -> (ShaderFile, &'static str) {
        let name = match self {
            Entry::Elements => "cp_elements",
            Entry::ElementChanges => "cp_element_changes",
            Entry::Slots => "cp_slots",
            Entry::Start => "cp_start",
            Entry::Gradient => "cp_gradient",
            Entry::ParticleCurvature => "cp_particle_curvature",
            Entry::CgResidual => "cp_cg_residual",
            Entry::CgTurn => "cp_cg_turn",
            Entry::CgAlpha => "cp_cg_alpha",
            Entry::CgBeta => "cp_cg_beta",
            Entry::Slope => "cp_slope",
            Entry::Trial => "cp_trial",
            Entry::ParticleChanges => "cp_particle_changes",
            Entry::FilterParticles => "cp_filter_particles",
            Entry::FilterPairs => "cp_filter_pairs",
            Entry::SetX => "cp_set_x",
            Entry::Finish => "cp_finish",
            Entry::Reduce => "cp_reduce",
            Entry::MaterialElements => "cp_material_elements",
            Entry::MaterialChanges => "cp_material_changes",
            Entry::MaterialFrames => "cp_material_frames",
            Entry::MaterialSlots => "cp_material_slots",
        };
        (ShaderFile::Coupled, name)
    }
}

/// Vector regions of `coupled.wgsl` (R_*).
pub(crate) mod region {
    pub const DIRECTION: usize = 1;
    pub const TRIAL: usize = 3;
    pub const X: usize = 8;
    pub const START: usize = 9;
    pub const PREDICTION: usize = 10;
    pub const LOAD: usize = 11;
    /// Regions in all.
    pub const COUNT: usize = 12;
}

/// Status words of `coupled.wgsl` (the header's `status`).
pub(crate) mod status {
    /// A coordinate moved / a trial differs from x (flag).
    pub const MOVED: usize = 0;
    /// First particle with a non-finite gradient or energy.
    pub const NON_FINITE_PARTICLE: usize = 1;
    /// First particle starting at d ≤ 0 from an obstacle.
    pub const INFEASIBLE: usize = 2;
    /// First element with a non-finite record (or a refused frame).
    pub const NON_FINITE_ELEMENT: usize = 3;
}
