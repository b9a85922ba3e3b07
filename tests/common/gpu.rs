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
use hyperpbd_gpu::{AdapterSummary, GpuBackend, Precision, StepMode, XpbdOptions, request_adapter};

/// Environment variable that turns a missing adapter from a skip into a
/// failure.
pub const REQUIRE_GPU_ENV: &str = "HYPERPBD_REQUIRE_GPU";

/// Where skipped GPU tests are recorded, one `<binary>::<test>\t<why>` line each
/// (the workspace's shared target folder; `scripts/test.sh` empties it
/// before a run and counts the distinct tests after it). `<test>` is the
/// libtest name of the running test (its thread's name, module path
/// included: tests of one subject share a binary, and two of its modules
/// may pass the same label), or the label passed when there is none.
pub const SKIP_LOG: &str = concat!(env!("CARGO_TARGET_TMPDIR"), "/gpu-skipped.txt");

/// Prints the `SKIPPED: no adapter` line of `test` and records it in
/// [`SKIP_LOG`]. A log that cannot be written fails the test: a skip that
/// is not counted would read as a pass.
pub fn record_skip(test: &str, why: &dyn std::fmt::Display) {
    use std::io::Write;
    eprintln!("SKIPPED: no adapter ({test}): {why}");
    let why = why.to_string().replace(['\n', '\t'], " ");
    let thread = std::thread::current();
    let name = thread.name().filter(|n| *n != "main").unwrap_or(test);
    let line = format!("{}::{name}\t{why}\n", env!("CARGO_CRATE_NAME"));
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

/// The libtest name of the test function `function` in the module
/// `module` (`module_path!()`): the path without the crate's name.
pub fn test_name(module: &str, function: &str) -> String {
    match module.split_once("::") {
        Some((_, path)) => format!("{path}::{function}"),
        None => function.to_string(),
    }
}

/// lavapipe's worker-thread variable (Mesa reads it when an instance is
/// created).
pub const LAVAPIPE_THREADS: &str = "LP_NUM_THREADS";

/// Whether the calling test `test` (its full name in its binary,
/// [`test_name`]) runs its
/// body in this process; a test of many small dispatches starts with
///
/// ```ignore
/// if !on_one_lavapipe_thread("my_test") {
///     return; // a child process ran it with LP_NUM_THREADS=0
/// }
/// ```
///
/// lavapipe hands every dispatch to its worker pool, 35–63 µs each with
/// its default threads, ~1 µs with `LP_NUM_THREADS=0` (the work runs on the
/// submitting thread; docs/performance.md): a scene of a few hundred
/// elements in 157 colours is dispatch-bound. A test cannot set the
/// variable in its own process (other test threads may read the
/// environment), so when it is unset the test runs itself again in a
/// child process with `LP_NUM_THREADS=0` (`--exact`, its output printed
/// here) and fails when the child fails or ran no test; it then returns
/// `false`. A variable already set (by the user, or in that child) is
/// kept: `true`, the body runs here. Other drivers never read it. The
/// child runs with llvmpipe's optimisation passes ([`one_thread_child`]).
pub fn on_one_lavapipe_thread(test: &str) -> bool {
    if std::env::var_os(LAVAPIPE_THREADS).is_some() {
        return true;
    }
    let exe = std::env::current_exe().expect("the test binary's path");
    let out = one_thread_child(exe)
        .args([test, "--exact", "--nocapture", "--test-threads=1"])
        .output()
        .unwrap_or_else(|e| panic!("{test}: cannot run it again with {LAVAPIPE_THREADS}=0: {e}"));
    let stdout = String::from_utf8_lossy(&out.stdout);
    print!("{stdout}");
    eprint!("{}", String::from_utf8_lossy(&out.stderr));
    assert!(
        out.status.success(),
        "{test} with {LAVAPIPE_THREADS}=0 failed ({}): its output is above",
        out.status
    );
    assert!(
        stdout.contains("test result: ok. 1 passed;"),
        "{test} with {LAVAPIPE_THREADS}=0 ran no test (is the name exact?)"
    );
    false
}

/// The command of a child that runs tests on one lavapipe thread:
/// `exe` with `LP_NUM_THREADS=0`, and without `GALLIVM_PERF=nopt`.
/// `scripts/test.sh` and the mutation harness set `nopt` for the `gpu`
/// binary, whose tests compile hundreds of short-lived pipelines; a child
/// steps a long scene on a few, where llvmpipe's passes pay (measured,
/// one after another on a warm shader cache: the six
/// `materials_closed_forms` tests 351 s with `nopt`, 301 s without;
/// `coupled_f32` 29.7 s, 22.4 s). The same IEEE operations in the same
/// order either way; any other value of the variable is kept.
fn one_thread_child(exe: std::path::PathBuf) -> std::process::Command {
    let mut child = std::process::Command::new(exe);
    child.env(LAVAPIPE_THREADS, "0");
    if std::env::var_os(LLVM_PASSES).is_some_and(|v| v == "nopt") {
        child.env_remove(LLVM_PASSES);
    }
    child
}

/// llvmpipe's switch for its LLVM passes (`nopt`: none).
const LLVM_PASSES: &str = "GALLIVM_PERF";

/// [`on_one_lavapipe_thread`] for a binary whose tests share one run (a
/// `OnceLock` every test reads: a report's sweep), where a child per test
/// would repeat the run: whether the calling test `test` ([`test_name`])
/// runs its body in this process.
///
/// With `LP_NUM_THREADS` set (by the user, or in the child): `true`.
/// Unset: the first caller runs the whole binary once in a child process
/// with `LP_NUM_THREADS=0` (this process's arguments, less
/// `--nocapture` / `--show-output`; its output printed here), and every
/// caller asserts that its own test printed `test <test> ... ok` there —
/// a test that failed, or did not run, in the child fails here — and
/// returns `false`.
pub fn binary_on_one_lavapipe_thread(test: &str) -> bool {
    use std::sync::OnceLock;
    if std::env::var_os(LAVAPIPE_THREADS).is_some() {
        return true;
    }
    static CHILD: OnceLock<String> = OnceLock::new();
    let stdout = CHILD.get_or_init(|| {
        let exe = std::env::current_exe().expect("the test binary's path");
        let args = std::env::args_os()
            .skip(1)
            .filter(|a| a != "--nocapture" && a != "--show-output");
        let out = one_thread_child(exe)
            .args(args)
            .output()
            .unwrap_or_else(|e| {
                panic!("{test}: cannot run the binary again with {LAVAPIPE_THREADS}=0: {e}")
            });
        let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
        print!("{stdout}");
        eprint!("{}", String::from_utf8_lossy(&out.stderr));
        println!("(the binary with {LAVAPIPE_THREADS}=0: {})", out.status);
        stdout
    });
    let passed = format!("test {test} ... ok");
    assert!(
        stdout.lines().any(|l| l == passed),
        "{test} did not pass in the binary's run with {LAVAPIPE_THREADS}=0 (its output is above)"
    );
    false
}

/// `plan` with `state` on `adapter` in `precision`, its step's dispatches
/// formed as `mode` says (the schedule tests compare the modes).
pub fn in_mode(
    adapter: &wgpu::Adapter,
    (plan, state): (&Plan, &State),
    precision: Precision,
    mode: StepMode,
) -> Result<GpuBackend, BackendError> {
    GpuBackend::with_options(
        adapter,
        plan.clone(),
        state,
        precision,
        XpbdOptions::mode(mode),
    )
}
