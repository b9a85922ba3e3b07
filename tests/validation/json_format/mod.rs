//! The JSON scene format: the issue's example loads, optional keys take
//! their documented defaults, unknown keys / wrong types / trailing garbage
//! are errors that name the JSON path, and scene → JSON → scene round-trips
//! every f64 bit for bit.

use hyperpbd::{
    ConstraintFamily, ConstraintKind, Damping, FamilyKind, Obstacle, Particle, Plan, Scene,
    SceneError, State,
};

/// The issue's example, with two more particles so that the
/// `simplex_measure` element [0, 2, 3] and the `oriented_measure` element
/// [1, 0, 2, 3] of the full example are valid.
const EXAMPLE: &str = include_str!("../../../scenes/example.json");

/// The issue's example exactly as written (two particles, one distance
/// family).
const ISSUE_EXAMPLE: &str = r#"{"dim": 3, "dt": 0.0166666, "substeps": 10, "iterations": 1,
 "gravity": [0.0, -9.81, 0.0],
 "particles": [{"position": [0,1,0], "velocity": [0,0,0], "mass": 1.0, "radius": 0.0, "gravity_scale": 1.0, "force": [0,0,0]},
               {"position": [0,2,0], "fixed": true}],
 "constraints": [{"type": "distance", "compliance": 0.0, "elements": [[0,1]], "rest": [1.0]}],
 "obstacles": [{"type": "hyperplane", "normal": [0,1,0], "offset": 0.0, "friction": 0.5, "compliance": 0.0}],
 "damping": {"rate": 0.5}}"#;

fn json_error(text: &str) -> (String, String) {
    match Scene::from_json_str(text) {
        Err(SceneError::Json { path, message }) => {
            assert!(!message.is_empty());
            (path, message)
        }
        other => panic!("expected a JSON error for {text}, got {other:?}"),
    }
}

/// A two-particle 2D document with `extra` spliced into the top level.
fn doc(extra: &str) -> String {
    format!(
        r#"{{"dim": 2, "dt": 0.01,
 "particles": [{{"position": [0, 0], "mass": 1}}, {{"position": [1, 0], "mass": 2}}]{extra}}}"#
    )
}

// ---------------------------------------------------------------- the example

#[test]
fn issue_example_loads() {
    let s = Scene::from_json_str(ISSUE_EXAMPLE).expect("issue example");
    assert_eq!(s.particles.len(), 2);
    assert!(s.particles[1].fixed);
    assert_eq!(s.particles[1].mass, None);
    Plan::compile(&s).expect("compiles");
}

#[test]
fn full_example_loads_with_every_value() {
    let s = Scene::from_json_str(EXAMPLE).expect("example");
    assert_eq!(s.dim, 3);
    assert_eq!(s.dt, 0.0166666);
    assert_eq!((s.substeps, s.iterations), (10, 1));
    assert_eq!(s.gravity, Some(vec![0.0, -9.81, 0.0]));
    assert_eq!(s.particles.len(), 4);
    let p0 = &s.particles[0];
    assert_eq!(p0.position, vec![0.0, 1.0, 0.0]);
    assert_eq!(p0.velocity, Some(vec![0.0; 3]));
    assert_eq!(p0.mass, Some(1.0));
    assert!(!p0.fixed);
    assert_eq!((p0.radius, p0.gravity_scale), (0.0, 1.0));
    assert_eq!(p0.force, Some(vec![0.0; 3]));
    assert!(s.particles[1].fixed);
    assert_eq!(s.particles[3].velocity, Some(vec![1.0, 0.0, 0.0]));
    let kinds: Vec<ConstraintKind> = s.constraints.iter().map(|c| c.kind).collect();
    assert_eq!(
        kinds,
        [
            ConstraintKind::Distance,
            ConstraintKind::SimplexMeasure,
            ConstraintKind::OrientedMeasure
        ]
    );
    assert_eq!(s.constraints[0].rest, Some(vec![1.0]));
    assert_eq!(s.constraints[1].compliance, 1e-6);
    assert_eq!(s.constraints[2].elements, vec![vec![1, 0, 2, 3]]);
    assert_eq!(
        s.obstacles,
        vec![Obstacle::Hyperplane {
            normal: vec![0.0, 1.0, 0.0],
            offset: 0.0,
            friction: 0.5,
            compliance: 0.0,
            motion: Vec::new(),
        }]
    );
    assert_eq!(s.damping, Some(Damping { rate: 0.5 }));

    let plan = Plan::compile(&s).expect("compiles");
    let names: Vec<&str> = plan.families.iter().map(|f| f.kind.name()).collect();
    assert_eq!(
        names,
        [
            "distance",
            "simplex_measure",
            "oriented_measure",
            "hyperplane_contact"
        ]
    );
    assert_eq!(plan.families[1].kind, FamilyKind::SimplexMeasure { k: 2 });
}

