#!/usr/bin/env bash
# The prepared device check (docs/device-check.md).
#
#   scripts/device-check.sh --stage   on a development machine: build the
#                                     release CLI and the timing example,
#                                     strip them, add Debian's libvulkan1
#                                     loader, the scenes and these scripts
#                                     into device-kit/ (git-ignored, ≤ 64 MiB)
#   device-kit/device-check.sh        on the GPU machine (no Rust, no network):
#                                     one run inside 8 minutes; a JSON and a
#                                     markdown report under $OUT
#   scripts/device-check.sh --dry     here, on lavapipe, tiny sizes, report
#                                     under $OUT or out/device-check/ (the
#                                     test suite runs it: tests/device_check.rs)
#
# The run: info (adapter, f64, passthrough, shader path) · gpu-f64 against the
# golden path and gpu-f32 against the f32 reference on the differential
# scenes under both shader paths (hyperpbd compare; --exact for f32) ·
# dispatch counts (hyperpbd plan) · the timings of src/bin/device_bench.rs
# (step fit t = a + b·N, frames per schedule, one dependent dispatch,
# batches, the pit and the column) · the CuPy floor (scripts/cupy_baseline.py,
# skipped cleanly without CuPy); HYPERPBD_DEVICE_SCENES="a b" overrides the
# compared scenes. Every step runs under `timeout` inside the
# run's budget; a step that fails or times out is recorded, never fatal.
set -u

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
mode=run
for arg in "$@"; do
    case "$arg" in
        --stage) mode=stage ;;
        --dry) mode=dry ;;
        -h | --help)
            sed -n '2,23p' "${BASH_SOURCE[0]}"
            exit 0
            ;;
        *)
            echo "device-check: unknown argument $arg (expected --stage or --dry)" >&2
            exit 2
            ;;
    esac
done

# Run from the kit (device-kit/device-check.sh, bin/hyperpbd beside it):
# the kit's binaries, scripts and scenes. Run as scripts/device-check.sh:
# this checkout's (release build, scripts/, scenes/), never a kit that may
# be stale; --stage writes the kit to device-kit/.
root="$(cd "$here/.." && pwd)"
staging="$root/device-kit"
kit=""
[ -x "$here/bin/hyperpbd" ] && kit="$here"

