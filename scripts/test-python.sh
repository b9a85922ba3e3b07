#!/usr/bin/env bash
# Builds the Python package (python/, pyo3 + numpy, by maturin) and runs its
# pytest suite, the way CI does (.ci/run calls it after scripts/test.sh).
#
#   venv     target/python-venv: maturin, numpy, pytest, matplotlib from PyPI
#   build    maturin build --release into the workspace's target/ (same
#            release profile, versions locked to the workspace's): the crates
#            scripts/test.sh built are reused where their features match
#   tests    python/tests against target/release/hyperpbd (the CLI), GPU tests
#            on the adapter scripts/test.sh uses (HYPERPBD_REQUIRE_GPU=1 makes
#            a missing adapter a failure, never a skip)
set -euo pipefail
cd "$(dirname "$0")/.."

# lavapipe (llvmpipe) runs LLVM's optimisation passes on every pipeline it
# compiles unless GALLIVM_PERF=nopt; the tests compile many pipelines and
# run each for a few steps, so they finish sooner without the passes
# (docs/testing.md, "Pipelines the driver compiles"). IEEE semantics are
# the same either way: every bit-for-bit test passes with both. The
# benchmarks (scripts/accuracy.sh, cargo bench) keep the default.
export GALLIVM_PERF="${GALLIVM_PERF-nopt}"
export CARGO_TARGET_DIR="$PWD/target"
venv="$CARGO_TARGET_DIR/python-venv"
python="${PYTHON:-python3}"
if [ ! -x "$venv/bin/python" ]; then
    "$python" -m venv "$venv"
fi
"$venv/bin/python" -m pip install --quiet --upgrade "maturin>=1.9,<2" numpy pytest matplotlib

# The CLI the equality tests compare against (scripts/test.sh builds it).
if [ ! -x target/release/hyperpbd ]; then
    cargo build --release --bin hyperpbd
fi
rm -rf target/wheels
(cd python && "$venv/bin/maturin" build --release --out "$CARGO_TARGET_DIR/wheels")
"$venv/bin/python" -m pip install --quiet --force-reinstall --no-deps target/wheels/hyperpbd-*.whl

# -rs prints every skip's reason; exit 5 (no tests collected) fails here.
"$venv/bin/pytest" -rs -q python/tests
