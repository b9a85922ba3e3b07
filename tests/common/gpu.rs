//! The one way GPU tests find an adapter.
//!
//! With an adapter: `Some`. Without one, the test prints a clear
//! `SKIPPED: no adapter (<test>): <why>` line and returns early — unless
//! `HYPERPBD_REQUIRE_GPU=1` (set by CI, which installs lavapipe), where a
//! missing adapter fails the test.

use hyperpbd_gpu::{AdapterSummary, Precision, request_adapter};

/// Environment variable that turns a missing adapter from a skip into a
/// failure.
pub const REQUIRE_GPU_ENV: &str = "HYPERPBD_REQUIRE_GPU";

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
            eprintln!("SKIPPED: no adapter ({test}): {e}");
            None
        }
    }
}
