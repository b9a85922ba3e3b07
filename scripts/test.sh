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

skip_log="${CARGO_TARGET_DIR:-target}/tmp/gpu-skipped.txt"
mkdir -p "$(dirname "$skip_log")"
: > "$skip_log"

# One profile (release) for everything: the physics tests need optimised
# code, and building wgpu twice would double the build time.
#
# lavapipe (llvmpipe) runs LLVM's optimisation passes on every pipeline it
# compiles unless GALLIVM_PERF=nopt. The `gpu` binary compiles hundreds of
# pipelines and runs each for a few steps, so it finishes sooner without
# the passes; the other binaries run longer scenes on fewer pipelines,
# where the passes pay (warm shader cache: `stability` 152 s with them,
# 195–198 s without; docs/testing.md, "Pipelines the driver compiles").
# IEEE semantics are the same either way: every bit-for-bit test passes
# with both. So every target but `gpu` runs first with the default, then
# `gpu` with nopt (unless GALLIVM_PERF is set). The test targets are
# cargo's own discovery: tests/NAME.rs and tests/NAME/main.rs of each
# package.
other_tests=()
for target in tests/*.rs tests/*/main.rs */tests/*.rs */tests/*/main.rs; do
    [ -e "$target" ] || continue
    name=${target%/main.rs}
    name=${name%.rs}
    name=${name##*/}
    [ "$name" = gpu ] || other_tests+=(--test "$name")
done
cargo test --release --workspace --lib --bins --examples --benches "${other_tests[@]}"
GALLIVM_PERF="${GALLIVM_PERF-nopt}" cargo test --release --test gpu
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
