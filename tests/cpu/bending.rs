//! Bending (the cosine fold, `core/src/kinds/bending.rs`): rigid motions
//! carry no force, the fold stays finite and unflipped near flat and near
//! shut, a bent hinge unfolds to its rest, and the cloth builder's hinges
//! are the triangulation's interior edges.

use crate::common;

use common::Lcg;
use common::hinges::{assert_no_rigid_force, opened, random_hinge};
use hyperpbd::builders::GridSpec;
use hyperpbd::core::expr::Columns;
use hyperpbd::kinds::{BendingModel, ExpressionKind};
use hyperpbd::{
    Backend, ConstraintFamily, ConstraintKind, CpuBackend, FamilyKind, Particle, Plan, Scene,
    SceneBuilder, State,
};

/// One bending element over `points` (4 particles in R^dim, all dynamic).
fn hinge(points: &[Vec<f64>], rest: Option<f64>) -> Scene {
    let dim = points[0].len();
    let mut scene = Scene::new(dim, 1.0 / 60.0, 10, 4);
    scene.particles = points
        .iter()
        .map(|p| Particle::new(p.clone(), 1.0))
        .collect();
    let mut family = ConstraintFamily::new(ConstraintKind::Bending, 0.0, vec![vec![0, 1, 2, 3]]);
    family.rest = rest.map(|r| vec![r]);
    scene.constraints.push(family);
    scene
}

fn kind_of(plan: &Plan) -> &ExpressionKind {
    match &plan.families[0].kind {
        FamilyKind::Expression(kind) => kind,
        other => panic!("bending compiles to an expression, not {other:?}"),
    }
}

/// c and ∇c at `points` (flat, 4 × dim).
fn fold(kind: &ExpressionKind, points: &[f64]) -> (f64, Vec<f64>) {
    let mut columns = Columns::new();
    kind.gradient.eval_f64(1, |j, _| points[j], &mut columns);
    let value = columns.get(kind.gradient.value, 0);
    let gradient = kind
        .gradient
        .gradient
        .iter()
        .map(|&s| columns.get(s, 0))
        .collect();
    (value, gradient)
}

#[test]
fn the_plan_names_bending_and_compiles_it_once_per_family() {
    let scene = hinge(
        &[
            vec![0.0, 0.0, 0.0],
            vec![1.0, 0.0, 0.0],
            vec![0.5, 1.0, 0.0],
            vec![0.5, -1.0, 0.2],
        ],
        None,
    );
    let plan = Plan::compile(&scene).expect("compiles");
    assert_eq!(plan.families[0].kind.name(), "bending");
    let kind = kind_of(&plan);
    assert_eq!(kind.arity, 4);
    // The authored rest is the fold there.
    let flat: Vec<f64> = scene
        .particles
        .iter()
        .flat_map(|p| p.position.clone())
        .collect();
    assert_eq!(
        plan.families[0].rest[0].to_bits(),
        fold(kind, &flat).0.to_bits()
    );
}

#[test]
fn rigid_motions_carry_no_force() {
    let mut rng = Lcg(0x5eed_b3d1);
    let mut checked = 0;
    for dim in 3..=5 {
        for _ in 0..200 {
            let points = random_hinge(&mut rng, dim);
            let plan = Plan::compile(&hinge(&points, Some(0.0))).expect("compiles");
            let flat: Vec<f64> = points.concat();
            let (c, g) = fold(kind_of(&plan), &flat);
            assert!((-1.0..=1.0).contains(&c), "{c}");
            // c is invariant under translation (Σ_j ∇_j c = 0) and rotation
            // (Σ_j x_j ∇_j cᵀ − ∇_j c x_jᵀ = 0): both at roundoff scale.
            assert_no_rigid_force(dim, &flat, &g);
            checked += 1;
        }
    }
    assert_eq!(checked, 600);
}

#[test]
fn the_fold_is_finite_and_unflipped_near_flat_and_near_shut() {
    let plan = Plan::compile(&hinge(&opened(2.0), Some(0.0))).expect("compiles");
    let kind = kind_of(&plan);
    for eps in [1e-2, 1e-4, 1e-8, 1e-12, 0.0] {
        for theta in [std::f64::consts::PI - eps, eps] {
            let (c, g) = fold(kind, &opened(theta).concat());
            // c = −cos θ: 1 flat, −1 shut, never past either.
            assert!((-1.0..=1.0).contains(&c), "θ = {theta}: c = {c}");
            assert!((c + theta.cos()).abs() <= 1e-12, "θ = {theta}: c = {c}");
            assert!(g.iter().all(|v| v.is_finite()), "θ = {theta}: ∇c = {g:?}");
        }
    }
}

#[test]
fn a_bent_hinge_unfolds_to_its_flat_rest_without_flipping() {
    // Rest flat (c = 1); start at 90°: x0, x1, x2 fixed, x3 moves.
    let mut scene = hinge(&opened(std::f64::consts::FRAC_PI_2), Some(1.0));
    for i in 0..3 {
        scene.particles[i] = Particle::fixed(scene.particles[i].position.clone());
    }
    scene.damping = Some(hyperpbd::Damping { rate: 2.0 });
    let plan = Plan::compile(&scene).expect("compiles");
    let mut cpu = CpuBackend::new(plan.clone(), &State::from_scene(&scene)).expect("loads");
    let kind = kind_of(&plan).clone();
    let mut last = fold(&kind, &cpu.read_state().expect("s").positions).0;
    assert!(last.abs() < 1e-12);
    for frame in 0..120 {
        cpu.step().unwrap_or_else(|e| panic!("frame {frame}: {e}"));
        let state = cpu.read_state().expect("s");
        let c = fold(&kind, &state.positions).0;
        assert!(c.is_finite() && c <= 1.0, "frame {frame}: c = {c}");
        // Wing B opens towards flat and stays there: the cosine cannot tell
        // the two sides of flat apart, so a step may overshoot flat by a
        // hair (measured 5e-7 m), but the wing never flips through the
        // other wing's plane (z ≈ −1 for a flipped 1 m wing).
        assert!(
            state.positions[11] >= -1e-4,
            "frame {frame}: z = {}",
            state.positions[11]
        );
        last = c;
    }
    assert!(
        1.0 - last < 1e-2,
        "after 2 s the hinge is flat to {:e}",
        1.0 - last
    );
}

#[test]
fn the_cloth_builder_adds_one_hinge_per_interior_edge() {
    let mut b = SceneBuilder::new(3)
        .dt(1.0 / 60.0)
        .substeps(10)
        .gravity_along(1, 9.81);
    let grid = b.grid(&GridSpec::cloth(5, 4, 0.1, 1.0));
    let family = b
        .grid_bending(&grid, 1e-3, BendingModel::Cosine)
        .expect("a 2-grid has hinges");
    let scene = b.build().expect("valid");
    let elements = &scene.constraints[family].elements;
    // (na−1)(nb−1) diagonals + (na−1)(nb−2) + (na−2)(nb−1) grid edges.
    assert_eq!(elements.len(), 4 * 3 + 4 * 2 + 3 * 3);
    // Authored flat: every rest fold is 1 (to rounding).
    let plan = Plan::compile(&scene).expect("compiles");
    let rest = &plan.families[family].rest;
    assert!(rest.iter().all(|c| (c - 1.0).abs() < 1e-12), "{rest:?}");
}
