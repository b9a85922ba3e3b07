//! Materials (StVK, Neo-Hookean) as terms of the coupled implicit step
//! (issue 16 item 1, docs/implicit.md §2 and §11): a hanging soft block
//! settles to the static solution the XPBD path reaches, a Neo-Hookean
//! element the inertial prediction would invert is held by rejected trials
//! (never a NaN), an element inverted at the step's start is a typed
//! refusal with the state unchanged, and the bytes do not depend on the
//! thread count. The finite-difference checks of the objective's new
//! gradient and Hessian–vector product are unit tests of the CPU crate
//! (`cargo test --release -p hyperpbd-cpu --lib coupled`).
//! `cargo test --release --test implicit -- materials:: --nocapture | grep '^BOUND'`.

use crate::common;

use common::bound::{check_bound, print_bound};
use hyperpbd::builders::{coords_of, kuhn_grid_elements};
use hyperpbd::{
    Backend, BackendError, ConstraintFamily, ConstraintKind, Convergence, Damping,
    IncrementalPotentialSettings, MinimisationStatus, Particle, Refusal, Scene, Solver, State,
    StepError,
};

const G: f64 = 9.81;
/// Cells of the block (x, y), 0.1 m each.
const CELLS: [usize; 2] = [4, 2];

fn implicit(tolerance: f64) -> Solver {
    Solver::IncrementalPotential(IncrementalPotentialSettings {
        barrier_stiffness: 1e3,
        activation_distance: 1e-3,
        convergence: Convergence::MaxAccelerationResidual { tolerance },
        max_iterations: 50,
        cg_iterations: None,
        warm_start: None,
        friction_slip_velocity: None,
    })
}

/// A 0.4 m × 0.2 m block of Kuhn triangles (density 1000 kg/m², E = 1e4
/// Pa, ν = 0.3) hanging from its fixed top row under gravity (it sags by
/// 11 % of its height: the laws' nonlinear range), on the implicit path
/// (one minimisation per 1/60 s frame) or on XPBD (20 substeps × 50
/// iterations, damped at 5 /s so that it settles too).
fn hanging_block(law: ConstraintKind, implicit_solver: bool) -> Scene {
    let nodes = [CELLS[0] + 1, CELLS[1] + 1];
    let (dt, substeps, iterations) = if implicit_solver {
        (1.0 / 60.0, 1, 1)
    } else {
        (1.0 / 60.0, 20, 50)
    };
    let mut scene = Scene::new(2, dt, substeps, iterations);
    scene.gravity = Some(vec![0.0, -G]);
    for i in 0..nodes[0] * nodes[1] {
        let c = coords_of(i, &nodes);
        let position = vec![0.1 * c[0] as f64, 0.1 * c[1] as f64];
        if c[1] == CELLS[1] {
            scene.particles.push(Particle::fixed(position));
        } else {
            let mut p = Particle::new(position, 1.0);
            p.mass = None;
            scene.particles.push(p);
        }
    }
    scene.constraints.push(
        ConstraintFamily::material(law, 1e4, 0.3, kuhn_grid_elements(&CELLS, 0))
            .with_density(1000.0),
    );
    if implicit_solver {
        scene.solver = implicit(1e-6);
    } else {
        scene.damping = Some(Damping { rate: 5.0 });
    }
    scene
}

/// Steps `steps` frames; panics on a refused minimisation; returns the
/// state, the Newton iterations of the last frame and its status.
fn settle(scene: &Scene, steps: usize, threads: usize) -> (State, u32, String) {
    let mut cpu = common::cpu_backend(scene, threads);
    let mut last = (0, String::new());
    for step in 0..steps {
        let report = cpu.step().unwrap_or_else(|e| panic!("step {step}: {e}"));
        for m in &report.minimisation {
            assert!(
                !matches!(m.status, MinimisationStatus::Refused(_)),
                "step {step}: {:?}",
                m.status
            );
            last = (m.iterations, format!("{:?}", m.status));
        }
    }
    (cpu.read_state().expect("state"), last.0, last.1)
}

