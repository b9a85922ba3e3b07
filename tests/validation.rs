//! `Scene::validate`: one test per rule.
//!
//! Every test starts from one valid scene (`base()`: dim 3, gravity, a
//! dynamic and a fixed particle plus two more, a distance, a
//! simplex-measure and an oriented-measure family, a hyperplane and
//! damping), breaks exactly one thing, and asserts the exact `SceneError`
//! variant with its exact field path. The last tests check that valid
//! scenes pass, that the first violation in document order is the one
//! reported, and that `Plan::compile` and `SceneBuilder::build` refuse
//! what validation refuses.

use hyperpbd::{
    ConstraintFamily, ConstraintKind, Damping, Obstacle, Particle, Plan, Scene, SceneBuilder,
    SceneError,
};

/// The valid starting point of every test.
fn base() -> Scene {
    let mut s = Scene::new(3, 1.0 / 60.0, 10, 2);
    s.gravity = Some(vec![0.0, -9.81, 0.0]);
    s.particles = vec![
        Particle::new(vec![0.0, 1.0, 0.0], 1.0)
            .with_velocity(vec![0.1, 0.0, 0.0])
            .with_force(vec![0.0, 0.0, 1.0])
            .with_radius(0.1)
            .with_gravity_scale(0.5),
        Particle::fixed(vec![0.0, 2.0, 0.0]),
        Particle::new(vec![0.5, 1.0, 0.0], 2.0),
        Particle::new(vec![0.0, 1.0, 0.5], 3.0),
    ];
    s.constraints = vec![
        ConstraintFamily {
            kind: ConstraintKind::Distance,
            compliance: 0.0,
            elements: vec![vec![0, 1], vec![2, 3]],
            rest: Some(vec![1.0, 0.7]),
            ..ConstraintFamily::new(ConstraintKind::Distance, 0.0, Vec::new())
        },
        ConstraintFamily::new(ConstraintKind::SimplexMeasure, 1e-6, vec![vec![0, 2, 3]]),
        ConstraintFamily::new(ConstraintKind::OrientedMeasure, 0.0, vec![vec![1, 0, 2, 3]]),
    ];
    s.obstacles = vec![plane(vec![0.0, 1.0, 0.0])];
    s.damping = Some(Damping { rate: 0.5 });
    s
}

fn plane(normal: Vec<f64>) -> Obstacle {
    Obstacle::Hyperplane {
        normal,
        offset: 0.0,
        friction: 0.5,
        compliance: 0.0,
    }
}

/// Mutable access to the fields of the base hyperplane.
fn hyperplane(s: &mut Scene) -> (&mut Vec<f64>, &mut f64, &mut f64, &mut f64) {
    let Obstacle::Hyperplane {
        normal,
        offset,
        friction,
        compliance,
    } = &mut s.obstacles[0]
    else {
        panic!("the base scene's obstacle is a hyperplane");
    };
    (normal, offset, friction, compliance)
}

/// One edit of the base scene.
type Edit = Box<dyn FnOnce(&mut Scene)>;

/// Applies `edit` to the base scene and returns the validation error,
/// checking on the way that `Plan::compile` and the builder refuse the
/// scene with the same error.
fn error(edit: impl FnOnce(&mut Scene)) -> SceneError {
    let mut s = base();
    edit(&mut s);
    let e = match s.validate() {
        Ok(()) => panic!("the edited scene was accepted: {s:#?}"),
        Err(e) => e,
    };
    let same = |other: &SceneError| format!("{other:?}") == format!("{e:?}");
    match Plan::compile(&s) {
        Ok(_) => panic!("Plan::compile accepted a scene validate rejects ({e})"),
        Err(c) => assert!(same(&c), "compile gave {c:?}, validate gave {e:?}"),
    }
    let mut b = SceneBuilder::new(s.dim);
    *b.scene_mut() = s;
    match b.build() {
        Ok(_) => panic!("SceneBuilder::build accepted a scene validate rejects ({e})"),
        Err(c) => assert!(same(&c), "build gave {c:?}, validate gave {e:?}"),
    }
    let message = e.to_string();
    assert!(!message.is_empty());
    e
}

/// `NonFinite` at `path` with a value for which `check` holds.
fn assert_non_finite(e: SceneError, path: &str, check: fn(f64) -> bool) {
    match e {
        SceneError::NonFinite { path: p, value } => {
            assert_eq!(p, path);
            assert!(check(value), "unexpected value {value}");
            assert!(
                SceneError::NonFinite { path: p, value }
                    .to_string()
                    .starts_with(&format!("{path}: "))
            );
        }
        other => panic!("expected NonFinite at {path}, got {other:?}"),
    }
}

