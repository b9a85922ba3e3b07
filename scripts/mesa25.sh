#!/usr/bin/env bash
# Unpacks Debian bookworm-backports' lavapipe (Mesa 25.0.7) into a private
# prefix WITHOUT installing it: the system's Mesa (22.3.6 on bookworm) is left
# alone, and only a process given the printed environment uses Mesa 25.
#
#   scripts/mesa25.sh                 # unpacks into /opt/mesa25, prints the env
#   MESA25_PREFIX=$HOME/mesa25 scripts/mesa25.sh
#   eval "$(scripts/mesa25.sh --env)" # only the exports (prefix must exist)
#
# Then, for example:
#   eval "$(scripts/mesa25.sh --env)"
#   NODEVICE_SELECT=1 cargo run --release -- info   # "Mesa 25.0.7-2~bpo12+1"
#
# What it fetches (apt-get download, no dpkg -i): mesa-vulkan-drivers and the
# two libraries it needs newer than bookworm has (libdrm2, libdrm-amdgpu1
# >= 2.4.121). Its LLVM is bookworm's own libLLVM-15 (already installed with
# the system's lavapipe). apt's state lives under $work, not /var/lib/apt.
# See docs/lavapipe-mesa25.md for what it measured.
set -euo pipefail

prefix=${MESA25_PREFIX:-/opt/mesa25}
libdir=$prefix/usr/lib/x86_64-linux-gnu
icd=$prefix/lvp_icd.mesa25.json

print_env() {
    echo "export VK_ICD_FILENAMES=$icd"
    echo "export LD_LIBRARY_PATH=$libdir\${LD_LIBRARY_PATH:+:\$LD_LIBRARY_PATH}"
}

if [ "${1:-}" = "--env" ]; then
    [ -f "$icd" ] || { echo "$0: $icd missing; run $0 first" >&2; exit 1; }
    print_env
    exit 0
fi

work=${MESA25_APT:-/tmp/aptbp}
mkdir -p "$work/lists/partial" "$work/archives/partial" "$work/dl" "$prefix"
# The system's own Debian mirror (its deb822 sources, else sources.list),
# suite bookworm-backports.
mirror=$(awk '/^URIs:/ {print $2; exit}' /etc/apt/sources.list.d/*.sources 2>/dev/null)
[ -n "$mirror" ] || mirror=$(awk '/^deb / {print $2; exit}' /etc/apt/sources.list 2>/dev/null)
[ -n "$mirror" ] || { echo "$0: no Debian mirror in the apt sources" >&2; exit 1; }
echo "deb $mirror bookworm-backports main" > "$work/bp.list"
apt_opts=(
    -o "Dir::Etc::SourceList=$work/bp.list"
    -o Dir::Etc::SourceParts=/dev/null
    -o "Dir::State::Lists=$work/lists"
    -o "Dir::Cache::archives=$work/archives"
)
if ! ls "$work"/lists/*bookworm-backports*Packages* >/dev/null 2>&1; then
    apt-get "${apt_opts[@]}" update
fi

version=25.0.7-2~bpo12+1
drm=2.4.123-1~bpo12+1
(
    cd "$work/dl"
    apt-get "${apt_opts[@]}" download \
        "mesa-vulkan-drivers=$version" "libdrm2=$drm" "libdrm-amdgpu1=$drm"
)
for deb in "$work"/dl/mesa-vulkan-drivers_*.deb "$work"/dl/libdrm2_*.deb "$work"/dl/libdrm-amdgpu1_*.deb; do
    dpkg-deb -x "$deb" "$prefix"
done

# The loader reads library_path from the ICD json; point it at the unpacked
# library (an absolute path), so the system's lvp_icd.x86_64.json is untouched.
sed "s#\"library_path\": \"[^\"]*\"#\"library_path\": \"$libdir/libvulkan_lvp.so\"#" \
    "$prefix/usr/share/vulkan/icd.d/lvp_icd.json" > "$icd"

# Everything it links must resolve (libLLVM-15 from the system).
if LD_LIBRARY_PATH=$libdir ldd "$libdir/libvulkan_lvp.so" | grep -q 'not found'; then
    LD_LIBRARY_PATH=$libdir ldd "$libdir/libvulkan_lvp.so" | grep 'not found' >&2
    echo "$0: libvulkan_lvp.so has unresolved libraries" >&2
    exit 1
fi

echo "# Mesa 25 lavapipe unpacked into $prefix; for one shell or process:"
print_env
