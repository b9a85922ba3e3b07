//! Compute pipelines: one per entry point, built once per (dimension,
//! precision) at backend creation, sharing one pipeline layout.
//!
//! ```text
//! group 0: x v p inv_mass gravity_scale force elements rest lambda status resid report
//! group 1: params (read-only storage, dynamic offset: one block per call)
//! ```

use crate::kernel_set::Binding;
use crate::shader::ShaderFile;

/// Every kernel entry point.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Entry {
    Predict,
    Velocity,
    Damping,
    ProjectDistance,
    ProjectSimplexMeasure,
    ProjectOrientedMeasure,
    ProjectContact,
    Friction,
    Residual,
    Reduce,
}

impl Entry {
    pub const ALL: [Entry; 10] = [
        Entry::Predict,
        Entry::Velocity,
        Entry::Damping,
        Entry::ProjectDistance,
        Entry::ProjectSimplexMeasure,
        Entry::ProjectOrientedMeasure,
        Entry::ProjectContact,
        Entry::Friction,
        Entry::Residual,
        Entry::Reduce,
    ];

    fn source(self) -> (ShaderFile, &'static str) {
        match self {
            Entry::Predict => (ShaderFile::Integrate, "predict"),
            Entry::Velocity => (ShaderFile::Integrate, "velocity"),
            Entry::Damping => (ShaderFile::Integrate, "damping"),
            Entry::ProjectDistance => (ShaderFile::Project, "project_distance"),
            Entry::ProjectSimplexMeasure => (ShaderFile::Project, "project_simplex_measure"),
            Entry::ProjectOrientedMeasure => (ShaderFile::Project, "project_oriented_measure"),
            Entry::ProjectContact => (ShaderFile::Project, "project_contact"),
            Entry::Friction => (ShaderFile::Friction, "friction"),
            Entry::Residual => (ShaderFile::Residual, "residual"),
            Entry::Reduce => (ShaderFile::Residual, "reduce"),
        }
    }
}

impl crate::kernel_set::EntryPoint for Entry {
    fn source(self) -> (ShaderFile, &'static str) {
        Entry::source(self)
    }
}

/// Group-0 bindings of the step kernels, in binding order:
/// x v p inv_mass gravity_scale force elements rest lambda status resid report.
pub const STATE_BINDINGS: [Binding; 12] = [
    Binding::WRITE,
    Binding::WRITE,
    Binding::WRITE,
    Binding::READ,
    Binding::READ,
    Binding::READ,
    Binding::READ,
    Binding::READ,
    Binding::WRITE,
    Binding::WRITE,
    Binding::WRITE,
    Binding::WRITE,
];
