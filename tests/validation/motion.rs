//! Prescribed motion (`motion` on a hyperplane, a simplex mesh or a fixed
//! particle): one test per rule, each with its exact variant and field
//! path; the messages are quoted in docs/errors.md ("Prescribed motion").

use super::*;
use hyperpbd::motion::Motion;

/// The base scene with `motion` on its hyperplane.
fn on_plane(motion: Vec<Motion>) -> SceneError {
    error(move |s| {
        let Obstacle::Hyperplane { motion: m, .. } = &mut s.obstacles[0] else {
            panic!("the base scene's obstacle is a hyperplane");
        };
        *m = motion;
    })
}

/// The base scene with `motion` on particle `i`.
fn on_particle(i: usize, motion: Vec<Motion>) -> SceneError {
    error(move |s| s.particles[i].motion = motion)
}

fn spin(plane: [usize; 2]) -> Vec<Motion> {
    vec![Motion::Rotate {
        plane,
        center: vec![0.0; 3],
        rate: 1.0,
    }]
}

fn frames(times: Vec<f64>, translations: Vec<Vec<f64>>) -> Vec<Motion> {
    vec![Motion::Keyframes {
        times,
        translations,
    }]
}

fn inconsistent(e: &SceneError) -> &str {
    match e {
        SceneError::Inconsistent { path, .. } => path,
        other => panic!("expected Inconsistent, got {other:?}"),
    }
}

#[test]
fn a_motion_on_a_dynamic_particle_is_refused() {
    let e = on_particle(0, spin([0, 1]));
    assert_eq!(inconsistent(&e), "particles[0].motion");
    // The fixed particle 1 takes it.
    let mut s = base();
    s.particles[1].motion = spin([0, 1]);
    s.validate().expect("a pin may move");
}

#[test]
fn rotation_axes_are_distinct_and_below_the_dimension() {
    let e = on_plane(spin([1, 1]));
    assert_eq!(inconsistent(&e), "obstacles[0].motion[0].plane");
    let e = on_plane(spin([0, 3]));
    assert_eq!(inconsistent(&e), "obstacles[0].motion[0].plane[1]");
}

#[test]
fn vectors_have_the_scene_dimension_and_numbers_are_finite() {
    let e = on_plane(vec![Motion::Translate {
        velocity: vec![1.0, 0.0],
    }]);
    assert_eq!(
        e,
        SceneError::WrongLength {
            path: "obstacles[0].motion[0].velocity".into(),
            expected: 3,
            found: 2
        }
    );
    let e = on_particle(
        1,
        vec![Motion::Rotate {
            plane: [0, 2],
            center: vec![0.0; 4],
            rate: 1.0,
        }],
    );
    assert!(
        matches!(&e, SceneError::WrongLength { path, .. } if path == "particles[1].motion[0].center")
    );
    let e = on_particle(
        1,
        vec![Motion::Rotate {
            plane: [0, 2],
            center: vec![0.0; 3],
            rate: f64::NAN,
        }],
    );
    assert!(
        matches!(&e, SceneError::NonFinite { path, .. } if path == "particles[1].motion[0].rate")
    );
    let e = on_plane(frames(vec![0.0], vec![vec![0.0, f64::INFINITY, 0.0]]));
    assert!(
        matches!(&e, SceneError::NonFinite { path, .. } if path == "obstacles[0].motion[0].translations[0][1]")
    );
}

#[test]
fn keyframe_times_increase_strictly_with_one_translation_each() {
    let e = on_plane(frames(vec![0.0, 1.0, 1.0], vec![vec![0.0; 3]; 3]));
    assert_eq!(inconsistent(&e), "obstacles[0].motion[0].times[2]");
    let e = on_plane(frames(vec![], vec![]));
    assert_eq!(inconsistent(&e), "obstacles[0].motion[0].times");
    let e = on_plane(frames(vec![0.0, 1.0], vec![vec![0.0; 3]]));
    assert_eq!(inconsistent(&e), "obstacles[0].motion[0].translations");
    let e = on_plane(frames(vec![f64::NAN], vec![vec![0.0; 3]]));
    assert!(
        matches!(&e, SceneError::NonFinite { path, .. } if path == "obstacles[0].motion[0].times[0]")
    );
}

#[test]
fn unknown_keys_and_kinds_are_refused_with_their_path() {
    let doc = |motion: &str| {
        format!(
            r#"{{"dim": 2, "dt": 0.01, "particles": [{{"position": [0, 1], "mass": 1}}],
                "obstacles": [{{"type": "hyperplane", "normal": [0, 1], "motion": [{motion}]}}]}}"#
        )
    };
    for (motion, path) in [
        (
            r#"{"type": "translate", "velocity": [1, 0], "speed": 2}"#,
            "obstacles[0].motion[0]",
        ),
        (r#"{"type": "wobble"}"#, "obstacles[0].motion[0]"),
        (
            r#"{"type": "rotate", "plane": [0, 1, 2], "center": [0, 0], "rate": 1}"#,
            "obstacles[0].motion[0]",
        ),
    ] {
        match Scene::from_json_str(&doc(motion)) {
            Err(SceneError::Json { path: p, .. }) => assert!(p.starts_with(path), "{p}"),
            other => panic!("{motion}: {other:?}"),
        }
    }
}

