#!/usr/bin/env bash
# Regenerates the coupled implicit step's energy figures,
# docs/figures/implicit_energy_*.png (docs/implicit.md §11): the evidence
# scenes of tests/implicit/step.rs on the CPU golden path (deterministic
# f64: the pictures only change when the physics or the drawing does).
#
#   scripts/implicit_figures.sh
set -euo pipefail
cd "$(dirname "$0")/.."
HYPERPBD_WRITE_FIGURES=1 cargo test --release --test implicit -- \
    step::energy_never_rises_in_any_evidence_scene --nocapture | grep -E '^(wrote|BOUND)'
