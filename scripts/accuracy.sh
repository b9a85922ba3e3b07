#!/usr/bin/env bash
# Regenerates the accuracy report from measurements on this machine:
#   docs/accuracy.md, docs/effects.md, docs/figures/{accuracy_pareto,
#   accuracy_cloth,scaling}.png, docs/figures/{accuracy,effects}.json, and the
#   README section "What accuracy costs".
#
#   scripts/accuracy.sh                 # the full report (tens of minutes on 2 cores)
#   scripts/accuracy.sh --only-effects  # only docs/effects.md, figures/effects.json
#                                       # and the README's effect lines (minutes)
#   scripts/accuracy.sh --reps 5        # extra options go to `hyperpbd accuracy`
#
# For a smoke test that leaves docs/ alone (under two minutes):
#   cargo run --release -- accuracy --quick        # writes target/accuracy/
#
# GPU points need a Vulkan adapter; without one they are skipped with a
# printed notice and the report says so. Like scripts/test.sh, this installs
# lavapipe (Mesa's software Vulkan driver) when no driver is present.
set -euo pipefail
cd "$(dirname "$0")/.."

source scripts/install-lavapipe.sh

# Silence the Mesa device-select layer's XDG_RUNTIME_DIR warnings.
export NODEVICE_SELECT=1
exec cargo run --release -- accuracy --out docs --readme README.md "$@"
