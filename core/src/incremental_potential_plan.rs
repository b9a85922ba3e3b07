//! The incremental-potential (barrier) path's part of the plan: the
//! barrier law, the stop test, the obstacles and, for a scene with
//! coupling terms, the coupled step's settings.

use crate::barrier::{BarrierLaw, BarrierObstacles};
use crate::implicit::CoupledPlan;
use crate::{Convergence, IncrementalPotentialSettings, Scene};

/// Everything the barrier path needs beyond the particle data of the plan.
#[derive(Debug, Clone, PartialEq)]
pub struct IncrementalPotentialPlan {
    /// κ and d^.
    pub law: BarrierLaw,
    /// The authored stop test.
    pub convergence: Convergence,
    /// Newton iterations allowed per substep.
    pub max_iterations: u32,
    /// The obstacles.
    pub obstacles: BarrierObstacles,
    /// The coupled step's settings (docs/implicit.md §7), `None` for a
    /// scene without coupling terms (the per-particle minimiser runs).
    pub coupled: Option<Box<CoupledPlan>>,
}

impl IncrementalPotentialPlan {
    /// The barrier-path part of the plan of a validated scene whose solver
    /// is `settings`.
    pub fn compile(scene: &Scene, settings: &IncrementalPotentialSettings) -> Self {
        let obstacles = BarrierObstacles::compile(scene);
        IncrementalPotentialPlan {
            coupled: CoupledPlan::compile(scene, settings, &obstacles).map(Box::new),
            law: BarrierLaw {
                stiffness: settings.barrier_stiffness,
                activation_distance: settings.activation_distance,
            },
            convergence: settings.convergence,
            max_iterations: settings.max_iterations,
            obstacles,
        }
    }
}
