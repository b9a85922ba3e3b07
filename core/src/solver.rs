//! Which solver path a scene takes, and the incremental-potential settings.
//!
//! ```text
//! "solver": {"type": "xpbd"}                                  (default)
//! "solver": {"type": "xpbd", "primal_residual": true}         (XPBD whose fixed
//!            point is backward Euler's; CPU only so far)
//! "solver": {"type": "incremental_potential",
//!            "barrier_stiffness": κ, "activation_distance": d^,
//!            "convergence": {"kind": "packed_gradient" | "max_acceleration_residual",
//!                            "tolerance": t},
//!            "max_iterations": n,
//!            "cg_iterations": c,                        (optional, default 200)
//!            "warm_start": "inertial" | "previous",      (optional, see below)
//!            "friction_slip_velocity": ε_v}             (optional, default 1e-3 m/s)
//! ```
//! A scene with constraint families, `collisions`, a hyperplane with
//! friction, or an explicit `warm_start` runs the coupled implicit step
//! (docs/implicit.md §7; CPU only); any other incremental-potential scene
//! runs the per-particle minimiser, which is that step's special case with
//! no coupling term and the warm start at x^t.

use serde::{Deserialize, Serialize};

/// The solver path of a scene.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum Solver {
    /// Substepped XPBD (the default).
    Xpbd(XpbdSettings),
    /// Per-step minimisation of the incremental potential with barriers.
    IncrementalPotential(IncrementalPotentialSettings),
}

impl Default for Solver {
    fn default() -> Self {
        Solver::Xpbd(XpbdSettings::default())
    }
}

impl Solver {
    /// True for the XPBD path with default settings (omitted from JSON
    /// output).
    pub fn is_xpbd(&self) -> bool {
        *self == Solver::default()
    }
}

/// Settings of the XPBD path (every key optional; an unknown key is
/// refused with its name, so a misspelt setting never runs the default).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct XpbdSettings {
    /// Carry the primal residual: every element keeps the displacement its
    /// force put on its particles and an update replaces it, so that the
    /// iteration's fixed point is the backward-Euler step's
    /// (`cpu/src/consistent.rs`, docs/equilibria.md). Off by
    /// default: the standard update, which assumes the residual is 0.
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub primal_residual: bool,
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
    /// CG iterations allowed per Newton direction of the coupled step (≥ 1;
    /// [`DEFAULT_CG_ITERATIONS`] when omitted).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cg_iterations: Option<u32>,
    /// Where the coupled step's Newton iteration starts ([`WarmStart::Inertial`]
    /// when omitted). Giving it asks for the coupled step even without
    /// coupling terms.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub warm_start: Option<WarmStart>,
    /// ε_v > 0, length/time: below this slip velocity lagged friction is the
    /// smoothed static branch ([`DEFAULT_FRICTION_SLIP_VELOCITY`] when
    /// omitted).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub friction_slip_velocity: Option<f64>,
}

/// CG iterations per Newton direction when `cg_iterations` is omitted.
pub const DEFAULT_CG_ITERATIONS: u32 = 200;

/// ε_v (m/s) when `friction_slip_velocity` is omitted: a sticking contact
/// creeps at most this fast (docs/implicit.md §8).
pub const DEFAULT_FRICTION_SLIP_VELOCITY: f64 = 1e-3;

/// The first Newton iterate of the coupled step.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum WarmStart {
    /// x^t + τ (x~ − x^t), τ the certified fraction of the inertial
    /// prediction over every barrier term.
    Inertial,
    /// x^t, the accepted state.
    Previous,
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
