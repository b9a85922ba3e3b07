//! What the coupled implicit step (docs/implicit.md §7) needs beyond the
//! per-particle barrier plan: its settings and the friction coefficients.
//!
//! ```text
//! coupled  ⇔  constraint families ∨ collisions ∨ an obstacle (hyperplane or simplex mesh)
//!             with μ > 0 ∨ an explicit warm_start
//! springs  = Plan::families (a geometric family is a spring C²/(2α), α > 0; a material
//!            family its law's energy V_0 Ψ)
//! pairs    = ball–ball barriers from the broadphase (collisions), friction μ_c = collisions.friction
//! planes   = μ_p per compiled plane (BarrierObstacles order)
//! simplices = μ_s per compiled simplex: its mesh's `friction` (BarrierObstacles order)
//! ```
//! Without any of these the step has no coupling term and the per-particle
//! minimiser (its special case with warm start x^t) runs instead.

use crate::barrier::BarrierObstacles;
use crate::{
    DEFAULT_CG_ITERATIONS, DEFAULT_FRICTION_SLIP_VELOCITY, IncrementalPotentialSettings, Obstacle,
    Scene, WarmStart,
};

/// Settings and coefficients of the coupled step.
#[derive(Debug, Clone, PartialEq)]
pub struct CoupledPlan {
    /// CG iterations per Newton direction.
    pub cg_iterations: u32,
    /// The first Newton iterate.
    pub warm_start: WarmStart,
    /// ε_v (length/time): the friction slip length is ε_v h.
    pub slip_velocity: f64,
    /// Whether ball–ball barriers are terms (`collisions`).
    pub collisions: bool,
    /// μ between balls (`collisions.friction`).
    pub pair_friction: f64,
    /// μ per compiled plane (`obstacles[k].friction`), in plane order.
    pub plane_friction: Vec<f64>,
    /// μ per compiled simplex (its mesh's `obstacles[k].friction`), in
    /// simplex order.
    pub simplex_friction: Vec<f64>,
}

impl CoupledPlan {
    /// μ of obstacle slot `o` of [`BarrierObstacles`] (planes first, then
    /// simplices).
    pub fn friction(&self, o: usize) -> f64 {
        let planes = self.plane_friction.len();
        if o < planes {
            self.plane_friction[o]
        } else {
            self.simplex_friction[o - planes]
        }
    }
}

impl CoupledPlan {
    /// The coupled part of an incremental-potential plan, `None` when the
    /// scene has no coupling term and no explicit warm start.
    pub fn compile(
        scene: &Scene,
        settings: &IncrementalPotentialSettings,
        obstacles: &BarrierObstacles,
    ) -> Option<CoupledPlan> {
        let plane_friction: Vec<f64> = obstacles
            .plane_source
            .iter()
            .map(|&o| friction(&scene.obstacles[o as usize]))
            .collect();
        let simplex_friction: Vec<f64> = obstacles
            .simplex_source
            .iter()
            .map(|&(o, _)| friction(&scene.obstacles[o as usize]))
            .collect();
        let coupled = scene.constraints.iter().any(|c| !c.elements.is_empty())
            || scene.collisions.is_some()
            || plane_friction.iter().any(|&mu| mu > 0.0)
            || simplex_friction.iter().any(|&mu| mu > 0.0)
            || settings.warm_start.is_some();
        coupled.then(|| CoupledPlan {
            cg_iterations: settings.cg_iterations.unwrap_or(DEFAULT_CG_ITERATIONS),
            warm_start: settings.warm_start.unwrap_or(WarmStart::Inertial),
            slip_velocity: settings
                .friction_slip_velocity
                .unwrap_or(DEFAULT_FRICTION_SLIP_VELOCITY),
            collisions: scene.collisions.is_some(),
            pair_friction: scene.collisions.as_ref().map_or(0.0, |c| c.friction),
            plane_friction,
            simplex_friction,
        })
    }
}

/// μ of an authored obstacle.
fn friction(obstacle: &Obstacle) -> f64 {
    match obstacle {
        Obstacle::Hyperplane { friction, .. } | Obstacle::SimplexMesh { friction, .. } => *friction,
    }
}
