#!/usr/bin/env bash
# Runs the whole test suite, the way CI does.
#
# Installs lavapipe (Mesa's software Vulkan driver) with apt-get when no
# Vulkan driver is present, so the GPU tests have an adapter. Set
# HYPERPBD_REQUIRE_GPU=1 to make a missing adapter a failure instead of a
# printed "SKIPPED: no adapter".
set -euo pipefail
cd "$(dirname "$0")/.."

if ! ls /usr/share/vulkan/icd.d/*.json >/dev/null 2>&1 || ! ldconfig -p | grep -q libvulkan.so.1; then
    echo "scripts/test.sh: no Vulkan driver found; installing lavapipe (mesa-vulkan-drivers, libvulkan1)"
    if [ "$(id -u)" -eq 0 ]; then
        apt-get update
        DEBIAN_FRONTEND=noninteractive apt-get install -y mesa-vulkan-drivers libvulkan1
    elif command -v sudo >/dev/null 2>&1; then
        sudo apt-get update
        sudo DEBIAN_FRONTEND=noninteractive apt-get install -y mesa-vulkan-drivers libvulkan1
    else
        echo "scripts/test.sh: cannot install lavapipe (not root, no sudo); GPU tests will skip unless HYPERPBD_REQUIRE_GPU=1" >&2
    fi
fi

# One profile (release) for everything: the physics tests need optimised
# code, and building wgpu twice would double the build time.
cargo test --release --workspace --all-targets
cargo test --release --workspace --doc
