//! The patches the patch study runs (`config.patch_cases`): dimension
//! and law.

use hyperpbd::ConstraintKind;
use serde::Serialize;

/// The hyperelastic law of a patch.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum PatchLaw {
    /// St. Venant–Kirchhoff.
    Stvk,
    /// Compressible Neo-Hookean.
    NeoHookean,
}

impl PatchLaw {
    /// The material family's kind.
    pub fn kind(self) -> ConstraintKind {
        match self {
            PatchLaw::Stvk => ConstraintKind::Stvk,
            PatchLaw::NeoHookean => ConstraintKind::NeoHookean,
        }
    }

    /// As written in tables.
    pub fn name(self) -> &'static str {
        match self {
            PatchLaw::Stvk => "StVK",
            PatchLaw::NeoHookean => "Neo-Hookean",
        }
    }
}

/// A stressed patch: dimension and law.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct PatchCase {
    /// N.
    pub dim: usize,
    /// The law.
    pub law: PatchLaw,
}

impl PatchCase {
    /// "2D StVK".
    pub fn name(self) -> String {
        format!("{}D {}", self.dim, self.law.name())
    }
}
