//! The `hyperpbd` binary, driven as a user would: output files and their
//! shapes, trajectories, `plan`, `scene`, `info`, `demo`, `compare`'s
//! verdict, and bad input (exit code 2, one message naming the field, no
//! output file left behind); the barrier path and thread counts through
//! the binary, `hyperpbd render` / `demo` pictures and `sweep --plot`'s
//! metric (modules that were their own binaries before, issue 33).

#[path = "../common/mod.rs"]
mod common;

mod bad_input;
mod barrier;
mod commands;
mod compare;
mod forces;
mod output_errors;
mod render;
mod render_motion;
mod run;
mod sweep;
mod sweep_metric;
mod threads;

use common::gpu::adapter_or_skip;
use hyperpbd::{Backend, Precision, Scene};
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