fn wrong_length(path: &str, found: usize) -> SceneError {
    SceneError::WrongLength {
        path: path.into(),
        expected: 3,
        found,
    }
}

// ---------------------------------------------------------------- step settings

#[test]
fn dim_zero() {
    let e = error(|s| {
        *s = Scene::new(0, 0.01, 1, 1);
    });
    assert_eq!(e, SceneError::ZeroDimension);
    assert!(e.to_string().starts_with("dim: "));
}

#[test]
fn dt_zero_and_negative() {
    assert_eq!(
        error(|s| s.dt = 0.0),
        SceneError::NonPositiveTimeStep { value: 0.0 }
    );
    assert_eq!(
        error(|s| s.dt = -0.01),
        SceneError::NonPositiveTimeStep { value: -0.01 }
    );
    let e = error(|s| s.dt = -0.0);
    assert!(matches!(e, SceneError::NonPositiveTimeStep { value } if value == 0.0));
    assert!(e.to_string().starts_with("dt: "));
}

#[test]
fn dt_non_finite() {
    assert_non_finite(error(|s| s.dt = f64::NAN), "dt", f64::is_nan);
    assert_non_finite(error(|s| s.dt = f64::INFINITY), "dt", |v| {
        v == f64::INFINITY
    });
    assert_non_finite(error(|s| s.dt = f64::NEG_INFINITY), "dt", |v| {
        v == f64::NEG_INFINITY
    });
}

#[test]
fn substeps_zero() {
    let e = error(|s| s.substeps = 0);
    assert_eq!(e, SceneError::ZeroSubsteps);
    assert!(e.to_string().starts_with("substeps: "));
}

#[test]
fn iterations_zero() {
    let e = error(|s| s.iterations = 0);
    assert_eq!(e, SceneError::ZeroIterations);
    assert!(e.to_string().starts_with("iterations: "));
}

// ---------------------------------------------------------------- non-finite values

#[test]
fn non_finite_position() {
    let e = error(|s| s.particles[1].position[2] = f64::NAN);
    assert_non_finite(e, "particles[1].position[2]", f64::is_nan);
}

#[test]
fn non_finite_velocity() {
    let e = error(|s| s.particles[0].velocity = Some(vec![0.0, f64::INFINITY, 0.0]));
    assert_non_finite(e, "particles[0].velocity[1]", f64::is_infinite);
}

#[test]
fn non_finite_force() {
    let e = error(|s| s.particles[3].force = Some(vec![f64::NAN, 0.0, 0.0]));
    assert_non_finite(e, "particles[3].force[0]", f64::is_nan);
}

#[test]
fn non_finite_gravity() {
    let e = error(|s| s.gravity = Some(vec![0.0, 0.0, f64::NEG_INFINITY]));
    assert_non_finite(e, "gravity[2]", |v| v == f64::NEG_INFINITY);
}

#[test]
fn non_finite_mass() {
    let e = error(|s| s.particles[2].mass = Some(f64::NAN));
    assert_non_finite(e, "particles[2].mass", f64::is_nan);
    let e = error(|s| s.particles[2].mass = Some(f64::INFINITY));
    assert_non_finite(e, "particles[2].mass", f64::is_infinite);
}

#[test]
fn non_finite_radius() {
    let e = error(|s| s.particles[0].radius = f64::NAN);
    assert_non_finite(e, "particles[0].radius", f64::is_nan);
    let e = error(|s| s.particles[0].radius = f64::INFINITY);
    assert_non_finite(e, "particles[0].radius", f64::is_infinite);
}

#[test]
fn non_finite_gravity_scale() {
    let e = error(|s| s.particles[3].gravity_scale = f64::NAN);
    assert_non_finite(e, "particles[3].gravity_scale", f64::is_nan);
}

#[test]
fn non_finite_constraint_compliance() {
    let e = error(|s| s.constraints[1].compliance = f64::NAN);
    assert_non_finite(e, "constraints[1].compliance", f64::is_nan);
    let e = error(|s| s.constraints[2].compliance = f64::INFINITY);
    assert_non_finite(e, "constraints[2].compliance", f64::is_infinite);
}

#[test]
fn non_finite_rest() {
    let e = error(|s| s.constraints[0].rest = Some(vec![1.0, f64::NAN]));
    assert_non_finite(e, "constraints[0].rest[1]", f64::is_nan);
}

