//! Failed simulations (exit 3), unwritable output (exit 4), atomic
//! replacement, a closed stdout pipe (exit 141), no partial output.

use super::*;

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
