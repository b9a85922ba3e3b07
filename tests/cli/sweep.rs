//! `hyperpbd sweep`: worlds are the cartesian product of the `--set` axes
//! (last fastest); each world's line is bit for bit the run of the scene
//! with those values on its own; shards concatenate to the whole sweep;
//! bad paths and values are refused with the field named and no file.

use super::{EXAMPLE, TempDir, adapter_or_skip, assert_success, hyperpbd, reference, text};
use hyperpbd::sweep::{FieldPath, Shard, Sweep};
use hyperpbd::{Precision, Scene};
use serde_json::Value;

const CHAIN: &str = include_str!("../../scenes/chain2d.json");

/// The 15-world sweep of the tests: 3 sideways gravities × 5 damping rates.
const AXES: [&str; 2] = ["gravity[0]=-1:1:3", "damping.rate=0:2:5"];

fn sweep_cli(dir: &TempDir, scene: &str, out: &str, extra: &[&str]) -> std::process::Output {
    sweep_axes(dir, scene, out, &AXES, extra)
}

fn sweep_axes(
    dir: &TempDir,
    scene: &str,
    out: &str,
    axes: &[&str],
    extra: &[&str],
) -> std::process::Output {
    let scene = dir.write("scene.json", scene);
    let out = dir.path(out);
    let mut args: Vec<std::ffi::OsString> = vec!["sweep".into(), scene.into()];
    for &axis in axes {
        args.extend(["--set".into(), axis.into()]);
    }
    args.extend(["--frames".into(), "12".into(), "--out".into(), out.into()]);
    args.extend(extra.iter().map(Into::into));
    hyperpbd(args)
}

fn lines(dir: &TempDir, name: &str) -> Vec<Value> {
    std::fs::read_to_string(dir.path(name))
        .expect("sweep output")
        .lines()
        .map(|l| serde_json::from_str(l).expect("one JSON object per line"))
        .collect()
}

fn rows(value: &Value) -> Vec<f64> {
    value
        .as_array()
        .expect("rows")
        .iter()
        .flat_map(|r| {
            r.as_array()
                .expect("row")
                .iter()
                .map(|c| c.as_f64().expect("number"))
        })
        .collect()
}

#[test]
fn every_world_is_its_own_run_bit_for_bit() {
    let dir = TempDir::new("sweep-cpu");
    let out = sweep_cli(&dir, CHAIN, "all.jsonl", &["--backend", "cpu"]);
    assert_success(&out);
    let worlds = lines(&dir, "all.jsonl");
    assert_eq!(worlds.len(), 15);
    let axes = AXES.iter().map(|a| a.parse().expect("axis")).collect();
    let sweep = Sweep::new(CHAIN, axes).expect("sweep");
    let sideways = [-1.0, 0.0, 1.0];
    let rates = [0.0, 0.5, 1.0, 1.5, 2.0];
    for (w, line) in worlds.iter().enumerate() {
        assert_eq!(line["world"], w);
        let (g, rate) = (sideways[w / 5], rates[w % 5]);
        assert_eq!(line["set"]["gravity[0]"], g, "world {w}");
        assert_eq!(line["set"]["damping.rate"], rate, "world {w}");
        // The world alone: the scene file with those two numbers edited.
        let mut scene = Scene::from_json_str(CHAIN).expect("chain");
        scene.gravity.as_mut().expect("chain2d has gravity")[0] = g;
        scene.damping.as_mut().expect("chain2d damps").rate = rate;
        assert_eq!(sweep.scene(w).expect("world scene"), scene, "world {w}");
        let alone = reference(&scene, 12);
        let bits = |v: &[f64]| v.iter().map(|c| c.to_bits()).collect::<Vec<_>>();
        assert_eq!(
            bits(&rows(&line["positions"])),
            bits(&alone.positions),
            "world {w}"
        );
        assert_eq!(
            bits(&rows(&line["velocities"])),
            bits(&alone.velocities),
            "world {w}"
        );
        assert!(line["report"]["max_violation"].as_f64().is_some());
    }
    // Different settings give different worlds (the values reach the physics).
    assert_ne!(
        rows(&worlds[0]["positions"]),
        rows(&worlds[14]["positions"])
    );
    assert_ne!(rows(&worlds[0]["positions"]), rows(&worlds[1]["positions"]));
    assert_ne!(
        rows(&worlds[0]["velocities"]),
        rows(&worlds[5]["velocities"])
    );
}