#[test]
fn non_finite_normal() {
    let e = error(|s| *hyperplane(s).0 = vec![0.0, f64::NAN, 0.0]);
    assert_non_finite(e, "obstacles[0].normal[1]", f64::is_nan);
}

#[test]
fn non_finite_offset() {
    let e = error(|s| *hyperplane(s).1 = f64::NEG_INFINITY);
    assert_non_finite(e, "obstacles[0].offset", f64::is_infinite);
}

#[test]
fn non_finite_friction() {
    let e = error(|s| *hyperplane(s).2 = f64::NAN);
    assert_non_finite(e, "obstacles[0].friction", f64::is_nan);
}

#[test]
fn non_finite_obstacle_compliance() {
    let e = error(|s| *hyperplane(s).3 = f64::INFINITY);
    assert_non_finite(e, "obstacles[0].compliance", f64::is_infinite);
}

#[test]
fn non_finite_damping_rate() {
    let e = error(|s| s.damping = Some(Damping { rate: f64::NAN }));
    assert_non_finite(e, "damping.rate", f64::is_nan);
}

// ---------------------------------------------------------------- vector lengths

#[test]
fn wrong_length_position() {
    let e = error(|s| s.particles[2].position = vec![0.0, 1.0]);
    assert_eq!(e, wrong_length("particles[2].position", 2));
    assert_eq!(
        e.to_string(),
        "particles[2].position: expected 3 components (the scene dimension), found 2"
    );
}

#[test]
fn wrong_length_velocity() {
    let e = error(|s| s.particles[0].velocity = Some(vec![0.0; 4]));
    assert_eq!(e, wrong_length("particles[0].velocity", 4));
}

#[test]
fn wrong_length_force() {
    let e = error(|s| s.particles[3].force = Some(vec![]));
    assert_eq!(e, wrong_length("particles[3].force", 0));
}

#[test]
fn wrong_length_gravity() {
    let e = error(|s| s.gravity = Some(vec![-9.81]));
    assert_eq!(e, wrong_length("gravity", 1));
}

#[test]
fn wrong_length_normal() {
    let e = error(|s| *hyperplane(s).0 = vec![0.0, 1.0, 0.0, 0.0]);
    assert_eq!(e, wrong_length("obstacles[0].normal", 4));
}

// ---------------------------------------------------------------- particles

#[test]
fn non_positive_mass() {
    let e = error(|s| s.particles[2].mass = Some(0.0));
    assert_eq!(
        e,
        SceneError::NonPositiveMass {
            path: "particles[2].mass".into(),
            value: 0.0
        }
    );
    let e = error(|s| s.particles[3].mass = Some(-1.5));
    assert_eq!(
        e,
        SceneError::NonPositiveMass {
            path: "particles[3].mass".into(),
            value: -1.5
        }
    );
}

#[test]
fn mass_on_a_fixed_particle_is_still_checked() {
    // A fixed particle may carry its mass (the builder's `fix` keeps it);
    // a nonpositive one is still rejected.
    let e = error(|s| s.particles[1].mass = Some(0.0));
    assert_eq!(
        e,
        SceneError::NonPositiveMass {
            path: "particles[1].mass".into(),
            value: 0.0
        }
    );
}

#[test]
fn missing_mass() {
    let e = error(|s| s.particles[2].mass = None);
    assert_eq!(
        e,
        SceneError::MissingMass {
            path: "particles[2].mass".into()
        }
    );
}

#[test]
fn fixed_particle_with_velocity() {
    let e = error(|s| s.particles[1].velocity = Some(vec![0.0, 0.0, 1e-300]));
    assert_eq!(
        e,
        SceneError::FixedParticleVelocity {
            path: "particles[1].velocity".into()
        }
    );
}

#[test]
fn negative_radius() {
    let e = error(|s| s.particles[3].radius = -0.25);
    assert_eq!(
        e,
        SceneError::Negative {
            path: "particles[3].radius".into(),
            value: -0.25
        }
    );
}

// ---------------------------------------------------------------- constraints

#[test]
fn negative_constraint_compliance() {
    let e = error(|s| s.constraints[1].compliance = -1e-9);
    assert_eq!(
        e,
        SceneError::NegativeCompliance {
            path: "constraints[1].compliance".into(),
            value: -1e-9
        }
    );
}

