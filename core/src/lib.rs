//! hyperpbd-core: the scene model, its validation, the compiled [`Plan`],
//! the [`Backend`] trait, typed errors, and the constraint math every
//! backend shares.
//!
//! ```text
//! Scene ──validate──▶ Plan::compile ──▶ Backend::step … read_state
//! ```
//! Nothing here knows about wgpu.

pub mod adaptive;
mod backend;
pub mod barrier;
pub mod broadphase;
pub mod builders;
mod coloring;
pub mod contact_forces;
mod error;
pub mod expr;
mod family;
pub mod geometry;
mod guard_rules;
pub mod guards;
pub mod implicit;
pub mod impulse_recorder;
mod incremental_potential_plan;
mod json;
pub mod kinds;
pub mod material;
mod material_plan;
mod minimisation;
pub mod motion;
pub mod moving_mesh;
mod plan;
mod precision;
mod scene;
mod solver;
mod state;
#[cfg(test)]
mod ulps;
mod validate;
mod validate_guards;
mod validate_material;
mod validate_motion;
mod validate_solver;
pub mod violation;

pub use backend::{Backend, FamilyResidual, StepReport, check_forces, check_kernel, check_state};
pub use builders::SceneBuilder;
pub use coloring::greedy_colors;
pub use contact_forces::ContactForces;
pub use error::{BackendError, GpuError, SceneError, StageName, StepError};
pub use family::{Family, FamilyKind};
pub use geometry::DEGENERATE_VOLUME_RATIO;
pub use guards::{Adaptive, Attempt, GuardKind, GuardRejection, GuardSubject, Guards};
pub use incremental_potential_plan::IncrementalPotentialPlan;
pub use material_plan::{FamilyMass, element_refusal, particle_masses};
pub use minimisation::{MinimisationReport, MinimisationStatus, Refusal};
pub use motion::{Motion, MotionPlan};
pub use plan::{Kernel, ParticleContacts, Plan, PredictTerms, SolverPlan};
pub use precision::Precision;
pub use scene::{
    Collisions, ConstraintFamily, ConstraintKind, Damping, MAX_DIM, Obstacle, ObstacleDocument,
    ObstacleKind, Particle, Scene,
};
pub use solver::{
    Convergence, DEFAULT_CG_ITERATIONS, DEFAULT_FRICTION_SLIP_VELOCITY,
    IncrementalPotentialSettings, Solver, WarmStart, XpbdSettings,
};
pub use state::State;

/// The scalar of the golden path.
pub type Real = f64;
