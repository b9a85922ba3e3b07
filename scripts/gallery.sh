#!/usr/bin/env bash
# Regenerates the gallery (docs/gallery.md), docs/gallery/*.png and *.gif: every
# shipped scene (scenes/*.json) run on the CPU golden backend (deterministic
# f64, so the pictures only change when the physics or the drawing does) and
# drawn by `hyperpbd render`.
#
#   scripts/gallery.sh            # all scenes
#   scripts/gallery.sh cloth      # some of them
#
# Each scene gets NAME.png (a still, palette PNG) and NAME.gif (the run).
# Sizes are kept modest (a few hundred KB for the whole gallery): 480x360
# stills, 320x240 animations with 16 colours. Options per scene are below.
set -euo pipefail
cd "$(dirname "$0")/.."

out=docs/gallery
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cargo build --release --quiet
bin=target/release/hyperpbd

# NAME|FRAMES|EVERY (animation stride)|STILL (frame number of the still)|view options
scenes=(
    "cloth|60|3|18|--perspective --elevation 35"
    "tesseract|120|8|120|--perspective --rotate 0,2 --rotate-speed 0.8"
    "chain2d|120|6|120|--color residual"
    "incline5d|90|5|90|--perspective --rotate 2,4 --rotate-speed 0.6 --azimuth 0 --elevation 15"
    "example|90|5|30|"
    "jelly4d|120|6|120|--perspective --rotate 0,2 --rotate-speed 0.8"
    "drum3d|240|12|240|"
    "drum4d|240|12|240|"
    "twirl|150|10|150|--perspective --elevation 20"
    "bowl3d|120|6|120|--perspective --elevation 30"
    "drape3d|180|9|180|--perspective --elevation 25"
)

wanted=("$@")
mkdir -p "$out"
for entry in "${scenes[@]}"; do
    IFS='|' read -r name frames every still view <<<"$entry"
    if [ ${#wanted[@]} -gt 0 ] && [[ ! " ${wanted[*]} " == *" $name "* ]]; then
        continue
    fi
    # shellcheck disable=SC2086 # $view is a list of options
    "$bin" render "scenes/$name.json" --backend cpu --frames "$frames" --every "$still" \
        --width 480 --height 360 --png-colors 128 $view --out "$work/$name-still" >/dev/null
    # shellcheck disable=SC2086
    "$bin" render "scenes/$name.json" --backend cpu --frames "$frames" --every "$every" \
        --width 320 --height 240 --gif-colors 16 --no-frames $view --out "$work/$name" >/dev/null
    cp "$work/$name-still/frame_$(printf %05d "$still").png" "$out/$name.png"
    cp "$work/$name/$name.gif" "$out/$name.gif"
    echo "$out/$name.png $(stat -c %s "$out/$name.png") bytes, $out/$name.gif $(stat -c %s "$out/$name.gif") bytes"
done
du -ch "$out"/*.png "$out"/*.gif | tail -1
