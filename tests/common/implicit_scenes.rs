//! The coupled implicit step's evidence scenes (issue 16, docs/implicit.md
//! §8), shared by the CPU evidence (`tests/implicit/step.rs`,
//! `tests/implicit/expressions.rs`) and the GPU's bit-identity tests
//! (`tests/gpu/coupled/`, `tests/gpu/coupled_f32.rs`).

use hyperpbd::builders::GridSpec;
use hyperpbd::core::barrier::BarrierLaw;
use hyperpbd::core::implicit::closed_forms::{barrier_gap_under_load, stacked_ball_heights};
use hyperpbd::kinds::BendingModel;
use hyperpbd::{
    Collisions, ConstraintFamily, ConstraintKind, Convergence, IncrementalPotentialSettings,
    Obstacle, Particle, Scene, SceneBuilder, Solver, WarmStart,
};

/// Standard gravity (m/s²).
pub const G: f64 = 9.81;

/// Incremental-potential settings with the acceleration criterion.
pub fn settings(
    stiffness: f64,
    activation: f64,
    tolerance: f64,
    max_iterations: u32,
) -> IncrementalPotentialSettings {
    IncrementalPotentialSettings {
        barrier_stiffness: stiffness,
        activation_distance: activation,
        convergence: Convergence::MaxAccelerationResidual { tolerance },
        max_iterations,
        cg_iterations: None,
        warm_start: None,
        friction_slip_velocity: None,
    }
}

/// A particle of `mass` kg (`None`: fixed) and `radius`.
pub fn particle(position: Vec<f64>, mass: Option<f64>, radius: f64) -> Particle {
    let mut p = Particle::new(position, mass.unwrap_or(1.0));
    if mass.is_none() {
        p.mass = None;
        p.fixed = true;
    }
    p.radius = radius;
    p
}

/// Two balls (radius 0.1 m, 1 kg) 1 m apart closing at 10 m/s each.
pub fn head_on() -> Scene {
    let mut scene = Scene::new(2, 1.0 / 60.0, 4, 1);
    for (x, v) in [(-0.5, 10.0), (0.5, -10.0)] {
        let mut p = particle(vec![x, 0.0], Some(1.0), 0.1);
        p.velocity = Some(vec![v, 0.0]);
        scene.particles.push(p);
    }
    scene.collisions = Some(Collisions {
        friction: 0.0,
        margin: 0.0,
    });
    scene.solver = Solver::IncrementalPotential(settings(1e4, 0.01, 1e-3, 200));
    scene
}

/// A 12-link chain (0.1 m links, compliance 1e-8 m/N) from a fixed top,
/// beads alternating 1 kg and 1e-6 kg, released horizontal: one
/// minimisation per 1/60 s frame. Its free end is a light bead.
pub fn alternating_chain() -> Scene {
    chain_ending(1e-6)
}

/// The alternating chain with its masses swapped (1e-6 kg first): its free
/// end is a heavy bead.
pub fn alternating_chain_heavy_end() -> Scene {
    chain_ending(1.0)
}

/// The alternating chain whose last (12th) bead weighs `end` kg.
pub fn chain_ending(end: f64) -> Scene {
    let other = if end == 1.0 { 1e-6 } else { 1.0 };
    let mut scene = Scene::new(2, 1.0 / 60.0, 1, 1);
    scene.gravity = Some(vec![0.0, -G]);
    scene.particles.push(particle(vec![0.0, 0.0], None, 0.0));
    for k in 1..=12 {
        let mass = if k % 2 == 0 { end } else { other };
        scene
            .particles
            .push(particle(vec![0.1 * k as f64, 0.0], Some(mass), 0.0));
    }
    scene.constraints.push(ConstraintFamily::new(
        ConstraintKind::Distance,
        1e-8,
        (0..12).map(|k| vec![k, k + 1]).collect(),
    ));
    scene.solver = Solver::IncrementalPotential(settings(1e3, 1e-3, 1e-1, 50));
    scene
}

