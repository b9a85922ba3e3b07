#!/usr/bin/env bash
# Mutation harness for the GPU kernels and their dispatch (docs/mutation.md).
# Runs at low priority: it rebuilds hyperpbd-gpu and the GPU test binaries
# once per mutant. Every option is scripts/mutants.py's (--help).
set -euo pipefail
cd "$(dirname "$0")/.."
exec nice -n 10 python3 scripts/mutants.py "$@"
