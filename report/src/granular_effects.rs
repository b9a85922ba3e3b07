//! Effect-cost rows on balls: particle–particle collisions and the barrier
//! path, which a cloth cannot show (its particles are linked).
//!
//! ```text
//! balls     scenes::column3d(side, height) (r = 0.05 m, 10 substeps ×
//!           4 iterations), floor friction set to 0 and `collisions` removed
//! ladder    balls on a frictionless floor (XPBD, no collisions)
//!           → + collisions (μ = 0, margin 0.01 m)   adds Broadphase + Collide
//!           → + ball–ball friction (μ = 0.5)        same kernels, more work
//! control   "+ collisions" written as JSON, its `collisions` key deleted and
//!           the JSON parsed again, must compile to exactly the plan of
//!           "+ collisions" with the collision parts taken out: contacts =
//!           None, Broadphase and Collide kernels removed from the substep
//!           schedule, stages recomputed from that schedule; every other
//!           field (particles, families, colours, settings) equal
//! solver    the same balls on the same plane under the incremental-potential
//!           (barrier) solver, 1 step = 1 minimisation (κ = 1000, d^ = 0.01,
//!           acceleration residual ≤ 1e-3 m/s², ≤ 100 Newton iterations):
//!           a different solver, compared with the XPBD row, not an added
//!           effect (the barrier path refuses collisions, friction, damping)
//! control   the XPBD row as JSON with "solver": {"type": "xpbd"} written
//!           explicitly must compile to the very same plan as omitting it
//! ```

use hyperpbd::{
    Collisions, Convergence, IncrementalPotentialSettings, Kernel, Obstacle, Plan, Scene, Solver,
};

/// How a row relates to another row of its group.
#[derive(Debug, Clone, PartialEq)]
pub enum Relation {
    /// A rung of a ladder: shown as the change from the rung above.
    Ladder,
    /// An authored-but-inert variant: same kernel schedule (and plan) as
    /// its twin.
    Control(usize),
    /// The twin with its particle–particle contact taken out: this row's
    /// plan must equal the twin's plan without contacts, Broadphase and
    /// Collide.
    TwinWithoutCollisions(usize),
    /// A different solver on the same scene: shown as a ratio, no plan
    /// claim.
    DifferentSolver(usize),
}

/// One row to measure: label, scene, relation.
pub type Rung = (String, Scene, Relation);

/// Ball-ball friction of the "+ friction" rung (column3d's value).
pub const BALL_FRICTION: f64 = 0.5;
/// Broadphase margin of the collision rungs (column3d's value).
pub const MARGIN: f64 = 0.01;

/// The balls with no collisions on a frictionless floor.
pub fn balls(side: usize, height: usize) -> Scene {
    let mut s = hyperpbd::scenes::column3d(side, height);
    s.collisions = None;
    for o in &mut s.obstacles {
        if let Obstacle::Hyperplane { friction, .. } = o {
            *friction = 0.0;
        }
    }
    s
}

fn with_collisions(s: &Scene, friction: f64) -> Scene {
    let mut s = s.clone();
    s.collisions = Some(Collisions {
        friction,
        margin: MARGIN,
    });
    s
}

/// `scene` under the incremental-potential solver, one minimisation per
/// step.
pub fn barrier(scene: &Scene) -> Scene {
    let mut s = scene.clone();
    s.substeps = 1;
    s.iterations = 1;
    s.solver = Solver::IncrementalPotential(IncrementalPotentialSettings {
        barrier_stiffness: 1000.0,
        activation_distance: 0.01,
        convergence: Convergence::MaxAccelerationResidual { tolerance: 1e-3 },
        max_iterations: 100,
        cg_iterations: None,
        warm_start: None,
        friction_slip_velocity: None,
    });
    s
}

/// `scene` written as JSON, edited as a JSON object, parsed again — the
/// way a user authors it.
fn edit_json(
    scene: &Scene,
    edit: impl FnOnce(&mut serde_json::Map<String, serde_json::Value>),
) -> Result<Scene, String> {
    let mut value: serde_json::Value =
        serde_json::from_str(&scene.to_json_string()).map_err(|e| e.to_string())?;
    let object = value
        .as_object_mut()
        .ok_or_else(|| "scene JSON is not an object".to_string())?;
    edit(object);
    Scene::from_json_str(&value.to_string()).map_err(|e| e.to_string())
}

/// The balls' rows: collision ladder, its control, the barrier solver and
/// the explicit-xpbd control. Indices in relations are into this list.
pub fn rows(side: usize, height: usize) -> Result<Vec<Rung>, String> {
    let base = balls(side, height);
    let contact = with_collisions(&base, 0.0);
    let friction = with_collisions(&base, BALL_FRICTION);
    let removed = edit_json(&contact, |o| {
        o.remove("collisions");
    })?;
    let explicit = edit_json(&base, |o| {
        o.insert("solver".into(), serde_json::json!({ "type": "xpbd" }));
    })?;
    let n = base.particles.len();
    Ok(vec![
        (
            format!("{n} balls on a frictionless floor (XPBD, no collisions)"),
            base.clone(),
            Relation::Ladder,
        ),
        ("+ collisions (μ = 0)".into(), contact, Relation::Ladder),
        (
            format!("+ ball–ball friction (μ = {BALL_FRICTION})"),
            friction,
            Relation::Ladder,
        ),
        (
            "control: \"+ collisions\" with its `collisions` key deleted from the JSON".into(),
            removed,
            Relation::TwinWithoutCollisions(1),
        ),
        (
            "barrier solver (incremental potential), same balls and floor".into(),
            barrier(&base),
            Relation::DifferentSolver(0),
        ),
        (
            "control: balls row with \"solver\": {\"type\": \"xpbd\"} written explicitly".into(),
            explicit,
            Relation::Control(0),
        ),
    ])
}

/// `plan` with its particle–particle contact taken out: what a scene
/// without `collisions` must compile to.
pub fn without_collisions(plan: &Plan) -> Plan {
    let mut p = plan.clone();
    p.contacts = None;
    p.substep_kernels
        .retain(|k| !matches!(k, Kernel::Broadphase | Kernel::Collide));
    p.stages.clear();
    for k in &p.substep_kernels {
        if p.stages.last() != Some(&k.stage()) {
            p.stages.push(k.stage());
        }
    }
    p
}