/// A 1 kg ball (radius 0.05 m) resting on a plane inclined by 20°, at the
/// barrier's equilibrium gap under its normal load, with friction μ.
pub fn incline(mu: f64) -> (Scene, f64) {
    let angle = 20f64.to_radians();
    let law = BarrierLaw {
        stiffness: 1e5,
        activation_distance: 1e-3,
    };
    let gap = barrier_gap_under_load(&law, G * angle.cos()).expect("a gap");
    let (s, c) = (angle.sin(), angle.cos());
    let mut scene = Scene::new(2, 1.0 / 60.0, 1, 1);
    scene.gravity = Some(vec![0.0, -G]);
    let r = 0.05;
    scene
        .particles
        .push(particle(vec![-s * (r + gap), c * (r + gap)], Some(1.0), r));
    scene.obstacles.push(Obstacle::Hyperplane {
        normal: vec![-s, c],
        offset: 0.0,
        friction: mu,
        compliance: 0.0,
        motion: Vec::new(),
    });
    scene.solver =
        Solver::IncrementalPotential(settings(law.stiffness, law.activation_distance, 1e-4, 50));
    (scene, angle)
}

/// Ten balls (radius 0.1 m, 1 kg) on the plane y = 0, released at rest
/// with every gap half the activation distance wider than at equilibrium,
/// and the closed-form equilibrium heights (docs/implicit.md §8).
pub fn stack() -> (Scene, Vec<f64>) {
    let law = BarrierLaw {
        stiffness: 1e5,
        activation_distance: 1e-2,
    };
    let heights = stacked_ball_heights(&law, 0.0, 0.1, 1.0, G, 10).expect("heights");
    let mut scene = Scene::new(2, 1.0 / 60.0, 1, 1);
    scene.gravity = Some(vec![0.0, -G]);
    for (k, &y) in heights.iter().enumerate() {
        let lifted = y + 0.5 * law.activation_distance * (k + 1) as f64;
        scene
            .particles
            .push(particle(vec![0.0, lifted], Some(1.0), 0.1));
    }
    scene.obstacles.push(Obstacle::Hyperplane {
        normal: vec![0.0, 1.0],
        offset: 0.0,
        friction: 0.0,
        compliance: 0.0,
        motion: Vec::new(),
    });
    scene.collisions = Some(Collisions {
        friction: 0.0,
        margin: 0.0,
    });
    scene.solver =
        Solver::IncrementalPotential(settings(law.stiffness, law.activation_distance, 1e-4, 50));
    (scene, heights)
}

/// The head-on balls with the second one 5 cm off axis and ball-pair
/// friction μ = 0.5: a glancing contact that slides.
pub fn glancing() -> Scene {
    let mut glancing = head_on();
    glancing.particles[1].position[1] = 0.05;
    glancing.collisions = Some(Collisions {
        friction: 0.5,
        margin: 0.0,
    });
    glancing
}

/// Three balls (r = 5 cm) on distance springs dropped into a V of two
/// mesh segments (2D).
pub fn balls_in_a_v() -> Scene {
    let mut scene = Scene::new(2, 1.0 / 60.0, 2, 1);
    scene.gravity = Some(vec![0.0, -9.81]);
    for k in 0..3 {
        let mut p = particle(vec![-0.25 + 0.25 * k as f64, 0.3], Some(1.0), 0.05);
        p.velocity = Some(vec![0.5, -1.0]);
        scene.particles.push(p);
    }
    scene.constraints.push(ConstraintFamily::new(
        ConstraintKind::Distance,
        1e-4,
        vec![vec![0, 1], vec![1, 2]],
    ));
    scene.obstacles.push(Obstacle::SimplexMesh {
        vertices: vec![vec![-1.0, 0.5], vec![0.0, -0.2], vec![1.0, 0.5]],
        simplices: vec![vec![0, 1], vec![1, 2]],
        friction: 0.0,
        motion: Vec::new(),
    });
    scene.collisions = Some(Collisions {
        friction: 0.0,
        margin: 0.0,
    });
    scene.solver = Solver::IncrementalPotential(settings(1e4, 0.02, 1e-3, 40));
    scene
}

