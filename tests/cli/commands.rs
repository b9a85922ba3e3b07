//! `plan`, `scene`, `info`, `demo`.

use super::*;

#[test]
fn plan_prints_stages_families_and_colors() {
    let dir = TempDir::new("plan");
    let scene_path = dir.write("scene.json", EXAMPLE);
    let out = hyperpbd(["plan".as_ref(), scene_path.as_os_str()]);
    assert_success(&out);
    let stdout = text(&out.stdout);
    for needle in [
        "dim 3  particles 4 (3 dynamic, 1 fixed)",
        "stages per substep: predict -> project -> velocity -> friction -> damping",
        "predict terms: gravity on, external force off",
        "family 0 constraints[0] distance: 1 elements",
        "family 1 constraints[1] simplex_measure: 1 elements",
        "family 2 constraints[2] oriented_measure: 1 elements",
        "family 3 obstacles[0] hyperplane_contact: 3 elements",
        "1 colors [3], friction 0.5",
        "damping: rate 0.5 1/s",
        "kernel calls per step: predict 10, project 40, velocity 10, friction 10, damping 10",
        "constraint projections per step: 60",
    ] {
        assert!(stdout.contains(needle), "missing {needle:?} in\n{stdout}");
    }
    assert_eq!(dir.files(), ["scene.json"]);
}

#[test]
fn plan_of_a_chain_has_two_colors() {
    // A 2D chain 0-1-2-3-4: edges alternate between two colors.
    let dir = TempDir::new("plan-chain");
    let scene_path = dir.write(
        "chain.json",
        r#"{"dim": 2, "dt": 0.01, "particles": [
            {"position": [0, 0], "fixed": true}, {"position": [1, 0], "mass": 1},
            {"position": [2, 0], "mass": 1}, {"position": [3, 0], "mass": 1},
            {"position": [4, 0], "mass": 1}],
          "constraints": [{"type": "distance", "elements": [[0, 1], [1, 2], [2, 3], [3, 4]]}]}"#,
    );
    let out = hyperpbd(["plan".as_ref(), scene_path.as_os_str()]);
    assert_success(&out);
    let stdout = text(&out.stdout);
    assert!(
        stdout.contains(
            "family 0 constraints[0] distance: 4 elements, compliance 0e0, 2 colors [2, 2]"
        ),
        "{stdout}"
    );
    assert!(
        stdout.contains("predict -> project -> velocity\n"),
        "{stdout}"
    );
}

#[test]
fn scene_cloth_then_run_it() {
    let dir = TempDir::new("cloth");
    let cloth = dir.path("cloth.json");
    let out = hyperpbd([
        "scene".as_ref(),
        "cloth".as_ref(),
        "--out".as_ref(),
        cloth.as_os_str(),
    ]);
    assert_success(&out);
    let written = std::fs::read_to_string(&cloth).expect("cloth.json");
    let scene = Scene::from_json_str(&written).expect("the written scene loads");
    assert_eq!(scene, hyperpbd::scenes::cloth(32));

    // Without --out the same text goes to stdout.
    let out = hyperpbd(["scene", "cloth"]);
    assert_success(&out);
    assert_eq!(text(&out.stdout), written);

    let final_path = dir.path("final.json");
    let out = hyperpbd([
        "run".as_ref(),
        cloth.as_os_str(),
        "--backend".as_ref(),
        "cpu".as_ref(),
        "--frames".as_ref(),
        "2".as_ref(),
        "--out".as_ref(),
        final_path.as_os_str(),
    ]);
    assert_success(&out);
    let record: Value =
        serde_json::from_str(&std::fs::read_to_string(&final_path).unwrap()).expect("JSON");
    check_record(&record, 2, scene.dt, &reference(&scene, 2));
    assert_eq!(dir.files(), ["cloth.json", "final.json"]);
}

#[test]
fn every_built_in_scene_can_be_written() {
    for name in hyperpbd::scenes::NAMES {
        let out = hyperpbd(["scene", name]);
        assert_success(&out);
        Scene::from_json_str(&text(&out.stdout)).unwrap_or_else(|e| panic!("scene {name}: {e}"));
    }
    let out = hyperpbd(["scene", "teapot"]);
    assert_eq!(out.status.code(), Some(2));
    let stderr = text(&out.stderr);
    assert!(stderr.contains("unknown scene \"teapot\""), "{stderr}");
    assert!(stderr.contains("cloth"), "{stderr}");
}

