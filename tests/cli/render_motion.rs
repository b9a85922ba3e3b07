//! `hyperpbd render` draws a moving hyperplane (and a moving simplex mesh:
//! render/src/mesh.rs) where its prescribed motion
//! has it at the snapshot's time (render/src/geometry.rs `Plane::at`),
//! by core's motion evaluation — the one every backend steps with.
//!
//! ```text
//! plane at t   n(t) = R(t) n̂,  k(t) = offset + n(t)·b(t)      (core::motion::rigid_at)
//! probe        the trace's foot f = k n (2D, unit n); pixels at f ± δ n, δ = 4 px:
//!              f + δ n is admissible (background), f − δ n excluded (shaded)
//! ```
//! Cases: a floor rising at 0.5 m/s (drawn 0.5 m higher at t = 1 than at
//! t = 0, with the very same particle state) and a floor turning a
//! quarter turn about the origin (a wall at t = 1). Before the fix both
//! were drawn where they were authored.

use hyperpbd::motion::{Motion, rigid_at};
use hyperpbd::{Obstacle, Particle, Scene, State};
use hyperpbd_render::{BACKGROUND, Image, Options, PixelMap, Renderer, Snapshot, View};

/// Two still balls at (±1.5, 1.5) and a floor n = e_1, offset 0, moving by `motion`.
fn scene(motion: Vec<Motion>) -> Scene {
    let mut s = Scene::new(2, 1.0 / 60.0, 1, 1);
    for x in [-1.5, 1.5] {
        s.particles
            .push(Particle::new(vec![x, 1.5], 1.0).with_radius(0.05));
    }
    s.obstacles.push(Obstacle::Hyperplane {
        normal: vec![0.0, 1.0],
        offset: 0.0,
        friction: 0.0,
        compliance: 0.0,
        motion,
    });
    s
}

/// The pictures of the scene's initial state at times 0 and 1 (one framing).
fn pictures(scene: &Scene) -> (Renderer, Image, Image) {
    let options = Options {
        axes: Some(vec![0, 1]),
        ..Options::default()
    };
    let view = View::new(scene, &options).expect("view");
    let state = State::from_scene(scene);
    let snaps: Vec<Snapshot> = [0.0, 1.0]
        .iter()
        .enumerate()
        .map(|(k, &time)| Snapshot {
            frame: k as u64,
            time,
            state: state.clone(),
        })
        .collect();
    let renderer = Renderer::new(scene, view, &snaps).expect("renderer");
    let a = renderer.draw(&snaps[0]).expect("draw");
    let b = renderer.draw(&snaps[1]).expect("draw");
    (renderer, a, b)
}

fn is_background(image: &Image, map: &PixelMap, x: [f64; 2]) -> bool {
    let (px, py) = (map.x0 + map.kx * x[0], map.y0 + map.ky * x[1]);
    let pixel = image
        .pixel(px.round() as u32, py.round() as u32)
        .unwrap_or_else(|| panic!("probe ({px}, {py}) outside the picture"));
    pixel[..3] == BACKGROUND
}

/// Asserts that `image` shows the floor of `motion` where core's motion
/// evaluation puts it at `time`: admissible side background, excluded
/// side shaded, δ = 4 px either side of the trace's foot.
fn assert_plane_at(image: &Image, map: &PixelMap, motion: &[Motion], time: f64) {
    let m = rigid_at(motion, 2, time);
    let n = m.rotate(&[0.0, 1.0]);
    let k = n[0] * m.translation[0] + n[1] * m.translation[1];
    let delta = 4.0 / map.kx.abs();
    let at = |s: f64| [n[0] * (k + s), n[1] * (k + s)];
    let (inside, outside) = (at(delta), at(-delta));
    println!(
        "t = {time}: n {n:?}, k {k:.4}; probes {inside:?} (admissible), {outside:?} (excluded)"
    );
    assert!(
        is_background(image, map, inside),
        "t = {time}: the admissible side of the plane at {k} is shaded"
    );
    assert!(
        !is_background(image, map, outside),
        "t = {time}: the excluded side of the plane at {k} is not shaded"
    );
}

#[test]
fn a_rising_floor_is_drawn_where_it_is_at_the_snapshots_time() {
    let motion = vec![Motion::Translate {
        velocity: vec![0.0, 0.5],
    }];
    let (renderer, first, later) = pictures(&scene(motion.clone()));
    let map = renderer.pixel_map().expect("orthographic, not turning");
    assert_plane_at(&first, &map, &motion, 0.0);
    assert_plane_at(&later, &map, &motion, 1.0);
    // Same particles, same framing: only the floor moved.
    assert_ne!(
        first.rgba(),
        later.rgba(),
        "the floor moved, the picture did not"
    );
    // The probes are 0.5 m apart (≫ 2δ): the authored place fails at t = 1.
    let authored_inside = [0.0, 4.0 / map.kx.abs()];
    assert!(
        !is_background(&later, &map, authored_inside),
        "at t = 1 the authored place of the floor is still admissible"
    );
}

#[test]
fn a_turning_floor_is_a_wall_a_quarter_turn_later() {
    let motion = vec![Motion::Rotate {
        plane: [0, 1],
        center: vec![0.0, 0.0],
        rate: std::f64::consts::FRAC_PI_2,
    }];
    let (renderer, first, later) = pictures(&scene(motion.clone()));
    let map = renderer.pixel_map().expect("orthographic, not turning");
    assert_plane_at(&first, &map, &motion, 0.0);
    // n(1) = Q(π/2) e_1 = −e_0: x_0 ≤ 0 admissible, x_0 > 0 excluded.
    assert_plane_at(&later, &map, &motion, 1.0);
    assert_ne!(first.rgba(), later.rgba());
}

#[test]
fn a_still_floor_draws_the_same_picture_at_every_time() {
    let (_, first, later) = pictures(&scene(Vec::new()));
    assert_eq!(first.rgba(), later.rgba());
}

#[test]
fn a_moving_mesh_is_drawn_where_its_motion_has_it() {
    // The floor replaced by a segment mesh from (−1, 0) to (1, 0) rising
    // at 0.5 m/s: drawn on y = 0 at t = 0 and on y = 0.5 at t = 1.
    let mut s = scene(Vec::new());
    // Two more balls below, so the framing holds the mesh's way.
    for x in [-1.5, 1.5] {
        s.particles
            .push(Particle::new(vec![x, -0.5], 1.0).with_radius(0.05));
    }
    s.obstacles = vec![Obstacle::SimplexMesh {
        vertices: vec![vec![-1.0, 0.0], vec![1.0, 0.0]],
        simplices: vec![vec![0, 1]],
        friction: 0.0,
        motion: vec![Motion::Translate {
            velocity: vec![0.0, 0.5],
        }],
    }];
    let (renderer, first, later) = pictures(&s);
    let map = renderer.pixel_map().expect("orthographic, not turning");
    for (image, y, time) in [(&first, 0.0, 0.0), (&later, 0.5, 1.0)] {
        assert!(
            !is_background(image, &map, [0.3, y]),
            "t = {time}: no mesh on y = {y}"
        );
        let off = 0.5 - y;
        assert!(
            is_background(image, &map, [0.3, off]),
            "t = {time}: mesh on y = {off}"
        );
    }
}
