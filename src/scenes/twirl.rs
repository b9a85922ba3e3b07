//! A cloth held by two moving corners (`twirl`): the hands close in and
//! spin the held edge about the vertical, so the cloth twists and flares.
//!
//! ```text
//! cloth   24 × 24 nodes, 1 m square, horizontal at y = 1.2 (edges and shear
//!         links, rigid)
//! step    1/60 s, 20 substeps (the whole cloth hangs on two nodes: with 10 the
//!         links by the hands stretch past 1 cm in the first frames), 1 iteration
//! hands   the two corners of the edge z = +0.5, fixed, each with the motion
//!           1. keyframes: toward the other hand by 0.2 m along x over the first second
//!           2. rotate in the plane [2, 0] about (0, 1.2, 0.5), the edge's midpoint,
//!              at 2 rad/s (e_2 toward e_0: the held edge spins about the vertical)
//! ```

use hyperpbd_core::builders::GridSpec;
use hyperpbd_core::motion::Motion;
use hyperpbd_core::{Scene, SceneBuilder};

/// The hands' spin rate (rad/s).
pub const TWIRL_RATE: f64 = 2.0;

/// The twirl scene (module docs).
pub fn twirl() -> Scene {
    let n = 24;
    let (height, spacing) = (1.2, 1.0 / (n - 1) as f64);
    let mut b = SceneBuilder::new(3)
        .dt(1.0 / 60.0)
        .substeps(20)
        .iterations(1)
        .gravity_along(1, 9.81)
        .damping(0.1);
    let grid = b.grid(&GridSpec::cloth(n, n, spacing, height));
    let scene = b.scene_mut();
    for i in 0..grid.len() {
        scene.particles[grid.first + i].radius = 0.25 * spacing;
    }
    for (hand, inward) in [
        (grid.index(&[0, n - 1]), 0.2),
        (grid.index(&[n - 1, n - 1]), -0.2),
    ] {
        let p = &mut scene.particles[hand];
        p.fixed = true;
        p.mass = None;
        p.motion = vec![
            Motion::Keyframes {
                times: vec![0.0, 1.0],
                translations: vec![vec![0.0; 3], vec![inward, 0.0, 0.0]],
            },
            Motion::Rotate {
                plane: [2, 0],
                center: vec![0.0, height, 0.5],
                rate: TWIRL_RATE,
            },
        ];
    }
    super::built(b)
}