#[test]
fn shards_concatenate_to_the_whole_sweep() {
    let dir = TempDir::new("sweep-shards");
    assert_success(&sweep_cli(&dir, CHAIN, "all.jsonl", &["--backend", "cpu"]));
    let whole = std::fs::read_to_string(dir.path("all.jsonl")).expect("whole");
    let mut joined = String::new();
    for k in 1..=4 {
        let name = format!("shard{k}.jsonl");
        let shard = format!("{k}/4");
        let out = sweep_cli(&dir, CHAIN, &name, &["--backend", "cpu", "--shard", &shard]);
        assert_success(&out);
        joined += &std::fs::read_to_string(dir.path(&name)).expect("shard");
    }
    assert_eq!(joined, whole);
    // Worlds run in parallel on the CPU: the same bytes on any thread count.
    for threads in ["1", "3"] {
        let name = format!("threads{threads}.jsonl");
        let extra = ["--backend", "cpu", "--threads", threads];
        assert_success(&sweep_cli(&dir, CHAIN, &name, &extra));
        let file = std::fs::read_to_string(dir.path(&name)).expect("sweep");
        assert_eq!(file, whole, "--threads {threads}");
    }
    // Slices are contiguous, cover every world once, and differ by ≤ 1.
    for count in 1..=20 {
        let mut next = 0;
        for index in 1..=count {
            let r = Shard { index, count }.range(15);
            assert_eq!(r.start, next);
            assert!(r.len() == 15 / count || r.len() == 15 / count + 1);
            next = r.end;
        }
        assert_eq!(next, 15);
    }
}

/// The gpu-f64 sweep of `axes` over chain2d equals the CPU sweep line for
/// line; what the GPU run printed (stdout, stderr).
fn gpu_f64_equals_cpu(test: &str, axes: &[&str]) -> Option<(String, String)> {
    gpu_f64_scene_equals_cpu(test, CHAIN, axes)
}

/// As [`gpu_f64_equals_cpu`] over the scene `scene`.
fn gpu_f64_scene_equals_cpu(test: &str, scene: &str, axes: &[&str]) -> Option<(String, String)> {
    adapter_or_skip(test, Precision::F64)?;
    let dir = TempDir::new(test);
    assert_success(&sweep_axes(
        &dir,
        scene,
        "cpu.jsonl",
        axes,
        &["--backend", "cpu"],
    ));
    let run = sweep_axes(&dir, scene, "gpu.jsonl", axes, &["--backend", "gpu-f64"]);
    assert_success(&run);
    let (cpu, gpu) = (lines(&dir, "cpu.jsonl"), lines(&dir, "gpu.jsonl"));
    for (c, g) in cpu.iter().zip(&gpu) {
        assert_eq!(c["positions"], g["positions"], "world {}", c["world"]);
        assert_eq!(c["velocities"], g["velocities"], "world {}", c["world"]);
        for key in ["max_violation", "residuals", "active_contacts"] {
            assert_eq!(c["report"][key], g["report"][key], "world {}", c["world"]);
        }
    }
    assert_eq!(gpu.len(), cpu.len());
    Some((
        String::from_utf8_lossy(&run.stdout).into_owned(),
        String::from_utf8_lossy(&run.stderr).into_owned(),
    ))
}

#[test]
fn gpu_f64_sweep_equals_the_cpu_sweep() {
    // damping.rate = 0 compiles no damping stage; the batch runs the
    // union of the worlds' stages, world 0 skipping damping: one batch.
    let Some((stdout, stderr)) = gpu_f64_equals_cpu("sweep-gpu", &AXES) else {
        return;
    };
    assert!(!stderr.contains("one GPU backend each"), "{stderr}");
    assert!(stdout.contains("gpu-f64, 15 worlds per batch"), "{stdout}");
}

#[test]
fn a_gpu_sweep_runs_its_worlds_as_one_batch() {
    let axes = ["gravity[0]=-3:3:3", "obstacles[0].offset=0:1.5:5"];
    let Some((stdout, stderr)) = gpu_f64_equals_cpu("sweep-gpu-batch", &axes) else {
        return;
    };
    assert!(!stderr.contains("one GPU backend each"), "{stderr}");
    assert!(stdout.contains("gpu-f64, 15 worlds per batch"), "{stdout}");
}