/// A segment mesh of R^2 with `motion` (JSON), and `extra` scene keys.
fn moving_mesh(motion: &str, extra: &str) -> Result<Scene, SceneError> {
    Scene::from_json_str(&format!(
        r#"{{"dim": 2, "dt": 0.01, "particles": [{{"position": [0, 1], "mass": 1}}],
            "obstacles": [{{"type": "simplex_mesh", "vertices": [[0, 0], [1, 0]],
            "simplices": [[0, 1]], "motion": [{motion}]}}]{extra}}}"#
    ))
}

#[test]
fn a_mesh_motion_is_read_and_checked_as_a_plane_motion() {
    let scene = moving_mesh(r#"{"type": "translate", "velocity": [1, 0]}"#, "").expect("valid");
    let Obstacle::SimplexMesh { motion, .. } = &scene.obstacles[0] else {
        panic!("a mesh: {:?}", scene.obstacles[0]);
    };
    assert_eq!(
        motion,
        &[Motion::Translate {
            velocity: vec![1.0, 0.0]
        }]
    );
    let plan = Plan::compile(&scene).expect("compiles");
    let moving = plan.motion.as_ref().expect("the mesh moves");
    assert_eq!((moving.meshes.len(), moving.planes.len()), (1, 0));
    let e = moving_mesh(
        r#"{"type": "rotate", "plane": [0, 2], "center": [0, 0], "rate": 1}"#,
        "",
    )
    .expect_err("refused");
    assert_eq!(inconsistent(&e), "obstacles[0].motion[0].plane[1]");
    let e = moving_mesh(r#"{"type": "translate", "velocity": [1]}"#, "").expect_err("refused");
    assert!(
        matches!(&e, SceneError::WrongLength { path, .. } if path == "obstacles[0].motion[0].velocity"),
        "{e:?}"
    );
}

#[test]
fn the_implicit_paths_and_primal_residual_refuse_motion_by_name() {
    let solver = r#", "solver": {"type": "incremental_potential", "barrier_stiffness": 100, "activation_distance": 0.1, "convergence": {"kind": "packed_gradient", "tolerance": 1e-8}, "max_iterations": 20}"#;
    let doc = |extra: &str| {
        format!(
            r#"{{"dim": 2, "dt": 0.01, "particles": [{{"position": [0, 1], "mass": 1}}, {{"position": [0, 2], "fixed": true, "motion": [{{"type": "translate", "velocity": [1, 0]}}]}}]{extra}}}"#
        )
    };
    let e = Scene::from_json_str(&doc(solver)).expect_err("refused");
    assert!(
        matches!(&e, SceneError::UnsupportedBySolver { path, solver: "incremental_potential", .. } if path == "particles[1].motion"),
        "{e:?}"
    );
    let e = Scene::from_json_str(&doc(
        r#", "solver": {"type": "xpbd", "primal_residual": true}"#,
    ))
    .expect_err("refused");
    assert!(
        matches!(&e, SceneError::UnsupportedBySolver { path, solver: "xpbd", .. } if path == "particles[1].motion"),
        "{e:?}"
    );
    // A moving mesh too, named by its obstacle.
    let e =
        moving_mesh(r#"{"type": "translate", "velocity": [1, 0]}"#, solver).expect_err("refused");
    assert!(
        matches!(&e, SceneError::UnsupportedBySolver { path, solver: "incremental_potential", .. } if path == "obstacles[0].motion"),
        "{e:?}"
    );
}

/// Every motion message quoted in docs/errors.md.
pub(super) fn catalogue() -> Vec<String> {
    let text = |e: SceneError| e.to_string();
    let json = |motion: &str| {
        let doc = format!(
            r#"{{"dim": 2, "dt": 0.01, "particles": [{{"position": [0, 1], "mass": 1}}],
                "obstacles": [{{"type": "hyperplane", "normal": [0, 1], "motion": [{motion}]}}]}}"#
        );
        text(Scene::from_json_str(&doc).expect_err("rejected"))
    };
    let solver = r#", "solver": {"type": "incremental_potential", "barrier_stiffness": 100, "activation_distance": 0.1, "convergence": {"kind": "packed_gradient", "tolerance": 1e-8}, "max_iterations": 20}"#;
    let pin = |extra: &str| {
        let doc = format!(
            r#"{{"dim": 2, "dt": 0.01, "particles": [{{"position": [0, 1], "mass": 1}}, {{"position": [0, 2], "fixed": true, "motion": [{{"type": "translate", "velocity": [1, 0]}}]}}]{extra}}}"#
        );
        text(Scene::from_json_str(&doc).expect_err("rejected"))
    };
    vec![
        text(on_particle(0, spin([0, 1]))),
        text(on_plane(spin([1, 1]))),
        text(on_plane(spin([0, 3]))),
        text(on_plane(frames(vec![0.0, 1.0, 1.0], vec![vec![0.0; 3]; 3]))),
        text(on_plane(frames(vec![], vec![]))),
        text(on_plane(frames(vec![0.0, 1.0], vec![vec![0.0; 3]]))),
        text(on_plane(vec![Motion::Translate {
            velocity: vec![1.0, 0.0],
        }])),
        json(r#"{"type": "translate", "velocity": [1, 0], "speed": 2}"#),
        json(r#"{"type": "wobble"}"#),
        pin(solver),
        pin(r#", "solver": {"type": "xpbd", "primal_residual": true}"#),
        text(
            moving_mesh(r#"{"type": "translate", "velocity": [1, 0]}"#, solver)
                .expect_err("rejected"),
        ),
    ]
}
