//! `scripts/device-check.sh --dry`: the prepared device check, run on
//! lavapipe at tiny sizes so the kit cannot rot (docs/device-check.md).
//!
//! ```text
//! run      the script with OUT = a fresh folder and this build's binaries
//!          (HYPERPBD_BIN, HYPERPBD_BENCH); exit 0
//! report   report.json and report.md exist; the adapter offers passthrough
//!          and the shader path is spirv; every compare row (both paths,
//!          f64 and f32) has frames and none differ (lavapipe neither
//!          contracts nor regroups); dispatch counts are read; the timing
//!          rows of every kind are there; the CuPy row is a result or a skip
//! ```
//! Without an adapter the test is skipped (printed), unless
//! `HYPERPBD_REQUIRE_GPU=1`.

mod common;

use common::gpu::adapter_or_skip;
use hyperpbd::Precision;
use std::path::PathBuf;
use std::process::Command;

#[test]
fn dry_device_check_runs_and_reports_every_section() {
    if adapter_or_skip("device check", Precision::F64).is_none() {
        return;
    }
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let out = std::env::temp_dir().join(format!("hyperpbd-device-check-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&out);
    let status = Command::new("bash")
        .arg(root.join("scripts/device-check.sh"))
        .arg("--dry")
        .env("OUT", &out)
        .env("HYPERPBD_BIN", env!("CARGO_BIN_EXE_hyperpbd"))
        .env("HYPERPBD_BENCH", env!("CARGO_BIN_EXE_device_bench"))
        .env_remove("HYPERPBD_SHADER_PATH")
        .status()
        .expect("bash runs");
    assert!(status.success(), "device-check.sh --dry: {status}");
    let text = std::fs::read_to_string(out.join("report.json")).expect("report.json");
    let report: serde_json::Value = serde_json::from_str(&text).expect("report.json parses");
    assert!(out.join("report.md").is_file());
    assert_eq!(report["dry"], true);
    assert_eq!(report["passthrough"], true, "{text}");
    assert_eq!(report["shader_path"], "spirv", "{text}");

    let rows = report["compare"].as_array().expect("compare rows");
    for path in ["spirv", "wgsl"] {
        for precision in ["f32", "f64"] {
            let row = rows
                .iter()
                .find(|r| r["path"] == path && r["precision"] == precision)
                .unwrap_or_else(|| panic!("no compare row {path} {precision}: {text}"));
            assert!(row["frames"].as_u64().unwrap_or(0) > 0, "{row}");
            assert_eq!(
                row["differing"], 0,
                "lavapipe differs from the reference: {row}"
            );
            assert_eq!(row["rc"], "0", "{row}");
        }
    }
    assert!(
        report["plan"]
            .as_object()
            .is_some_and(|p| !p.is_empty() && p.values().all(|n| n.as_u64().is_some_and(|n| n > 0))),
        "{text}"
    );
    let bench = report["bench"].as_array().expect("bench rows");
    for kind in [
        "adapter", "step", "step_fit", "frame", "dispatch", "batch", "implicit", "granular",
    ] {
        assert!(
            bench.iter().any(|r| r["kind"] == kind),
            "no {kind} row in the timings: {text}"
        );
    }
    assert!(
        !bench
            .iter()
            .any(|r| r["kind"] == "skipped"
                && r["what"].as_str().is_some_and(|w| w.contains("step"))),
        "a step row was skipped: {text}"
    );
    let cupy = &report["cupy"];
    assert!(
        cupy.get("skipped").is_some() || cupy.get("chain_seconds").is_some(),
        "{cupy}"
    );
    for (name, step) in report["steps"].as_object().expect("steps") {
        assert_eq!(step["rc"], "0", "step {name} failed: {text}");
    }
    let _ = std::fs::remove_dir_all(&out);
}
