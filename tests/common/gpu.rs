//! The one way GPU tests find an adapter (and load a backend on it).
//!
//! With an adapter: `Some`. Without one, the test prints a clear
//! `SKIPPED: no adapter (<test>): <why>` line, appends `<test>` to
//! [`SKIP_LOG`] and returns early — unless `HYPERPBD_REQUIRE_GPU=1` (set by
//! CI, which installs lavapipe), where a missing adapter fails the test.
//! `scripts/test.sh` prints one line counting the tests in [`SKIP_LOG`] and
//! fails on a nonzero count unless `HYPERPBD_NO_GPU=1` says no GPU is
//! expected, so a run without an adapter never reads as a full pass.

use hyperpbd::{Backend, BackendError, BackendKind, Plan, State};
use hyperpbd_gpu::{AdapterSummary, Precision, request_adapter};

/// Environment variable that turns a missing adapter from a skip into a
/// failure.
pub const REQUIRE_GPU_ENV: &str = "HYPERPBD_REQUIRE_GPU";

/// Where skipped GPU tests are recorded, one `<binary>::<test>\t<why>` line each
/// (the workspace's shared target folder; `scripts/test.sh` empties it
/// before a run and counts the distinct tests after it).
pub const SKIP_LOG: &str = concat!(env!("CARGO_TARGET_TMPDIR"), "/gpu-skipped.txt");

/// Prints the `SKIPPED: no adapter` line of `test` and records it in
/// [`SKIP_LOG`]. A log that cannot be written fails the test: a skip that
/// is not counted would read as a pass.
pub fn record_skip(test: &str, why: &dyn std::fmt::Display) {
    use std::io::Write;
    eprintln!("SKIPPED: no adapter ({test}): {why}");
    let why = why.to_string().replace(['\n', '\t'], " ");
    let line = format!("{}::{test}\t{why}\n", env!("CARGO_CRATE_NAME"));
    std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(SKIP_LOG)
        .and_then(|mut f| f.write_all(line.as_bytes()))
        .unwrap_or_else(|e| panic!("cannot record the skip of {test} in {SKIP_LOG}: {e}"));
}

/// Whether `HYPERPBD_REQUIRE_GPU=1` is set.
pub fn gpu_required() -> bool {
    std::env::var(REQUIRE_GPU_ENV).is_ok_and(|v| v == "1")
}

/// An adapter for `precision`, or `None` after printing why the test
/// `test` is skipped. Panics instead of skipping when
/// `HYPERPBD_REQUIRE_GPU=1`.
///
/// Use as:
///
/// ```ignore
/// let Some((adapter, summary)) = adapter_or_skip("my_test", Precision::F32) else {
///     return;
/// };
/// ```
pub fn adapter_or_skip(
    test: &str,
    precision: Precision,
) -> Option<(wgpu::Adapter, AdapterSummary)> {
    match request_adapter(precision) {
        Ok(found) => {
            eprintln!("{test}: {precision} adapter: {}", found.1);
            Some(found)
        }
        Err(e) if gpu_required() => panic!(
            "{REQUIRE_GPU_ENV}=1 but no adapter for {precision} ({test}): {e}\n\
             Install lavapipe (apt-get install mesa-vulkan-drivers libvulkan1) or a GPU driver, \
             or unset {REQUIRE_GPU_ENV} to skip GPU tests."
        ),
        Err(e) => {
            record_skip(test, &e);
            None
        }
    }
}

/// `plan` with `state` on `kind` through the backend factory: the CPU, or
/// the GPU backend of the plan's solver on the adapter of
/// [`adapter_or_skip`]. `Ok(None)` when the GPU test `test` is skipped,
/// `Err` for a typed refusal of the backend.
pub fn load_or_skip(
    test: &str,
    kind: BackendKind,
    plan: Plan,
    state: &State,
) -> Result<Option<Box<dyn Backend>>, BackendError> {
    match kind {
        BackendKind::Gpu(precision) => {
            let Some((adapter, _)) = adapter_or_skip(test, precision) else {
                return Ok(None);
            };
            hyperpbd::load_on_adapter(&adapter, plan, state, precision).map(Some)
        }
        cpu_or_auto => hyperpbd::load(plan, state, cpu_or_auto).map(Some),
    }
}
