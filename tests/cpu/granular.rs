//! Particle–particle contact on the CPU golden path: the plan it compiles
//! to, analytic two-ball cases, the convergence of the averaged
//! gather-Jacobi solve on deep stacks, and invariants of the shipped
//! granular scenes over long (chaotic) horizons.
//!
//! Chaotic scenes are judged on invariants, not trajectories: the deepest
//! overlap of any two balls (checked exhaustively, not only over the
//! candidate pairs) and the total energy, which must not rise without
//! input (no forces do work on these scenes but gravity, which is in the
//! energy).

use crate::common;

use common::bound::print_bound;
use common::energy;
use hyperpbd::{Backend, CpuBackend, Kernel, Plan, Scene, StageName, State};
use hyperpbd_core::broadphase::{Aabbs, exhaustive_pairs};
use hyperpbd_core::{Collisions, Particle, SceneBuilder};

/// Deepest overlap max(0, r_i + r_j − |x_i − x_j|) over all pairs.
fn deepest_overlap(scene: &Scene, state: &State) -> f64 {
    let radius: Vec<f64> = scene.particles.iter().map(|p| p.radius).collect();
    let boxes = Aabbs::particles(state.dim, &state.positions, &radius, 0.0);
    let mut deepest: f64 = 0.0;
    for [i, j] in exhaustive_pairs(&boxes) {
        let (i, j) = (i as usize, j as usize);
        let d: f64 = state
            .position(i)
            .iter()
            .zip(state.position(j))
            .map(|(a, b)| (a - b) * (a - b))
            .sum::<f64>()
            .sqrt();
        deepest = deepest.max(radius[i] + radius[j] - d);
    }
    deepest
}

fn backend(scene: &Scene) -> CpuBackend {
    let plan = Plan::compile(scene).expect("valid scene");
    CpuBackend::new(plan, &State::from_scene(scene)).expect("loads")
}

#[test]
fn collisions_add_a_broadphase_and_one_collide_per_iteration() {
    let mut scene = hyperpbd::scenes::sandpile2d();
    let plan = Plan::compile(&scene).expect("valid");
    assert_eq!(
        plan.stages,
        vec![
            StageName::Predict,
            StageName::Broadphase,
            StageName::Project,
            StageName::Velocity,
            StageName::Friction
        ]
    );
    let collides = plan
        .substep_kernels
        .iter()
        .filter(|k| **k == Kernel::Collide)
        .count();
    assert_eq!(collides, scene.iterations as usize);
    assert_eq!(plan.substep_kernels[1], Kernel::Broadphase);
    assert_eq!(plan.substep_kernels[2], Kernel::Collide);
    scene.collisions = None;
    let plain = Plan::compile(&scene).expect("valid");
    assert!(plain.contacts.is_none());
    assert!(!plain.substep_kernels.contains(&Kernel::Broadphase));
    assert!(!plain.substep_kernels.contains(&Kernel::Collide));
}

fn two_balls(dim: usize, friction: f64) -> Scene {
    let mut b = SceneBuilder::new(dim).dt(0.01).substeps(4).iterations(2);
    let mut x = vec![0.0; dim];
    x[0] = -0.5;
    let mut v = vec![0.0; dim];
    v[0] = 1.0;
    if dim > 1 && friction > 0.0 {
        v[1] = 0.05;
    }
    b.particle(
        Particle::new(x.clone(), 1.0)
            .with_radius(0.1)
            .with_velocity(v.clone()),
    );
    x[0] = 0.5;
    v.iter_mut().for_each(|c| *c = -*c);
    b.particle(Particle::new(x, 1.0).with_radius(0.2).with_velocity(v));
    b.scene_mut().collisions = Some(Collisions {
        friction,
        margin: 0.0,
    });
    b.build().expect("valid")
}