/// A 3D tetrahedron of distance, oriented- and simplex-measure springs,
/// tethered to a fixed point, falling onto a frictional plane, with the
/// "previous" warm start, the packed criterion and a CG budget of 12.
pub fn spring_tetrahedron() -> Scene {
    let mut scene = Scene::new(3, 1.0 / 60.0, 2, 1);
    scene.gravity = Some(vec![0.0, -9.81, 0.0]);
    for (k, p) in [
        [0.0, 0.3, 0.0],
        [0.2, 0.32, 0.0],
        [0.0, 0.31, 0.2],
        [0.05, 0.5, 0.05],
    ]
    .into_iter()
    .enumerate()
    {
        let mut q = particle(p.to_vec(), Some(0.5 + 0.25 * k as f64), 0.02);
        q.velocity = Some(vec![0.3, 0.0, -0.1 * k as f64]);
        scene.particles.push(q);
    }
    scene
        .particles
        .push(particle(vec![0.0, 1.0, 0.0], None, 0.0));
    scene.constraints.push(ConstraintFamily::new(
        ConstraintKind::Distance,
        1e-5,
        vec![vec![0, 1], vec![1, 2], vec![2, 0], vec![0, 3]],
    ));
    scene.constraints.push(ConstraintFamily::new(
        ConstraintKind::Tether,
        1e-4,
        vec![vec![4, 3]],
    ));
    scene.constraints.push(ConstraintFamily::new(
        ConstraintKind::OrientedMeasure,
        1e-3,
        vec![vec![0, 1, 2, 3]],
    ));
    scene.constraints.push(ConstraintFamily::new(
        ConstraintKind::SimplexMeasure,
        1e-3,
        vec![vec![0, 1, 2]],
    ));
    scene.obstacles.push(Obstacle::Hyperplane {
        normal: vec![0.0, 1.0, 0.0],
        offset: 0.0,
        friction: 0.4,
        compliance: 0.0,
        motion: Vec::new(),
    });
    let mut s = settings(1e4, 0.01, 1e-3, 40);
    s.convergence = Convergence::PackedGradient { tolerance: 1e-9 };
    s.warm_start = Some(WarmStart::Previous);
    s.cg_iterations = Some(12);
    scene.solver = Solver::IncrementalPotential(s);
    scene
}

/// Stopping tolerance of [`chain_of`] (m/s²).
pub const CHAIN_TOLERANCE: f64 = 1e-5;

/// A horizontal chain of `links` 0.1 m links (1 kg beads, the first fixed)
/// released under gravity, as a `kind` family of compliance 1e-4 m/N.
pub fn chain_of(kind: ConstraintKind, links: usize) -> Scene {
    let mut scene = Scene::new(2, 1.0 / 60.0, 1, 1);
    scene.gravity = Some(vec![0.0, -G]);
    scene.particles.push(particle(vec![0.0, 0.0], None, 0.0));
    for k in 1..=links {
        scene
            .particles
            .push(particle(vec![0.1 * k as f64, 0.0], Some(1.0), 0.0));
    }
    scene.constraints.push(ConstraintFamily::new(
        kind,
        1e-4,
        (0..links).map(|k| vec![k, k + 1]).collect(),
    ));
    scene.solver = Solver::IncrementalPotential(settings(1e3, 1e-3, CHAIN_TOLERANCE, 200));
    scene
}

/// One hinge in R³: the shared edge x0x1 and the wing x2 fixed, the wing x3
/// (1 kg, held to x0 and x1 by stiff links) folded to 90°, rest flat
/// (c_rest = −u_A·u_B = 1), no gravity.
pub fn folded_hinge() -> Scene {
    let mut scene = Scene::new(3, 1.0 / 60.0, 1, 1);
    for p in [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.5, 1.0, 0.0]] {
        scene.particles.push(particle(p.to_vec(), None, 0.0));
    }
    scene
        .particles
        .push(particle(vec![0.5, 0.0, 1.0], Some(1.0), 0.0));
    let mut bending = ConstraintFamily::new(ConstraintKind::Bending, 1e-3, vec![vec![0, 1, 2, 3]]);
    bending.rest = Some(vec![1.0]);
    scene.constraints.push(bending);
    // The wing's edges hold x3 at its distances from the hinge's edge.
    scene.constraints.push(ConstraintFamily::new(
        ConstraintKind::Distance,
        1e-6,
        vec![vec![0, 3], vec![1, 3]],
    ));
    scene.solver = Solver::IncrementalPotential(settings(1e3, 1e-3, 1e-4, 100));
    scene
}

/// A 6 × 6 cloth (0.1 m, compliance 1e-6 m/N) with bending of `model`,
/// two corners fixed, under gravity, on the coupled step.
pub fn bending_cloth(model: BendingModel) -> Scene {
    let mut b = SceneBuilder::new(3).dt(1.0 / 60.0).gravity_along(1, G);
    let mut spec = GridSpec::cloth(6, 6, 0.1, 0.0);
    spec.compliance = 1e-6;
    let grid = b.grid(&spec);
    b.grid_bending(&grid, 1e-2, model).expect("hinges");
    b.fix(grid.index(&[0, 0]));
    b.fix(grid.index(&[5, 0]));
    let mut scene = b.build().expect("valid");
    scene.solver = Solver::IncrementalPotential(settings(1e3, 1e-3, 1e-4, 100));
    scene
}
