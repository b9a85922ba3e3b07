#!/usr/bin/env bash
# Installs lavapipe (Mesa's software Vulkan driver) with apt-get when no
# Vulkan driver is present, so GPU code has an adapter on a machine without
# a GPU. Sourced by scripts/test.sh and scripts/accuracy.sh.
if ! ls /usr/share/vulkan/icd.d/*.json >/dev/null 2>&1 || ! ldconfig -p | grep -q libvulkan.so.1; then
    echo "$0: no Vulkan driver found; installing lavapipe (mesa-vulkan-drivers, libvulkan1)"
    if [ "$(id -u)" -eq 0 ]; then
        apt-get update
        DEBIAN_FRONTEND=noninteractive apt-get install -y mesa-vulkan-drivers libvulkan1
    elif command -v sudo >/dev/null 2>&1; then
        sudo apt-get update
        sudo DEBIAN_FRONTEND=noninteractive apt-get install -y mesa-vulkan-drivers libvulkan1
    else
        echo "$0: cannot install lavapipe (not root, no sudo); GPU work will skip or fail" >&2
    fi
fi
