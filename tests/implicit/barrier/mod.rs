//! The incremental-potential (barrier) path on the CPU golden backend:
//! closest points, the barrier law, the step filter, the seed's
//! backward-Euler example for both criteria, drops that must never reach
//! d ≤ 0, resting contact, sliding over a 4D triangle mesh, validation.
//!
//! Every bound is printed as `BOUND | name | measured | bound | rationale`.

use crate::common;

mod closest_point;
mod drops;
mod law_and_filter;
mod mesh_slide;
mod plan_and_validation;
mod seed_example;

use common::Lcg;
use common::bound::check_bound as bound;
use hyperpbd::barrier::{
    BarrierLaw, BarrierObstacles, FILTER_SAFETY, ParticleBarrier, evaluate_particle_barrier,
    filter_fraction,
};
use hyperpbd::geometry::closest_point_on_simplex;
use hyperpbd::{
    Backend, BackendError, Convergence, CpuBackend, IncrementalPotentialSettings, Kernel,
    MinimisationStatus, Obstacle, Particle, Plan, Scene, SceneError, Solver, StageName, State,
    StepError,
};

fn ip(kappa: f64, dhat: f64, convergence: Convergence, max_iterations: u32) -> Solver {
    Solver::IncrementalPotential(IncrementalPotentialSettings {
        barrier_stiffness: kappa,
        activation_distance: dhat,
        convergence,
        max_iterations,
        cg_iterations: None,
        warm_start: None,
        friction_slip_velocity: None,
    })
}

fn plane(normal: Vec<f64>, offset: f64) -> Obstacle {
    Obstacle::Hyperplane {
        normal,
        offset,
        friction: 0.0,
        compliance: 0.0,
        motion: Vec::new(),
    }
}

fn cpu(scene: &Scene) -> CpuBackend {
    let plan = Plan::compile(scene).expect("valid scene");
    CpuBackend::new(plan, &State::from_scene(scene)).expect("backend")
}

/// Smallest d over every free particle and obstacle of `scene` at `state`.
fn min_distance(scene: &Scene, state: &State) -> f64 {
    let obstacles = BarrierObstacles::compile(scene);
    let mut n = vec![0.0; scene.dim];
    let mut d = f64::INFINITY;
    for (i, p) in scene.particles.iter().enumerate() {
        for o in 0..obstacles.len() {
            d = d.min(obstacles.distance(o, state.position(i), p.radius, &mut n));
        }
    }
    d
}

fn drop_scene(speed: f64, dhat: f64) -> Scene {
    let mut scene = Scene::new(3, 1.0 / 60.0, 1, 1);
    scene.gravity = Some(vec![0.0, -9.81, 0.0]);
    scene.particles.push(
        Particle::new(vec![0.3, 2.0, -0.1], 1.0)
            .with_velocity(vec![0.0, -speed, 0.0])
            .with_radius(0.05),
    );
    scene.obstacles.push(plane(vec![0.0, 1.0, 0.0], 0.0));
    scene.solver = ip(
        1e3,
        dhat,
        Convergence::MaxAccelerationResidual { tolerance: 1e-4 },
        200,
    );
    scene
}
