//! `hyperpbd run --forces`: one JSON object per frame, the library's
//! contact forces bit for bit, from the CPU and the GPU (gpu-f64 on
//! lavapipe byte for byte the CPU's); an unwritable path (exit 4) leaves
//! no output.

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
fn a_gpu_backend_writes_the_golden_paths_forces() {
    // gpu-f64 on lavapipe: the same bytes as `--backend cpu` (its states and
    // forces are the golden path's); gpu (f32): the floor holds 2 kg · g to
    // its f32 bound (tests/gpu/contact_forces.rs: ε32 X / (g h²), X = 0.1 m
    // the resting ball's largest coordinate, h = dt / 10: 4.4e-4).
    let dir = TempDir::new("forces-gpu");
    let cpu = dir.path("cpu.jsonl");
    assert_success(&run_forces(&dir, "cpu", &cpu, 30));
    let golden = std::fs::read_to_string(&cpu).expect("cpu forces");
    for (backend, precision) in [("gpu-f64", Precision::F64), ("gpu", Precision::F32)] {
        let test = "a_gpu_backend_writes_the_golden_paths_forces";
        let Some((_, summary)) = adapter_or_skip(test, precision) else {
            continue;
        };
        let path = dir.path(&format!("{backend}.jsonl"));
        assert_success(&run_forces(&dir, backend, &path, 30));
        let text = std::fs::read_to_string(&path).expect("--forces file");
        assert_eq!(text.lines().count(), 30, "{backend}: one line per frame");
        if precision == Precision::F64 && summary.name.contains("llvmpipe") {
            assert_eq!(
                text, golden,
                "{backend}: the golden path's forces, byte for byte"
            );
            continue;
        }
        let last: Value = serde_json::from_str(text.lines().last().expect("a line")).expect("JSON");
        let floor = last["obstacles"][0]["force"][1].as_f64().expect("number");
        let error = (floor - 2.0 * 9.81).abs() / (2.0 * 9.81);
        println!("BOUND {backend} --forces floor: relative error {error:.3e} / 4.4e-4");
        assert!(error <= 4.4e-4, "{backend}: {floor}");
    }
}