#[test]
fn index_out_of_range() {
    let e = error(|s| s.constraints[0].elements[1] = vec![2, 4]);
    assert_eq!(
        e,
        SceneError::IndexOutOfRange {
            path: "constraints[0].elements[1][1]".into(),
            index: 4,
            count: 4
        }
    );
    let e = error(|s| s.constraints[2].elements[0][3] = usize::MAX);
    assert_eq!(
        e,
        SceneError::IndexOutOfRange {
            path: "constraints[2].elements[0][3]".into(),
            index: usize::MAX,
            count: 4
        }
    );
}

#[test]
fn repeated_particle() {
    let e = error(|s| s.constraints[1].elements[0] = vec![0, 2, 0]);
    assert_eq!(
        e,
        SceneError::RepeatedParticle {
            path: "constraints[1].elements[0][2]".into(),
            particle: 0
        }
    );
    let e = error(|s| s.constraints[0].elements[0] = vec![3, 3]);
    assert_eq!(
        e,
        SceneError::RepeatedParticle {
            path: "constraints[0].elements[0][1]".into(),
            particle: 3
        }
    );
}

fn arity(path: &str, kind: &'static str, expected: &str, found: usize) -> SceneError {
    SceneError::WrongArity {
        path: path.into(),
        kind,
        expected: expected.into(),
        found,
    }
}

/// `constraints[0]` turned into a tether family (same elements and rest).
fn as_tether(s: &mut Scene) {
    s.constraints[0].kind = ConstraintKind::Tether;
}

#[test]
fn tether_arity_and_rest() {
    let e = error(|s| {
        as_tether(s);
        s.constraints[0].elements[1] = vec![2];
    });
    assert_eq!(e, arity("constraints[0].elements[1]", "tether", "2", 1));
    let e = error(|s| {
        as_tether(s);
        s.constraints[0].rest = Some(vec![1.0, -0.5]);
    });
    assert_eq!(
        e,
        SceneError::DegenerateRest {
            path: "constraints[0].rest[1]".into(),
            why: "a rest length must be >= 0".into()
        }
    );
    let mut ok = base();
    as_tether(&mut ok);
    ok.validate()
        .expect("a tether family like the distance family is valid");
}

#[test]
fn distance_arity() {
    let e = error(|s| s.constraints[0].elements[1] = vec![2]);
    assert_eq!(e, arity("constraints[0].elements[1]", "distance", "2", 1));
    let e = error(|s| s.constraints[0].elements[0] = vec![0, 1, 2]);
    assert_eq!(e, arity("constraints[0].elements[0]", "distance", "2", 3));
}

#[test]
fn simplex_measure_arity_outside_range() {
    let expected = "k + 1 with 1 <= k <= 3 (2..=4)";
    let e = error(|s| s.constraints[1].elements[0] = vec![0]);
    assert_eq!(
        e,
        arity("constraints[1].elements[0]", "simplex_measure", expected, 1)
    );
    let e = error(|s| {
        s.particles.push(Particle::new(vec![1.0, 1.0, 1.0], 1.0));
        s.constraints[1].elements[0] = vec![0, 1, 2, 3, 4];
    });
    assert_eq!(
        e,
        arity("constraints[1].elements[0]", "simplex_measure", expected, 5)
    );
}

#[test]
fn simplex_measure_mixed_k_in_one_family() {
    let e = error(|s| s.constraints[1].elements = vec![vec![0, 2, 3], vec![0, 2]]);
    assert_eq!(
        e,
        arity(
            "constraints[1].elements[1]",
            "simplex_measure",
            "3 (one k per family, as in elements[0])",
            2
        )
    );
}

#[test]
fn oriented_measure_arity() {
    let e = error(|s| s.constraints[2].elements[0] = vec![0, 2, 3]);
    assert_eq!(
        e,
        arity(
            "constraints[2].elements[0]",
            "oriented_measure",
            "4 (dim + 1)",
            3
        )
    );
}

#[test]
fn rest_count_mismatch() {
    let e = error(|s| s.constraints[0].rest = Some(vec![1.0]));
    assert_eq!(
        e,
        SceneError::RestCountMismatch {
            path: "constraints[0].rest".into(),
            expected: 2,
            found: 1
        }
    );
    let e = error(|s| s.constraints[1].rest = Some(vec![]));
    assert_eq!(
        e,
        SceneError::RestCountMismatch {
            path: "constraints[1].rest".into(),
            expected: 1,
            found: 0
        }
    );
}

fn degenerate(path: &str, why: &str) -> SceneError {
    SceneError::DegenerateRest {
        path: path.into(),
        why: why.into(),
    }
}

