//! Contact forces out (core/src/contact_forces.rs, cpu/src/contact_forces.rs):
//! closed forms at rest on both solver paths — m g on a plane, a ball
//! pressed by another, an incline held by static friction (normal
//! m g cos θ, friction m g sin θ), a moving plane — the particles' forces
//! against the obstacles', the same bytes on 1 and 2 threads, and a step
//! that is not asked reports nothing and changes nothing.

use crate::common;

use common::force_scenes::{
    assert_close, bits, imbalance, incline, on_floor, plane, square_box, stack, support, weight,
};
use common::implicit_scenes::{particle, settings};
use common::motion_scenes::G;
use hyperpbd::motion::Motion;
use hyperpbd::{Backend, ContactForces, CpuBackend, Plan, Scene, Solver, State, XpbdSettings};

/// `scene` on the golden path with contact forces requested, on `threads`.
fn asking(scene: &Scene, threads: usize) -> CpuBackend {
    let plan = Plan::compile(scene).expect("valid scene");
    let mut b = CpuBackend::with_threads(plan, &State::from_scene(scene), threads).expect("loads");
    b.request_contact_forces(true)
        .expect("the CPU reports forces");
    b
}

/// The forces of the last of `frames` steps.
fn forces_after(b: &mut CpuBackend, frames: usize) -> ContactForces {
    let mut last = None;
    for _ in 0..frames {
        last = b.step().expect("step").contact_forces;
    }
    last.expect("requested forces are reported")
}

#[test]
fn a_box_at_rest_on_a_plane_presses_on_it_with_its_weight_xpbd() {
    let scene = square_box(on_floor(2, 10, 4, 0.0));
    let f = forces_after(&mut asking(&scene, 1), 240);
    assert_close(
        "xpbd box: obstacle force = m g",
        f.obstacle(0),
        &support(2, 2.0),
        1e-9,
    );
    let top: f64 = (2..4).map(|i| f.particle(i)[1].abs()).sum();
    assert_eq!(top, 0.0, "the top corners touch nothing: {f:?}");
    let sum = imbalance(&f);
    println!("xpbd box: Σ particles − Σ obstacles = {sum:?}");
    assert!(sum.iter().all(|c| c.abs() <= 1e-12 * 2.0 * G), "{sum:?}");
}

#[test]
fn one_particle_at_rest_reports_m_g_in_every_dimension_xpbd() {
    for dim in [2usize, 3, 4] {
        let mut s = on_floor(dim, 8, 1, 0.0);
        let mut x = vec![0.0; dim];
        x[1] = 0.1;
        s.particles.push(particle(x, Some(3.0), 0.1));
        let f = forces_after(&mut asking(&s, 1), 60);
        assert_close(
            &format!("R^{dim} particle"),
            f.obstacle(0),
            &support(dim, 3.0),
            1e-9,
        );
        let minus: Vec<f64> = weight(dim, 3.0).iter().map(|c| -c).collect();
        assert_close(
            &format!("R^{dim} particle's own"),
            f.particle(0),
            &minus,
            1e-9,
        );
    }
}

fn check_stack(what: &str, f: &ContactForces) {
    // B is held up by A alone; A carries its own weight net (the floor's
    // 3 kg g up, B's 2 kg g down); the floor carries both.
    assert_close(
        &format!("{what}: floor"),
        f.obstacle(0),
        &support(2, 3.0),
        1e-9,
    );
    assert_close(&format!("{what}: B"), f.particle(1), &[0.0, 2.0 * G], 1e-9);
    assert_close(&format!("{what}: A"), f.particle(0), &[0.0, G], 1e-9);
}

#[test]
fn a_ball_pressed_by_another_carries_its_weight_xpbd() {
    let scene = stack(on_floor(2, 10, 4, 0.0));
    check_stack("xpbd stack", &forces_after(&mut asking(&scene, 1), 300));
}

fn check_incline(what: &str, f: &ContactForces, n: &[f64], theta: f64, bound: f64) {
    // The plane's force on the particle: n m g cos θ, and friction up the
    // slope m g sin θ.
    let (m, push) = (1.5, f.obstacle(0));
    let normal = push[0] * n[0] + push[1] * n[1];
    let along = [n[1], -n[0]]; // up the slope
    let friction = push[0] * along[0] + push[1] * along[1];
    println!("{what}: normal {normal}, friction {friction}");
    assert_close(
        &format!("{what}: normal"),
        &[normal],
        &[m * G * theta.cos()],
        bound,
    );
    assert_close(
        &format!("{what}: friction"),
        &[friction],
        &[m * G * theta.sin()],
        bound,
    );
    assert_close(&format!("{what}: total"), push, &support(2, m), bound);
    let sum = imbalance(f);
    assert!(
        sum.iter().all(|c| c.abs() <= 1e-12 * m * G),
        "{what}: {sum:?}"
    );
}

