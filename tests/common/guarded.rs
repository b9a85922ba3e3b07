//! The guarded soft block of tests/cpu/guards.rs and tests/gpu/guards.rs.
//!
//! ```text
//! Kuhn block in R^dim, 3 cells of 0.1 m per axis, compliant oriented
//! measures (1e-7) and edges (1e-6), 0.1 kg nodes, bottom 0.2 m above
//! the plane y = 0, every node at −speed along y; one step of 1/30 s in
//! ONE substep, 10 iterations, gravity 9.81 m/s²
//! ```

use hyperpbd::builders::BlockSpec;
use hyperpbd::{
    Adaptive, BackendError, ConstraintFamily, ConstraintKind, GuardRejection, Guards, Scene,
    SceneBuilder, State, StepError, StepReport,
};

/// The block of the module doc with `guards` and `adaptive` (k).
pub fn dropped_block(
    dim: usize,
    speed: f64,
    guards: Option<Guards>,
    adaptive: Option<u32>,
) -> Scene {
    let mut b = SceneBuilder::new(dim)
        .dt(1.0 / 30.0)
        .substeps(1)
        .iterations(10)
        .gravity_along(1, -9.81);
    let mut origin = vec![0.0; dim];
    origin[1] = 0.2;
    b.soft_block(&BlockSpec {
        cells: vec![3; dim],
        origin,
        spacing: 0.1,
        mass: 0.1,
        compliance: 1e-7,
        edge_compliance: Some(1e-6),
    });
    let mut up = vec![0.0; dim];
    up[1] = 1.0;
    b.hyperplane(up, 0.0, 0.0);
    let mut scene = b.build().expect("valid block");
    for p in &mut scene.particles {
        let mut v = vec![0.0; dim];
        v[1] = -speed;
        p.velocity = Some(v);
    }
    scene.guards = guards;
    scene.adaptive = adaptive.map(|k| Adaptive {
        max_subdivisions: k,
    });
    scene.validate().expect("valid guarded block");
    scene
}

/// The block of [`dropped_block`] at `speed`, its simplices one `law`
/// material family instead (E = 2e5 Pa, ν = 0.3, rest shape = the initial
/// positions; no edge springs), with `guards` and `adaptive` (k).
pub fn material_block(
    dim: usize,
    speed: f64,
    law: ConstraintKind,
    guards: Option<Guards>,
    adaptive: Option<u32>,
) -> Scene {
    let mut scene = dropped_block(dim, speed, None, None);
    let elements = scene.constraints[0].elements.clone();
    scene.constraints = vec![ConstraintFamily::material(law, 2e5, 0.3, elements)];
    scene.guards = guards;
    scene.adaptive = adaptive.map(|k| Adaptive {
        max_subdivisions: k,
    });
    scene.validate().expect("valid material block");
    scene
}

/// Only the orientation guard.
pub fn orientation() -> Guards {
    Guards {
        orientation: true,
        ..Guards::default()
    }
}

/// The bits of positions and velocities.
pub fn bits(state: &State) -> (Vec<u64>, Vec<u64>) {
    (
        state.positions.iter().map(|x| x.to_bits()).collect(),
        state.velocities.iter().map(|x| x.to_bits()).collect(),
    )
}

/// The guard rejection `result` must be.
pub fn rejection(result: Result<StepReport, BackendError>) -> GuardRejection {
    match result {
        Err(BackendError::Step(StepError::GuardRejected(r))) => r,
        other => panic!("expected a guard rejection, got {other:?}"),
    }
}