/// Two equal balls meeting head-on (plus a shear velocity): the contact
/// stops their approach (relative normal velocity → 0, PBD's perfectly
/// inelastic contact), keeps them apart, conserves momentum to rounding,
/// and, with μ large enough, also cancels their relative sliding.
#[test]
fn two_balls_meet_stop_and_conserve_momentum() {
    for dim in 1..=5 {
        for friction in [0.0, 10.0] {
            let scene = two_balls(dim, friction);
            let mut b = backend(&scene);
            for _ in 0..100 {
                b.step().expect("step");
            }
            let s = b.read_state().expect("read");
            let momentum: f64 = (0..dim)
                .map(|a| (s.velocity(0)[a] + s.velocity(1)[a]).abs())
                .fold(0.0, f64::max);
            // Bound: rounding of 400 substeps of ~10 operations at |v| ≤ 1.
            assert!(
                momentum <= 1e-12,
                "dim {dim} μ {friction}: momentum {momentum:e}"
            );
            let distance: f64 = (0..dim)
                .map(|a| (s.position(1)[a] - s.position(0)[a]).powi(2))
                .sum::<f64>()
                .sqrt();
            let gap = distance - 0.3;
            assert!(gap.abs() <= 1e-12, "dim {dim} μ {friction}: gap {gap:e}");
            // Inelastic and, with μ = 10, sticking: no relative velocity.
            let relative: f64 = (0..dim)
                .map(|a| (s.velocity(1)[a] - s.velocity(0)[a]).abs())
                .fold(0.0, f64::max);
            assert!(
                relative <= 1e-9,
                "dim {dim} μ {friction}: relative velocity {relative:e}"
            );
        }
    }
}

/// A vertical stack of `k` balls on a floor in 2D.
fn stack(k: usize, iterations: u32) -> Scene {
    let mut b = SceneBuilder::new(2)
        .dt(1.0 / 60.0)
        .substeps(10)
        .iterations(iterations)
        .gravity_along(1, 9.81);
    for i in 0..k {
        b.particle(Particle::new(vec![0.0, 0.1 + 0.2 * i as f64], 1.0).with_radius(0.1));
    }
    b.hyperplane(vec![0.0, 1.0], 0.0, 0.0);
    b.scene_mut().collisions = Some(Collisions {
        friction: 0.0,
        margin: 0.01,
    });
    b.build().expect("valid")
}

/// Deep stacks: the averaged Jacobi solve stays stable (no explosion, no
/// energy gain) and its steady overlap grows with the stack height and
/// falls with iterations. Prints the convergence table of
/// docs/collisions.md.
#[test]
fn deep_stacks_are_stable_and_converge_with_iterations() {
    println!("| stack height | iterations | deepest overlap / r after 2 s | energy change (J) |");
    println!("|---|---|---|---|");
    for k in [10usize, 20, 40] {
        let mut previous = f64::INFINITY;
        for iterations in [1u32, 4, 16] {
            let scene = stack(k, iterations);
            let mut b = backend(&scene);
            let e0 = energy(&scene, &State::from_scene(&scene));
            let mut e_max = e0;
            for _ in 0..120 {
                b.step().expect("step");
                let s = b.read_state().expect("read");
                e_max = e_max.max(energy(&scene, &s));
            }
            let s = b.read_state().expect("read");
            let overlap = deepest_overlap(&scene, &s) / 0.1;
            println!(
                "| {k} | {iterations} | {overlap:.4} | {:+.3e} |",
                energy(&scene, &s) - e0
            );
            assert!(s.positions.iter().all(|x| x.is_finite()));
            // Bound: energy may only fall (inelastic contacts); rounding
            // allowance 1e-9 J.
            assert!(
                e_max <= e0 + 1e-9,
                "k {k} it {iterations}: energy rose by {:e}",
                e_max - e0
            );
            assert!(
                overlap <= previous,
                "k {k}: more iterations, deeper overlap"
            );
            previous = overlap;
        }
        // Bound: with 16 iterations even a 40-ball stack stays within
        // 25 % of a radius (measured: see the printed table).
        assert!(
            previous <= 0.25,
            "k {k}: overlap {previous} r with 16 iterations"
        );
    }
}

