//! Scenes with prescribed motion (tests/cpu/motion.rs, tests/gpu/motion.rs).

use hyperpbd::motion::Motion;
use hyperpbd::{ConstraintFamily, ConstraintKind, Obstacle, Particle, Scene};

pub const G: f64 = 9.81;

/// A hyperplane with friction μ moving by `motion`.
pub fn moving_plane(normal: Vec<f64>, offset: f64, friction: f64, motion: Vec<Motion>) -> Obstacle {
    Obstacle::Hyperplane {
        normal,
        offset,
        friction,
        compliance: 0.0,
        motion,
    }
}

/// One ball of radius 0.1 resting on the plane y = 0 of R^dim (gravity
/// −y), the plane with `motion` and friction μ.
pub fn resting(dim: usize, mu: f64, motion: Vec<Motion>, substeps: u32) -> Scene {
    let mut s = Scene::new(dim, 1.0 / 60.0, substeps, 1);
    let mut g = vec![0.0; dim];
    g[1] = -G;
    s.gravity = Some(g);
    let mut x = vec![0.0; dim];
    x[1] = 0.1;
    s.particles = vec![Particle::new(x, 1.0).with_radius(0.1)];
    let mut n = vec![0.0; dim];
    n[1] = 1.0;
    s.obstacles = vec![moving_plane(n, 0.0, mu, motion)];
    s
}

/// A pendulum in R^2 hung from a pin that moves by `motion`.
pub fn circling_pin(motion: Vec<Motion>) -> Scene {
    let mut s = Scene::new(2, 1.0 / 60.0, 8, 2);
    s.gravity = Some(vec![0.0, -G]);
    s.particles = vec![
        Particle::fixed(vec![1.0, 2.0]).with_motion(motion),
        Particle::new(vec![1.0, 1.0], 1.0),
    ];
    s.constraints = vec![ConstraintFamily::new(
        ConstraintKind::Distance,
        0.0,
        vec![vec![0, 1]],
    )];
    s
}

pub fn belt(u: f64, dim: usize) -> Vec<Motion> {
    let mut velocity = vec![0.0; dim];
    velocity[0] = u;
    vec![Motion::Translate { velocity }]
}

pub fn spin(plane: [usize; 2], center: Vec<f64>, rate: f64) -> Vec<Motion> {
    vec![Motion::Rotate {
        plane,
        center,
        rate,
    }]
}

/// Every kind of motion on both kinds of mover, in R^2, R^3 and R^4
/// (the differential tests' cases): a belt, a rising plane, a turntable,
/// a plane tilting in (e1, e3) of R^4 with a keyframed lift, a pin on a
/// circle, a plane tilting 1 km from the world origin (a shifted scene
/// origin in f32), and the shipped conveyor (three balls on a belt, a rope between
/// two turning pins, one keyframed).
pub fn cases() -> Vec<(&'static str, Scene)> {
    let mut turntable = resting(3, 0.8, spin([0, 2], vec![0.0; 3], 1.0), 20);
    turntable.particles[0].position = vec![0.5, 0.1, 0.0];
    let mut tilt = spin([1, 3], vec![0.0; 4], 0.2);
    tilt.push(Motion::Keyframes {
        times: vec![0.1, 0.3],
        translations: vec![vec![0.0; 4], vec![0.0, 0.05, 0.0, 0.0]],
    });
    let mut tilting = resting(4, 1.0, tilt, 20);
    tilting.particles[0].position = vec![0.3, 0.1, -0.2, 0.4];
    let rising = resting(
        2,
        0.0,
        vec![Motion::Translate {
            velocity: vec![0.0, 0.5],
        }],
        10,
    );
    // Far from the world origin: the f32 kernels store x − o, and the
    // tilting plane's shift and carry move by n·o and Ā o.
    let mut far = resting(3, 1.0, spin([1, 2], vec![0.0, 0.0, 1000.0], 0.2), 20);
    far.particles[0].position = vec![0.3, 0.1, 1000.2];
    let conveyor = Scene::from_json_str(include_str!("../../scenes/conveyor.json"))
        .expect("the shipped conveyor loads");
    vec![
        ("belt 3D", resting(3, 0.5, belt(2.0, 3), 20)),
        ("rising plane 2D", rising),
        ("turntable 3D", turntable),
        ("tilting plane 4D", tilting),
        (
            "pin on a circle 2D",
            circling_pin(spin([0, 1], vec![0.0, 2.0], 3.0)),
        ),
        ("tilting plane 1 km out 3D", far),
        ("conveyor.json", conveyor),
    ]
}
