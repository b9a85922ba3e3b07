//! Rotating drums of granular balls (`drum3d`, `drum4d`): a ring of
//! hyperplanes turning together about the drum axis, closed along the
//! other axes by end walls that turn with them.
//!
//! ```text
//! ring      K walls, wall k: n_k = −(cos φ_k e_0 + sin φ_k e_1), φ_k = 2πk/K,
//!           n_k·x ≥ −R   (a regular K-gon of apothem R about the axis)
//! ends      ±e_a·x ≥ −L for every axis a ≥ 2 (3D: the two end caps; 4D: four walls)
//! motion    every wall: rotate in the plane [0, 1] about the origin at ω rad/s
//!           (e_0 toward e_1: the bottom moves toward +x_0 and carries the pile up
//!           on that side); the end walls' normals are fixed by it, their
//!           material points turn, so their friction drags the balls along
//! gravity   g along −e_1 (in the rotation plane)
//! balls     a lattice of spacing 2r·1.05 filling the drum's cross-section up to
//!           height `fill`·R above the bottom, every ball at least 1.05 r inside
//!           the ring (|x_01| ≤ R − 1.05 r) and the ends; every third ball
//!           (k mod 3 = 1) of radius 0.7 r, so the pile is no crystal
//! ```
//! Wall friction μ_w, ball–ball friction μ_b: the walls carry the pile up
//! until its surface passes the angle of repose, then it avalanches (the
//! rolling/cascading regime: Froude number ω²R/g ≈ 0.05–0.1).

use hyperpbd_core::motion::{Motion, rigid_at};
use hyperpbd_core::{Collisions, Obstacle, Particle, Scene, SceneBuilder};

/// The drum's rotation rate ω (rad/s) of both built-in drums.
pub const DRUM_RATE: f64 = 1.2;

/// The shape of one drum.
#[derive(Debug, Clone)]
pub struct DrumSpec {
    /// Dimension N ≥ 3 (the ring lies in the plane of axes 0 and 1).
    pub dim: usize,
    /// Walls in the ring, K ≥ 3.
    pub walls: usize,
    /// Apothem of the ring R (m).
    pub radius: f64,
    /// Half-length of the drum along every axis a ≥ 2 (m).
    pub half_length: f64,
    /// Ball radius r (m).
    pub ball: f64,
    /// Ball mass (kg).
    pub mass: f64,
    /// Fill height above the bottom, as a fraction of R (0..2).
    pub fill: f64,
    /// Rotation rate ω (rad/s).
    pub rate: f64,
    /// Wall friction μ_w.
    pub wall_friction: f64,
    /// Ball–ball friction μ_b.
    pub ball_friction: f64,
}

/// The rotation every wall of the drum shares.
pub fn drum_motion(dim: usize, rate: f64) -> Vec<Motion> {
    vec![Motion::Rotate {
        plane: [0, 1],
        center: vec![0.0; dim],
        rate,
    }]
}

/// A drum scene (module docs): 1/60 s frames, 10 substeps, 4 iterations,
/// g = 9.81 m/s².
pub fn drum(spec: &DrumSpec) -> Scene {
    let n = spec.dim;
    let mut b = SceneBuilder::new(n)
        .dt(1.0 / 60.0)
        .substeps(10)
        .iterations(4)
        .gravity_along(1, 9.81);
    let (r, big) = (spec.ball, spec.radius);
    let step = 2.0 * r * 1.05;
    let inner = big - 1.05 * r;
    let top = -big + spec.fill * big;
    // Lattice along axis 1 from the bottom up, the others centred.
    let across = (inner / step).floor() as i64;
    let along = ((spec.half_length - 1.05 * r) / step).floor() as i64;
    let layers = ((top + big - 1.05 * r) / step).floor() as i64;
    let mut index = vec![0i64; n];
    let ranges: Vec<(i64, i64)> = (0..n)
        .map(|a| match a {
            0 => (-across, across),
            1 => (0, layers),
            _ => (-along, along),
        })
        .collect();
    for (a, &(lo, _)) in ranges.iter().enumerate() {
        index[a] = lo;
    }
    loop {
        let mut x = vec![0.0; n];
        for a in 0..n {
            x[a] = match a {
                1 => -big + 1.05 * r + step * index[a] as f64,
                _ => step * index[a] as f64,
            };
        }
        if (x[0] * x[0] + x[1] * x[1]).sqrt() <= inner && x[1] <= top {
            // Every third ball smaller: a lattice of equal balls is a
            // crystal that the drum would carry up as one block.
            let k = b.scene().particles.len();
            let radius = if k % 3 == 1 { 0.7 * r } else { r };
            b.particle(Particle::new(x, spec.mass).with_radius(radius));
        }
        // Next lattice point (axis 0 fastest).
        let mut a = 0;
        while a < n {
            index[a] += 1;
            if index[a] <= ranges[a].1 {
                break;
            }
            index[a] = ranges[a].0;
            a += 1;
        }
        if a == n {
            break;
        }
    }
    let motion = drum_motion(n, spec.rate);
    for k in 0..spec.walls {
        let phi = 2.0 * std::f64::consts::PI * k as f64 / spec.walls as f64;
        // −e_0 turned by φ in the plane [0, 1] (core's libm rotation).
        let mut first = vec![0.0; n];
        first[0] = -1.0;
        let normal = rigid_at(&drum_motion(n, phi), n, 1.0).rotate(&first);
        b.hyperplane(normal, -big, spec.wall_friction);
    }
    for a in 2..n {
        for sign in [1.0, -1.0] {
            let mut normal = vec![0.0; n];
            normal[a] = sign;
            b.hyperplane(normal, -spec.half_length, spec.wall_friction);
        }
    }
    let scene = b.scene_mut();
    for o in &mut scene.obstacles {
        if let Obstacle::Hyperplane { motion: m, .. } = o {
            *m = motion.clone();
        }
    }
    scene.collisions = Some(Collisions {
        friction: spec.ball_friction,
        margin: 0.2 * r,
    });
    super::built(b)
}

/// The built-in drum of dimension `dim`: 16 walls, R = 0.5 m,
/// ω = [`DRUM_RATE`], μ_w = 0.8, μ_b = 0.3, filled to 0.8 R with balls of
/// 10 g; 3D: r = 0.03 m, 0.3 m long; otherwise (4D): r = 0.05 m, closed at
/// ±0.16 m along every axis from 2 on.
pub fn drum_spec(dim: usize) -> DrumSpec {
    let (ball, half_length) = if dim == 3 { (0.03, 0.15) } else { (0.05, 0.16) };
    DrumSpec {
        dim,
        walls: 16,
        radius: 0.5,
        half_length,
        ball,
        mass: 0.01,
        fill: 0.8,
        rate: DRUM_RATE,
        wall_friction: 0.8,
        ball_friction: 0.3,
    }
}

/// The 3D drum ([`drum_spec`]`(3)`: 174 balls).
pub fn drum3d() -> Scene {
    drum(&drum_spec(3))
}

/// The 4D drum ([`drum_spec`]`(4)`: 198 balls).
pub fn drum4d() -> Scene {
    drum(&drum_spec(4))
}