#[test]
fn a_gpu_sweep_of_a_contact_scene_runs_one_batch() {
    // 18 balls in a pit, ball–ball friction from 0 (the frictionless
    // branch of the collide kernel) to 0.6: one batch, in f64 each world
    // its own CPU run, and in f32 one batch too (no notice).
    let pit = serde_json::to_string(&hyperpbd::scenes::pit3d(3, 2)).expect("json");
    let axes = ["collisions.friction=0:0.6:3"];
    let Some((stdout, stderr)) = gpu_f64_scene_equals_cpu("sweep-gpu-contact", &pit, &axes) else {
        return;
    };
    assert!(!stderr.contains("one GPU backend each"), "{stderr}");
    assert!(stdout.contains("gpu-f64, 3 worlds per batch"), "{stdout}");
    let dir = TempDir::new("sweep-gpu-contact-f32");
    let run = sweep_axes(&dir, &pit, "f32.jsonl", &axes, &["--backend", "gpu"]);
    assert_success(&run);
    let (stdout, stderr) = (text(&run.stdout), text(&run.stderr));
    assert!(!stderr.contains("one GPU backend each"), "{stderr}");
    assert!(stdout.contains("gpu-f32, 3 worlds per batch"), "{stdout}");
    assert_eq!(lines(&dir, "f32.jsonl").len(), 3);
}

#[test]
fn a_gpu_sweep_of_a_guarded_adaptive_scene_runs_one_batch() {
    // The 40 m/s Neo-Hookean drop under the orientation guard, adaptive,
    // its plane 3, 2, 1 and 0 m lower: each world's step is rejected and
    // retried alone with more substeps in its own frames (3, 2, 1 and 2, 1),
    // the other worlds' accepted in the batch (gpu/src/batch/retry.rs).
    let block = crate::common::guarded::material_block(
        2,
        40.0,
        hyperpbd::ConstraintKind::NeoHookean,
        Some(crate::common::guarded::orientation()),
        Some(6),
    );
    let scene = serde_json::to_string(&block).expect("json");
    let axes = ["obstacles[0].offset=-3:0:4"];
    let test = "sweep-gpu-guarded";
    let Some((stdout, stderr)) = gpu_f64_scene_equals_cpu(test, &scene, &axes) else {
        return;
    };
    assert!(!stderr.contains("one GPU backend each"), "{stderr}");
    assert!(stdout.contains("gpu-f64, 4 worlds per batch"), "{stdout}");
}

#[test]
fn a_gpu_sweep_of_an_implicit_scene_runs_one_batch() {
    // The coupled implicit chain at four gravities: each world its own
    // backend, stepped in lockstep on one device (gpu/src/batch/lockstep.rs),
    // each world's line its CPU run's.
    let scene = include_str!("../../scenes/chain2d_implicit.json");
    let axes = ["gravity[1]=-12:-6:4"];
    let test = "sweep-gpu-implicit";
    let Some((stdout, stderr)) = gpu_f64_scene_equals_cpu(test, scene, &axes) else {
        return;
    };
    assert!(!stderr.contains("one GPU backend each"), "{stderr}");
    assert!(stdout.contains("gpu-f64, 4 worlds per batch"), "{stdout}");
}

#[test]
fn worlds_of_another_topology_run_one_gpu_backend_each_with_a_notice() {
    // World 1's first link is heavier: masses are the batch's topology.
    let axes = ["gravity[0]=-1:1:3", "particles[1].mass=0.1:0.3:5"];
    let Some((stdout, stderr)) = gpu_f64_equals_cpu("sweep-gpu-alone", &axes) else {
        return;
    };
    assert!(
        stderr.contains(
            "sweep: the worlds run one GPU backend each: worlds[1].particles[1].mass: differs \
             from worlds[0]"
        ),
        "{stderr}"
    );
    assert!(!stdout.contains("worlds per batch"), "{stdout}");
}

