//! The coupled implicit step's typed refusals (issue 16): α = 0 at load,
//! what the GPU does not run yet, `hyperpbd run --backend gpu` on a coupled
//! scene, a refused step that leaves the state byte for byte, and the new
//! solver keys in JSON.

use crate::common;

use std::process::Command;

use hyperpbd::{
    BackendError, BackendKind, GpuError, MinimisationStatus, Plan, Precision, Refusal, Scene,
    SceneError, State, StepError,
};

/// Two balls joined by a distance spring above a plane, with ball–ball
/// barriers: every kind of coupling term. `compliance` is the spring's α.
fn coupled_json(compliance: f64, second_x: f64) -> String {
    format!(
        r#"{{
  "dim": 2, "dt": 0.016666666666666666, "substeps": 1, "iterations": 1,
  "gravity": [0, -9.81],
  "particles": [
    {{"position": [0.0, 0.5], "mass": 1.0, "radius": 0.1}},
    {{"position": [{second_x}, 0.5], "mass": 1.0, "radius": 0.1}}
  ],
  "constraints": [{{"type": "distance", "compliance": {compliance}, "elements": [[0, 1]]}}],
  "obstacles": [{{"type": "hyperplane", "normal": [0, 1], "offset": 0, "friction": 0.3}}],
  "collisions": {{"friction": 0.2}},
  "solver": {{"type": "incremental_potential", "barrier_stiffness": 1000.0,
             "activation_distance": 0.01,
             "convergence": {{"kind": "max_acceleration_residual", "tolerance": 0.001}},
             "max_iterations": 50, "cg_iterations": 100, "warm_start": "inertial",
             "friction_slip_velocity": 0.001}}
}}"#
    )
}

#[test]
fn zero_compliance_is_refused_naming_the_field_with_a_value() {
    let err = Scene::from_json_str(&coupled_json(0.0, 0.3)).expect_err("α = 0 is refused");
    let text = err.to_string();
    println!("{text}");
    assert!(
        matches!(&err, SceneError::UnsupportedBySolver { path, .. } if path == "constraints[0].compliance"),
        "{err:?}"
    );
    assert!(text.contains("e.g. 1e-8"), "{text}");
}

