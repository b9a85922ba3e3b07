//! Which solver path a scene takes, and the incremental-potential settings.
//!
//! ```text
//! "solver": {"type": "xpbd"}                                  (default)
//! "solver": {"type": "incremental_potential",
//!            "barrier_stiffness": κ, "activation_distance": d^,
//!            "convergence": {"kind": "packed_gradient" | "max_acceleration_residual",
//!                            "tolerance": t},
//!            "max_iterations": n}
//! ```

use serde::{Deserialize, Serialize};

/// The solver path of a scene.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum Solver {
    /// Substepped XPBD (the default).
    #[default]
    Xpbd,
    /// Per-step minimisation of the incremental potential with barriers.
    IncrementalPotential(IncrementalPotentialSettings),
}

impl Solver {
    /// True for the default XPBD path (omitted from JSON output).
    pub fn is_xpbd(&self) -> bool {
        matches!(self, Solver::Xpbd)
    }
}

/// Settings of the incremental-potential path.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct IncrementalPotentialSettings {
    /// κ > 0 of b(d) = −κ (d − d^)² ln(d / d^), in energy / length².
    pub barrier_stiffness: f64,
    /// d^ > 0: the barrier is zero at and beyond this distance.
    pub activation_distance: f64,
    /// The explicit stop test.
    pub convergence: Convergence,
    /// Newton iterations allowed per substep (≥ 1).
    pub max_iterations: u32,
}

/// The authored stop test of the Newton iteration.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum Convergence {
    /// ‖∇F‖₂ over all free particles ≤ tolerance (mass·length).
    PackedGradient {
        /// Tolerance > 0 in mass·length.
        tolerance: f64,
    },
    /// maxᵢ ‖∇ᵢF‖ / (mᵢ h²) over free particles ≤ tolerance (length/time²).
    MaxAccelerationResidual {
        /// Tolerance > 0 in length/time².
        tolerance: f64,
    },
}

impl Convergence {
    /// The tolerance, in the criterion's own unit.
    pub fn tolerance(&self) -> f64 {
        match *self {
            Convergence::PackedGradient { tolerance }
            | Convergence::MaxAccelerationResidual { tolerance } => tolerance,
        }
    }

    /// JSON name of the criterion.
    pub fn as_str(&self) -> &'static str {
        match self {
            Convergence::PackedGradient { .. } => "packed_gradient",
            Convergence::MaxAccelerationResidual { .. } => "max_acceleration_residual",
        }
    }
}