#[test]
fn negative_rest_length() {
    let e = error(|s| s.constraints[0].rest = Some(vec![1.0, -0.5]));
    assert_eq!(
        e,
        degenerate("constraints[0].rest[1]", "a rest length must be >= 0")
    );
}

#[test]
fn negative_simplex_rest() {
    let e = error(|s| s.constraints[1].rest = Some(vec![-1e-12]));
    assert_eq!(
        e,
        degenerate("constraints[1].rest[0]", "a squared measure must be >= 0")
    );
}

#[test]
fn zero_oriented_rest() {
    let e = error(|s| s.constraints[2].rest = Some(vec![0.0]));
    assert_eq!(
        e,
        degenerate(
            "constraints[2].rest[0]",
            "an oriented rest measure of zero has no orientation to preserve"
        )
    );
}

#[test]
fn zero_volume_authored_oriented_simplex() {
    // Particle 3 moved into the plane of 1, 0, 2: volume exactly 0.
    let e = error(|s| s.particles[3].position = vec![0.25, 1.5, 0.0]);
    match &e {
        SceneError::DegenerateRest { path, why } => {
            assert_eq!(path, "constraints[2].elements[0]");
            assert!(
                why.starts_with("the authored simplex has signed volume"),
                "{why}"
            );
            assert!(why.contains("degeneracy floor"), "{why}");
        }
        other => panic!("expected DegenerateRest, got {other:?}"),
    }
    // Nearly flat (relative volume 1e-14 < 1e-12) is degenerate too.
    let e = error(|s| s.particles[3].position = vec![0.25, 1.5, 1e-14]);
    assert!(
        matches!(&e, SceneError::DegenerateRest { path, .. } if path == "constraints[2].elements[0]"),
        "{e:?}"
    );
}

// ---------------------------------------------------------------- obstacles and damping

#[test]
fn negative_friction() {
    let e = error(|s| *hyperplane(s).2 = -0.1);
    assert_eq!(
        e,
        SceneError::NegativeFriction {
            path: "obstacles[0].friction".into(),
            value: -0.1
        }
    );
}

#[test]
fn zero_normal() {
    let e = error(|s| *hyperplane(s).0 = vec![0.0, -0.0, 0.0]);
    assert_eq!(
        e,
        SceneError::ZeroNormal {
            path: "obstacles[0].normal".into()
        }
    );
}

#[test]
fn negative_obstacle_compliance() {
    let e = error(|s| *hyperplane(s).3 = -1.0);
    assert_eq!(
        e,
        SceneError::NegativeCompliance {
            path: "obstacles[0].compliance".into(),
            value: -1.0
        }
    );
}

#[test]
fn negative_damping_rate() {
    let e = error(|s| s.damping = Some(Damping { rate: -0.5 }));
    assert_eq!(
        e,
        SceneError::Negative {
            path: "damping.rate".into(),
            value: -0.5
        }
    );
}

#[test]
fn second_obstacle_is_named_by_its_index() {
    let e = error(|s| s.obstacles.push(plane(vec![0.0, 0.0])));
    assert_eq!(e, wrong_length("obstacles[1].normal", 2));
}

// ---------------------------------------------------------------- order, valid scenes, compile

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

// ---------------------------------------------------------------- known gaps

/// A normal whose squared length underflows passes validation (it is not
/// all zeros), but `Plan::compile` divides by the underflowed length
/// (plan.rs, `let length = normal.iter().map(|x| x * x).sum::<f64>().sqrt()`)
/// and the compiled normal is non-finite; with 1e200 the length overflows
/// and the compiled normal is silently zero.
#[test]
fn extreme_normal_magnitudes_compile_to_a_unit_normal() {
    for scale in [1e-200, 1e200] {
        let mut s = base();
        *hyperplane(&mut s).0 = vec![0.0, scale, 0.0];
        if s.validate().is_err() {
            continue; // rejecting it is a fine answer too
        }
        let plan = Plan::compile(&s).expect("compiles");
        let normal = plan
            .families
            .iter()
            .find_map(|f| match &f.kind {
                hyperpbd::FamilyKind::HyperplaneContact { normal, .. } => Some(normal.clone()),
                _ => None,
            })
            .expect("contact family");
        let length: f64 = normal.iter().map(|x| x * x).sum::<f64>().sqrt();
        assert!(
            (length - 1.0).abs() < 1e-12,
            "scale {scale}: compiled normal {normal:?}"
        );
    }
}

