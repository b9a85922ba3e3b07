//! Prescribed motion (core/src/motion.rs) on the golden path and the f32
//! reference: closed forms for a conveyor, a rising plane, a turntable, a
//! tilting plane in R^4, and pins that follow their motion exactly at
//! every step; the plan pays nothing without motion.

use crate::common;

use common::motion_scenes::{G, circling_pin, resting};
use hyperpbd::motion::{Motion, rigid_at};
use hyperpbd::{Backend, CpuBackend, F32Reference, Plan, Scene, StageName, State};

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
fn a_belt_brings_a_resting_box_to_its_speed_after_u_over_mu_g() {
    let (u, mu) = (2.0, 0.5);
    let belt = vec![Motion::Translate {
        velocity: vec![u, 0.0, 0.0],
    }];
    let scene = resting(3, mu, belt, 20);
    let mut sim = backend(&scene);
    // Kinetic friction accelerates it at μ g until it moves with the belt.
    let t_catch = u / (mu * G);
    let steps_half = (0.5 * t_catch * 60.0).round() as usize;
    let half = run(&mut sim, steps_half);
    let t = steps_half as f64 / 60.0;
    let want = mu * G * t;
    let got = half.velocities[0];
    println!("v(t = {t:.3} s) = {got:.6}, μ g t = {want:.6}");
    assert!((got - want).abs() <= 0.02 * want, "{got} vs {want}");
    // Past u/(μ g) it rides the belt at u (static friction carries it).
    let late = run(&mut sim, 2 * steps_half + 30);
    println!("v late = {:?}", late.velocities);
    assert!(
        (late.velocities[0] - u).abs() <= 1e-9 * u,
        "{:?}",
        late.velocities
    );
    assert!(late.velocities[1].abs() <= 1e-9);
    assert!(
        (late.positions[1] - 0.1).abs() <= 1e-9,
        "{:?}",
        late.positions
    );
}

#[test]
fn a_rising_plane_lifts_a_resting_particle_at_its_speed() {
    let rise = 0.5;
    let lift = vec![Motion::Translate {
        velocity: vec![0.0, rise],
    }];
    let scene = resting(2, 0.0, lift, 10);
    let mut sim = backend(&scene);
    for k in 1..=60 {
        let st = run(&mut sim, 1);
        let t = k as f64 / 60.0;
        // On the plane at every step end: y = r + rise t.
        let y = st.positions[1];
        assert!((y - (0.1 + rise * t)).abs() <= 1e-12, "step {k}: y = {y}");
        if k > 1 {
            assert!(
                (st.velocities[1] - rise).abs() <= 1e-9,
                "step {k}: {:?}",
                st.velocities
            );
        }
    }
    let report = sim.step().expect("step");
    assert!(report.residuals[0].max_violation <= 1e-12, "{report:?}");
    assert_eq!(report.active_contacts, 1);
}

