//! Guards and adaptive steps on the CPU golden path (issue 15 item 4).
//!
//! ```text
//! soft block   2D Kuhn block, 3 × 3 cells of 0.1 m, compliant oriented
//!              measures and edges, dropped at 40 m/s onto y = 0, its
//!              bottom 0.2 m above: one step of 1/30 s in ONE substep
//! guards       orientation, min_measure_ratio, max_speed
//! ```
//! Without guards the one substep flattens the block onto the plane (the
//! smallest measure ratio J ends at ≤ 0); with `orientation` that step is
//! a typed rejection and the state stays as it was, byte for byte; with
//! `adaptive` the step is retried with 2, 4, 8 substeps and accepted at 8,
//! bit for bit the step a plain 8-substep scene takes.

use crate::common;

use common::guarded::{bits, orientation, rejection};
use hyperpbd::{
    Backend, BackendError, CpuBackend, GuardKind, GuardSubject, Guards, Plan, Scene, State,
    StepError,
};

/// The 2D block of `common::guarded` falling at `speed` onto y = 0.
fn dropped_block(speed: f64, guards: Option<Guards>, adaptive: Option<u32>) -> Scene {
    common::guarded::dropped_block(2, speed, guards, adaptive)
}

fn cpu(scene: &Scene) -> CpuBackend {
    let plan = Plan::compile(scene).expect("plan");
    CpuBackend::with_threads(plan, &State::from_scene(scene), 1).expect("cpu backend")
}

/// Smallest J over the block's oriented-measure family at `state`.
fn smallest_ratio(scene: &Scene, state: &State) -> f64 {
    let plan = Plan::compile(scene).expect("plan");
    let fam = &plan.families[0];
    (0..fam.len())
        .map(|slot| hyperpbd::guards::element_ratio_at(&plan, 0, slot, &state.positions))
        .fold(f64::INFINITY, f64::min)
}

#[test]
fn the_unguarded_drop_flattens_the_block() {
    let scene = dropped_block(40.0, None, None);
    let mut b = cpu(&scene);
    b.step().expect("an unguarded step is accepted");
    let j = smallest_ratio(&scene, &b.read_state().expect("state"));
    println!("unguarded: smallest J after one substep {j:e}");
    assert!(
        j <= 0.0,
        "the drop must collapse or invert an element: J = {j}"
    );
}

#[test]
fn without_adaptive_the_drop_is_a_typed_orientation_rejection_with_the_state_unchanged() {
    let scene = dropped_block(40.0, Some(orientation()), None);
    let mut b = cpu(&scene);
    let before = bits(&b.read_state().expect("state"));
    let r = rejection(b.step());
    println!("{r}");
    assert_eq!(r.guard, GuardKind::Orientation);
    assert_eq!(r.limit, 0.0);
    assert_eq!(r.substep, 0);
    assert!(r.value <= 0.0, "{r}");
    let GuardSubject::Element {
        family,
        family_label,
        element,
    } = &r.subject
    else {
        panic!("an element rejection: {r}");
    };
    assert_eq!((*family, family_label.as_str()), (0, "constraints[0]"));
    assert!(*element < 18, "3 × 3 cells of 2 simplices: {element}");
    assert_eq!(bits(&b.read_state().expect("state")), before);
    // The same rejection again: nothing of the failed step stayed behind.
    assert_eq!(rejection(b.step()), r);
    assert_eq!(bits(&b.read_state().expect("state")), before);
    let text = BackendError::from(StepError::GuardRejected(r)).to_string();
    assert!(
        text.contains("guard orientation") && text.contains("constraints[0] element"),
        "{text}"
    );
}

#[test]
fn min_measure_ratio_rejects_the_squashed_element() {
    let guards = Guards {
        min_measure_ratio: Some(0.5),
        ..Guards::default()
    };
    let scene = dropped_block(40.0, Some(guards), None);
    let mut b = cpu(&scene);
    let r = rejection(b.step());
    println!("{r}");
    assert_eq!(
        (r.guard, r.limit, r.substep),
        (GuardKind::MinMeasureRatio, 0.5, 0)
    );
    assert!(r.value < 0.5, "{r}");
}