fn largest_difference(a: &State, b: &State) -> f64 {
    a.positions
        .iter()
        .zip(&b.positions)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

fn sag(scene: &Scene, s: &State) -> f64 {
    (0..scene.particles.len())
        .map(|i| scene.particles[i].position[1] - s.positions[2 * i + 1])
        .fold(0.0, f64::max)
}

#[test]
fn a_hanging_block_settles_where_xpbd_does() {
    for law in [ConstraintKind::NeoHookean, ConstraintKind::Stvk] {
        let implicit_scene = hanging_block(law, true);
        let (ip, newton, status) = settle(&implicit_scene, 600, 1);
        let speed = ip.velocities.iter().map(|v| v.abs()).fold(0.0, f64::max);
        let (xpbd, _, _) = settle(&hanging_block(law, false), 600, 1);
        let drop = sag(&implicit_scene, &ip);
        println!(
            "{law:?}: implicit sag {drop:e} m (last frame: {newton} Newton iterations, {status}), \
             XPBD sag {:e} m",
            sag(&implicit_scene, &xpbd)
        );
        check_bound(
            &format!("implicit {law:?} hanging block: max |v| after 10 s (m/s)"),
            speed,
            1e-6,
            "settled (backward Euler dissipates)",
        );
        check_bound(
            &format!("implicit {law:?} hanging block: max |x_implicit − x_xpbd| / sag after 10 s"),
            largest_difference(&ip, &xpbd) / drop,
            1e-3,
            "one static equilibrium ∇U = 0; what is left is XPBD's iteration error (it falls 4× \
             when substeps and iterations double: NH 1.8e-4 → 4.6e-5)",
        );
    }
}

/// One Neo-Hookean triangle (E = 100 Pa) whose free vertex moves at 200
/// m/s towards its fixed edge: the inertial prediction x~ is inverted
/// (J < 0), so the warm start and the first Newton trials are refused by
/// the law; the step must still end at a feasible, finite state.
fn crushed_triangle(speed: f64) -> Scene {
    let mut scene = Scene::new(2, 1.0 / 60.0, 1, 1);
    scene.particles.push(Particle::fixed(vec![0.0, 0.0]));
    scene.particles.push(Particle::fixed(vec![1.0, 0.0]));
    let mut free = Particle::new(vec![0.0, 1.0], 1.0);
    free.velocity = Some(vec![0.0, -speed]);
    scene.particles.push(free);
    scene.constraints.push(ConstraintFamily::material(
        ConstraintKind::NeoHookean,
        100.0,
        0.3,
        vec![vec![0, 1, 2]],
    ));
    scene.solver = implicit(1e-6);
    scene
}

#[test]
fn an_inverting_prediction_is_a_rejected_trial_not_a_nan() {
    let scene = crushed_triangle(200.0);
    let predicted = 1.0 - 200.0 / 60.0;
    assert!(predicted < 0.0, "the prediction inverts the triangle");
    let mut cpu = common::cpu_backend(&scene, 1);
    let mut lowest = f64::INFINITY;
    for step in 0..30 {
        let report = cpu.step().unwrap_or_else(|e| panic!("step {step}: {e}"));
        let m = &report.minimisation[0];
        assert!(
            !matches!(m.status, MinimisationStatus::Refused(_)),
            "step {step}: {:?}",
            m.status
        );
        let s = cpu.read_state().expect("state");
        assert!(
            s.positions
                .iter()
                .chain(&s.velocities)
                .all(|v| v.is_finite())
        );
        lowest = lowest.min(s.positions[5]);
    }
    print_bound(
        "implicit NH triangle crushed at 200 m/s: lowest height of the free vertex over 30 frames (J = height)",
        format_args!("{lowest:e}"),
        "> 0",
        "inverting trials are rejected (F = +∞), never accepted or NaN",
    );
    assert!(lowest > 0.0);
}

#[test]
fn an_element_inverted_at_the_start_is_refused_by_name_and_the_state_kept() {
    let mut scene = crushed_triangle(0.0);
    scene.particles[2].position = vec![0.0, -1.0];
    let rest = vec![vec![0.0, 0.0], vec![1.0, 0.0], vec![0.0, 1.0]];
    scene.constraints[0] = scene.constraints[0].clone().with_rest_positions(rest);
    let mut cpu = common::cpu_backend(&scene, 1);
    let before = cpu.read_state().expect("state");
    let error = cpu.step().expect_err("an inverted start is refused");
    match &error {
        BackendError::Step(StepError::MinimisationRefused {
            reason:
                Refusal::Material {
                    family_label,
                    element,
                    ..
                },
            ..
        }) => {
            assert_eq!(family_label, "constraints[0]");
            assert_eq!(*element, 0);
        }
        other => panic!("expected a material refusal, got {other}"),
    }
    println!("{error}");
    let after = cpu.read_state().expect("state");
    assert_eq!(
        common::differing_values(&before, &after),
        0,
        "the state is kept byte for byte"
    );
}

#[test]
fn material_scenes_are_byte_identical_for_any_thread_count() {
    let scenes = [
        (
            "NH block",
            hanging_block(ConstraintKind::NeoHookean, true),
            40,
        ),
        ("StVK block", hanging_block(ConstraintKind::Stvk, true), 40),
        ("crushed triangle", crushed_triangle(200.0), 10),
    ];
    for (name, scene, steps) in scenes {
        let (one, _, _) = settle(&scene, steps, 1);
        let (two, _, _) = settle(&scene, steps, 2);
        common::check_byte_identical(
            format_args!("implicit {name}: values differing, 1 vs 2 threads (chunks of 1)"),
            &one,
            &two,
            "fixed-order gathers, block-tree sums",
        );
    }
}
