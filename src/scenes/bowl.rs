//! Balls poured into a triangulated bowl (`bowl3d`): simplex-mesh contact
//! on the XPBD path with friction on the mesh and between the balls.
//!
//! ```text
//! bowl    y = 0.4 (x² + z²) over [−1, 1]², 12 × 12 cells, 2 triangles each
//!         (288), μ = 0.3
//! balls   6 × 6, r = 0.06 m, 0.1 kg, 0.25–0.35 m above the bowl, jittered
//!         in a fixed pattern; between them μ = 0.2, margin 0.01
//! step    1/60 s, 8 substeps, 2 iterations
//! ```
//! They roll to the bottom and settle in a heap on the curved mesh.

use hyperpbd_core::{Collisions, Obstacle, Particle, Scene, SceneBuilder};

/// The bowl's height at (x, z).
fn bowl_height(x: f64, z: f64) -> f64 {
    0.4 * (x * x + z * z)
}

/// The bowl scene (module docs).
pub fn bowl3d() -> Scene {
    let mut b = SceneBuilder::new(3)
        .dt(1.0 / 60.0)
        .substeps(8)
        .iterations(2)
        .gravity_along(1, 9.81);
    for k in 0..36 {
        let (i, j) = ((k / 6) as f64, (k % 6) as f64);
        let x = -0.55 + 0.22 * i + 0.013 * ((k * 7) % 5) as f64;
        let z = -0.55 + 0.22 * j + 0.011 * ((k * 3) % 7) as f64;
        let y = bowl_height(x, z) + 0.25 + 0.05 * (k % 3) as f64;
        b.particle(Particle::new(vec![x, y, z], 0.1).with_radius(0.06));
    }
    let cells = 12;
    let side = cells + 1;
    let mut vertices = Vec::with_capacity(side * side);
    for i in 0..side {
        for j in 0..side {
            let x = -1.0 + 2.0 * i as f64 / cells as f64;
            let z = -1.0 + 2.0 * j as f64 / cells as f64;
            vertices.push(vec![x, bowl_height(x, z), z]);
        }
    }
    let mut simplices = Vec::with_capacity(2 * cells * cells);
    for i in 0..cells {
        for j in 0..cells {
            let (a, c) = (i * side + j, (i + 1) * side + j + 1);
            simplices.push(vec![a, (i + 1) * side + j, c]);
            simplices.push(vec![a, c, a + 1]);
        }
    }
    let scene = b.scene_mut();
    scene.collisions = Some(Collisions {
        friction: 0.2,
        margin: 0.01,
    });
    scene.obstacles.push(Obstacle::SimplexMesh {
        vertices,
        simplices,
        friction: 0.3,
        motion: Vec::new(),
    });
    super::built(b)
}
