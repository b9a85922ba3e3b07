#!/usr/bin/env bash
# Regenerates the accuracy report from measurements on this machine:
#   docs/accuracy.md, docs/effects.md, docs/figures/{accuracy_pareto,
#   accuracy_cloth,accuracy_patch,scaling}.png and
#   docs/figures/{accuracy,effects,implicit,patch}.json
#   (docs only: the README's summary table reads docs/accuracy.md, see
#   scripts/readme-summary.py).
#
#   scripts/accuracy.sh                 # the full report (tens of minutes on 2 cores)
#   scripts/accuracy.sh --only-effects  # only docs/effects.md, figures/effects.json
#                                       # (minutes)
#   scripts/accuracy.sh --only-implicit # only the implicit rows (Newton × CG budgets):
#                                       # figures/implicit.json, their section of
#                                       # docs/accuracy.md (a minute)
#   scripts/accuracy.sh --only-patch    # only the patch test (standard XPBD, the
#                                       # primal residual, the implicit path):
#                                       # figures/patch.json, accuracy_patch.png,
#                                       # their section of docs/accuracy.md (minutes)
#   scripts/accuracy.sh --reps 5        # extra options go to `hyperpbd-report`
#
# For a smoke test that leaves docs/ alone (under two minutes):
#   cargo run --release -p hyperpbd-report -- --quick   # writes target/accuracy/
#
# GPU points need a Vulkan adapter; without one they are skipped with a
# printed notice and the report says so. Like scripts/test.sh, this installs
# lavapipe (Mesa's software Vulkan driver) when no driver is present.
set -euo pipefail
cd "$(dirname "$0")/.."

source scripts/install-lavapipe.sh

exec cargo run --release -p hyperpbd-report -- --out docs "$@"
