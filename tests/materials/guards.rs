//! Guards over the material families (issue 15 items 4 and its number):
//! a soft Neo-Hookean block dropped at 40 m/s onto a plane in one substep
//! of 1/30 s.
//!
//! ```text
//! block     the Kuhn block of common::guarded (3 cells of 0.1 m per axis,
//!           0.1 kg nodes, bottom 0.2 m above y = 0, every node at −40 m/s),
//!           its simplices one neo_hookean (or stvk) family, E = 2e5 Pa,
//!           ν = 0.3, rest shape = the initial positions
//! J         the material's own measure ratio: det F̂ (k = N), √(det G/det G_0) (k < N)
//! ```
//! Without guards the one substep crushes the block onto the plane and the
//! Neo-Hookean law refuses the collapsed element (`MaterialRefused`); with
//! the orientation guard that refusal is the guard's rejection, the state
//! unchanged byte for byte; with `adaptive` the step is retried with more
//! substeps until no element inverts, and no element ever does afterwards.

use crate::common;

use common::guarded::{bits, orientation, rejection};
use hyperpbd::{
    Backend, BackendError, ConstraintFamily, ConstraintKind, CpuBackend, GuardKind, GuardSubject,
    Guards, Particle, Plan, Scene, State, StepError,
};

/// The 40 m/s drop with its simplices as one `law` family.
fn material_block(
    dim: usize,
    law: ConstraintKind,
    guards: Option<Guards>,
    adaptive: Option<u32>,
) -> Scene {
    common::guarded::material_block(dim, 40.0, law, guards, adaptive)
}

fn cpu(scene: &Scene) -> CpuBackend {
    let plan = Plan::compile(scene).expect("plan");
    CpuBackend::with_threads(plan, &State::from_scene(scene), 1).expect("cpu backend")
}

/// Smallest J over family 0 at `state`.
fn smallest_ratio(scene: &Scene, state: &State) -> f64 {
    let plan = Plan::compile(scene).expect("plan");
    (0..plan.families[0].len())
        .map(|slot| hyperpbd::guards::element_ratio_at(&plan, 0, slot, &state.positions))
        .fold(f64::INFINITY, f64::min)
}

#[test]
fn the_unguarded_neo_hookean_drop_is_a_material_refusal() {
    for dim in [2, 3] {
        let scene = material_block(dim, ConstraintKind::NeoHookean, None, None);
        let mut b = cpu(&scene);
        let before = bits(&b.read_state().expect("state"));
        match b.step() {
            Err(BackendError::Step(StepError::MaterialRefused { family, .. })) => {
                assert_eq!(family, 0)
            }
            other => panic!("{dim}D: expected a material refusal, got {other:?}"),
        }
        assert_eq!(bits(&b.read_state().expect("state")), before);
    }
}

#[test]
fn with_the_orientation_guard_the_drop_is_a_typed_rejection_with_the_state_unchanged() {
    for dim in [2, 3] {
        let scene = material_block(dim, ConstraintKind::NeoHookean, Some(orientation()), None);
        let mut b = cpu(&scene);
        let before = bits(&b.read_state().expect("state"));
        let r = rejection(b.step());
        println!("{dim}D: {r}");
        assert_eq!(
            (r.guard, r.limit, r.substep),
            (GuardKind::Orientation, 0.0, 0)
        );
        let GuardSubject::Element {
            family,
            family_label,
            element,
        } = &r.subject
        else {
            panic!("an element rejection: {r}");
        };
        assert_eq!((*family, family_label.as_str()), (0, "constraints[0]"));
        let simplices = if dim == 2 { 18 } else { 27 * 6 };
        assert!(*element < simplices, "{r}");
        assert_eq!(bits(&b.read_state().expect("state")), before);
        assert_eq!(rejection(b.step()), r, "the same rejection again");
        assert_eq!(bits(&b.read_state().expect("state")), before);
    }
}

