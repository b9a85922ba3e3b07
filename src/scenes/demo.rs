//! The demo scene (`hyperpbd demo`): bending and prescribed motion in one
//! picture.
//!
//! ```text
//! cloth   32 × 32 nodes, 1 m square at y = 0.6 (edges and shear links,
//!         rigid; the cosine fold over every interior edge, compliance 1e-3)
//! hands   the two corners of the far edge, fixed, lowered by 0.35 m over
//!         the first second (keyframes), then held
//! belt    the ground plane y = 0, friction 0.6, moving along x at 0.5 m/s
//! ```
//! The free edge falls onto the belt, which drags it along x while the
//! hands hold the far edge: the cloth drapes from the hands to the belt and
//! folds where the belt pulls it.

use hyperpbd_core::motion::Motion;
use hyperpbd_core::{Obstacle, Scene};

/// The belt's speed along x (m/s).
pub const BELT_SPEED: f64 = 0.5;

/// The demo scene (module docs).
pub fn demo() -> Scene {
    let n = 32;
    let spacing = 1.0 / (n - 1) as f64;
    let mut b = super::cloth_in_3d();
    let grid = super::folding_cloth(&mut b, n, spacing, 0.6);
    b.hyperplane(vec![0.0, 1.0, 0.0], 0.0, 0.6);
    let lowered = Motion::Keyframes {
        times: vec![0.0, 1.0],
        translations: vec![vec![0.0; 3], vec![0.0, -0.35, 0.0]],
    };
    let scene = b.scene_mut();
    for i in 0..grid.len() {
        scene.particles[grid.first + i].radius = 0.25 * spacing;
    }
    for hand in [grid.index(&[0, n - 1]), grid.index(&[n - 1, n - 1])] {
        let p = &mut scene.particles[hand];
        p.fixed = true;
        p.mass = None;
        p.motion = vec![lowered.clone()];
    }
    if let Some(Obstacle::Hyperplane { motion, .. }) = scene.obstacles.last_mut() {
        *motion = vec![Motion::Translate {
            velocity: vec![BELT_SPEED, 0.0, 0.0],
        }];
    }
    b.build()
        .unwrap_or_else(|e| unreachable!("the demo scene is valid: {e}"))
}