#[test]
fn example_file_in_the_repository_loads() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/example.json");
    if path.exists() {
        let s = Scene::from_json_file(&path).expect("scenes/example.json");
        Plan::compile(&s).expect("scenes/example.json compiles");
    }
}

// ---------------------------------------------------------------- defaults

#[test]
fn optional_keys_take_their_defaults() {
    let text = r#"{"dim": 2, "dt": 0.01,
        "particles": [{"position": [0, 0], "mass": 1},
                      {"position": [3, 4], "mass": 2},
                      {"position": [0, 1], "mass": 1},
                      {"position": [1, 1], "fixed": true}],
        "constraints": [{"type": "distance", "elements": [[0, 1]]},
                        {"type": "simplex_measure", "elements": [[0, 1, 2]]},
                        {"type": "oriented_measure", "elements": [[0, 1, 2]]}],
        "obstacles": [{"type": "hyperplane", "normal": [0, 2]}]}"#;
    let s = Scene::from_json_str(text).expect("minimal document");
    assert_eq!((s.substeps, s.iterations), (1, 1));
    assert_eq!(s.gravity, None);
    assert_eq!(s.damping, None);
    for p in &s.particles {
        assert_eq!(p.velocity, None);
        assert_eq!(p.force, None);
        assert_eq!(p.radius, 0.0);
        assert_eq!(p.gravity_scale, 1.0);
    }
    assert!(!s.particles[0].fixed);
    assert_eq!(s.particles[3].mass, None);
    for c in &s.constraints {
        assert_eq!(c.compliance, 0.0);
        assert_eq!(c.rest, None);
    }
    assert_eq!(
        s.obstacles[0],
        Obstacle::Hyperplane {
            normal: vec![0.0, 2.0],
            offset: 0.0,
            friction: 0.0,
            compliance: 0.0,
            motion: Vec::new(),
        }
    );

    // What the defaults mean once compiled.
    let state = State::from_scene(&s);
    assert!(state.velocities.iter().all(|&v| v == 0.0));
    let plan = Plan::compile(&s).expect("compiles");
    assert_eq!(plan.gravity, vec![0.0, 0.0]);
    assert!(!plan.predict.gravity && !plan.predict.force);
    assert!(plan.force.iter().all(|&f| f == 0.0));
    assert_eq!(plan.gravity_scale, vec![1.0; 4]);
    assert_eq!(plan.radius, vec![0.0; 4]);
    assert_eq!(plan.inverse_mass, vec![1.0, 0.5, 1.0, 0.0]);
    assert_eq!(plan.damping, None);
    // Rest values are the authored geometry.
    assert_eq!(plan.families[0].rest, vec![5.0]); // |(3, 4)|
    // Triangle (0,0), (3,4), (0,1): area 1.5, squared 2.25 = det(EᵀE)/(2!)².
    approx::assert_relative_eq!(plan.families[1].rest[0], 2.25, max_relative = 1e-14);
    // Signed area det([x1 − x0, x2 − x0]) / 2! = (3·1 − 4·0) / 2.
    approx::assert_relative_eq!(plan.families[2].rest[0], 1.5, max_relative = 1e-14);
    // The hyperplane normal is normalized on load; rest = offset + radius.
    let contact = &plan.families[3];
    assert_eq!(
        contact.kind,
        FamilyKind::HyperplaneContact {
            normal: vec![0.0, 1.0],
            friction: 0.0
        }
    );
    assert_eq!(contact.rest, vec![0.0; 3]); // one per dynamic particle
    assert_eq!(contact.compliance, 0.0);
}