#[test]
fn adaptive_steps_retry_until_no_element_inverts_and_report_every_attempt() {
    let scene = dropped_block(40.0, Some(orientation()), Some(4));
    let mut b = cpu(&scene);
    let report = b.step().expect("accepted after subdivision");
    let substeps: Vec<u32> = report.attempts.iter().map(|a| a.substeps).collect();
    println!("attempts {substeps:?}");
    assert_eq!(substeps, vec![1, 2, 4, 8]);
    for a in &report.attempts[..3] {
        let r = a.rejection.as_ref().expect("a rejected attempt");
        assert_eq!(r.guard, GuardKind::Orientation, "{r}");
        assert!(r.substep < a.substeps);
    }
    assert_eq!(report.attempts[3].rejection, None);
    assert_eq!(report.retries(), 3);
    let accepted = b.read_state().expect("state");

    // The accepted attempt is the step of the same scene with 8 substeps,
    // from the same state, bit for bit.
    let mut eight = dropped_block(40.0, None, None);
    eight.substeps = 8;
    let mut plain = cpu(&eight);
    plain.step().expect("8 substeps");
    assert_eq!(bits(&plain.read_state().expect("state")), bits(&accepted));

    // Every later frame keeps every element oriented (the guard holds at
    // every accepted substep; the state is checked here at frame ends).
    let mut smallest = smallest_ratio(&scene, &accepted);
    for _ in 1..30 {
        b.step().expect("guarded frame");
        smallest = smallest.min(smallest_ratio(&scene, &b.read_state().expect("state")));
    }
    println!("adaptive: smallest J over 30 frames {smallest}");
    assert!(smallest > 0.0, "an element inverted: J = {smallest}");
}

#[test]
fn adaptive_steps_are_the_same_bytes_for_any_thread_count() {
    let scene = dropped_block(40.0, Some(orientation()), Some(4));
    let plan = Plan::compile(&scene).expect("plan");
    let state = State::from_scene(&scene);
    let mut one = CpuBackend::with_threads(plan.clone(), &state, 1).expect("cpu");
    let mut two = CpuBackend::with_threads(plan, &state, 2)
        .expect("cpu")
        .with_max_chunk(2);
    for _ in 0..5 {
        assert_eq!(
            one.step().expect("one"),
            hyperpbd::StepReport {
                threads: 1,
                ..two.step().expect("two")
            }
        );
        assert_eq!(
            bits(&one.read_state().unwrap()),
            bits(&two.read_state().unwrap())
        );
    }
}

/// The block in free fall at 40 m/s (no plane: nothing slows it).
fn falling_block(guards: Option<Guards>, adaptive: Option<u32>) -> Scene {
    let mut scene = dropped_block(40.0, guards, adaptive);
    scene.obstacles.clear();
    scene
}

#[test]
fn max_speed_rejects_the_first_fast_particle_and_subdivision_cannot_help() {
    let guards = Guards {
        max_speed: Some(30.0),
        ..Guards::default()
    };
    let scene = falling_block(Some(guards.clone()), None);
    let mut b = cpu(&scene);
    let before = bits(&b.read_state().expect("state"));
    let r = rejection(b.step());
    println!("{r}");
    assert_eq!(
        (r.guard, r.limit, r.substep),
        (GuardKind::MaxSpeed, 30.0, 0)
    );
    assert_eq!(r.subject, GuardSubject::Particle(0));
    // The value is |v_0| of the rejected substep: the unguarded step's.
    let mut free = cpu(&falling_block(None, None));
    free.step().expect("unguarded");
    let v = free.read_state().expect("state").velocities;
    let speed = hyperpbd::guards::squared_speed(&v[..2]).sqrt();
    assert_eq!(r.value.to_bits(), speed.to_bits(), "{} vs {speed}", r.value);
    assert_eq!(bits(&b.read_state().expect("state")), before);

    // Adaptive: every attempt is rejected; the last one's rejection is
    // returned and the state is unchanged.
    let scene = falling_block(Some(guards), Some(2));
    let mut b = cpu(&scene);
    let last = rejection(b.step());
    assert_eq!(last.guard, GuardKind::MaxSpeed);
    assert!(last.substep < 4, "{last}");
    assert_eq!(bits(&b.read_state().expect("state")), before);
}

#[test]
fn guards_are_kernels_at_the_end_of_each_substep() {
    let guards = Guards {
        orientation: true,
        max_speed: Some(100.0),
        ..Guards::default()
    };
    let plan = Plan::compile(&dropped_block(1.0, Some(guards), None)).expect("plan");
    let tail = &plan.substep_kernels[plan.substep_kernels.len() - 2..];
    assert_eq!(
        tail,
        [
            hyperpbd::Kernel::GuardMeasure { family: 0 },
            hyperpbd::Kernel::GuardSpeed
        ]
    );
    assert_eq!(plan.stages.last(), Some(&hyperpbd::StageName::Guard));
    let plain = Plan::compile(&dropped_block(1.0, None, None)).expect("plan");
    assert!(!plain.stages.contains(&hyperpbd::StageName::Guard));
    assert_eq!(plain.substep_kernels.len() + 2, plan.substep_kernels.len());
}

