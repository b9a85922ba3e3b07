#!/usr/bin/env bash
# Runs the whole test suite, the way CI does.
#
# Installs lavapipe (Mesa's software Vulkan driver) with apt-get when no
# Vulkan driver is present, so the GPU tests have an adapter. Set
# HYPERPBD_REQUIRE_GPU=1 to make a missing adapter a failure instead of a
# printed "SKIPPED: no adapter".
set -euo pipefail
cd "$(dirname "$0")/.."

source scripts/install-lavapipe.sh

# One profile (release) for everything: the physics tests need optimised
# code, and building wgpu twice would double the build time.
cargo test --release --workspace --all-targets
cargo test --release --workspace --doc
# `cargo run --release -- demo` after this must reuse the build: the same
# features for every shared crate (see the root Cargo.toml).
bash scripts/feature-diff.sh