/// A scene with no vectors at all accepts any `dim`; compiling it then
/// allocates `dim` gravity components and panics (capacity overflow) or
/// aborts (out of memory) instead of returning an error.
#[test]
fn huge_dimension_does_not_panic() {
    let s = Scene::new(1 << 62, 0.01, 1, 1);
    let result = std::panic::catch_unwind(|| Plan::compile(&s).map(|_| ()));
    assert!(result.is_ok(), "Plan::compile panicked");
}

// ---------------------------------------------------------------- docs/errors.md

/// Every message quoted in docs/errors.md, generated by triggering it.
fn catalogue() -> Vec<String> {
    let v = |edit: Edit| {
        let mut s = base();
        edit(&mut s);
        s.validate().expect_err("rejected").to_string()
    };
    let j = |text: &str| {
        Scene::from_json_str(text)
            .expect_err("rejected")
            .to_string()
    };
    let mut out = vec![
        v(Box::new(|s| s.dim = 0)),
        v(Box::new(|s| s.dim = 4611686018427387904)),
        v(Box::new(|s| s.dt = 0.0)),
        v(Box::new(|s| s.dt = f64::NAN)),
        v(Box::new(|s| s.dt = f64::INFINITY)),
        v(Box::new(|s| s.substeps = 0)),
        v(Box::new(|s| s.iterations = 0)),
        v(Box::new(|s| {
            s.gravity = Some(vec![0.0, f64::NEG_INFINITY, 0.0])
        })),
        v(Box::new(|s| s.gravity = Some(vec![0.0, -9.81]))),
        v(Box::new(|s| s.particles[1].position[2] = f64::NAN)),
        v(Box::new(|s| s.particles[2].position = vec![0.5, 1.0])),
        v(Box::new(|s| s.particles[0].velocity = Some(vec![0.0; 4]))),
        v(Box::new(|s| {
            s.particles[1].velocity = Some(vec![0.0, 0.0, 1.0])
        })),
        v(Box::new(|s| {
            s.particles[3].force = Some(vec![f64::NAN, 0.0, 0.0])
        })),
        v(Box::new(|s| s.particles[2].mass = Some(0.0))),
        v(Box::new(|s| s.particles[2].mass = Some(-1.0))),
        v(Box::new(|s| s.particles[2].mass = None)),
        v(Box::new(|s| s.particles[3].radius = -0.25)),
        v(Box::new(|s| s.particles[3].gravity_scale = f64::NAN)),
        v(Box::new(|s| s.constraints[1].compliance = -1e-9)),
        v(Box::new(|s| s.constraints[0].elements[1] = vec![2, 4])),
        v(Box::new(|s| s.constraints[1].elements[0] = vec![0, 2, 0])),
        v(Box::new(|s| s.constraints[0].elements[1] = vec![2])),
        v(Box::new(|s| {
            as_tether(s);
            s.constraints[0].elements[1] = vec![2];
        })),
        v(Box::new(|s| s.constraints[1].elements[0] = vec![0])),
        v(Box::new(|s| {
            s.constraints[1].elements = vec![vec![0, 2, 3], vec![0, 2]];
        })),
        v(Box::new(|s| s.constraints[2].elements[0] = vec![0, 2, 3])),
        v(Box::new(|s| s.constraints[0].rest = Some(vec![1.0]))),
        v(Box::new(|s| s.constraints[0].rest = Some(vec![1.0, -0.5]))),
        v(Box::new(|s| s.constraints[1].rest = Some(vec![-1.0]))),
        v(Box::new(|s| s.constraints[2].rest = Some(vec![0.0]))),
        v(Box::new(|s| s.particles[3].position = vec![0.25, 1.5, 0.0])),
        v(Box::new(|s| *hyperplane(s).0 = vec![0.0; 3])),
        v(Box::new(|s| *hyperplane(s).1 = f64::NAN)),
        v(Box::new(|s| *hyperplane(s).2 = -0.1)),
        v(Box::new(|s| *hyperplane(s).3 = -1.0)),
        v(Box::new(|s| s.damping = Some(Damping { rate: -0.5 }))),
    ];
    let doc = |extra: &str| {
        format!(r#"{{"dim": 1, "dt": 0.1, "particles": [{{"position": [0], "mass": 1}}]{extra}}}"#)
    };
    out.extend([
        j(&doc(r#", "gravty": [-9.81]"#)),
        j(r#"{"dim": 1, "dt": 0.1, "particles": [{"position": [0], "mass": 1, "colour": 1}]}"#),
        j(&doc(
            r#", "constraints": [{"type": "distance", "elements": [], "stiffness": 1}]"#,
        )),
        j(&doc(
            r#", "obstacles": [{"type": "hyperplane", "normal": [1], "restitution": 1}]"#,
        )),
        j(&doc(r#", "damping": {"rate": 1, "linear": 1}"#)),
        j(r#"{"dim": "3", "dt": 0.1}"#),
        j(r#"{"dim": 1, "dt": 0.1, "particles": [{"position": ["0"], "mass": 1}]}"#),
        j(&doc(
            r#", "obstacles": [{"type": "hyperplane", "normal": ["1"]}]"#,
        )),
        j(r#"{"dim": 1, "dt": 0.1, "substeps": 4294967296}"#),
        j(&doc(
            r#", "constraints": [{"type": "distance", "elements": [[0, -1]]}]"#,
        )),
        j(r#"{"dim": 1, "dt": 0.1, "particles": [{"position": [1e400], "mass": 1}]}"#),
        j(&doc(
            r#", "constraints": [{"type": "bending", "elements": []}]"#,
        )),
        j(&doc(r#", "obstacles": [{"type": "sphere"}]"#)),
        j(r#"{"dim": 1}"#),
        j(r#"{"dim": 1, "dt": 0.1, "particles": [{"mass": 1}]}"#),
        j(r#"{"dim": 1, "dt": 0.1, "particles": [{"position": [0], "mass": 1, "mass": 2}]}"#),
        j(r#"{"dim": 1, "dt": 0.1} x"#),
        j(r#"{"dim": 1, "dt": 0.1"#),
        j(r#"{"dim": 1,"#),
        j(""),
    ]);
    out.extend(barrier_catalogue());
    let missing = std::path::Path::new("no-such-scene.json");
    out.push(
        Scene::from_json_file(missing)
            .expect_err("missing")
            .to_string(),
    );

    // Step errors.
    use hyperpbd::Backend;
    let overflow = Scene::from_json_str(
        r#"{"dim": 1, "dt": 1, "particles": [{"position": [1.7e308], "velocity": [1.7e308], "mass": 1}]}"#,
    )
    .expect("valid");
    let mut b = hyperpbd::cpu_backend(&overflow).expect("backend");
    out.push(b.step().expect_err("overflows").to_string());
    let far = Scene::from_json_str(
        r#"{"dim": 1, "dt": 0.01, "particles": [{"position": [-1e308], "mass": 1}, {"position": [1e308], "mass": 1}],
            "constraints": [{"type": "distance", "elements": [[0, 1]], "rest": [1.0]}]}"#,
    )
    .expect("valid");
    let mut b = hyperpbd::cpu_backend(&far).expect("backend");
    out.push(b.step().expect_err("infinite length").to_string());
    // An API call that does not fit the plan.
    let mut b = hyperpbd::cpu_backend(&far).expect("backend");
    out.push(
        b.set_forces(&[1.0, 0.0])
            .expect_err("no force term")
            .to_string(),
    );
    out
}

/// The messages of the incremental-potential (barrier) path.
fn barrier_catalogue() -> Vec<String> {
    let j = |text: String| {
        Scene::from_json_str(&text)
            .expect_err("rejected")
            .to_string()
    };
    let solver = |kappa: &str, dhat: &str, tolerance: &str, iterations: &str| {
        format!(
            r#", "solver": {{"type": "incremental_potential", "barrier_stiffness": {kappa}, "activation_distance": {dhat}, "convergence": {{"kind": "packed_gradient", "tolerance": {tolerance}}}, "max_iterations": {iterations}}}"#
        )
    };
    let scene = |extra: &str| {
        format!(
            r#"{{"dim": 2, "dt": 0.01, "particles": [{{"position": [0, 1], "mass": 1}}], "obstacles": [{{"type": "hyperplane", "normal": [0, 1]}}]{extra}}}"#
        )
    };
    let ok = solver("100", "0.1", "1e-8", "20");
    let mesh = |vertices: &str, simplices: &str, extra: &str| {
        format!(
            r#"{{"dim": 2, "dt": 0.01, "particles": [{{"position": [0, 1], "mass": 1}}], "obstacles": [{{"type": "simplex_mesh", "vertices": {vertices}, "simplices": {simplices}}}]{extra}}}"#
        )
    };
    let mut out = vec![
        j(scene(&solver("0", "0.1", "1e-8", "20"))),
        j(scene(&solver("100", "-0.1", "1e-8", "20"))),
        j(scene(&solver("100", "0.1", "0", "20"))),
        j(scene(&solver("100", "0.1", "1e-8", "0"))),
        j(scene(&format!(r#", "damping": {{"rate": 1}}{ok}"#))),
        // Hyperplane friction is a term of the coupled step (issue 16); the
        // coupled step's own keys are checked instead.
        j(scene(
            r#", "solver": {"type": "incremental_potential", "barrier_stiffness": 1, "activation_distance": 1, "convergence": {"kind": "packed_gradient", "tolerance": 1}, "max_iterations": 3, "cg_iterations": 0}"#,
        )),
        j(scene(
            r#", "solver": {"type": "incremental_potential", "barrier_stiffness": 1, "activation_distance": 1, "convergence": {"kind": "packed_gradient", "tolerance": 1}, "max_iterations": 3, "friction_slip_velocity": 0}"#,
        )),
        j(format!(
            r#"{{"dim": 2, "dt": 0.01, "particles": [{{"position": [0, 1], "mass": 1}}], "obstacles": [{{"type": "hyperplane", "normal": [0, 1], "compliance": 1e-6}}]{ok}}}"#
        )),
        j(format!(
            r#"{{"dim": 2, "dt": 0.01, "particles": [{{"position": [0, 1], "mass": 1}}, {{"position": [0, 2], "mass": 1}}], "constraints": [{{"type": "distance", "elements": [[0, 1]]}}]{ok}}}"#
        )),
        j(format!(
            r#"{{"dim": 2, "dt": 0.01, "particles": [{{"position": [0, -1], "mass": 1}}], "obstacles": [{{"type": "hyperplane", "normal": [0, 1]}}]{ok}}}"#
        )),
        j(mesh("[[0, 0], [1, 0]]", "[[0, 1]]", "")),
        j(mesh("[[0, 0], [1, 0]]", "[[0, 2]]", &ok)),
        j(mesh("[[0, 0], [1, 0]]", "[[1, 1]]", &ok)),
        j(mesh("[[0, 0], [1, 0], [2, 0]]", "[[0, 1, 2]]", &ok)),
        j(mesh("[[0, 0], [1, 0], [2, 0]]", "[[0, 1], [0, 1, 2]]", &ok)),
        j(mesh("[[0, 0], [1, 0]]", "[[0, 1]]", "")),
        j(scene(r#", "solver": {"type": "newton"}"#)),
        j(scene(
            r#", "solver": {"type": "incremental_potential", "barrier_stiffness": 1, "activation_distance": 1, "convergence": {"kind": "energy", "tolerance": 1}, "max_iterations": 3}"#,
        )),
        j(r#"{"dim": 2, "dt": 0.1, "obstacles": [{"type": "simplex_mesh", "simplices": []}]}"#.into()),
        j(r#"{"dim": 2, "dt": 0.1, "obstacles": [{"type": "hyperplane", "normal": [0, 1], "vertices": []}]}"#.into()),
    ];
    // A step refused because the state written is infeasible.
    use hyperpbd::Backend;
    let scene = Scene::from_json_str(&scene(&ok)).expect("valid");
    let mut b = hyperpbd::cpu_backend(&scene).expect("backend");
    let mut state = b.read_state().expect("state");
    state.positions[1] = -0.5;
    b.write_state(&state).expect("fits");
    out.push(b.step().expect_err("infeasible").to_string());
    // The coupled step refuses two balls that start overlapping.
    let overlapping = Scene::from_json_str(&format!(
        r#"{{"dim": 2, "dt": 0.01, "particles": [{{"position": [0, 1], "mass": 1, "radius": 0.1}}, {{"position": [0.15, 1], "mass": 1, "radius": 0.1}}], "collisions": {{}}{ok}}}"#
    ))
    .expect("valid");
    let mut b = hyperpbd::cpu_backend(&overlapping).expect("backend");
    out.push(b.step().expect_err("overlapping").to_string());
    out
}

#[test]
fn docs_errors_md_quotes_every_message() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/errors.md");
    let docs = std::fs::read_to_string(&path).unwrap_or_default();
    let missing: Vec<String> = catalogue()
        .into_iter()
        .filter(|m| !docs.contains(m.as_str()))
        .collect();
    assert!(
        missing.is_empty(),
        "docs/errors.md does not quote these messages verbatim (regenerate them \
         by triggering each error):\n{}",
        missing.join("\n")
    );
}
