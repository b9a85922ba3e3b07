//! What the scene's `guards` and `adaptive` keys ask, which families the
//! measure guards check, and what a guard's rejection says: the state
//! guards' data, apart from the checks (guards.rs), so that the scene, the
//! plan and the step errors can name them without depending on the checks.

use serde::{Deserialize, Serialize};

use crate::{Family, FamilyKind};

/// The `guards` key of a scene: which checks every completed substep
/// must pass (each optional).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Guards {
    /// Reject an element whose signed measure changed sign (J ≤ 0).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub orientation: bool,
    /// Reject an element with J below this ratio, 0 < r ≤ 1.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub min_measure_ratio: Option<f64>,
    /// Reject a dynamic particle faster than this (> 0, length/time).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_speed: Option<f64>,
}

impl Guards {
    /// True when some element check is on.
    pub fn checks_measures(&self) -> bool {
        self.orientation || self.min_measure_ratio.is_some()
    }
}

/// The `adaptive` key of a scene: a step rejected by a guard is retried
/// over the same interval with 2, 4, … 2^k times the substeps.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Adaptive {
    /// k ≥ 1: the most subdivisions of a rejected step.
    pub max_subdivisions: u32,
}

/// Largest `adaptive.max_subdivisions` (2^16 times the substeps).
pub const MAX_SUBDIVISIONS: u32 = 16;

/// Which guard rejected a substep.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum GuardKind {
    /// `orientation`: J ≤ 0.
    Orientation,
    /// `min_measure_ratio`: J < r.
    MinMeasureRatio,
    /// `max_speed`: |v| > v.
    MaxSpeed,
    /// Always on for a moving simplex mesh (no key): a point of the mesh
    /// moves by d ≥ r in one substep, r the smallest radius of a particle
    /// it contacts, so it could pass through that particle
    /// (`moving_mesh::reach_rejection`).
    MeshReach,
}

impl GuardKind {
    /// The JSON key of the guard.
    pub fn as_str(self) -> &'static str {
        match self {
            GuardKind::Orientation => "orientation",
            GuardKind::MinMeasureRatio => "min_measure_ratio",
            GuardKind::MaxSpeed => "max_speed",
            GuardKind::MeshReach => "moving_mesh",
        }
    }
}

/// What a guard rejected: an element of a family or a particle.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum GuardSubject {
    /// Element `element` (authored order) of plan family `family`.
    Element {
        /// Index of the family in the plan.
        family: usize,
        /// `constraints[2]`.
        family_label: String,
        /// Element index in the authored order.
        element: usize,
    },
    /// Particle `particle`.
    Particle(usize),
    /// Authored obstacle `obstacle` (`obstacles[k]`).
    Obstacle(usize),
}

impl std::fmt::Display for GuardSubject {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            GuardSubject::Element {
                family_label,
                element,
                ..
            } => write!(f, "{family_label} element {element}"),
            GuardSubject::Particle(i) => write!(f, "particle {i}"),
            GuardSubject::Obstacle(o) => write!(f, "obstacles[{o}]"),
        }
    }
}

/// A completed substep that a guard rejected.
#[derive(Debug, Clone, PartialEq)]
pub struct GuardRejection {
    /// The guard.
    pub guard: GuardKind,
    /// The element or particle.
    pub subject: GuardSubject,
    /// J (orientation, ratio) or |v| (speed).
    pub value: f64,
    /// The bound it broke: 0 (orientation), r, or v.
    pub limit: f64,
    /// The substep of the attempt (0-based) it happened in.
    pub substep: u32,
}

impl std::fmt::Display for GuardRejection {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let (name, relation) = match self.guard {
            GuardKind::Orientation => ("measure ratio", "<="),
            GuardKind::MinMeasureRatio => ("measure ratio", "<"),
            GuardKind::MaxSpeed => ("speed", ">"),
            GuardKind::MeshReach => ("a displacement per substep", ">="),
        };
        write!(
            f,
            "guard {} rejected substep {}: {} has {name} {} {relation} {}",
            self.guard.as_str(),
            self.substep,
            self.subject,
            self.value,
            self.limit
        )
    }
}

/// One attempt of a step: its substeps and, when a guard rejected it,
/// why.
#[derive(Debug, Clone, PartialEq)]
pub struct Attempt {
    /// Substeps the attempt ran (the plan's times 2^subdivision).
    pub substeps: u32,
    /// The rejection, for a failed attempt.
    pub rejection: Option<GuardRejection>,
}

/// True for the families whose elements are simplices with a rest shape
/// — the families the measure guards check: the oriented measure and the
/// material families. A new simplex family with a rest shape plugs in with
/// one arm here and one in `ElementRatios::ratio`.
pub fn has_rest_shape(family: &Family) -> bool {
    matches!(
        family.kind,
        FamilyKind::OrientedMeasure | FamilyKind::Material { .. }
    )
}

/// The plan's families the measure guards check, in plan order (none
/// without an element guard).
pub fn guarded_families(plan_families: &[Family], guards: &Guards) -> Vec<usize> {
    if !guards.checks_measures() {
        return Vec::new();
    }
    (0..plan_families.len())
        .filter(|&f| has_rest_shape(&plan_families[f]) && !plan_families[f].is_empty())
        .collect()
}
