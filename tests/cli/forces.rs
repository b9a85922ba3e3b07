//! `hyperpbd run --forces`: one JSON object per frame, the library's
//! contact forces bit for bit; an unwritable path (exit 4) and a backend
//! that cannot report them (exit 2, GPU) leave no output.

use super::*;

/// A 2 kg ball resting on the plane y = 0 (μ = 0.5) and a free one above.
const RESTING: &str = r#"{"dim": 2, "dt": 0.016666666666666666, "substeps": 10, "iterations": 2,
 "gravity": [0.0, -9.81],
 "particles": [{"position": [0.0, 0.1], "mass": 2.0, "radius": 0.1},
               {"position": [1.0, 3.0], "mass": 1.0, "radius": 0.1}],
 "obstacles": [{"type": "hyperplane", "normal": [0, 1], "offset": 0.0, "friction": 0.5},
               {"type": "hyperplane", "normal": [1, 0], "offset": -5.0}]}"#;

fn run_forces(dir: &TempDir, backend: &str, forces: &Path, frames: u64) -> Output {
    let scene_path = dir.write("scene.json", RESTING);
    hyperpbd([
        "run".as_ref(),
        scene_path.as_os_str(),
        "--backend".as_ref(),
        backend.as_ref(),
        "--frames".as_ref(),
        frames.to_string().as_ref(),
        "--forces".as_ref(),
        forces.as_os_str(),
    ])
}

fn numbers(v: &Value) -> Vec<u64> {
    v.as_array()
        .expect("array")
        .iter()
        .map(|x| x.as_f64().expect("number").to_bits())
        .collect()
}

#[test]
fn run_writes_each_frames_contact_forces() {
    let dir = TempDir::new("forces");
    let path = dir.path("forces.jsonl");
    let out = run_forces(&dir, "cpu", &path, 30);
    assert_success(&out);
    let scene = Scene::from_json_str(RESTING).expect("scene");
    let mut b = hyperpbd::cpu_backend(&scene).expect("backend");
    b.request_contact_forces(true).expect("cpu reports forces");
    let text = std::fs::read_to_string(&path).expect("--forces file");
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines.len(), 30, "one line per frame");
    for (k, line) in lines.iter().enumerate() {
        let want = b.step().expect("step").contact_forces.expect("forces");
        let record: Value = serde_json::from_str(line).expect("a JSON line");
        let mut keys: Vec<&str> = record
            .as_object()
            .expect("object")
            .keys()
            .map(String::as_str)
            .collect();
        keys.sort_unstable();
        assert_eq!(keys, ["frame", "obstacles", "particles", "time"]);
        assert_eq!(record["frame"].as_u64(), Some(k as u64 + 1));
        assert_eq!(record["time"].as_f64(), Some((k + 1) as f64 * scene.dt));
        let obstacles = record["obstacles"].as_array().expect("obstacles");
        assert_eq!(obstacles.len(), 2, "one entry per obstacle");
        for (o, entry) in obstacles.iter().enumerate() {
            let want: Vec<u64> = want.obstacle(o).iter().map(|x| x.to_bits()).collect();
            assert_eq!(numbers(&entry["force"]), want, "frame {k} obstacle {o}");
        }
        let particles = record["particles"].as_array().expect("particles");
        assert_eq!(particles.len(), 2);
        for (i, row) in particles.iter().enumerate() {
            let want: Vec<u64> = want.particle(i).iter().map(|x| x.to_bits()).collect();
            assert_eq!(numbers(row), want, "frame {k} particle {i}");
        }
    }
    // At rest on the floor: the floor holds up 2 kg · g; the wall nothing.
    let last: Value = serde_json::from_str(lines[29]).expect("JSON");
    let floor = last["obstacles"][0]["force"][1].as_f64().expect("number");
    assert!((floor - 2.0 * 9.81).abs() <= 1e-9 * 2.0 * 9.81, "{floor}");
    assert_eq!(last["obstacles"][1]["force"][0].as_f64(), Some(0.0));
}

#[test]
fn an_unwritable_forces_path_exits_4_and_writes_nothing() {
    let dir = TempDir::new("forces-bad");
    let path = dir.path("no-such-dir").join("f.jsonl");
    let out = run_forces(&dir, "cpu", &path, 3);
    assert_eq!(out.status.code(), Some(4));
    let stderr = text(&out.stderr);
    assert!(stderr.starts_with("error: cannot write "), "{stderr}");
    assert!(stderr.contains("f.jsonl"), "{stderr}");
    assert_eq!(dir.files(), ["scene.json"]);
}

#[test]
fn a_gpu_backend_refuses_forces_with_its_reason() {
    for (backend, precision) in [("gpu", Precision::F32), ("gpu-f64", Precision::F64)] {
        if adapter_or_skip("a_gpu_backend_refuses_forces_with_its_reason", precision).is_none() {
            continue;
        }
        let dir = TempDir::new("forces-gpu");
        let path = dir.path("f.jsonl");
        let out = run_forces(&dir, backend, &path, 3);
        let stderr = text(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{stderr}");
        // (Notices about the adapter may come first.)
        let error = stderr.lines().find(|l| l.starts_with("error: "));
        assert!(
            error.is_some_and(|e| e.starts_with("error: --forces: ")),
            "{stderr}"
        );
        assert!(
            stderr.contains("do not read their contact multipliers back"),
            "{stderr}"
        );
        assert_eq!(dir.files(), ["scene.json"], "{backend}");
    }
}
