//! `examples/wgpu_render` (the GPU backend inside a wgpu application,
//! issue 14 item 3) on lavapipe: its picture — drawn by a wgpu render
//! pipeline from the backend's exported positions — against the CPU
//! renderer's picture of the same state with the same camera.
//!
//! ```text
//! scene        48 free balls (2D, radius 0.1 m, collisions, gravity, no
//!              obstacles or constraints: the CPU renderer draws discs only)
//! silhouette   the pixels that are not background, in each picture
//! IoU          |A ∩ B| / |A ∪ B| ≥ ((r − 1) / (r + 1))², r the smallest
//!              disc radius in pixels: the CPU renderer antialiases, so its
//!              disc of radius r touches pixels up to r + 1 from the centre,
//!              while the pipeline keeps pixels whose centre lies within r
//!              (at least those within r − 1 of it) — per disc the two
//!              silhouettes differ by at most that ring
//! ```

#[allow(dead_code)]
#[path = "../../examples/wgpu_render/main.rs"]
mod example;

use crate::common;

use hyperpbd::{Collisions, Particle, Precision, Scene};
use hyperpbd_render::{BACKGROUND, Snapshot};

fn balls() -> Scene {
    let mut scene = Scene::new(2, 1.0 / 60.0, 4, 2);
    scene.gravity = Some(vec![0.0, -9.81]);
    for j in 0..6 {
        for i in 0..8 {
            let position = vec![0.25 * i as f64, 0.25 * j as f64];
            let velocity = vec![0.3 * ((i * 7 + j * 3) % 5) as f64 - 0.6, 0.2 * j as f64];
            scene.particles.push(
                Particle::new(position, 1.0)
                    .with_radius(0.1)
                    .with_velocity(velocity),
            );
        }
    }
    scene.collisions = Some(Collisions {
        friction: 0.0,
        margin: 0.0,
    });
    scene.validate().expect("valid balls");
    scene
}

#[test]
fn the_wgpu_picture_matches_the_cpu_renderers_silhouette() {
    let test = "the_wgpu_picture_matches_the_cpu_renderers_silhouette";
    if common::gpu::adapter_or_skip(test, Precision::F32).is_none() {
        return;
    }
    let scene = balls();
    let frames = 20;
    let (picture, state, renderer) =
        example::simulate_and_draw(&scene, frames, (320, 240)).expect("the example draws");
    let cpu = renderer
        .draw(&Snapshot {
            frame: frames,
            time: frames as f64 * scene.dt,
            state,
        })
        .expect("the CPU renderer draws");
    assert_eq!((cpu.width(), cpu.height()), (picture.width, picture.height));
    let map = renderer.pixel_map().expect("orthographic");
    let r = (0.1 * map.scale).max(map.min_radius_px);
    let cpu_rgba = cpu.rgba();
    let covered = |rgba: &[u8], k: usize| rgba[4 * k..4 * k + 3] != BACKGROUND;
    let pixels = (picture.width * picture.height) as usize;
    let (mut both, mut either, mut gpu_only) = (0usize, 0usize, 0usize);
    for k in 0..pixels {
        let (a, b) = (covered(&picture.rgba, k), covered(&cpu_rgba, k));
        both += usize::from(a && b);
        either += usize::from(a || b);
        gpu_only += usize::from(a && !b);
    }
    let iou = both as f64 / either.max(1) as f64;
    let bound = ((r - 1.0) / (r + 1.0)).powi(2);
    common::bound::print_bound(
        "wgpu_render vs CPU renderer, silhouette IoU",
        format_args!("{iou:.4}"),
        format_args!(">= {bound:.4}"),
        format_args!("discs of {r:.2} px, {either} px covered, {gpu_only} px only on the GPU"),
    );
    assert!(either > 0, "nothing drawn");
    assert!(iou >= bound, "IoU {iou} < {bound}");
}
