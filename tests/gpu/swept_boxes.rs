//! The GPU contact step builds each particle's broadphase box over its
//! whole substep sweep, as the golden path does: box = [min(p, x) − r,
//! max(p, x) + r] per axis (grid.wgsl `build_box`). A fast ball that only
//! meets its neighbour at the END of a substep, moving towards −x (where a
//! box from one end only would hold the START), must collide on the GPU
//! exactly as on the CPU: gpu-f64 bit for bit, frame by frame.

use crate::common;

use common::differential::differential;
use common::gpu::adapter_or_skip;
use hyperpbd::{Collisions, Particle, Precision, Scene};

/// Ball A at the origin flying at 30 m/s towards −x into ball B resting
/// 0.45 m away (radii 0.1 m): one substep of 1/60 s moves A 0.5 m, so its
/// end overlaps B while its start box [−0.1, 0.1] does not reach B's
/// [−0.55, −0.35]. Balls along ±y and ±z make every axis's swept box count.
fn fast_ball() -> Scene {
    let mut scene = Scene::new(3, 1.0 / 60.0, 1, 4);
    let ball = |x: [f64; 3], v: [f64; 3]| {
        Particle::new(x.to_vec(), 1.0)
            .with_radius(0.1)
            .with_velocity(v.to_vec())
    };
    for axis in 0..3 {
        let mut start = [0.0; 3];
        start[axis] = 10.0 * axis as f64;
        let mut v = [0.0; 3];
        v[axis] = -30.0;
        scene.particles.push(ball(start, v));
        let mut target = start;
        target[axis] -= 0.45;
        scene.particles.push(ball(target, [0.0; 3]));
    }
    scene.collisions = Some(Collisions {
        friction: 0.0,
        margin: 0.0,
    });
    scene.validate().expect("valid balls");
    scene
}

#[test]
fn a_ball_that_meets_its_neighbour_only_at_the_end_of_a_substep_collides_as_on_the_cpu() {
    let test =
        "a_ball_that_meets_its_neighbour_only_at_the_end_of_a_substep_collides_as_on_the_cpu";
    let Some((adapter, summary)) = adapter_or_skip(test, Precision::F64) else {
        return;
    };
    differential(
        &adapter,
        &summary,
        "fast ball 3D",
        &fast_ball(),
        4,
        Precision::F64,
    );
}
