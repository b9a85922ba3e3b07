//! Moving simplex meshes on the golden path and the f32 reference
//! (core/src/moving_mesh.rs): a triangulated floor as a belt, a lift, a
//! turntable and a plane tilting in R^4 give the moving plane's closed
//! forms; the contact force and power on a rising mesh; the f32 reference
//! within its rounding of the golden path; the built-in `drape3d` (a cloth
//! on a turning, rising dome) turns with its dome.

use crate::common;

use common::meshes::moving_floor;
use common::motion_scenes::{G, belt, resting, spin};
use hyperpbd::motion::{Motion, rigid_at};
use hyperpbd::{Backend, CpuBackend, F32Reference, Plan, Scene, State};

/// `resting`'s ball on a triangulated floor y = 0 (half-width `half`, μ)
/// moving by `motion`, instead of the plane.
fn on_mesh(dim: usize, mu: f64, motion: Vec<Motion>, half: f64) -> Scene {
    let mut s = resting(dim, mu, Vec::new(), 20);
    s.obstacles = vec![moving_floor(dim, (0.0, half, 3), mu, motion)];
    s
}

fn backend(scene: &Scene) -> CpuBackend {
    let plan = Plan::compile(scene).expect("valid scene");
    CpuBackend::with_threads(plan, &State::from_scene(scene), 1).expect("loads")
}

fn run(sim: &mut CpuBackend, steps: usize) -> State {
    for _ in 0..steps {
        sim.step().expect("step");
    }
    sim.read_state().expect("state")
}

#[test]
fn a_belt_mesh_brings_a_resting_ball_to_its_speed_after_u_over_mu_g() {
    let (u, mu) = (2.0, 0.5);
    let mut sim = backend(&on_mesh(3, mu, belt(u, 3), 2.0));
    let t_catch = u / (mu * G);
    let steps_half = (0.5 * t_catch * 60.0).round() as usize;
    let half = run(&mut sim, steps_half);
    let t = steps_half as f64 / 60.0;
    let (want, got) = (mu * G * t, half.velocities[0]);
    println!("v(t = {t:.3} s) = {got:.6}, μ g t = {want:.6}");
    assert!((got - want).abs() <= 0.02 * want, "{got} vs {want}");
    let late = run(&mut sim, 2 * steps_half + 30);
    println!("v late = {:?}", late.velocities);
    assert!((late.velocities[0] - u).abs() <= 1e-9 * u, "{late:?}");
    assert!(late.velocities[1].abs() <= 1e-9, "{late:?}");
    assert!((late.positions[1] - 0.1).abs() <= 1e-9, "{late:?}");
}

#[test]
fn a_rising_mesh_lifts_a_resting_ball_at_its_speed() {
    let rise = 0.5;
    let lift = vec![Motion::Translate {
        velocity: vec![0.0, rise],
    }];
    let mut sim = backend(&on_mesh(2, 0.0, lift, 1.0));
    for k in 1..=60 {
        let st = run(&mut sim, 1);
        let t = k as f64 / 60.0;
        let y = st.positions[1];
        assert!((y - (0.1 + rise * t)).abs() <= 1e-12, "step {k}: y = {y}");
    }
}

#[test]
fn a_turning_mesh_carries_a_ball_round_its_circle() {
    let (omega, radius, mu) = (1.0, 0.5, 0.8);
    let mut scene = on_mesh(3, mu, spin([0, 2], vec![0.0; 3], omega), 1.0);
    scene.particles[0].position = vec![radius, 0.1, 0.0];
    scene.particles[0].velocity = Some(vec![0.0, 0.0, omega * radius]);
    let steps = 90;
    let st = run(&mut backend(&scene), steps);
    let t = steps as f64 / 60.0;
    let (x, z) = (st.positions[0], st.positions[2]);
    let (r, angle) = (x.hypot(z), z.atan2(x));
    println!("r = {r:.9}, angle = {angle:.6}, ω t = {:.6}", omega * t);
    assert!((r - radius).abs() <= 1e-3 * radius, "r = {r}");
    assert!((angle - omega * t).abs() <= 1e-3, "angle {angle}");
    let speed = st.velocities[0].hypot(st.velocities[2]);
    assert!(
        (speed - omega * radius).abs() <= 1e-3 * omega * radius,
        "{speed}"
    );
}

#[test]
fn a_mesh_tilting_in_plane_1_3_of_r4_carries_a_ball_with_it() {
    let tilt = spin([1, 3], vec![0.0; 4], 0.2);
    let x0 = [0.3, 0.1, -0.2, 0.4];
    let mut scene = on_mesh(4, 1.0, tilt.clone(), 1.0);
    scene.particles[0].position = x0.to_vec();
    let steps = 60;
    let st = run(&mut backend(&scene), steps);
    let t = steps as f64 / 60.0;
    let target = rigid_at(&tilt, 4, t).apply(&x0);
    let err = (st.positions.iter().zip(&target))
        .map(|(a, b)| (a - b) * (a - b))
        .sum::<f64>()
        .sqrt();
    println!(
        "x = {:?}, M(t) x0 = {target:?}, |Δ| = {err:e}",
        st.positions
    );
    assert!(err <= 1e-3, "{err}");
    // On the turned floor: its normal n(t) = R e1, n·x = r.
    let n = rigid_at(&tilt, 4, t).rotate(&[0.0, 1.0, 0.0, 0.0]);
    let gap: f64 = n.iter().zip(&st.positions).map(|(a, b)| a * b).sum::<f64>() - 0.1;
    assert!(gap.abs() <= 1e-9, "gap {gap}");
}

