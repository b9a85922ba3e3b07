//! The `hyperpbd` binary, driven as a user would: output files and their
//! shapes, trajectories, `plan`, `scene`, `info`, `demo`, and bad input
//! (exit code 2, one message naming the field, no output file left behind).

use hyperpbd::{Backend, Scene};
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::atomic::{AtomicUsize, Ordering};

/// A scratch directory, removed on drop.
struct TempDir(PathBuf);

impl TempDir {
    fn new(name: &str) -> TempDir {
        static COUNTER: AtomicUsize = AtomicUsize::new(0);
        let n = COUNTER.fetch_add(1, Ordering::Relaxed);
        let dir =
            std::env::temp_dir().join(format!("hyperpbd-cli-{}-{n}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("create temp dir");
        TempDir(dir)
    }

    fn path(&self, name: &str) -> PathBuf {
        self.0.join(name)
    }

    fn write(&self, name: &str, text: &str) -> PathBuf {
        let path = self.path(name);
        std::fs::write(&path, text).expect("write scene");
        path
    }

    /// Names of the files in the directory, sorted.
    fn files(&self) -> Vec<String> {
        let mut names: Vec<String> = std::fs::read_dir(&self.0)
            .expect("read temp dir")
            .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        names
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

fn hyperpbd<I, S>(args: I) -> Output
where
    I: IntoIterator<Item = S>,
    S: AsRef<std::ffi::OsStr>,
{
    let dir = TempDir::new("cwd");
    hyperpbd_in(&dir.0, args)
}

/// Runs the binary with `cwd` as its working directory (so nothing it
/// writes by default lands in the repository).
fn hyperpbd_in<I, S>(cwd: &Path, args: I) -> Output
where
    I: IntoIterator<Item = S>,
    S: AsRef<std::ffi::OsStr>,
{
    Command::new(env!("CARGO_BIN_EXE_hyperpbd"))
        .args(args)
        .current_dir(cwd)
        .output()
        .expect("run the hyperpbd binary")
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

fn assert_success(out: &Output) {
    assert!(
        out.status.success(),
        "exit {:?}\nstdout:\n{}\nstderr:\n{}",
        out.status.code(),
        text(&out.stdout),
        text(&out.stderr)
    );
}

/// The example scene of the issue (4 particles, 3 families, a plane).
const EXAMPLE: &str = r#"{"dim": 3, "dt": 0.0166666, "substeps": 10, "iterations": 1,
 "gravity": [0.0, -9.81, 0.0],
 "particles": [{"position": [0,1,0], "velocity": [0,0,0], "mass": 1.0, "radius": 0.0, "gravity_scale": 1.0, "force": [0,0,0]},
               {"position": [0,2,0], "fixed": true},
               {"position": [0.5,1,0], "mass": 1.0},
               {"position": [0,1,0.5], "mass": 1.0, "velocity": [1,0,0]}],
 "constraints": [{"type": "distance", "compliance": 0.0, "elements": [[0,1]], "rest": [1.0]},
                 {"type": "simplex_measure", "compliance": 1e-6, "elements": [[0,2,3]]},
                 {"type": "oriented_measure", "compliance": 0.0, "elements": [[1,0,2,3]]}],
 "obstacles": [{"type": "hyperplane", "normal": [0,1,0], "offset": 0.0, "friction": 0.5, "compliance": 0.0}],
 "damping": {"rate": 0.5}}"#;

/// The library's own result for `frames` steps of `scene`.
fn reference(scene: &Scene, frames: u64) -> hyperpbd::State {
    let mut b = hyperpbd::cpu_backend(scene).expect("backend");
    for _ in 0..frames {
        b.step().expect("step");
    }
    b.read_state().expect("state")
}

/// Checks one state record against `state` bit for bit.
fn check_record(record: &Value, frames: u64, dt: f64, state: &hyperpbd::State) {
    let obj = record.as_object().expect("a JSON object");
    let mut keys: Vec<&str> = obj.keys().map(String::as_str).collect();
    keys.sort_unstable();
    assert_eq!(keys, ["frames", "positions", "time", "velocities"]);
    assert_eq!(obj["frames"].as_u64(), Some(frames));
    assert_eq!(
        obj["time"].as_f64().map(f64::to_bits),
        Some((frames as f64 * dt).to_bits())
    );
    for (key, flat) in [
        ("positions", &state.positions),
        ("velocities", &state.velocities),
    ] {
        let rows = obj[key].as_array().expect("array of rows");
        assert_eq!(rows.len(), state.len(), "{key}: one row per particle");
        let mut values = Vec::new();
        for row in rows {
            let row = row.as_array().expect("row");
            assert_eq!(row.len(), state.dim, "{key}: dim values per row");
            values.extend(row.iter().map(|x| x.as_f64().expect("number")));
        }
        let got: Vec<u64> = values.iter().map(|x| x.to_bits()).collect();
        let want: Vec<u64> = flat.iter().map(|x| x.to_bits()).collect();
        assert_eq!(got, want, "{key} differ from the library's result");
    }
}

// ---------------------------------------------------------------- run

#[test]
fn run_writes_the_final_state() {
    let dir = TempDir::new("run");
    let scene_path = dir.write("scene.json", EXAMPLE);
    let out_path = dir.path("final.json");
    let out = hyperpbd([
        "run".as_ref(),
        scene_path.as_os_str(),
        "--backend".as_ref(),
        "cpu".as_ref(),
        "--frames".as_ref(),
        "7".as_ref(),
        "--out".as_ref(),
        out_path.as_os_str(),
    ]);
    assert_success(&out);
    let scene = Scene::from_json_str(EXAMPLE).expect("example");
    let state = reference(&scene, 7);
    let record: Value =
        serde_json::from_str(&std::fs::read_to_string(&out_path).expect("--out file"))
            .expect("--out is JSON");
    check_record(&record, 7, scene.dt, &state);
    // The fixed particle did not move; the others fell.
    assert_eq!(state.position(1), [0.0, 2.0, 0.0]);
    let stdout = text(&out.stdout);
    assert!(
        stdout.contains(&format!("state hash {:016x}", state.hash())),
        "{stdout}"
    );
    assert!(stdout.contains("cpu-f64"), "{stdout}");
    assert_eq!(dir.files(), ["final.json", "scene.json"]);
}

#[test]
fn run_writes_a_trajectory_every_k_frames() {
    let dir = TempDir::new("trajectory");
    let scene_path = dir.write("scene.json", EXAMPLE);
    let scene = Scene::from_json_str(EXAMPLE).expect("example");
    for (frames, every) in [(10u64, 3u64), (10, 1), (10, 5), (4, 10), (0, 2)] {
        let traj = dir.path("traj.jsonl");
        let out_path = dir.path("final.json");
        let out = hyperpbd([
            "run".as_ref(),
            scene_path.as_os_str(),
            "--backend".as_ref(),
            "cpu".as_ref(),
            "--frames".as_ref(),
            frames.to_string().as_ref(),
            "--trajectory".as_ref(),
            traj.as_os_str(),
            "--every".as_ref(),
            every.to_string().as_ref(),
            "--out".as_ref(),
            out_path.as_os_str(),
        ]);
        assert_success(&out);
        let lines: Vec<String> = std::fs::read_to_string(&traj)
            .expect("trajectory")
            .lines()
            .map(str::to_string)
            .collect();
        assert_eq!(
            lines.len() as u64,
            frames / every + 1,
            "--frames {frames} --every {every}"
        );
        for (n, line) in lines.iter().enumerate() {
            let frame = n as u64 * every;
            let record: Value = serde_json::from_str(line).expect("one JSON object per line");
            check_record(&record, frame, scene.dt, &reference(&scene, frame));
        }
        let last: Value = serde_json::from_str(&std::fs::read_to_string(&out_path).unwrap())
            .expect("--out is JSON");
        check_record(&last, frames, scene.dt, &reference(&scene, frames));
        assert_eq!(dir.files(), ["final.json", "scene.json", "traj.jsonl"]);
        std::fs::remove_file(traj).unwrap();
        std::fs::remove_file(out_path).unwrap();
    }
}

#[test]
fn run_without_outputs_just_reports() {
    let dir = TempDir::new("report");
    let scene_path = dir.write("scene.json", EXAMPLE);
    let out = hyperpbd([
        "run".as_ref(),
        scene_path.as_os_str(),
        "--backend".as_ref(),
        "cpu".as_ref(),
        "--frames".as_ref(),
        "3".as_ref(),
    ]);
    assert_success(&out);
    let stdout = text(&out.stdout);
    assert!(stdout.contains("3 frames"), "{stdout}");
    assert!(stdout.contains("constraints[0] max violation"), "{stdout}");
    assert!(stdout.contains("obstacles[0] max violation"), "{stdout}");
    assert_eq!(dir.files(), ["scene.json"]);
}

#[test]
fn run_with_backend_auto_says_which_backend_it_picked() {
    let dir = TempDir::new("auto");
    let scene_path = dir.write("scene.json", EXAMPLE);
    let out_path = dir.path("final.json");
    let out = hyperpbd([
        "run".as_ref(),
        scene_path.as_os_str(),
        "--frames".as_ref(),
        "2".as_ref(),
        "--out".as_ref(),
        out_path.as_os_str(),
    ]);
    assert_success(&out);
    let stderr = text(&out.stderr);
    assert!(stderr.contains("notice: backend auto -> "), "{stderr}");
    if stderr.contains("-> cpu-f64") {
        let scene = Scene::from_json_str(EXAMPLE).unwrap();
        let record: Value =
            serde_json::from_str(&std::fs::read_to_string(&out_path).unwrap()).unwrap();
        check_record(&record, 2, scene.dt, &reference(&scene, 2));
    }
}

// ---------------------------------------------------------------- plan, scene, info, demo

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

// ---------------------------------------------------------------- bad input

/// Runs `run` on `scene_text` with --out and --trajectory and checks the
/// failure: exit code, a single `error:` line that contains every needle,
/// and no output (neither file nor its `.tmp`).
fn assert_rejected(scene_text: &str, code: i32, needles: &[&str]) -> String {
    let dir = TempDir::new("bad");
    let scene_path = dir.write("scene.json", scene_text);
    let out_path = dir.path("final.json");
    let traj = dir.path("traj.jsonl");
    let out = hyperpbd([
        "run".as_ref(),
        scene_path.as_os_str(),
        "--backend".as_ref(),
        "cpu".as_ref(),
        "--frames".as_ref(),
        "3".as_ref(),
        "--out".as_ref(),
        out_path.as_os_str(),
        "--trajectory".as_ref(),
        traj.as_os_str(),
    ]);
    let stderr = text(&out.stderr);
    assert_eq!(out.status.code(), Some(code), "stderr: {stderr}");
    assert_eq!(stderr.lines().count(), 1, "one message: {stderr}");
    assert!(stderr.starts_with("error: "), "{stderr}");
    for needle in needles {
        assert!(stderr.contains(needle), "{needle:?} not in {stderr}");
    }
    assert_eq!(
        dir.files(),
        ["scene.json"],
        "no output may be written on failure"
    );
    // `plan` refuses the same input with the same code (input errors only).
    if code == 2 {
        let plan = hyperpbd(["plan".as_ref(), scene_path.as_os_str()]);
        assert_eq!(plan.status.code(), Some(2));
        assert_eq!(text(&plan.stderr), stderr);
        assert!(plan.stdout.is_empty());
    }
    stderr
}

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
    // With a usable adapter the GPU backend runs the scene; without one it
    // must fail with one clear message and no output — never a silent CPU
    // fallback.
    let dir = TempDir::new("gpu");
    let scene_path = dir.write("scene.json", EXAMPLE);
    let scene = Scene::from_json_str(EXAMPLE).unwrap();
    for backend in ["gpu", "gpu-f64"] {
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
        if out.status.success() {
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

// ---------------------------------------------------------------- simulation and output errors

/// Valid, but the first prediction overflows to infinity.
const OVERFLOWING: &str = r#"{"dim": 1, "dt": 1, "particles": [
    {"position": [1.7e308], "velocity": [1.7e308], "mass": 1}]}"#;

#[test]
fn failed_simulation_exits_3_and_writes_nothing() {
    let stderr = assert_rejected(OVERFLOWING, 3, &["frame 1: step aborted in stage predict"]);
    assert!(
        stderr.contains("particle 0 became non-finite; state rolled back"),
        "{stderr}"
    );
}

#[test]
fn unwritable_output_exits_4() {
    let dir = TempDir::new("unwritable");
    let scene_path = dir.write("scene.json", EXAMPLE);
    let out_path = dir.path("no-such-dir").join("final.json");
    let out = hyperpbd([
        "run".as_ref(),
        scene_path.as_os_str(),
        "--backend".as_ref(),
        "cpu".as_ref(),
        "--frames".as_ref(),
        "2".as_ref(),
        "--out".as_ref(),
        out_path.as_os_str(),
    ]);
    assert_eq!(out.status.code(), Some(4));
    let stderr = text(&out.stderr);
    assert!(stderr.starts_with("error: cannot write "), "{stderr}");
    assert!(stderr.contains("final.json"), "{stderr}");
    assert_eq!(dir.files(), ["scene.json"]);

    let traj = dir.path("no-such-dir").join("t.jsonl");
    let out = hyperpbd([
        "run".as_ref(),
        scene_path.as_os_str(),
        "--backend".as_ref(),
        "cpu".as_ref(),
        "--trajectory".as_ref(),
        traj.as_os_str(),
    ]);
    assert_eq!(out.status.code(), Some(4));
    assert_eq!(dir.files(), ["scene.json"]);
}

/// When `--out` cannot be written after a successful simulation, the
/// trajectory's temporary file stays behind: run.rs returns from
/// `write_atomically(path, …)?` before `finish_trajectory` runs.
#[test]
fn failed_out_write_leaves_no_trajectory_tmp() {
    let dir = TempDir::new("tmp-left");
    let scene_path = dir.write("scene.json", EXAMPLE);
    let out_path = dir.path("no-such-dir").join("final.json");
    let traj = dir.path("t.jsonl");
    let out = hyperpbd([
        "run".as_ref(),
        scene_path.as_os_str(),
        "--backend".as_ref(),
        "cpu".as_ref(),
        "--frames".as_ref(),
        "2".as_ref(),
        "--out".as_ref(),
        out_path.as_os_str(),
        "--trajectory".as_ref(),
        traj.as_os_str(),
    ]);
    assert_eq!(out.status.code(), Some(4));
    assert_eq!(dir.files(), ["scene.json"]);
}

#[test]
fn output_paths_are_atomic_replacements() {
    // An existing --out file is replaced as a whole by a successful run.
    let dir = TempDir::new("replace");
    let scene_path = dir.write("scene.json", EXAMPLE);
    let out_path = dir.write("final.json", "old contents that are longer than nothing");
    let out = hyperpbd([
        "run".as_ref(),
        scene_path.as_os_str(),
        "--backend".as_ref(),
        "cpu".as_ref(),
        "--frames".as_ref(),
        "1".as_ref(),
        "--out".as_ref(),
        out_path.as_os_str(),
    ]);
    assert_success(&out);
    let scene = Scene::from_json_str(EXAMPLE).unwrap();
    let record: Value =
        serde_json::from_str(&std::fs::read_to_string(Path::new(&out_path)).unwrap()).unwrap();
    check_record(&record, 1, scene.dt, &reference(&scene, 1));
    assert_eq!(dir.files(), ["final.json", "scene.json"]);
}

#[test]
fn docs_errors_md_quotes_the_cli_messages() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/errors.md");
    let docs = std::fs::read_to_string(path).unwrap_or_default();
    let dir = TempDir::new("docs");
    let overflow = dir.write("of.json", OVERFLOWING);
    let mut messages = Vec::new();
    let out = hyperpbd([
        "run".as_ref(),
        overflow.as_os_str(),
        "--backend".as_ref(),
        "cpu".as_ref(),
    ]);
    messages.push(text(&out.stderr));
    let out = hyperpbd([
        "run".as_ref(),
        overflow.as_os_str(),
        "--trajectory".as_ref(),
        "t.jsonl".as_ref(),
        "--every".as_ref(),
        "0".as_ref(),
    ]);
    messages.push(text(&out.stderr));
    messages.push(text(&hyperpbd(["scene", "teapot"]).stderr));
    let out = hyperpbd(["bogus"]);
    messages.push(text(&out.stderr).lines().next().unwrap_or("").to_string());
    for m in messages {
        let m = m.trim_end();
        assert!(!m.is_empty());
        assert!(docs.contains(m), "docs/errors.md does not quote {m:?}");
    }
}

/// `hyperpbd scene cloth | head -c 1`: the reader closes the pipe after one
/// byte; the writer must stop quietly (nothing on stderr) with the status
/// a shell gives a process killed by SIGPIPE, 141, instead of panicking
/// with "failed printing to stdout: Broken pipe" — and without claiming a
/// success it could not deliver (`set -o pipefail` sees the 141).
#[test]
fn a_closed_stdout_pipe_ends_quietly() {
    use std::io::Read;
    let dir = TempDir::new("pipe");
    let mut child = Command::new(env!("CARGO_BIN_EXE_hyperpbd"))
        .args(["scene", "cloth"])
        .current_dir(&dir.0)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("run the hyperpbd binary");
    let mut first = [0u8; 1];
    child
        .stdout
        .take()
        .expect("stdout")
        .read_exact(&mut first)
        .expect("one byte");
    // The pipe's read end is dropped here; the scene is ~170 kB, far more
    // than a pipe buffer, so the writer hits EPIPE.
    let out = child.wait_with_output().expect("wait");
    assert_eq!(first[0], b'{');
    assert_eq!(
        out.status.code(),
        Some(141),
        "stderr: {}",
        text(&out.stderr)
    );
    assert!(out.stderr.is_empty(), "stderr: {}", text(&out.stderr));
}

/// A run that fails after seven good frames (a particle at 1e308 moving
/// at 1e307 m/s overflows in frame 8), with a trajectory written every
/// frame: the seven written lines must not survive under any name —
/// no partial `--trajectory`, no `--out`, no `.tmp`.
#[test]
fn a_failure_mid_run_leaves_no_partial_output() {
    let dir = TempDir::new("mid-run");
    let scene_path = dir.write(
        "scene.json",
        r#"{"dim": 1, "dt": 1, "particles": [{"position": [1e308], "velocity": [1e307], "mass": 1}]}"#,
    );
    let out = hyperpbd([
        "run".as_ref(),
        scene_path.as_os_str(),
        "--backend".as_ref(),
        "cpu".as_ref(),
        "--frames".as_ref(),
        "20".as_ref(),
        "--out".as_ref(),
        dir.path("final.json").as_os_str(),
        "--trajectory".as_ref(),
        dir.path("traj.jsonl").as_os_str(),
        "--every".as_ref(),
        "1".as_ref(),
    ]);
    let stderr = text(&out.stderr);
    assert_eq!(out.status.code(), Some(3), "stderr: {stderr}");
    assert!(
        stderr.contains("frame 8: step aborted in stage predict") && stderr.contains("rolled back"),
        "{stderr}"
    );
    assert_eq!(dir.files(), ["scene.json"], "no partial output may remain");
}