#[test]
fn a_turntable_carries_a_particle_round_its_circle() {
    // The plane y = 0 of R^3 turning in (e0, e2) about the origin at ω:
    // the plane is the same set, its points move on circles. A particle at
    // radius R with ω² R < μ g is carried along the circle.
    let (omega, radius, mu) = (1.0, 0.5, 0.8);
    let spin = vec![Motion::Rotate {
        plane: [0, 2],
        center: vec![0.0; 3],
        rate: omega,
    }];
    let mut scene = resting(3, mu, spin, 20);
    scene.particles[0].position = vec![radius, 0.1, 0.0];
    // It starts moving with the table (its velocity at x = R e0).
    scene.particles[0].velocity = Some(vec![0.0, 0.0, omega * radius]);
    let mut sim = backend(&scene);
    let steps = 90;
    let st = run(&mut sim, steps);
    let t = steps as f64 / 60.0;
    let (x, z) = (st.positions[0], st.positions[2]);
    let r = x.hypot(z);
    let angle = z.atan2(x);
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
fn a_plane_tilting_in_plane_1_3_of_r4_carries_a_particle_with_it() {
    // The plane y = 0 of R^4 turning slowly in (e1, e3) about the origin:
    // it tilts, and with μ > tan θ the particle stays where the plane's
    // material point under it goes, M(t)(x0).
    let rate = 0.2;
    let tilt = vec![Motion::Rotate {
        plane: [1, 3],
        center: vec![0.0; 4],
        rate,
    }];
    let mut scene = resting(4, 1.0, tilt.clone(), 20);
    scene.particles[0].position = vec![0.3, 0.1, -0.2, 0.4];
    let mut sim = backend(&scene);
    let steps = 60;
    let st = run(&mut sim, steps);
    let t = steps as f64 / 60.0;
    let target = rigid_at(&tilt, 4, t).apply(&[0.3, 0.1, -0.2, 0.4]);
    let err: f64 = st
        .positions
        .iter()
        .zip(&target)
        .map(|(a, b)| (a - b) * (a - b))
        .sum::<f64>()
        .sqrt();
    println!(
        "x = {:?}, M(t) x0 = {target:?}, |Δ| = {err:e}",
        st.positions
    );
    assert!(err <= 1e-3, "{err}");
    // In contact with the tilted plane: n(t)·x = r.
    let n = rigid_at(&tilt, 4, t).rotate(&[0.0, 1.0, 0.0, 0.0]);
    let gap: f64 = n.iter().zip(&st.positions).map(|(a, b)| a * b).sum::<f64>() - 0.1;
    assert!(gap.abs() <= 1e-9, "gap {gap}");
}

#[test]
fn a_pin_follows_its_circle_exactly_at_every_step() {
    let spin = vec![Motion::Rotate {
        plane: [0, 1],
        center: vec![0.0, 2.0],
        rate: 3.0,
    }];
    let scene = circling_pin(spin.clone());
    let mut sim = backend(&scene);
    for k in 1..=120u64 {
        let st = run(&mut sim, 1);
        let t = hyperpbd::motion::substep_time(k - 1, scene.dt, 8, scene.dt / 8.0);
        let want = rigid_at(&spin, 2, t).apply(&[1.0, 2.0]);
        assert_eq!(st.position(0), &want[..], "step {k}");
        let r = (st.position(0)[0]).hypot(st.position(0)[1] - 2.0);
        assert!((r - 1.0).abs() <= 1e-14, "radius {r}");
        // The link holds.
        let d = st
            .position(1)
            .iter()
            .zip(st.position(0))
            .map(|(a, b)| (a - b) * (a - b));
        assert!((d.sum::<f64>().sqrt() - 1.0).abs() <= 1e-6);
        // The pin's velocity is its last substep's: 3 rad/s on radius 1.
        let speed = st.velocity(0)[0].hypot(st.velocity(0)[1]);
        assert!((speed - 3.0).abs() <= 1e-3, "{speed}");
    }
}

#[test]
fn keyframed_pins_hold_their_ends_and_move_linearly_between() {
    let frames = vec![Motion::Keyframes {
        times: vec![0.5, 1.0],
        translations: vec![vec![0.0, 0.0], vec![0.6, -0.3]],
    }];
    let scene = circling_pin(frames);
    let mut sim = backend(&scene);
    for k in 1..=90 {
        let st = run(&mut sim, 1);
        let t = hyperpbd::motion::substep_time(k - 1, scene.dt, 8, scene.dt / 8.0);
        let a = ((t - 0.5) / 0.5).clamp(0.0, 1.0);
        let want = [1.0 + a * 0.6, 2.0 + a * -0.3];
        for (x, w) in st.position(0).iter().zip(want) {
            assert!(
                (x - w).abs() <= 1e-15,
                "step {k}: {:?} vs {want:?}",
                st.position(0)
            );
        }
        if t <= 0.5 || t > 1.0 + scene.dt / 8.0 {
            assert_eq!(st.velocity(0), [0.0, 0.0], "step {k}: held");
        }
    }
}

#[test]
fn the_plan_runs_motion_first_only_when_the_scene_has_one() {
    let still = resting(3, 0.5, Vec::new(), 4);
    let plan = Plan::compile(&still).expect("plan");
    assert!(plan.motion.is_none());
    assert!(!plan.stages.contains(&StageName::Motion));
    let belt = vec![Motion::Translate {
        velocity: vec![1.0, 0.0, 0.0],
    }];
    let plan = Plan::compile(&resting(3, 0.5, belt, 4)).expect("plan");
    assert_eq!(plan.stages[0], StageName::Motion);
    assert_eq!(plan.kernel_counts()[0], (StageName::Motion, 4));
    // Pins alone move even with no dynamic particle.
    let mut pins = circling_pin(vec![Motion::Translate {
        velocity: vec![1.0, 0.0],
    }]);
    pins.particles.truncate(1);
    pins.constraints.clear();
    let mut sim = backend(&pins);
    let st = run(&mut sim, 60);
    assert!(
        (st.position(0)[0] - 2.0).abs() <= 1e-12,
        "{:?}",
        st.position(0)
    );
}

#[test]
fn a_failed_step_and_a_revert_keep_the_clock() {
    let belt = vec![Motion::Translate {
        velocity: vec![0.0, 1.0, 0.0],
    }];
    let scene = resting(3, 0.0, belt, 4);
    let mut a = backend(&scene);
    let mut b = backend(&scene);
    run(&mut a, 3);
    run(&mut b, 4);
    b.revert_step().expect("revert");
    run(&mut b, 1);
    run(&mut a, 1);
    assert_eq!(a.read_state().unwrap(), b.read_state().unwrap());
}

/// The f32 reference runs motion scenes as the device would.
fn f32_and_golden(scene: &Scene, steps: usize) -> (State, State) {
    let plan = Plan::compile(scene).expect("plan");
    let state = State::from_scene(scene);
    let origin = vec![0.0; scene.dim];
    let mut f32_ref = F32Reference::new(plan, &state, &origin).expect("reference");
    for _ in 0..steps {
        f32_ref.step().expect("f32 step");
    }
    (f32_ref.read_state(), run(&mut backend(scene), steps))
}

fn largest_difference(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

#[test]
fn the_f32_reference_carries_the_belt_box_within_its_rounding() {
    let belt = vec![Motion::Translate {
        velocity: vec![2.0, 0.0, 0.0],
    }];
    let (got, gold) = f32_and_golden(&resting(3, 0.5, belt, 20), 60);
    let worst = largest_difference(&got.positions, &gold.positions);
    // x reaches 1.6 m over 60 × 20 substeps; each substep rounds the
    // position a few times (x += h v, q = p + D, x −= t): at most 4
    // roundings of ulp(2)/2 = 2⁻²³ per substep, 4 · 1200 · 1.19e-7.
    let bound = 4.0 * 1200.0 * f64::from(f32::EPSILON);
    println!("belt: f32 reference vs golden {worst:e} (bound {bound:e})");
    assert!(worst <= bound, "{worst} > {bound}");
    assert!(
        (got.velocities[0] - 2.0).abs() <= 1e-5,
        "{:?}",
        got.velocities
    );
}

#[test]
fn the_f32_reference_places_pins_at_the_rounded_golden_positions() {
    let spin = vec![Motion::Rotate {
        plane: [0, 1],
        center: vec![0.0, 2.0],
        rate: 3.0,
    }];
    let (got, gold) = f32_and_golden(&circling_pin(spin), 60);
    // The pin is the host's f64 position rounded once: |Δ| ≤ ulp(3)/2.
    let pin = largest_difference(got.position(0), gold.position(0));
    assert!(pin <= 2.0 * f64::from(f32::EPSILON), "{pin}");
    // The bob is whipped round by the pin (a driven pendulum: f32 and f64
    // trajectories part exponentially), so it is held to the invariant,
    // the rigid link's length, not to the golden trajectory.
    let link = got
        .position(1)
        .iter()
        .zip(got.position(0))
        .map(|(a, b)| (a - b) * (a - b))
        .sum::<f64>()
        .sqrt();
    println!("pin {pin:e}, link {link}");
    assert!((link - 1.0).abs() <= 1e-5, "{link}");
}
