//! A cloth dropped onto a turning, rising dome (`drape3d`): bending, a
//! moving simplex mesh and friction in one scene.
//!
//! ```text
//! cloth   24 × 24 nodes, 0.9 m square at y = 0.45 (edges and shear links,
//!         rigid; the cosine fold over every interior edge, compliance 1e-3)
//! dome    the cap y = 0.25 − 1.25 (x² + z²) ≥ 0 (radius 0.45 m): the
//!         triangles of a 16 × 16-cell height field over [−0.5, 0.5]² with
//!         a vertex above y = 0, μ = 0.8; its motion:
//!           1. keyframes: up by 0.1 m over the first second, then held
//!           2. rotate in the plane [2, 0] about the y axis at 1 rad/s
//!              (e_2 toward e_0: it turns about the vertical)
//! ground  the plane y = 0, μ = 0.4
//! step    1/60 s, 10 substeps, 1 iteration, damping 0.1 /s
//! ```
//! The cloth falls on the dome and drapes over it to the ground; the dome
//! lifts it by its top, and the top of the drape turns with the dome
//! (friction carries it) while the hem drags on the ground.

use hyperpbd_core::motion::Motion;
use hyperpbd_core::{Obstacle, Scene};

/// The dome's turning rate about the vertical (rad/s).
pub const DOME_RATE: f64 = 1.0;

/// The dome's height at (x, z) (module docs).
pub fn dome_height(x: f64, z: f64) -> f64 {
    (0.25 - 1.25 * (x * x + z * z)).max(0.0)
}

/// The dome's motion list (module docs).
pub fn dome_motion() -> Vec<Motion> {
    vec![
        Motion::Keyframes {
            times: vec![0.0, 1.0],
            translations: vec![vec![0.0; 3], vec![0.0, 0.1, 0.0]],
        },
        Motion::Rotate {
            plane: [2, 0],
            center: vec![0.0; 3],
            rate: DOME_RATE,
        },
    ]
}

/// The drape scene (module docs).
pub fn drape3d() -> Scene {
    let n = 24;
    let spacing = 0.9 / (n - 1) as f64;
    let mut b = super::cloth_in_3d();
    let grid = super::folding_cloth(&mut b, n, spacing, 0.45);
    b.hyperplane(vec![0.0, 1.0, 0.0], 0.0, 0.4);
    let cells = 16;
    let side = cells + 1;
    let mut vertices = Vec::with_capacity(side * side);
    for i in 0..side {
        for j in 0..side {
            let x = -0.5 + i as f64 / cells as f64;
            let z = -0.5 + j as f64 / cells as f64;
            vertices.push(vec![x, dome_height(x, z), z]);
        }
    }
    let mut simplices = Vec::with_capacity(2 * cells * cells);
    for i in 0..cells {
        for j in 0..cells {
            let (a, c) = (i * side + j, (i + 1) * side + j + 1);
            for triangle in [vec![a, (i + 1) * side + j, c], vec![a, c, a + 1]] {
                // The cap: a vertex above the base.
                if triangle.iter().any(|&v| vertices[v][1] > 0.0) {
                    simplices.push(triangle);
                }
            }
        }
    }
    let scene = b.scene_mut();
    for i in 0..grid.len() {
        scene.particles[grid.first + i].radius = 0.25 * spacing;
    }
    scene.obstacles.push(Obstacle::SimplexMesh {
        vertices,
        simplices,
        friction: 0.8,
        motion: dome_motion(),
    });
    super::built(b)
}