#[test]
fn only_dim_and_dt_are_required_at_the_top_level() {
    let s = Scene::from_json_str(r#"{"dim": 4, "dt": 0.5}"#).expect("bare scene");
    assert_eq!(s, Scene::new(4, 0.5, 1, 1));
    assert_eq!(
        json_error(r#"{"dt": 0.5}"#),
        (
            "(document)".into(),
            "missing field `dim` at line 1 column 11".into()
        )
    );
    assert_eq!(json_error(r#"{"dim": 4}"#).0, "(document)");
    // `null` for an optional vector means omitted.
    let s = Scene::from_json_str(r#"{"dim": 1, "dt": 0.5, "gravity": null}"#).expect("null");
    assert_eq!(s.gravity, None);
}

#[test]
fn required_keys_inside_items_name_the_item() {
    let (path, message) = json_error(&doc(r#", "constraints": [{"type": "distance"}]"#));
    assert_eq!(path, "constraints[0]");
    assert!(message.starts_with("missing field `elements`"), "{message}");
    let (path, message) = json_error(&doc(r#", "constraints": [{"elements": [[0, 1]]}]"#));
    assert_eq!(path, "constraints[0]");
    assert!(message.starts_with("missing field `type`"), "{message}");
    let (path, message) = json_error(r#"{"dim": 1, "dt": 1, "particles": [{"mass": 1}]}"#);
    assert_eq!(path, "particles[0]");
    assert!(message.starts_with("missing field `position`"), "{message}");
    let (path, message) = json_error(&doc(r#", "obstacles": [{"type": "hyperplane"}]"#));
    assert_eq!(path, "obstacles[0]");
    assert!(message.starts_with("missing field `normal`"), "{message}");
    let (path, message) = json_error(&doc(r#", "obstacles": [{"normal": [0, 1]}]"#));
    assert_eq!(path, "obstacles[0]");
    assert!(message.starts_with("missing field `type`"), "{message}");
    let (path, message) = json_error(&doc(r#", "damping": {}"#));
    assert_eq!(path, "damping");
    assert!(message.starts_with("missing field `rate`"), "{message}");
}

// ---------------------------------------------------------------- unknown keys

#[test]
fn unknown_key_at_top_level() {
    let (path, message) = json_error(&doc(r#", "gravty": [0, -9.81]"#));
    assert_eq!(path, "gravty");
    assert!(message.starts_with("unknown field `gravty`, expected one of `dim`, `dt`"));
}

#[test]
fn unknown_key_in_a_particle() {
    let text = r#"{"dim": 1, "dt": 1, "particles": [{"position": [0], "mass": 1},
        {"position": [1], "mass": 1, "colour": "red"}]}"#;
    let (path, message) = json_error(text);
    assert_eq!(path, "particles[1].colour");
    assert!(message.starts_with("unknown field `colour`, expected one of `position`"));
}

#[test]
fn unknown_key_in_a_constraint() {
    let (path, message) = json_error(&doc(
        r#", "constraints": [{"type": "distance", "elements": [[0, 1]], "stiffness": 1e3}]"#,
    ));
    assert_eq!(path, "constraints[0].stiffness");
    assert!(message.starts_with("unknown field `stiffness`, expected one of `type`"));
}

#[test]
fn unknown_key_in_an_obstacle() {
    let (path, message) = json_error(&doc(
        r#", "obstacles": [{"type": "hyperplane", "normal": [0, 1]}, {"type": "hyperplane", "normal": [0, 1], "restitution": 0.5}]"#,
    ));
    // The obstacle is named; the key is named in the message.
    assert!(path.starts_with("obstacles[1]"), "{path}");
    assert!(
        message.starts_with("unknown field `restitution`"),
        "{message}"
    );
}

#[test]
fn unknown_key_in_damping() {
    let (path, message) = json_error(&doc(r#", "damping": {"rate": 1, "linear": 2}"#));
    assert_eq!(path, "damping.linear");
    assert!(message.starts_with("unknown field `linear`, expected `rate`"));
}

#[test]
fn unknown_kind_names_the_type_key() {
    let (path, message) = json_error(&doc(
        r#", "constraints": [{"type": "twist", "elements": []}]"#,
    ));
    assert_eq!(path, "constraints[0].type");
    assert!(message.starts_with("unknown variant `twist`, expected one of `distance`"));
    let (path, message) = json_error(&doc(
        r#", "obstacles": [{"type": "sphere", "normal": [0, 1]}]"#,
    ));
    assert_eq!(path, "obstacles[0].type");
    assert!(message.starts_with("unknown variant `sphere`, expected `hyperplane`"));
}

#[test]
fn duplicate_key_is_an_error() {
    let (path, message) = json_error(
        r#"{"dim": 1, "dt": 1, "particles": [{"position": [0], "mass": 1, "mass": 2}]}"#,
    );
    assert_eq!(path, "particles[0]");
    assert!(message.starts_with("duplicate field `mass`"), "{message}");
}

// ---------------------------------------------------------------- wrong types

#[test]
fn wrong_types_name_the_path() {
    let cases = [
        (r#"{"dim": "3", "dt": 1}"#.to_string(), "dim"),
        (r#"{"dim": 3.0, "dt": 1}"#.to_string(), "dim"),
        (r#"{"dim": -1, "dt": 1}"#.to_string(), "dim"),
        (r#"{"dim": 1, "dt": [1]}"#.to_string(), "dt"),
        (
            r#"{"dim": 1, "dt": 1, "substeps": 4294967296}"#.to_string(),
            "substeps",
        ),
        (
            r#"{"dim": 1, "dt": 1, "iterations": 1.5}"#.to_string(),
            "iterations",
        ),
        (
            r#"{"dim": 1, "dt": 1, "gravity": 9.81}"#.to_string(),
            "gravity",
        ),
        (
            r#"{"dim": 1, "dt": 1, "particles": {}}"#.to_string(),
            "particles",
        ),
        (
            r#"{"dim": 2, "dt": 1, "particles": [{"position": [0, "a"], "mass": 1}]}"#.to_string(),
            "particles[0].position[1]",
        ),
        (
            r#"{"dim": 1, "dt": 1, "particles": [{"position": [0], "fixed": 1}]}"#.to_string(),
            "particles[0].fixed",
        ),
        (
            r#"{"dim": 1, "dt": 1, "particles": [{"position": [0], "mass": "1"}]}"#.to_string(),
            "particles[0].mass",
        ),
        (
            r#"{"dim": 1, "dt": 1, "particles": [{"position": [0], "mass": 1, "radius": null}]}"#
                .to_string(),
            "particles[0].radius",
        ),
        (
            doc(r#", "constraints": [{"type": "distance", "elements": [[0, "1"]]}]"#),
            "constraints[0].elements[0][1]",
        ),
        (
            doc(r#", "constraints": [{"type": "distance", "elements": [[0, -1]]}]"#),
            "constraints[0].elements[0][1]",
        ),
        (
            doc(r#", "constraints": [{"type": "distance", "elements": [[0, 1]], "rest": 1}]"#),
            "constraints[0].rest",
        ),
        (
            doc(r#", "constraints": [{"type": 3, "elements": [[0, 1]]}]"#),
            "constraints[0].type",
        ),
        (doc(r#", "damping": {"rate": "fast"}"#), "damping.rate"),
        (doc(r#", "damping": 0.5"#), "damping"),
        // Out-of-range numbers (the only way to write ±Inf in JSON).
        (
            r#"{"dim": 1, "dt": 1, "particles": [{"position": [1e400], "mass": 1}]}"#.to_string(),
            "particles[0].position[0]",
        ),
        (
            doc(r#", "obstacles": [{"type": "hyperplane", "normal": [0, -1e999]}]"#),
            "obstacles[0].normal[1]",
        ),
    ];
    for (text, expected) in cases {
        let (path, message) = json_error(&text);
        assert_eq!(path, expected, "{text}: {message}");
        assert!(message.contains(" at line "), "{message}");
    }
}

#[test]
fn wrong_type_inside_an_obstacle_names_at_least_the_obstacle() {
    let (path, message) = json_error(&doc(
        r#", "obstacles": [{"type": "hyperplane", "normal": [0, 1], "friction": "high"}]"#,
    ));
    assert!(path.starts_with("obstacles[0]"), "{path}");
    assert!(message.starts_with("invalid type: string \"high\", expected f64"));
}

/// Inside an obstacle (`#[serde(tag = "type")]`, buffered by serde before
/// the variant is known) paths stop at `obstacles[i]`, unlike everywhere
/// else in the document.
#[test]
fn wrong_type_inside_an_obstacle_names_the_field() {
    let (path, _) = json_error(&doc(
        r#", "obstacles": [{"type": "hyperplane", "normal": [0, 1], "friction": "high"}]"#,
    ));
    assert_eq!(path, "obstacles[0].friction");
    let (path, _) = json_error(&doc(
        r#", "obstacles": [{"type": "hyperplane", "normal": [0, "1"]}]"#,
    ));
    assert_eq!(path, "obstacles[0].normal[1]");
    let (path, _) = json_error(&doc(
        r#", "obstacles": [{"type": "hyperplane", "normal": [0, 1], "restitution": 0.5}]"#,
    ));
    assert_eq!(path, "obstacles[0].restitution");
}

// ---------------------------------------------------------------- syntax

#[test]
fn trailing_garbage_is_an_error() {
    for tail in [" x", "{}", ",", "]", " 1", " null", "\n{\"dim\": 1}"] {
        let text = format!("{}{tail}", r#"{"dim": 1, "dt": 1}"#);
        let (path, message) = json_error(&text);
        assert_eq!(path, "(document)", "{text:?}");
        assert!(message.starts_with("trailing characters"), "{message}");
    }
    // Trailing whitespace is fine.
    Scene::from_json_str("{\"dim\": 1, \"dt\": 1}\n\t \r\n").expect("whitespace");
}

#[test]
fn malformed_documents_are_errors() {
    for text in [
        "",
        "   ",
        "{",
        "null",
        "3",
        "\"scene\"",
        r#"{"dim": 1, "dt": 1,}"#,
        r#"{"dim": 1 "dt": 1}"#,
        r#"{"dim": 1, "dt": NaN}"#,
        r#"{"dim": 1, "dt": Infinity}"#,
        r#"{'dim': 1, 'dt': 1}"#,
        "{\"dim\": 1, \"dt\": 1 // comment\n}",
    ] {
        let (path, message) = json_error(text);
        assert!(!path.is_empty(), "{text:?}");
        assert!(message.contains("line"), "{text:?}: {message}");
    }
}

#[test]
fn json_error_display_is_path_colon_message() {
    let e = Scene::from_json_str(&doc(r#", "damping": {"rate": 1, "linear": 2}"#)).unwrap_err();
    let SceneError::Json { path, message } = &e else {
        panic!("{e:?}")
    };
    assert_eq!(e.to_string(), format!("{path}: {message}"));
}

#[test]
fn loading_validates_but_parsing_does_not() {
    let text = r#"{"dim": 1, "dt": 1, "particles": [{"position": [0], "mass": 1}, {"position": [1], "mass": -2}]}"#;
    let parsed = Scene::parse_json(text).expect("parse_json does not validate");
    assert_eq!(parsed.particles[1].mass, Some(-2.0));
    assert_eq!(
        Scene::from_json_str(text),
        Err(SceneError::NonPositiveMass {
            path: "particles[1].mass".into(),
            value: -2.0
        })
    );
}

#[test]
fn missing_file_is_an_io_error_naming_the_file() {
    let path = std::env::temp_dir().join(format!(
        "hyperpbd-json-format-missing-{}.json",
        std::process::id()
    ));
    match Scene::from_json_file(&path) {
        Err(SceneError::Io { file, message }) => {
            assert_eq!(file, path.display().to_string());
            assert!(!message.is_empty());
        }
        other => panic!("expected Io, got {other:?}"),
    }
}

mod round_trip;