#[test]
fn bad_sets_name_the_field_and_leave_no_file() {
    let dir = TempDir::new("sweep-bad");
    let scene = dir.write("scene.json", EXAMPLE);
    let cases = [
        ("obstacles[0].frction=0:1:2", "obstacles[0].frction"),
        ("obstacles[3].friction=0:1:2", "index 3 is out of range"),
        ("obstacles[0].friction=-1:1:3", "obstacles[0].friction"),
        ("gravity=0:1:2", "is not a number"),
        ("gravity[1]=0:x:2", "HI `x`"),
        ("damping.rate=0:1:0", "COUNT"),
        ("damping.rate=0:1:1", "COUNT 1 needs LO = HI"),
        ("particles[1.mass=0:1:2", "unclosed"),
    ];
    for (set, expected) in cases {
        let out_path = dir.path("out.jsonl");
        let out = hyperpbd([
            "sweep".as_ref(),
            scene.as_os_str(),
            "--set".as_ref(),
            set.as_ref(),
            "--frames".as_ref(),
            "1".as_ref(),
            "--backend".as_ref(),
            "cpu".as_ref(),
            "--out".as_ref(),
            out_path.as_os_str(),
        ]);
        assert_eq!(out.status.code(), Some(2), "{set}: {}", text(&out.stderr));
        assert!(
            text(&out.stderr).contains(expected),
            "{set}: {}",
            text(&out.stderr)
        );
        assert!(!out_path.exists(), "{set}: left an output file");
    }
}

#[test]
fn a_missing_optional_vector_is_created_as_zeros() {
    // Particle 2 of the example has no velocity: setting one axis of it
    // makes the vector with the other axes zero.
    let axes = vec!["particles[2].velocity[1]=0.5:0.5:1".parse().expect("axis")];
    let sweep = Sweep::new(EXAMPLE, axes).expect("sweep");
    let scene = sweep.scene(0).expect("scene");
    assert_eq!(scene.particles[2].velocity, Some(vec![0.0, 0.5, 0.0]));
    let path: FieldPath = "constraints[2].compliance".parse().expect("path");
    assert_eq!(path.segments().len(), 3);
    assert!("[0].x".parse::<FieldPath>().is_err());
    assert!("a..b".parse::<FieldPath>().is_err());
}

#[test]
fn plot_draws_a_png_beside_the_output() {
    let dir = TempDir::new("sweep-plot");
    let out = sweep_cli(
        &dir,
        CHAIN,
        "s.jsonl",
        &["--backend", "cpu", "--plot", "height"],
    );
    assert_success(&out);
    let png = std::fs::read(dir.path("s.height.png")).expect("the chart");
    assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
    for (extra, expected) in [
        (&["--plot", "speediness"][..], "unknown metric `speediness`"),
        (
            &["--plot", "height", "--set", "dt=0.01:0.02:2"][..],
            "one or two --set axes",
        ),
    ] {
        let mut args = vec!["--backend", "cpu"];
        args.extend_from_slice(extra);
        let out = sweep_cli(&dir, CHAIN, "bad.jsonl", &args);
        assert_eq!(out.status.code(), Some(2), "{}", text(&out.stderr));
        assert!(
            text(&out.stderr).contains(expected),
            "{}",
            text(&out.stderr)
        );
        assert!(!dir.path("bad.jsonl").exists());
    }
}

#[test]
fn metrics_are_what_the_docs_say() {
    use hyperpbd::State;
    use hyperpbd::sweep::Metric;
    // Two dynamic particles (mass 1 and 2) and a fixed one; gravity −y.
    let scene = Scene::from_json_str(
        r#"{"dim": 2, "dt": 0.01, "gravity": [0, -9.81],
            "particles": [{"position": [0, 1], "mass": 1, "velocity": [3, 4]},
                          {"position": [1, 3], "mass": 2, "velocity": [0, -1]},
                          {"position": [0, 9], "fixed": true}]}"#,
    )
    .expect("scene");
    let state = State::from_scene(&scene);
    assert_eq!(Metric::Height.value(&scene, &state, None), 2.0);
    assert_eq!(
        Metric::KineticEnergy.value(&scene, &state, None),
        0.5 * 25.0 + 0.5 * 2.0
    );
    assert_eq!(Metric::MaxSpeed.value(&scene, &state, None), 5.0);
    assert_eq!(Metric::MaxViolation.value(&scene, &state, None), 0.0);
}