/// The shipped granular scenes over long horizons: no overlap deeper than
/// a stated fraction of the radius, energy never above the initial energy.
#[test]
fn granular_scenes_keep_overlap_small_and_energy_falling() {
    for (name, frames, overlap_bound) in [
        ("sandpile2d", 240, 0.15),
        ("ballpit4d", 240, 0.15),
        ("column3d", 30, 0.15),
    ] {
        let scene = hyperpbd::scenes::by_name(name).expect("built-in");
        let r_min = scene
            .particles
            .iter()
            .map(|p| p.radius)
            .fold(f64::INFINITY, f64::min);
        let mut b = backend(&scene);
        let e0 = energy(&scene, &State::from_scene(&scene));
        let (mut worst, mut e_max) = (0.0f64, e0);
        let mut e_last = e0;
        for frame in 0..frames {
            b.step().expect("step");
            let s = b.read_state().expect("read");
            e_last = energy(&scene, &s);
            e_max = e_max.max(e_last);
            if frame % 10 == 9 || frame + 1 == frames {
                worst = worst.max(deepest_overlap(&scene, &s) / r_min);
            }
        }
        print_bound(
            format_args!("{name} {frames} frames deepest overlap / r_min"),
            format_args!("{worst:.4}"),
            format_args!("{overlap_bound}"),
            format_args!(
                "averaged Jacobi, {} iterations x {} substeps",
                scene.iterations, scene.substeps
            ),
        );
        print_bound(
            format_args!("{name} energy rise E_max − E_0"),
            format_args!("{:+.3e} J", e_max - e0),
            "0 (+1e-9 rounding)",
            format_args!("no input but gravity; E_end − E_0 = {:+.3e} J", e_last - e0),
        );
        assert!(worst <= overlap_bound, "{name}: overlap {worst} r");
        assert!(
            e_max <= e0 + 1e-9,
            "{name}: energy rose by {:e}",
            e_max - e0
        );
        assert!(e_last < e0, "{name}: the pile must lose energy");
    }
}

#[test]
fn granular_steps_are_bit_identical_across_runs() {
    let scene = hyperpbd::scenes::ballpit4d();
    let run = || {
        let mut b = backend(&scene);
        for _ in 0..20 {
            b.step().expect("step");
        }
        b.read_state().expect("read").hash()
    };
    assert_eq!(run(), run());
}

#[test]
fn collisions_settings_are_validated_with_their_paths() {
    let mut scene = two_balls(2, 0.0);
    scene.collisions = Some(Collisions {
        friction: -1.0,
        margin: 0.0,
    });
    let e = Plan::compile(&scene).expect_err("negative friction");
    assert_eq!(
        e.to_string(),
        "collisions.friction: friction coefficient must be >= 0, got -1"
    );
    scene.collisions = Some(Collisions {
        friction: 0.0,
        margin: f64::NAN,
    });
    let e = Plan::compile(&scene).expect_err("NaN margin");
    assert_eq!(e.to_string(), "collisions.margin: value NaN is not finite");
    let json =
        r#"{"dim": 1, "dt": 0.1, "collisions": {"friction": 0.5, "margin": 0.1, "stiff": 1}}"#;
    assert!(
        Scene::from_json_str(json).is_err(),
        "unknown keys are rejected"
    );
    let json = r#"{"dim": 1, "dt": 0.1, "collisions": {}}"#;
    let scene = Scene::from_json_str(json).expect("defaults");
    assert_eq!(
        scene.collisions,
        Some(Collisions {
            friction: 0.0,
            margin: 0.0
        })
    );
}

/// A contact whose distance overflows (coordinates ±1e308) fails the step
/// in the project stage, after Predict has moved a third particle, and
/// leaves the state byte-identical.
#[test]
fn a_failing_contact_rolls_the_step_back() {
    let mut b = SceneBuilder::new(2).dt(0.01);
    b.particle(Particle::new(vec![-1e308, 0.0], 1.0).with_radius(1e308));
    b.particle(Particle::new(vec![1e308, 0.0], 1.0).with_radius(1e308));
    b.particle(Particle::new(vec![0.0, 5.0], 1.0).with_velocity(vec![1.0, 0.0]));
    b.scene_mut().collisions = Some(Collisions {
        friction: 0.0,
        margin: 0.0,
    });
    let scene = b.build().expect("valid");
    let mut backend = backend(&scene);
    let before = backend.read_state().expect("read");
    // Predict alone changes the state, so the step has something to undo.
    let mut predicted = self::backend(&scene);
    predicted.run_kernel(Kernel::Predict).expect("predict");
    assert_ne!(predicted.read_state().expect("read").hash(), before.hash());
    let error = backend.step().expect_err("the contact distance overflows");
    assert!(
        error.to_string().contains("stage project"),
        "unexpected error: {error}"
    );
    assert_eq!(backend.read_state().expect("read").hash(), before.hash());
}