#[test]
fn static_friction_on_an_incline_balances_gravity_xpbd() {
    let theta: f64 = 0.3;
    for primal_residual in [false, true] {
        let (mut scene, n) = incline(on_floor(2, 10, 2, 0.0), theta, 0.8);
        scene.solver = Solver::Xpbd(XpbdSettings { primal_residual });
        let mut b = asking(&scene, 1);
        let f = forces_after(&mut b, 120);
        let state = b.read_state().expect("state");
        assert!(state.velocities.iter().all(|v| v.abs() < 1e-9), "{state:?}");
        let what = format!("xpbd incline (primal_residual {primal_residual})");
        check_incline(&what, &f, &n, theta, 1e-9);
    }
}

#[test]
fn a_plane_rising_at_constant_speed_carries_the_weight_xpbd() {
    let lift = vec![Motion::Translate {
        velocity: vec![0.0, 0.5],
    }];
    let mut s = on_floor(2, 10, 1, 0.0);
    s.obstacles = vec![plane(vec![0.0, 1.0], 0.0, lift)];
    s.particles.push(particle(vec![0.0, 0.1], Some(2.0), 0.1));
    let f = forces_after(&mut asking(&s, 1), 60);
    assert_close("rising plane", f.obstacle(0), &support(2, 2.0), 1e-9);
}

#[test]
fn a_belt_drags_a_sliding_box_with_mu_m_g() {
    // Kinetic friction while the belt (2 m/s) is faster than the box.
    let belt = vec![Motion::Translate {
        velocity: vec![2.0, 0.0],
    }];
    let (mu, m) = (0.5, 2.0);
    let mut s = on_floor(2, 20, 1, mu);
    s.obstacles = vec![plane(vec![0.0, 1.0], mu, belt)];
    s.particles.push(particle(vec![0.0, 0.1], Some(m), 0.1));
    let f = forces_after(&mut asking(&s, 1), 5);
    // The belt drags the box forward with μ m g and holds it up with m g.
    assert_close("belt", f.obstacle(0), &[mu * m * G, m * G], 1e-9);
    assert!(
        imbalance(&f).iter().all(|c| c.abs() <= 1e-12 * m * G),
        "{f:?}"
    );
}

/// A scene on the incremental-potential path with a tight stop test.
fn implicit(mut s: Scene) -> Scene {
    s.solver = Solver::IncrementalPotential(settings(1e4, 0.01, 1e-10, 100));
    s
}

#[test]
fn a_particle_at_rest_on_a_barrier_reports_m_g() {
    // The force is −∇B at the accepted iterate, so it is as exact as the
    // minimiser's stop: |F − m g| ≤ m r_final (r: the acceleration
    // residual, v = 0 at rest). A stiff, thin barrier and one substep put
    // that floor below 1e-9 relative (κ = 1e4, d^ = 0.01 at h = 1/240
    // stops at its rounding floor, 2.6e-8 relative).
    let (m, mut s) = (2.0, on_floor(3, 1, 1, 0.0));
    s.solver = Solver::IncrementalPotential(settings(1e8, 1e-4, 1e-10, 100));
    s.particles
        .push(particle(vec![0.0, 0.10005, 0.0], Some(m), 0.1));
    let mut b = asking(&s, 1);
    let f = forces_after(&mut b, 120);
    assert_close("barrier particle", f.obstacle(0), &support(3, m), 1e-9);
    assert_close(
        "barrier particle's own",
        f.particle(0),
        &[0.0, m * G, 0.0],
        1e-9,
    );
    let report = b.step().expect("step");
    let stop = report.minimisation[0].final_residual.expect("a residual");
    let f = report.contact_forces.expect("forces");
    let error = (f.obstacle(0)[1] - m * G).abs();
    println!("|F − m g| = {error:.3e} N, m r_final = {:.3e} N", m * stop);
    assert!(
        error <= m * stop * (1.0 + 1e-6) + 1e-13 * m * G,
        "{error} vs {stop}"
    );
}