#[test]
fn a_rising_mesh_bears_the_weight_and_does_its_work() {
    let (rise, m) = (0.5, 2.0);
    let lift = vec![Motion::Translate {
        velocity: vec![0.0, rise],
    }];
    let mut scene = on_mesh(2, 0.0, lift, 1.0);
    scene.particles[0].mass = Some(m);
    let plan = Plan::compile(&scene).expect("valid scene");
    let mut sim = CpuBackend::with_threads(plan, &State::from_scene(&scene), 1).expect("loads");
    sim.request_contact_forces(true)
        .expect("the CPU reports forces");
    let mut last = None;
    for _ in 0..30 {
        last = sim.step().expect("step").contact_forces;
    }
    let forces = last.expect("requested forces are reported");
    // At constant speed the mesh holds the ball up: F = m g, P = F·u.
    let (f, p) = (forces.obstacles[1], forces.obstacle_power[0]);
    println!(
        "F_y = {f:.9} (m g = {}), P = {p:.9} (m g u = {})",
        m * G,
        m * G * rise
    );
    assert!((f - m * G).abs() <= 1e-6 * m * G, "{forces:?}");
    assert!(forces.obstacles[0].abs() <= 1e-9, "{forces:?}");
    assert!(
        (p - m * G * rise).abs() <= 1e-6 * m * G * rise,
        "{forces:?}"
    );
}

#[test]
fn the_f32_reference_rides_the_belt_mesh_within_its_rounding() {
    let scene = on_mesh(3, 0.5, belt(2.0, 3), 2.0);
    let plan = Plan::compile(&scene).expect("plan");
    let state = State::from_scene(&scene);
    let mut reference = F32Reference::new(plan, &state, &[0.0; 3]).expect("reference");
    let mut golden = backend(&scene);
    for _ in 0..60 {
        reference.step().expect("f32 step");
    }
    let (got, gold) = (reference.read_state(), run(&mut golden, 60));
    let worst = (got.positions.iter().zip(&gold.positions))
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    // The moving plane's bound (tests/cpu/motion.rs): ≤ 4 roundings of
    // ulp(2)/2 per substep over 60 × 20 substeps; the frame map adds one
    // rounding per query (x − b), within the same count.
    let bound = 4.0 * 1200.0 * f64::from(f32::EPSILON);
    println!("belt mesh: f32 reference vs golden {worst:e} (bound {bound:e})");
    assert!(worst <= bound, "{worst} > {bound}");
    assert!(
        (got.velocities[0] - 2.0).abs() <= 1e-5,
        "{:?}",
        got.velocities
    );
}

#[test]
fn the_drape_turns_with_its_dome_and_stays_on_it() {
    use hyperpbd::scenes::{DOME_RATE, dome_height, dome_motion, drape3d};
    let scene = drape3d();
    let n = 24;
    let mut sim = backend(&scene);
    // Nodes of the cloth over the cap, off its axis: (i, j) grid nodes.
    let watched = [(12, 8), (8, 12), (16, 11), (11, 16)];
    // The dome turns e_2 toward e_0: the angle from e_2 toward e_0.
    let angle = |st: &State, i: usize| st.positions[3 * i].atan2(st.positions[3 * i + 2]);
    let (frames, settle) = (150, 60);
    let settled = run(&mut sim, settle);
    let last = run(&mut sim, frames - settle);
    let dome = rigid_at(&dome_motion(), 3, frames as f64 / 60.0);
    let mut below: f64 = 0.0;
    for p in last.positions.chunks_exact(3) {
        // Into the dome's frame: y = Rᵀ (x − b).
        let d: Vec<f64> = (0..3).map(|a| p[a] - dome.translation[a]).collect();
        let local: Vec<f64> = (0..3)
            .map(|a| (0..3).map(|b| dome.rotation[b * 3 + a] * d[b]).sum())
            .collect();
        if local[0].hypot(local[2]) < 0.4 {
            below = below.max(dome_height(local[0], local[2]) - local[1]);
        }
    }
    let turned: Vec<f64> = watched
        .iter()
        .map(|&(i, j)| {
            let k = i * n + j;
            let a = angle(&last, k) - angle(&settled, k);
            (a + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI
        })
        .collect();
    let want = DOME_RATE * (frames - settle) as f64 / 60.0;
    println!("turned {turned:?} of the dome's {want:.4} rad; deepest below the cap {below:e} m");
    // Friction carries the top of the drape round with the dome.
    for a in &turned {
        assert!((a - want).abs() <= 0.05 * want, "{turned:?} vs {want}");
    }
    // The cap's triangles lie under the paraboloid between their vertices
    // (it is concave): within the flattening of a 1/16 m cell, 1.25 (1/16)²/4.
    assert!(below <= 1.25 / 16.0 / 16.0 / 4.0 + 1e-9, "{below}");
}
