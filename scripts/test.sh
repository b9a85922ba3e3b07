#!/usr/bin/env bash
# Runs the whole test suite, the way CI does.
#
# Installs lavapipe (Mesa's software Vulkan driver) with apt-get when no
# Vulkan driver is present, so the GPU tests have an adapter. Set
# HYPERPBD_REQUIRE_GPU=1 to make a missing adapter a failure of each GPU
# test instead of a printed "SKIPPED: no adapter".
#
# A GPU test that finds no adapter records itself in
# target/tmp/gpu-skipped.txt (tests/common/gpu.rs); at the end this script
# prints one line counting them and fails when any did not run, unless
# HYPERPBD_NO_GPU=1 says that no GPU is expected on this machine.
set -euo pipefail
cd "$(dirname "$0")/.."

source scripts/install-lavapipe.sh

# lavapipe (llvmpipe) runs LLVM's optimisation passes on every pipeline it
# compiles unless GALLIVM_PERF=nopt; the tests compile many pipelines and
# run each for a few steps, so they finish sooner without the passes
# (docs/testing.md, "Pipelines the driver compiles"). IEEE semantics are
# the same either way: every bit-for-bit test passes with both. The
# benchmarks (scripts/accuracy.sh, cargo bench) keep the default.
export GALLIVM_PERF="${GALLIVM_PERF-nopt}"

skip_log="${CARGO_TARGET_DIR:-target}/tmp/gpu-skipped.txt"
mkdir -p "$(dirname "$skip_log")"
: > "$skip_log"

# One profile (release) for everything: the physics tests need optimised
# code, and building wgpu twice would double the build time.
cargo test --release --workspace --all-targets
cargo test --release --workspace --doc
# `cargo run --release -- demo` after this must reuse the build: the same
# features for every shared crate (see the root Cargo.toml).
bash scripts/feature-diff.sh

skipped=$(cut -f1 "$skip_log" | sort -u | grep -c . || true)
if [ "$skipped" -eq 0 ]; then
    echo "GPU tests that did not run (no adapter): 0"
elif [ "${HYPERPBD_NO_GPU:-0}" = "1" ]; then
    echo "GPU tests that did not run (no adapter): $skipped (HYPERPBD_NO_GPU=1: no GPU expected; list in $skip_log)"
else
    echo "GPU tests that did not run (no adapter): $skipped (list in $skip_log); set HYPERPBD_NO_GPU=1 if no GPU is expected here" >&2
    exit 1
fi