#[test]
fn a_spring_box_at_rest_reports_m_g_on_the_coupled_path() {
    let mut s = implicit(square_box(on_floor(2, 4, 1, 0.0)));
    s.constraints[0].compliance = 1e-6;
    for p in &mut s.particles {
        p.position[1] += 0.005;
    }
    let f = forces_after(&mut asking(&s, 1), 240);
    assert_close("coupled box", f.obstacle(0), &support(2, 2.0), 1e-9);
    assert!(
        imbalance(&f).iter().all(|c| c.abs() <= 1e-9 * 2.0 * G),
        "{f:?}"
    );
}

#[test]
fn a_ball_pressed_by_another_carries_its_weight_on_the_coupled_path() {
    let mut s = implicit(stack(on_floor(2, 4, 1, 0.0)));
    s.particles[0].position[1] += 0.005;
    s.particles[1].position[1] += 0.015;
    check_stack("coupled stack", &forces_after(&mut asking(&s, 1), 240));
}

#[test]
fn lagged_friction_on_an_incline_balances_gravity_on_the_coupled_path() {
    let theta: f64 = 0.3;
    let (mut scene, n) = incline(implicit(on_floor(2, 4, 1, 0.0)), theta, 0.8);
    let p = &mut scene.particles[0].position;
    p[0] += 0.005 * n[0];
    p[1] += 0.005 * n[1];
    let f = forces_after(&mut asking(&scene, 1), 240);
    check_incline("coupled incline", &f, &n, theta, 1e-9);
}

#[test]
fn forces_are_the_same_bytes_on_one_and_two_threads_and_change_nothing() {
    let scenes = [
        stack(on_floor(2, 10, 4, 0.3)),
        incline(on_floor(2, 10, 2, 0.0), 0.3, 0.8).0,
        {
            let mut s = implicit(stack(on_floor(2, 4, 1, 0.0)));
            s.particles[0].position[1] += 0.005;
            s.particles[1].position[1] += 0.015;
            s
        },
    ];
    for scene in &scenes {
        let (mut one, mut two) = (asking(scene, 1), asking(scene, 2));
        let plan = Plan::compile(scene).expect("valid");
        let mut quiet =
            CpuBackend::with_threads(plan, &State::from_scene(scene), 2).expect("loads");
        for _ in 0..30 {
            let (a, b, c) = (one.step(), two.step(), quiet.step().expect("quiet"));
            let (a, b) = (a.expect("one"), b.expect("two"));
            let (fa, fb) = (
                a.contact_forces.expect("one"),
                b.contact_forces.expect("two"),
            );
            assert_eq!(bits(&fa), bits(&fb));
            assert!(c.contact_forces.is_none(), "not asked, not reported");
        }
        let (sa, sc) = (one.read_state().expect("a"), quiet.read_state().expect("c"));
        assert_eq!(sa.hash(), sc.hash(), "asking for forces changes no result");
    }
}

#[test]
fn a_request_can_be_withdrawn() {
    let scene = stack(on_floor(2, 10, 4, 0.0));
    let mut b = asking(&scene, 1);
    assert!(b.step().expect("step").contact_forces.is_some());
    b.request_contact_forces(false).expect("withdrawn");
    assert!(b.step().expect("step").contact_forces.is_none());
}

#[test]
fn a_retried_step_reports_the_forces_of_its_accepted_attempt() {
    // The adaptive drop of tests/cpu/guards.rs is accepted at 8 substeps; its
    // forces are those of the same step run with 8 substeps from the
    // start (the rejected attempts leave nothing behind).
    let guards = common::guarded::orientation();
    let retried = common::guarded::dropped_block(2, 40.0, Some(guards), Some(4));
    let mut b = asking(&retried, 1);
    let report = b.step().expect("accepted after retries");
    let substeps = report.attempts.last().expect("attempts").substeps;
    assert!(
        report.retries() > 0 && substeps > retried.substeps,
        "{report:?}"
    );
    let mut direct = common::guarded::dropped_block(2, 40.0, None, None);
    direct.substeps = substeps;
    let want = asking(&direct, 1).step().expect("step").contact_forces;
    let (got, want) = (report.contact_forces.expect("got"), want.expect("want"));
    assert!(got.obstacle(0)[1] > 0.0, "the block lands: {got:?}");
    assert_eq!(bits(&got), bits(&want));
}
