//! Host waits: every `device.poll` of the GPU crate goes through one
//! counted choke point (`GpuContext::poll`), each step's report carries
//! its count (`StepReport::host_waits`), and the counts of the shipped
//! scenes stay within their ceilings (docs/performance.md, "Host waits").
//!
//! ```text
//! choke point     gpu/src/**.rs name `wgpu::PollType` (what `device.poll`
//!                 takes) exactly once (context.rs), and
//!                 `map_async` only where that poll completes it
//! report = count  the report's count is the backend's counter over the step
//! XPBD            one wait per step (the status/report read; with contact
//!                 the outcome read with it)
//! IP barrier4d    ≤ 5 per frame (Newton's stop test on the device)
//! run             `hyperpbd run` prints the library's mean over the same frames
//! coupled chain   ≤ 30 per frame, ≤ 20 on average over its first 10 frames
//!                 (today 28 … 11; 46 per frame before): NOT yet the issue's
//!                 5 (the stop test, the filter, PCG's chunks and Armijo's
//!                 acceptance still read back per Newton iteration;
//!                 docs/performance.md)
//! ```

use crate::common;

use std::path::{Path, PathBuf};

use common::gpu::adapter_or_skip;
use hyperpbd::gpu::{GpuBackend, GpuBarrierBackend, GpuCoupledBackend};
use hyperpbd::{Backend, Plan, Precision, Scene, State};

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).expect("readable source dir") {
        let path = entry.expect("entry").path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// (file name, occurrences) of `needle` over gpu/src, sorted.
fn occurrences(needle: &str) -> Vec<(String, usize)> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("gpu/src");
    let mut files = Vec::new();
    rust_files(&root, &mut files);
    let mut found: Vec<(String, usize)> = files
        .iter()
        .filter_map(|path| {
            let text = std::fs::read_to_string(path).expect("readable source");
            let count = text.matches(needle).count();
            let name = path.strip_prefix(&root).expect("under root");
            (count > 0).then(|| (name.display().to_string(), count))
        })
        .collect();
    found.sort();
    found
}

#[test]
fn the_gpu_crate_polls_the_device_in_one_counted_place() {
    assert_eq!(
        occurrences("PollType"),
        vec![("context.rs".to_string(), 1)],
        "every wait must go through GpuContext::poll, which counts it"
    );
    // A mapping completes only in a poll: readback.rs (the counted read)
    // and the state snapshot (resident.rs, completed by the step's read or
    // by GpuContext::poll).
    assert_eq!(
        occurrences("map_async("),
        vec![
            ("readback.rs".to_string(), 1),
            ("resident.rs".to_string(), 1)
        ]
    );
}

fn scene(name: &str) -> Scene {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenes")
        .join(format!("{name}.json"));
    Scene::from_json_file(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// Steps `frames` frames; each report's count must equal the backend's
/// counter over the step (`counter`); returns the counts.
fn counts<B: Backend>(backend: &mut B, counter: impl Fn(&B) -> u64, frames: usize) -> Vec<u64> {
    (0..frames)
        .map(|frame| {
            let before = counter(backend);
            let report = backend.step().expect("steps");
            let waited = counter(backend) - before;
            assert_eq!(report.host_waits, waited, "frame {frame}");
            waited
        })
        .collect()
}

/// `name` from scenes/, its plan and its initial state.
fn loaded(name: &str) -> (Plan, State) {
    let s = scene(name);
    (Plan::compile(&s).expect("compiles"), State::from_scene(&s))
}

#[test]
fn an_xpbd_step_waits_once() {
    let Some((adapter, _)) = adapter_or_skip("an_xpbd_step_waits_once", Precision::F64) else {
        return;
    };
    let (plan, state) = loaded("chain2d");
    let mut gpu = GpuBackend::with_adapter(&adapter, plan, &state, Precision::F64).expect("loads");
    assert_eq!(counts(&mut gpu, GpuBackend::host_waits, 5), vec![1; 5]);
}

#[test]
fn a_contact_step_waits_once() {
    let Some((adapter, _)) = adapter_or_skip("a_contact_step_waits_once", Precision::F32) else {
        return;
    };
    let scene = hyperpbd::scenes::pit3d(8, 6);
    let plan = Plan::compile(&scene).expect("compiles");
    let state = State::from_scene(&scene);
    let mut gpu = GpuBackend::with_adapter(&adapter, plan, &state, Precision::F32).expect("loads");
    gpu.step()
        .expect("first step (its lists may grow: a rerun, more waits)");
    assert_eq!(counts(&mut gpu, GpuBackend::host_waits, 4), vec![1; 4]);
}

#[test]
fn an_incremental_potential_frame_waits_at_most_5_times() {
    for precision in [Precision::F64, Precision::F32] {
        let Some((adapter, _)) = adapter_or_skip("ip_frame_waits", precision) else {
            return;
        };
        let (plan, state) = loaded("barrier4d");
        let mut gpu =
            GpuBarrierBackend::with_adapter(&adapter, plan, &state, precision).expect("loads");
        let waits = counts(&mut gpu, GpuBarrierBackend::host_waits, 20);
        eprintln!("barrier4d {precision}: host waits per frame {waits:?} / bound 5");
        assert!(waits.iter().all(|&w| (1..=5).contains(&w)), "{waits:?}");
    }
}

#[test]
fn a_coupled_frame_waits_within_its_ceiling() {
    let Some((adapter, _)) = adapter_or_skip("coupled_frame_waits", Precision::F64) else {
        return;
    };
    let (plan, state) = loaded("chain2d_implicit");
    let mut gpu =
        GpuCoupledBackend::with_adapter(&adapter, plan, &state, Precision::F64).expect("loads");
    let waits = counts(&mut gpu, GpuCoupledBackend::host_waits, 10);
    // Ceilings: today's counts (docs/performance.md); the issue's target is
    // 5, which needs the line search and the filter on the device.
    let mean = waits.iter().sum::<u64>() as f64 / waits.len() as f64;
    eprintln!(
        "chain2d_implicit f64: host waits per frame {waits:?} (mean {mean}) / ceilings 30, mean 20"
    );
    assert!(waits.iter().all(|&w| (1..=30).contains(&w)), "{waits:?}");
    assert!(mean <= 20.0, "{waits:?}");
}

/// `hyperpbd run` prints the mean of its steps' counts: on the same
/// adapter it is the library's mean over the same frames.
#[test]
fn run_prints_the_mean_host_waits_per_frame() {
    let Some((adapter, _)) = adapter_or_skip("run_prints_host_waits", Precision::F64) else {
        return;
    };
    let frames = 3;
    let (plan, state) = loaded("chain2d_implicit");
    let mut gpu =
        GpuCoupledBackend::with_adapter(&adapter, plan, &state, Precision::F64).expect("loads");
    let waits = counts(&mut gpu, GpuCoupledBackend::host_waits, frames);
    let mean = waits.iter().sum::<u64>() as f64 / frames as f64;
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/chain2d_implicit.json");
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_hyperpbd"))
        .arg("run")
        .arg(&scene)
        .args(["--backend", "gpu-f64", "--frames", &frames.to_string()])
        .output()
        .expect("runs");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{stdout}");
    let printed: f64 = stdout
        .lines()
        .find_map(|l| l.strip_prefix("host waits per frame: "))
        .unwrap_or_else(|| panic!("no host waits line in:\n{stdout}"))
        .parse()
        .expect("a number");
    assert_eq!(printed, mean, "{stdout}");
}
