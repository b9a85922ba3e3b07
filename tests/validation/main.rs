//! `Scene::validate`: one test per rule.
//!
//! Every test starts from one valid scene (`base()`: dim 3, gravity, a
//! dynamic and a fixed particle plus two more, a distance, a
//! simplex-measure and an oriented-measure family, a hyperplane and
//! damping), breaks exactly one thing, and asserts the exact `SceneError`
//! variant with its exact field path. The last tests check that valid
//! scenes pass, that the first violation in document order is the one
//! reported, and that `Plan::compile` and `SceneBuilder::build` refuse
//! what validation refuses. The JSON format's round trips and errors
//! (`json_format`) and proptest over the loader (`fuzz_scenes`) are modules
//! of this binary (their own binaries before, issue 33).

mod constraints;
mod errors_doc;
mod fuzz_scenes;
mod json_format;
mod known_gaps;
mod motion;
mod non_finite;
mod obstacles_and_damping;
mod order_and_valid_scenes;
mod particles;
mod step_settings;
mod vector_lengths;

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
        motion: Vec::new(),
    }
}

/// Mutable access to the fields of the base hyperplane.
fn hyperplane(s: &mut Scene) -> (&mut Vec<f64>, &mut f64, &mut f64, &mut f64) {
    let Obstacle::Hyperplane {
        normal,
        offset,
        friction,
        compliance,
        ..
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

/// `constraints[0]` turned into a tether family (same elements and rest).
fn as_tether(s: &mut Scene) {
    s.constraints[0].kind = ConstraintKind::Tether;
}