#[test]
fn info_exits_zero() {
    let out = hyperpbd(["info"]);
    assert_success(&out);
    assert!(
        text(&out.stdout).contains("CPU golden backend: cpu-f64"),
        "{}",
        text(&out.stdout)
    );
}

#[test]
fn demo_runs() {
    let dir = TempDir::new("demo");
    let out = hyperpbd_in(&dir.0, ["demo", "--frames", "10", "--backend", "cpu"]);
    assert_success(&out);
    let stdout = text(&out.stdout);
    assert!(stdout.contains("hyperpbd demo"), "{stdout}");
    assert!(stdout.contains("state hash"), "{stdout}");
    assert!(stdout.contains("backend: cpu-f64"), "{stdout}");
    let out = hyperpbd_in(&dir.0, ["demo", "--frames", "10"]);
    assert_success(&out);
}

/// Outside a desktop session (no XDG_RUNTIME_DIR) Mesa's device-select
/// Vulkan layer used to print `error: XDG_RUNTIME_DIR is invalid or not set
/// in the environment.` twice per command; the GPU adapter code now keeps
/// the layer quiet before the first instance (see gpu/src/adapter.rs), with
/// no help from the caller's environment.
#[test]
fn gpu_commands_print_no_mesa_session_noise() {
    let dir = TempDir::new("quiet");
    let scene = dir.write("scene.json", EXAMPLE);
    let commands: [&[&std::ffi::OsStr]; 3] = [
        &["info".as_ref()],
        &[
            "run".as_ref(),
            scene.as_os_str(),
            "--frames".as_ref(),
            "1".as_ref(),
        ],
        &[
            "compare".as_ref(),
            scene.as_os_str(),
            "--frames".as_ref(),
            "1".as_ref(),
        ],
    ];
    for args in commands {
        let out = Command::new(env!("CARGO_BIN_EXE_hyperpbd"))
            .args(args)
            .env_remove("NODEVICE_SELECT")
            .env_remove("MESA_VK_DEVICE_SELECT")
            .env_remove("XDG_RUNTIME_DIR")
            .output()
            .expect("run the hyperpbd binary");
        let stderr = text(&out.stderr);
        assert!(!stderr.contains("XDG_RUNTIME_DIR"), "{args:?}: {stderr}");
    }
}

#[test]
fn plan_prints_an_expression_family_as_compiled() {
    let dir = TempDir::new("plan-expression");
    let scene_path = dir.write(
        "ring.json",
        r#"{"dim": 3, "dt": 0.01, "gravity": [0, -9.81, 0],
            "particles": [{"position": [1, 0, 0], "mass": 1}, {"position": [1, -0.5, 0], "mass": 1}],
            "constraints": [
              {"type": "expression", "value": "let d = x0 - c; norm(d)", "params": {"c": [0, 0, 0]},
               "elements": [[0]]},
              {"type": "expression", "value": "norm(x1 - x0)", "relation": "<=", "elements": [[0, 1]]}]}"#,
    );
    let out = hyperpbd(["plan".as_ref(), scene_path.as_os_str()]);
    assert_success(&out);
    let stdout = text(&out.stdout);
    for needle in [
        "family 0 constraints[0] expression: 1 elements",
        "relation ==, arity 1: ",
        "ops (value + ∇C, 3 entries)",
        "(+ ∇²C, 6 entries)",
        "family 1 constraints[1] expression: 1 elements",
        "relation <=, arity 2: 15 ops (value), 27 ops (value + ∇C, 6 entries), 110 ops (+ ∇²C, 21 entries)",
    ] {
        assert!(stdout.contains(needle), "missing {needle:?} in\n{stdout}");
    }
    // A bad expression: exit code 2, one message naming the path and position.
    let bad = dir.write(
        "bad.json",
        r#"{"dim": 2, "dt": 0.01, "particles": [{"position": [0, 0], "mass": 1}],
            "constraints": [{"type": "expression", "value": "norm(x0 - y)", "elements": [[0]]}]}"#,
    );
    let out = hyperpbd(["plan".as_ref(), bad.as_os_str()]);
    assert_eq!(out.status.code(), Some(2));
    let stderr = text(&out.stderr);
    assert!(
        stderr.contains("constraints[0].value: at 1:11: unknown name `y`"),
        "{stderr}"
    );
}
