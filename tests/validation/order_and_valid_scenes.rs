//! The first violation in document order, valid scenes, builder scenes,
//! messages that start with their path.

use super::*;

#[test]
fn first_violation_in_document_order_is_reported() {
    // Broken: gravity, particle 3's mass, constraint 0's rest, the normal.
    let e = error(|s| {
        *hyperplane(s).0 = vec![0.0; 3];
        s.constraints[0].rest = Some(vec![-1.0, -1.0]);
        s.particles[3].mass = Some(-1.0);
        s.gravity = Some(vec![f64::NAN; 3]);
    });
    assert_non_finite(e, "gravity[0]", f64::is_nan);
    let e = error(|s| {
        *hyperplane(s).0 = vec![0.0; 3];
        s.constraints[0].rest = Some(vec![-1.0, -1.0]);
        s.particles[3].mass = Some(-1.0);
    });
    assert!(matches!(e, SceneError::NonPositiveMass { .. }), "{e:?}");
    let e = error(|s| {
        *hyperplane(s).0 = vec![0.0; 3];
        s.constraints[0].rest = Some(vec![-1.0, -1.0]);
    });
    assert!(matches!(e, SceneError::DegenerateRest { .. }), "{e:?}");
}

#[test]
fn valid_scenes_pass() {
    let s = base();
    s.validate().expect("base scene");
    let plan = Plan::compile(&s).expect("base scene compiles");
    assert_eq!(plan.families.len(), 4);

    // Empty scene, one particle, one fixed particle: every dimension 1..=6.
    for dim in 1..=6 {
        let mut s = Scene::new(dim, 0.01, 1, 1);
        s.validate().expect("empty scene");
        Plan::compile(&s).expect("empty scene compiles");
        s.particles.push(Particle::new(vec![0.0; dim], 1.0));
        s.validate().expect("one particle");
        s.particles[0] = Particle::fixed(vec![1.0; dim]).with_velocity(vec![0.0; dim]);
        s.validate().expect("one fixed particle with zero velocity");
        Plan::compile(&s).expect("one fixed particle compiles");
    }

    // Boundary values that are allowed.
    let mut s = base();
    s.particles[0].radius = 0.0;
    s.particles[0].gravity_scale = -2.0; // buoyant: any finite scale
    s.particles[1].mass = Some(5.0); // a fixed particle may keep its mass
    s.constraints[0].rest = Some(vec![0.0, 0.0]); // zero rest length
    s.constraints[1].rest = Some(vec![0.0]); // zero squared measure
    s.constraints[2].rest = Some(vec![-0.1]); // inverted orientation
    s.constraints.push(ConstraintFamily::new(
        ConstraintKind::Distance,
        0.0,
        Vec::new(),
    )); // empty family
    s.damping = Some(Damping { rate: 0.0 });
    let (_, offset, friction, compliance) = hyperplane(&mut s);
    *offset = -3.0;
    *friction = 0.0;
    *compliance = 1.0;
    s.obstacles.push(plane(vec![0.0, 0.0, -1e-3])); // normal of any length
    s.validate().expect("boundary values");
    Plan::compile(&s).expect("boundary values compile");

    // simplex_measure k = 1 .. dim, oriented_measure in 1D and 4D.
    for k in 1..=3 {
        let mut s = base();
        s.constraints[1].elements = vec![(0..=k).map(|j| [0, 2, 3, 1][j]).collect()];
        s.validate().unwrap_or_else(|e| panic!("k = {k}: {e}"));
    }
    let mut s = Scene::new(1, 0.01, 1, 1);
    s.particles = vec![Particle::new(vec![0.0], 1.0), Particle::new(vec![1.0], 1.0)];
    s.constraints = vec![ConstraintFamily::new(
        ConstraintKind::OrientedMeasure,
        0.0,
        vec![vec![1, 0]],
    )];
    s.validate().expect("1D oriented segment (negative length)");
}

#[test]
fn builder_scenes_are_valid() {
    for name in hyperpbd::scenes::NAMES {
        let s = hyperpbd::scenes::by_name(name).expect("built-in scene");
        s.validate()
            .unwrap_or_else(|e| panic!("built-in scene {name}: {e}"));
        Plan::compile(&s).unwrap_or_else(|e| panic!("built-in scene {name}: {e}"));
    }
}

#[test]
fn every_error_message_starts_with_its_path() {
    let cases: Vec<(Edit, &str)> = vec![
        (
            Box::new(|s| s.particles[1].position[2] = f64::NAN),
            "particles[1].position[2]: ",
        ),
        (
            Box::new(|s| s.particles[2].mass = None),
            "particles[2].mass: ",
        ),
        (
            Box::new(|s| s.constraints[0].elements[1] = vec![2, 9]),
            "constraints[0].elements[1][1]: ",
        ),
        (
            Box::new(|s| *hyperplane(s).0 = vec![0.0; 3]),
            "obstacles[0].normal: ",
        ),
        (
            Box::new(|s| s.damping = Some(Damping { rate: -1.0 })),
            "damping.rate: ",
        ),
    ];
    for (edit, prefix) in cases {
        let m = error(edit).to_string();
        assert!(m.starts_with(prefix), "{m:?} should start with {prefix:?}");
    }
}
