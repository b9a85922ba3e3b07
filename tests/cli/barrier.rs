//! `hyperpbd run`, `plan` and `compare` on a barrier (incremental-potential)
//! scene, driven as a user would.

use crate::common;

use std::process::Command;

fn hyperpbd(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_hyperpbd"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("the binary runs")
}

#[test]
fn plan_shows_the_minimise_stage() {
    let out = hyperpbd(&["plan", "scenes/barrier4d.json"]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{text}");
    assert!(text.contains("stages per substep: minimise"), "{text}");
    assert!(text.contains("max_acceleration_residual"), "{text}");
}

#[test]
fn run_on_the_cpu_succeeds() {
    let out = hyperpbd(&[
        "run",
        "scenes/barrier4d.json",
        "--backend",
        "cpu",
        "--frames",
        "30",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// `compare` exits 0 only when every frame is within the barrier-path bound.
#[test]
fn compare_runs_within_its_bound() {
    for precision in ["f32", "f64"] {
        let p = if precision == "f32" {
            hyperpbd::gpu::Precision::F32
        } else {
            hyperpbd::gpu::Precision::F64
        };
        if common::gpu::adapter_or_skip("compare_runs_within_its_bound", p).is_none() {
            continue;
        }
        let out = hyperpbd(&[
            "compare",
            "scenes/barrier4d.json",
            "--frames",
            "30",
            "--every",
            "10",
            "--precision",
            precision,
        ]);
        let text = String::from_utf8_lossy(&out.stdout);
        assert!(
            out.status.success(),
            "{precision}: {text}{}",
            String::from_utf8_lossy(&out.stderr)
        );
        assert!(text.contains("all 30 frames within the bound"), "{text}");
        println!("{text}");
    }
}
