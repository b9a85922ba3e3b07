//! Bad input: exit code 2, one message naming the field, no output left
//! behind; `--backend gpu` never falls back to the CPU.

use super::*;

fn example_with(from: &str, to: &str) -> String {
    assert!(EXAMPLE.contains(from), "{from}");
    EXAMPLE.replacen(from, to, 1)
}

#[test]
fn negative_mass_is_rejected() {
    let stderr = assert_rejected(
        &example_with(
            r#"{"position": [0.5,1,0], "mass": 1.0}"#,
            r#"{"position": [0.5,1,0], "mass": -1.0}"#,
        ),
        2,
        &[
            "scene.json: ",
            "particles[2].mass: mass must be > 0, got -1",
        ],
    );
    assert!(stderr.ends_with("for an immovable particle)\n"), "{stderr}");
}

#[test]
fn index_out_of_range_is_rejected() {
    assert_rejected(
        &example_with("[[0,2,3]]", "[[0,2,4]]"),
        2,
        &["constraints[1].elements[0][2]: particle index 4 is out of range (4 particles)"],
    );
}

#[test]
fn unknown_key_is_rejected() {
    assert_rejected(
        &example_with(
            r#""damping": {"rate": 0.5}"#,
            r#""damping": {"rate": 0.5, "drag": 1}"#,
        ),
        2,
        &["damping.drag: unknown field `drag`, expected `rate`"],
    );
    assert_rejected(
        &example_with(r#""mass": 1.0, "radius""#, r#""mas": 1.0, "radius""#),
        2,
        &["particles[0].mas: unknown field `mas`"],
    );
}

#[test]
fn an_unknown_key_of_the_xpbd_solver_is_rejected() {
    // A misspelt setting must not silently run the default.
    assert_rejected(
        &example_with(
            r#""damping": {"rate": 0.5}"#,
            r#""damping": {"rate": 0.5}, "solver": {"type": "xpbd", "iterations": 20}"#,
        ),
        2,
        &["solver: unknown field `iterations`, expected `primal_residual`"],
    );
}

#[test]
fn wrong_length_is_rejected() {
    assert_rejected(
        &example_with(
            r#""gravity": [0.0, -9.81, 0.0]"#,
            r#""gravity": [0.0, -9.81]"#,
        ),
        2,
        &["gravity: expected 3 components (the scene dimension), found 2"],
    );
}

#[test]
fn zero_normal_is_rejected() {
    assert_rejected(
        &example_with(r#""normal": [0,1,0]"#, r#""normal": [0,0,0]"#),
        2,
        &["obstacles[0].normal: the hyperplane normal has zero length"],
    );
}

#[test]
fn wrong_type_is_rejected() {
    assert_rejected(
        &example_with(r#""substeps": 10"#, r#""substeps": "10""#),
        2,
        &["substeps: invalid type: string \"10\", expected u32"],
    );
}

#[test]
fn out_of_range_number_is_rejected() {
    // JSON has no NaN/Inf; an overflowing literal is the closest thing.
    assert_rejected(
        &example_with(r#""position": [0,2,0]"#, r#""position": [0,2e400,0]"#),
        2,
        &["particles[1].position[1]: number out of range"],
    );
}

#[test]
fn degenerate_rest_is_rejected() {
    assert_rejected(
        &example_with(r#""rest": [1.0]"#, r#""rest": [-1.0]"#),
        2,
        &["constraints[0].rest[0]: degenerate rest geometry: a rest length must be >= 0"],
    );
    assert_rejected(
        &example_with(
            r#"{"position": [0,1,0.5], "mass""#,
            r#"{"position": [0,1,0], "mass""#,
        ),
        2,
        &[
            "constraints[2].elements[0]: degenerate rest geometry: the authored simplex has signed volume 0e0",
        ],
    );
}

#[test]
fn fixed_particle_velocity_is_rejected() {
    assert_rejected(
        &example_with(
            r#"{"position": [0,2,0], "fixed": true}"#,
            r#"{"position": [0,2,0], "fixed": true, "velocity": [1,0,0]}"#,
        ),
        2,
        &["particles[1].velocity: a fixed particle does not move"],
    );
}

#[test]
fn negative_compliance_and_friction_are_rejected() {
    assert_rejected(
        &example_with(r#""compliance": 1e-6"#, r#""compliance": -1e-6"#),
        2,
        &["constraints[1].compliance: compliance must be >= 0, got -0.000001"],
    );
    assert_rejected(
        &example_with(r#""friction": 0.5"#, r#""friction": -0.5"#),
        2,
        &["obstacles[0].friction: friction coefficient must be >= 0, got -0.5"],
    );
}

#[test]
fn malformed_json_is_rejected() {
    assert_rejected(
        &format!("{EXAMPLE} trailing"),
        2,
        &["(document): trailing characters"],
    );
    assert_rejected(
        "{\"dim\": 3,",
        2,
        &["EOF while parsing a value at line 1 column 10"],
    );
}

#[test]
fn missing_scene_file_is_rejected() {
    let dir = TempDir::new("missing");
    let out_path = dir.path("final.json");
    let out = hyperpbd([
        "run".as_ref(),
        dir.path("nope.json").as_os_str(),
        "--out".as_ref(),
        out_path.as_os_str(),
    ]);
    assert_eq!(out.status.code(), Some(2));
    let stderr = text(&out.stderr);
    assert!(stderr.contains("cannot read scene file"), "{stderr}");
    assert!(stderr.contains("nope.json"), "{stderr}");
    assert!(dir.files().is_empty());
}

#[test]
fn an_existing_output_file_survives_a_rejected_run() {
    let dir = TempDir::new("keep");
    let scene_path = dir.write(
        "scene.json",
        &example_with(r#""dt": 0.0166666"#, r#""dt": 0"#),
    );
    let out_path = dir.write("final.json", "previous result");
    let out = hyperpbd([
        "run".as_ref(),
        scene_path.as_os_str(),
        "--out".as_ref(),
        out_path.as_os_str(),
    ]);
    assert_eq!(out.status.code(), Some(2));
    assert!(text(&out.stderr).contains("dt: the time step must be > 0, got 0"));
    assert_eq!(
        std::fs::read_to_string(&out_path).unwrap(),
        "previous result"
    );
    assert_eq!(dir.files(), ["final.json", "scene.json"]);
}

#[test]
fn backend_gpu_runs_or_errors_clearly() {
    // With a usable adapter (common::gpu: required under
    // HYPERPBD_REQUIRE_GPU=1) the GPU backend runs the scene; without one it
    // must fail with one clear message and no output — never a silent CPU
    // fallback.
    let dir = TempDir::new("gpu");
    let scene_path = dir.write("scene.json", EXAMPLE);
    let scene = Scene::from_json_str(EXAMPLE).unwrap();
    for (backend, precision) in [("gpu", Precision::F32), ("gpu-f64", Precision::F64)] {
        let adapter = adapter_or_skip("backend_gpu_runs_or_errors_clearly", precision).is_some();
        let out_path = dir.path("final.json");
        let traj = dir.path("t.jsonl");
        let out = hyperpbd([
            "run".as_ref(),
            scene_path.as_os_str(),
            "--backend".as_ref(),
            backend.as_ref(),
            "--frames".as_ref(),
            "3".as_ref(),
            "--out".as_ref(),
            out_path.as_os_str(),
            "--trajectory".as_ref(),
            traj.as_os_str(),
        ]);
        let stderr = text(&out.stderr);
        if adapter {
            assert_success(&out);
            assert!(
                !text(&out.stdout).contains("cpu-f64"),
                "{backend}: fell back to the CPU"
            );
            let record: Value =
                serde_json::from_str(&std::fs::read_to_string(&out_path).unwrap()).unwrap();
            let positions = record["positions"].as_array().expect("positions");
            assert_eq!(positions.len(), 4);
            for row in positions {
                let row = row.as_array().expect("row");
                assert_eq!(row.len(), 3);
                assert!(row.iter().all(|x| x.as_f64().is_some_and(f64::is_finite)));
            }
            assert_eq!(record["frames"].as_u64(), Some(3));
            assert_eq!(record["time"].as_f64(), Some(3.0 * scene.dt));
            let lines = std::fs::read_to_string(&traj).unwrap().lines().count();
            assert_eq!(lines, 4);
            std::fs::remove_file(&out_path).unwrap();
            std::fs::remove_file(&traj).unwrap();
        } else {
            assert_ne!(out.status.code(), Some(0));
            assert!(stderr.starts_with("error: --backend gpu"), "{stderr}");
            assert_eq!(stderr.lines().count(), 1, "{stderr}");
        }
        assert_eq!(dir.files(), ["scene.json"], "{backend}");
    }
    // Invalid input is rejected before any device is touched.
    let bad = dir.write(
        "bad.json",
        &example_with(r#""dt": 0.0166666"#, r#""dt": -1"#),
    );
    let out = hyperpbd([
        "run".as_ref(),
        bad.as_os_str(),
        "--backend".as_ref(),
        "gpu".as_ref(),
    ]);
    assert_eq!(out.status.code(), Some(2));
    assert!(text(&out.stderr).contains("dt: the time step must be > 0, got -1"));
}

#[test]
fn every_zero_errors() {
    let dir = TempDir::new("every");
    let scene_path = dir.write("scene.json", EXAMPLE);
    let traj = dir.path("t.jsonl");
    let out = hyperpbd([
        "run".as_ref(),
        scene_path.as_os_str(),
        "--backend".as_ref(),
        "cpu".as_ref(),
        "--trajectory".as_ref(),
        traj.as_os_str(),
        "--every".as_ref(),
        "0".as_ref(),
    ]);
    assert_eq!(out.status.code(), Some(2));
    assert_eq!(text(&out.stderr), "error: --every: must be at least 1\n");
    assert_eq!(dir.files(), ["scene.json"]);
    // --every without --trajectory is a usage error.
    let out = hyperpbd([
        "run".as_ref(),
        scene_path.as_os_str(),
        "--every".as_ref(),
        "2".as_ref(),
    ]);
    assert_eq!(out.status.code(), Some(2));
    assert!(text(&out.stderr).contains("--trajectory"));
}

#[test]
fn usage_errors_exit_2() {
    for args in [
        vec![],
        vec!["run"],
        vec!["frobnicate"],
        vec!["run", "x.json", "--frames", "-1"],
        vec!["run", "x.json", "--backend", "tpu"],
        vec!["demo", "--frames", "many"],
    ] {
        let out = hyperpbd(&args);
        assert_eq!(out.status.code(), Some(2), "{args:?}");
        assert!(!out.stderr.is_empty(), "{args:?}");
    }
}