#[test]
fn adaptive_steps_keep_every_neo_hookean_element_oriented() {
    for dim in [2, 3] {
        let scene = material_block(
            dim,
            ConstraintKind::NeoHookean,
            Some(orientation()),
            Some(8),
        );
        let mut b = cpu(&scene);
        let report = b.step().expect("accepted after subdivision");
        let substeps: Vec<u32> = report.attempts.iter().map(|a| a.substeps).collect();
        println!("{dim}D attempts {substeps:?}");
        let (last, rejected) = report.attempts.split_last().expect("attempts");
        assert!(
            !rejected.is_empty(),
            "the one-substep attempt must be rejected"
        );
        for a in rejected {
            let r = a.rejection.as_ref().expect("a rejected attempt");
            assert_eq!(r.guard, GuardKind::Orientation, "{r}");
        }
        assert_eq!(last.rejection, None);
        let accepted = b.read_state().expect("state");

        // The accepted attempt is the plain scene with its substeps.
        let mut plain = material_block(dim, ConstraintKind::NeoHookean, None, None);
        plain.substeps = last.substeps;
        let mut p = cpu(&plain);
        p.step().expect("the subdivided step");
        assert_eq!(bits(&p.read_state().expect("state")), bits(&accepted));

        let mut smallest = smallest_ratio(&scene, &accepted);
        for _ in 1..30 {
            b.step().expect("guarded frame");
            smallest = smallest.min(smallest_ratio(&scene, &b.read_state().expect("state")));
        }
        println!("{dim}D adaptive: smallest J over 30 frames {smallest}");
        assert!(smallest > 0.0, "an element inverted: J = {smallest}");
    }
}

#[test]
fn the_end_of_substep_check_guards_a_stvk_family_that_never_refuses() {
    // StVK is defined for every deformation: the projection finishes and
    // the guard kernel after the substep finds the inverted element.
    let unguarded = material_block(2, ConstraintKind::Stvk, None, None);
    let mut free = cpu(&unguarded);
    free.step().expect("StVK never refuses");
    let j = smallest_ratio(&unguarded, &free.read_state().expect("state"));
    println!("unguarded StVK: smallest J {j:e}");
    assert!(
        j <= 0.0,
        "the drop must collapse or invert an element: J = {j}"
    );

    let guarded = material_block(2, ConstraintKind::Stvk, Some(orientation()), None);
    let mut b = cpu(&guarded);
    let before = bits(&b.read_state().expect("state"));
    let r = rejection(b.step());
    println!("{r}");
    assert_eq!((r.guard, r.limit), (GuardKind::Orientation, 0.0));
    assert!(r.value <= 0.0, "{r}");
    assert_eq!(bits(&b.read_state().expect("state")), before);

    let ratio = Guards {
        min_measure_ratio: Some(0.5),
        ..Guards::default()
    };
    let mut b = cpu(&material_block(2, ConstraintKind::Stvk, Some(ratio), None));
    let r = rejection(b.step());
    assert_eq!((r.guard, r.limit), (GuardKind::MinMeasureRatio, 0.5));
    assert!(r.value < 0.5, "{r}");
}

#[test]
fn the_measure_ratio_of_an_embedded_triangle_is_its_area_ratio() {
    // One triangle in R^3 (k = 2 < N = 3), stretched by 2 along x and 3
    // along z after rest: J = √(det G / det G_0) = area ratio = 6 here
    // (the triangle spans x and z).
    let rest = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]];
    let mut scene = Scene::new(3, 0.01, 1, 1);
    for p in rest {
        scene.particles.push(Particle::new(p.to_vec(), 1.0));
    }
    scene.constraints.push(ConstraintFamily::material(
        ConstraintKind::NeoHookean,
        100.0,
        0.3,
        vec![vec![0, 1, 2]],
    ));
    scene.guards = Some(orientation());
    scene.validate().expect("valid membrane");
    let plan = Plan::compile(&scene).expect("plan");
    let stretched = [0.0, 0.0, 0.0, 2.0, 0.0, 0.0, 0.0, 0.0, 3.0];
    let j = hyperpbd::guards::element_ratio_at(&plan, 0, 0, &stretched);
    println!("embedded triangle: J = {j}");
    assert!((j - 6.0).abs() <= 1e-12, "J = {j}");
    let at_rest: Vec<f64> = rest.iter().flatten().copied().collect();
    let j = hyperpbd::guards::element_ratio_at(&plan, 0, 0, &at_rest);
    assert!((j - 1.0).abs() <= 1e-15, "J at rest = {j}");
}