fn scene_error(json_tail: &str) -> String {
    let text = format!(
        r#"{{"dim": 2, "dt": 0.01, "particles": [{{"position": [0, 0], "mass": 1}}]{json_tail}}}"#
    );
    match Scene::from_json_str(&text) {
        Ok(_) => panic!("accepted: {json_tail}"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn bad_guard_and_adaptive_keys_are_named() {
    let cases = [
        (
            r#", "guards": {"min_measure_ratio": 0}"#,
            "guards.min_measure_ratio: must be in (0, 1], got 0",
        ),
        (
            r#", "guards": {"min_measure_ratio": 1.5}"#,
            "guards.min_measure_ratio: must be in (0, 1], got 1.5",
        ),
        (
            r#", "guards": {"max_speed": -1}"#,
            "guards.max_speed: must be in (0, inf), got -1",
        ),
        (
            r#", "guards": {"speed": 1}"#,
            "guards.speed: unknown field `speed`, expected one of `orientation`, `min_measure_ratio`, `max_speed` at line 1 column 89",
        ),
        (
            r#", "guards": {"orientation": true}, "adaptive": {"max_subdivisions": 0}"#,
            "adaptive.max_subdivisions: must be in 1 ..= 16, got 0",
        ),
        (
            r#", "guards": {"orientation": true}, "adaptive": {"max_subdivisions": 17}"#,
            "adaptive.max_subdivisions: must be in 1 ..= 16, got 17",
        ),
        (
            r#", "substeps": 4000000000, "guards": {"orientation": true}, "adaptive": {"max_subdivisions": 1}"#,
            "adaptive.max_subdivisions: substeps 4000000000 times 2^1 does not fit in 32 bits",
        ),
        (
            r#", "adaptive": {"max_subdivisions": 2}"#,
            "adaptive: needs \"guards\" or a moving simplex_mesh: only a guard rejection is retried",
        ),
        (
            r#", "guards": {"max_speed": 1}, "solver": {"type": "incremental_potential", "barrier_stiffness": 1, "activation_distance": 0.1, "convergence": {"kind": "packed_gradient", "tolerance": 1e-9}, "max_iterations": 20}"#,
            "guards: not supported by the incremental_potential solver: guards check XPBD substeps (the barrier path keeps feasibility with its step filter)",
        ),
    ];
    let docs = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/errors.md"),
    )
    .unwrap_or_default();
    for (tail, expected) in cases {
        let message = scene_error(tail);
        println!("{message}");
        assert_eq!(message, expected, "{tail}");
        assert!(
            docs.contains(&message),
            "docs/errors.md does not quote: {message}"
        );
    }
}

#[test]
fn docs_errors_md_quotes_the_step_rejections() {
    let docs = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/errors.md"),
    )
    .unwrap_or_default();
    let speed = Guards {
        max_speed: Some(30.0),
        ..Guards::default()
    };
    for scene in [
        dropped_block(40.0, Some(orientation()), None),
        falling_block(Some(speed), None),
    ] {
        let message = cpu(&scene).step().expect_err("rejected").to_string();
        assert!(
            docs.contains(&message),
            "docs/errors.md does not quote: {message}"
        );
    }
}

#[test]
fn guards_and_adaptive_round_trip_through_json() {
    let guards = Guards {
        orientation: true,
        min_measure_ratio: Some(0.25),
        max_speed: Some(80.0),
    };
    let scene = dropped_block(40.0, Some(guards), Some(3));
    let back = Scene::from_json_str(&scene.to_json_string()).expect("round trip");
    assert_eq!(back, scene);
}

#[test]
fn run_prints_a_line_per_retried_frame() {
    let scene = dropped_block(40.0, Some(orientation()), Some(4));
    let dir = std::env::temp_dir().join(format!("hyperpbd-guards-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let path = dir.join("drop.json");
    std::fs::write(&path, scene.to_json_string()).expect("scene file");
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_hyperpbd"))
        .args([
            "run",
            path.to_str().expect("utf-8 path"),
            "--frames",
            "3",
            "--backend",
            "cpu",
        ])
        .output()
        .expect("hyperpbd run");
    let stdout = String::from_utf8_lossy(&out.stdout);
    println!("{stdout}{}", String::from_utf8_lossy(&out.stderr));
    assert!(out.status.success());
    let retried: Vec<&str> = stdout.lines().filter(|l| l.contains("retried")).collect();
    assert_eq!(retried.len(), 1, "{stdout}");
    assert!(
        retried[0].starts_with("frame 1: retried, accepted with 8 substeps after 3 rejected attempts (1 substeps: guard orientation"),
        "{}",
        retried[0]
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn guards_that_never_reject_change_no_bit() {
    let text = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/tesseract.json"),
    )
    .expect("scenes/tesseract.json");
    let plain = Scene::from_json_str(&text).expect("tesseract");
    let mut guarded = plain.clone();
    guarded.guards = Some(Guards {
        orientation: true,
        min_measure_ratio: Some(0.05),
        max_speed: Some(100.0),
    });
    let (mut a, mut b) = (cpu(&plain), cpu(&guarded));
    for _ in 0..20 {
        let report = b.step().expect("never rejected");
        assert_eq!(report.retries(), 0);
        a.step().expect("plain");
    }
    assert_eq!(
        bits(&a.read_state().unwrap()),
        bits(&b.read_state().unwrap())
    );
}