#[test]
fn the_solver_keys_parse_and_round_trip() {
    let scene = Scene::from_json_str(&coupled_json(1e-8, 0.3)).expect("parses");
    let text = scene.to_json_string();
    assert!(text.contains(r#""warm_start":"inertial""#), "{text}");
    assert_eq!(Scene::from_json_str(&text).expect("reads back"), scene);
    let plan = Plan::compile(&scene).expect("compiles");
    let coupled = plan
        .incremental_potential()
        .and_then(|ip| ip.coupled.as_deref());
    let coupled = coupled.expect("a coupled plan");
    assert_eq!(coupled.cg_iterations, 100);
    assert_eq!(coupled.plane_friction, vec![0.3]);
    assert_eq!(coupled.pair_friction, 0.2);
}

#[test]
fn a_refused_step_leaves_the_state_byte_for_byte() {
    // The balls overlap (centres 0.15 m apart, radii 0.1 m): the ball–ball
    // barrier is undefined at the start, so the step is refused.
    let scene = Scene::from_json_str(&coupled_json(1e-8, 0.15)).expect("parses");
    let plan = Plan::compile(&scene).expect("compiles");
    let state = State::from_scene(&scene);
    let mut cpu = hyperpbd::load(plan, &state, BackendKind::Cpu).expect("loads");
    let before = cpu.read_state().expect("state");
    let err = cpu.step().expect_err("refused");
    println!("{err}");
    match &err {
        BackendError::Step(StepError::MinimisationRefused { reason, report, .. }) => {
            assert!(
                matches!(
                    reason,
                    Refusal::OverlappingStart {
                        first: 0,
                        second: 1,
                        ..
                    }
                ),
                "{reason:?}"
            );
            assert!(matches!(report.status, MinimisationStatus::Refused(_)));
        }
        other => panic!("{other:?}"),
    }
    let after = cpu.read_state().expect("state");
    let bits = |s: &State| -> Vec<u64> {
        s.positions
            .iter()
            .chain(&s.velocities)
            .map(|v| v.to_bits())
            .collect()
    };
    assert_eq!(bits(&before), bits(&after));
}

/// What the GPU's coupled step does not run yet (material families in
/// f32) is a typed refusal saying why and which backend runs it; the scene
/// itself (springs, a frictional plane, ball pairs with friction) loads on
/// gpu-f64 and gpu-f32 through the factory (`GpuCoupledBackend`), and with
/// a material family on gpu-f64.
#[test]
fn the_gpu_refuses_what_its_coupled_step_does_not_run_yet() {
    let scene = Scene::from_json_str(&coupled_json(1e-8, 0.3)).expect("parses");
    let mut material = scene.clone();
    material
        .particles
        .push(hyperpbd::Particle::new(vec![0.1, 1.0], 1.0));
    material.constraints.push(
        hyperpbd::ConstraintFamily::material(
            hyperpbd::ConstraintKind::NeoHookean,
            1e4,
            0.3,
            vec![vec![0, 1, 2]],
        )
        .with_density(1000.0),
    );
    for (precision, scene, why) in [
        (Precision::F32, &material, "material family"),
        (Precision::F64, &material, ""),
        (Precision::F64, &scene, ""),
        (Precision::F32, &scene, ""),
    ] {
        let plan = Plan::compile(scene).expect("compiles");
        let loaded = common::gpu::load_or_skip(
            "the_gpu_refuses_what_its_coupled_step_does_not_run_yet",
            BackendKind::Gpu(precision),
            plan,
            &State::from_scene(scene),
        );
        match loaded {
            Ok(None) => return,
            Ok(Some(_)) => assert!(
                why.is_empty(),
                "{precision}: loaded, expected a refusal ({why})"
            ),
            Err(err) => {
                println!("{precision}: {err}");
                assert!(!why.is_empty(), "{precision}: {err}");
                assert!(
                    matches!(&err, BackendError::Gpu(GpuError::Unsupported { what })
                        if what.contains("coupled implicit step") && what.contains(why)
                            && what.contains("--backend cpu")),
                    "{err:?}"
                );
            }
        }
    }
}

/// `hyperpbd run --backend gpu` (f32) runs the coupled step (it refused
/// it, naming the backends that ran it, until the f32 step was built), and
/// so does `--backend cpu`.
#[test]
fn run_with_the_f32_gpu_backend_runs_the_coupled_step() {
    if !common::gpu::gpu_required()
        && let Err(e) = hyperpbd_gpu::request_adapter(Precision::F32)
    {
        common::gpu::record_skip("run_with_the_f32_gpu_backend_runs_the_coupled_step", &e);
        return;
    }
    let dir = std::env::temp_dir().join(format!("hyperpbd-implicit-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let path = dir.join("coupled.json");
    std::fs::write(&path, coupled_json(1e-8, 0.3)).expect("write");
    let out = Command::new(env!("CARGO_BIN_EXE_hyperpbd"))
        .args([
            "run",
            path.to_str().expect("utf-8"),
            "--backend",
            "gpu",
            "--frames",
            "2",
        ])
        .output()
        .expect("the binary runs");
    let stderr = String::from_utf8_lossy(&out.stderr);
    println!("{stderr}");
    assert!(out.status.success(), "{stderr}");
    let cpu = Command::new(env!("CARGO_BIN_EXE_hyperpbd"))
        .args([
            "run",
            path.to_str().expect("utf-8"),
            "--backend",
            "cpu",
            "--frames",
            "2",
        ])
        .output()
        .expect("the binary runs");
    assert!(
        cpu.status.success(),
        "{}",
        String::from_utf8_lossy(&cpu.stderr)
    );
    let _ = std::fs::remove_dir_all(&dir);
}
