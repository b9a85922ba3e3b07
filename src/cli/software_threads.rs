//! lavapipe's worker threads (`LP_NUM_THREADS`) for the command line:
//! chosen from the scene's size (`hyperpbd::gpu::software_threads`) and
//! set once, before the process's first wgpu instance.
//!
//! ```text
//! the user's LP_NUM_THREADS, when set, is kept
//! largest dispatch < CROSSOVER  → LP_NUM_THREADS=0 (one thread)
//! otherwise                     → lavapipe's default
//! ```

use hyperpbd::gpu::software_threads::{CROSSOVER, Threads, VARIABLE};
use hyperpbd::{BackendKind, Plan, Precision};

/// Sets lavapipe's threads for `plan` before the process's first wgpu
/// instance (the first call of the process decides).
pub fn choose(plan: &Plan) {
    choose_threads(&Threads::for_plan(plan));
}

/// Sets lavapipe's threads for a batch of `worlds` worlds of `plan` (its
/// dispatches `worlds` times as large), as [`choose`] does, and says so
/// on stderr on a software adapter.
pub fn choose_for_batch(plan: &Plan, worlds: usize, precision: Precision) {
    let mut threads = Threads::for_plan(plan);
    threads.work *= worlds;
    choose_threads(&threads);
    if let Ok((_, summary)) = hyperpbd::gpu::request_adapter(precision)
        && summary.device_type == "Cpu"
    {
        threads.environment = std::env::var(VARIABLE).ok();
        eprintln!("notice: {} threads: {threads}", summary.name);
    }
}

fn choose_threads(threads: &Threads) {
    static DECIDED: std::sync::Once = std::sync::Once::new();
    DECIDED.call_once(|| {
        if let Some(value) = threads.wanted() {
            // SAFETY: `set_var` is unsound only while code outside Rust's
            // environment lock (a C library, a driver thread) reads the
            // environment. Every command reaches this before creating any
            // wgpu instance, so no Vulkan loader or driver thread exists
            // yet; the only other threads a command may have started are
            // the CPU backend's rayon workers, which run hyperpbd's kernels
            // and never read the environment; `Once` makes this the first
            // and only write.
            unsafe { std::env::set_var(VARIABLE, value) };
        }
    });
}

/// For an explicit GPU backend on a software adapter, says on stderr what
/// threads it runs with.
pub fn notice(kind: BackendKind, plan: &Plan) {
    if let BackendKind::Gpu(precision) = kind
        && let Ok((_, summary)) = hyperpbd::gpu::request_adapter(precision)
        && summary.device_type == "Cpu"
    {
        eprintln!(
            "notice: {} threads: {}",
            summary.name,
            Threads::for_plan(plan)
        );
    }
}

/// The `info` line on lavapipe's threads.
pub fn info_line() -> String {
    match std::env::var(VARIABLE) {
        Ok(value) => format!("lavapipe threads: {VARIABLE}={value} (from the environment)"),
        Err(_) => format!(
            "lavapipe threads: chosen per scene by the simulating commands: one thread \
             ({VARIABLE}=0) when the largest dispatch has fewer than {CROSSOVER} items, \
             lavapipe's default above; set {VARIABLE} to override"
        ),
    }
}

/// `hyperpbd plan`'s line: the GPU schedule the first adapter would run
/// and its dispatches per step.
pub fn dispatches_line(plan: &Plan) -> String {
    let (software, on) = match hyperpbd::gpu::request_adapter(Precision::F32) {
        Ok((_, summary)) => (summary.device_type == "Cpu", summary.name),
        Err(_) => (false, "a hardware GPU (no adapter here)".to_string()),
    };
    match hyperpbd::gpu::dispatches_per_step(plan, software) {
        Some((mode, chosen, exact)) => format!(
            "gpu step on {on}: {} schedule, {chosen} compute dispatches per step \
             (one per kernel call: {exact})",
            mode.as_str()
        ),
        None => "gpu step: incremental potential, dispatched per Newton iteration".into(),
    }
}