stage() {
    set -e
    cd "$root"
    nice -n 5 cargo build --release --bin hyperpbd --bin device_bench
    rm -rf "$staging"
    mkdir -p "$staging/bin" "$staging/vulkan"
    cp target/release/hyperpbd target/release/device_bench "$staging/bin/"
    strip "$staging/bin/hyperpbd" "$staging/bin/device_bench"
    cp -r scenes "$staging/scenes"
    cp scripts/device-check.sh scripts/cupy_baseline.py scripts/device_report.py "$staging/"
    local debs
    debs="$(mktemp -d)"
    (cd "$debs" && apt-get download libvulkan1)
    for deb in "$debs"/*.deb; do
        dpkg -x "$deb" "$staging/vulkan"
        basename "$deb" >>"$staging/vulkan/PACKAGES"
    done
    rm -rf "$debs"
    git rev-parse HEAD >"$staging/COMMIT" 2>/dev/null || echo unknown >"$staging/COMMIT"
    local bytes
    bytes="$(du -sb "$staging" | cut -f1)"
    echo "staged $staging: $bytes bytes ($(cat "$staging/COMMIT"))"
    if [ "$bytes" -gt $((64 * 1024 * 1024)) ]; then
        echo "device-check: the kit is over 64 MiB" >&2
        exit 1
    fi
}

if [ "$mode" = stage ]; then
    stage
    exit $?
fi

dry=""
[ "$mode" = dry ] && dry="--dry"
# $OUT gets three files (the run tool brings back at most 8): report.json,
# report.md and logs.tar.gz (every step's log and steps.tsv); the logs are
# written in a scratch folder first.
out="${OUT:-$root/out/device-check}"
mkdir -p "$out"
work="$(mktemp -d "${TMPDIR:-/tmp}/hyperpbd-device-check.XXXXXX")"
mkdir -p "$work/logs"
: >"$work/steps.tsv"

# Binaries: the kit's, else (dry mode, or HYPERPBD_BIN/HYPERPBD_BENCH) the
# release build of this checkout.
hyperpbd="${HYPERPBD_BIN:-}"
bench="${HYPERPBD_BENCH:-}"
if [ -n "$kit" ]; then
    [ -z "$hyperpbd" ] && hyperpbd="$kit/bin/hyperpbd"
    [ -z "$bench" ] && bench="$kit/bin/device_bench"
    scenes="$kit/scenes"
    scripts="$kit"
else
    [ -z "$hyperpbd" ] && hyperpbd="$root/target/release/hyperpbd"
    [ -z "$bench" ] && bench="$root/target/release/device_bench"
    scenes="$root/scenes"
    scripts="$root/scripts"
fi
report="$scripts/device_report.py"
cupy="$scripts/cupy_baseline.py"

# The Vulkan loader: the system's, else the kit's libvulkan1. The NVIDIA
# ICD ships with the driver; where its manifest is missing but the driver's
# library is present, write one.
if [ -n "$kit" ] && ! ldconfig -p 2>/dev/null | grep -q 'libvulkan\.so\.1 '; then
    for lib in "$kit"/vulkan/usr/lib/*-linux-gnu; do
        [ -d "$lib" ] && export LD_LIBRARY_PATH="$lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
    done
fi
icd_found=no
for dir in /usr/share/vulkan/icd.d /etc/vulkan/icd.d /usr/local/share/vulkan/icd.d; do
    ls "$dir"/*.json >/dev/null 2>&1 && icd_found=yes
done
nvidia_icd=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
if [ "$icd_found" = no ] && [ -z "${VK_DRIVER_FILES:-}" ]; then
    if [ -f "$nvidia_icd" ]; then
        export VK_DRIVER_FILES="$nvidia_icd" VK_ICD_FILENAMES="$nvidia_icd"
    elif ldconfig -p 2>/dev/null | grep -q 'libGLX_nvidia\.so\.0 '; then
        cat >"$work/nvidia_icd.json" <<'JSON'
{"file_format_version": "1.0.0", "ICD": {"library_path": "libGLX_nvidia.so.0", "api_version": "1.3.0"}}
JSON
        export VK_DRIVER_FILES="$work/nvidia_icd.json" VK_ICD_FILENAMES="$work/nvidia_icd.json"
    fi
fi
export NODEVICE_SELECT=1

# The run's budget: 8 minutes on the GPU machine less a margin for the
# report; the dry run is held to 3 minutes.
if [ -n "$dry" ]; then budget=180; else budget=450; fi
start=$(date +%s)

# step NAME SECONDS COMMAND…: run under `timeout` (at most SECONDS, never
# past the budget), output to logs/NAME.log; record rc and milliseconds.
step() {
    local name="$1" limit="$2"
    shift 2
    local left=$((budget - ($(date +%s) - start)))
    [ "$limit" -gt "$left" ] && limit="$left"
    if [ "$limit" -le 0 ]; then
        printf '%s\t%s\t%s\n' "$name" "skipped" "0" >>"$work/steps.tsv"
        return
    fi
    local t0 rc
    t0=$(date +%s%N)
    timeout --kill-after=5 "$limit" "$@" >"$work/logs/$name.log" 2>&1
    rc=$?
    printf '%s\t%s\t%s\n' "$name" "$rc" "$((($(date +%s%N) - t0) / 1000000))" >>"$work/steps.tsv"
}

step info 60 "$hyperpbd" info

if [ -n "$dry" ]; then
    diff_scenes="chain2d"
    frames=2
else
    diff_scenes="chain2d cloth tesseract jelly4d incline5d example barrier4d sandpile2d ballpit4d column3d bowl3d drape3d"
    frames=20
fi
diff_scenes="${HYPERPBD_DEVICE_SCENES:-$diff_scenes}"
for scene in $diff_scenes; do
    step "plan-$scene" 30 "$hyperpbd" plan "$scenes/$scene.json"
done
step cupy 60 python3 "$cupy" $dry
compare_all() {
    local path="$1"
    for scene in $diff_scenes; do
        HYPERPBD_SHADER_PATH=$path step "compare-$path-f64-$scene" 60 \
            "$hyperpbd" compare "$scenes/$scene.json" --precision f64 --frames "$frames"
        HYPERPBD_SHADER_PATH=$path step "compare-$path-f32-$scene" 60 \
            "$hyperpbd" compare "$scenes/$scene.json" --precision f32 --exact --frames "$frames"
        # A plan the f32 reference does not run (the incremental potential):
        # against the golden path's bound only.
        if grep -q -- '--exact: needs' "$work/logs/compare-$path-f32-$scene.log"; then
            sed -i "/^compare-$path-f32-$scene\t/d" "$work/steps.tsv"
            HYPERPBD_SHADER_PATH=$path step "compare-$path-f32-$scene" 60 \
                "$hyperpbd" compare "$scenes/$scene.json" --precision f32 --frames "$frames"
        fi
    done
}
# The timings run between the two shader paths' comparisons, so a slow
# comparison cannot starve them.
compare_all spirv
HYPERPBD_SHADER_PATH=spirv step bench 240 "$bench" $dry
compare_all wgsl

python3 "$report" "$work" $dry
rc=$?
cp "$work/report.json" "$work/report.md" "$out/" 2>/dev/null
tar czf "$out/logs.tar.gz" -C "$work" logs steps.tsv
rm -rf "$work"
echo "device-check: report in $out/report.md and $out/report.json ($(($(date +%s) - start)) s)"
exit $rc
