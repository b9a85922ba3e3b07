//! `hyperpbd run`: final states, trajectories, `--backend auto`.

use super::*;

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
