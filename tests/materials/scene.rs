//! The material families as scene input: typed errors naming field and
//! index, lumped mass from density (and its plan report), the typed
//! Neo-Hookean refusal of a step with the state unchanged byte for byte.

use crate::common;

use hyperpbd::core::material::LawRefusal;
use hyperpbd::{
    Backend, BackendError, ConstraintFamily, ConstraintKind, Plan, Scene, SceneError, State,
    StepError,
};

/// The unit square of two Neo-Hookean triangles, masses from density.
fn square() -> Scene {
    common::materials::lumped_square()
}

/// An edit of the base scene and the start of the error it must give.
type Case = (Box<dyn Fn(&mut Scene)>, &'static str);

fn error_of(scene: &Scene) -> String {
    scene.validate().expect_err("invalid").to_string()
}

#[test]
fn bad_material_input_names_the_field_and_index() {
    let cases: Vec<Case> = vec![
        (
            Box::new(|s| s.constraints[0].elements[1][1] = 9),
            "constraints[0].elements[1][1]: particle index 9 is out of range",
        ),
        (
            Box::new(|s| {
                s.particles[3].mass = Some(1.0);
                s.constraints[0].elements[1][2] = 0
            }),
            "constraints[0].elements[1][2]: particle 0 appears twice",
        ),
        (
            Box::new(|s| {
                s.particles[3].mass = Some(1.0);
                s.constraints[0].elements[1] = vec![0, 2]
            }),
            "constraints[0].elements[1]: neo_hookean elements need 3",
        ),
        (
            Box::new(|s| s.constraints[0].youngs_modulus = Some(0.0)),
            "constraints[0].youngs_modulus: youngs_modulus must be finite and > 0",
        ),
        (
            Box::new(|s| s.constraints[0].poisson_ratio = Some(1.0)),
            "constraints[0].poisson_ratio: poisson_ratio must be finite with -1 < ν < 1",
        ),
        (
            Box::new(|s| s.constraints[0].poisson_ratio = Some(-0.2)),
            "constraints[0].poisson_ratio: poisson_ratio -0.2 < 0",
        ),
        (
            Box::new(|s| s.constraints[0].poisson_ratio = None),
            "constraints[0].poisson_ratio: neo_hookean families need this key",
        ),
        (
            Box::new(|s| s.constraints[0].density = Some(-1.0)),
            "constraints[0].density: density must be finite and > 0",
        ),
        (
            Box::new(|s| s.constraints[0].compliance = 1e-3),
            "constraints[0].compliance: not used by neo_hookean families",
        ),
        (
            Box::new(|s| s.constraints[0].rest_positions = Some(vec![vec![0.0, 0.0]; 3])),
            "constraints[0].rest_positions: 3 rest positions for 4 particles",
        ),
        (
            Box::new(|s| s.constraints[0].rest_positions = Some(vec![vec![0.0, 0.0, 0.0]; 4])),
            "constraints[0].rest_positions[0]: expected 2 components",
        ),
        (
            Box::new(|s| {
                s.constraints[0].rest_positions = Some(vec![
                    vec![0.0, 0.0],
                    vec![1.0, 0.0],
                    vec![2.0, 0.0],
                    vec![0.0, 1.0],
                ])
            }),
            "constraints[0].elements[0]: degenerate rest geometry",
        ),
        (
            Box::new(|s| s.constraints[0].density = None),
            "particles[0].mass: missing mass",
        ),
        (
            Box::new(|s| {
                s.constraints.push(ConstraintFamily {
                    density: Some(1.0),
                    ..ConstraintFamily::new(ConstraintKind::Distance, 0.0, vec![vec![0, 1]])
                })
            }),
            "constraints[1].density: not used by distance families",
        ),
    ];
    for (edit, expected) in cases {
        let mut scene = square();
        edit(&mut scene);
        let message = error_of(&scene);
        assert!(
            message.starts_with(expected),
            "expected {expected:?}, got {message:?}"
        );
    }
    // The JSON form reads the same keys.
    let json = square().to_json_string();
    assert_eq!(Scene::from_json_str(&json).expect("round trip"), square());
    assert!(matches!(
        Scene::from_json_str(&json.replace("\"density\":3.0", "\"density\":0.0")),
        Err(SceneError::Material { .. })
    ));
}

#[test]
fn particles_without_mass_take_the_lumped_mass() {
    let plan = Plan::compile(&square()).expect("valid");
    // Each triangle: 3 · ½ = 1.5, a third to each vertex.
    let expected = [1.0, 0.5, 1.0, 0.5];
    for (w, m) in plan.inverse_mass.iter().zip(expected) {
        assert!(((1.0 / w) - m).abs() <= 4.0 * f64::EPSILON, "{w} vs 1/{m}");
    }
    let report = &plan.lumped_mass[0];
    assert_eq!(report.label, "constraints[0]");
    assert!((report.element_total - 3.0).abs() <= 4.0 * f64::EPSILON);
    assert!((report.vertex_total - 3.0).abs() <= 4.0 * f64::EPSILON);
    // An authored mass wins.
    let mut scene = square();
    scene.particles[1].mass = Some(7.0);
    let plan = Plan::compile(&scene).expect("valid");
    assert_eq!(plan.inverse_mass[1], 1.0 / 7.0);
}

#[test]
fn an_inverting_neo_hookean_step_is_refused_and_the_state_unchanged() {
    let mut scene = square();
    // Particle 2 flies through the opposite edge within one step.
    scene.particles[2].velocity = Some(vec![-300.0, -300.0]);
    let plan = Plan::compile(&scene).expect("valid");
    let mut backend = hyperpbd::CpuBackend::new(plan, &State::from_scene(&scene)).expect("loads");
    let before = backend.read_state().expect("state");
    let error = backend.step().expect_err("inverted");
    match &error {
        BackendError::Step(StepError::MaterialRefused {
            family_label,
            refusal,
            ..
        }) => {
            assert_eq!(family_label, "constraints[0]");
            assert!(matches!(
                refusal,
                LawRefusal::Inverted { .. } | LawRefusal::Collapsed { .. }
            ));
        }
        other => panic!("expected a material refusal, got {other}"),
    }
    let after = backend.read_state().expect("state");
    let bits = |s: &State| -> Vec<u64> {
        s.positions
            .iter()
            .chain(&s.velocities)
            .map(|x| x.to_bits())
            .collect()
    };
    assert_eq!(bits(&before), bits(&after), "{error}");
    // StVK never refuses: the same motion steps.
    scene.constraints[0].kind = ConstraintKind::Stvk;
    let mut stvk = hyperpbd::cpu_backend(&scene).expect("loads");
    stvk.step().expect("StVK is defined for every deformation");
}
