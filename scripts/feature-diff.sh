#!/usr/bin/env bash
# Fails when `scripts/test.sh` and `cargo run --release -- demo` would
# resolve different features for a shared crate (then the second command
# rebuilds wgpu and everything above it). Compares the features Cargo
# resolves for the whole workspace with dev-dependencies (the test build)
# against the root package's normal and build dependencies (the binary).
# Fix a difference by naming the feature in the root Cargo.toml's aligned
# dependencies. Takes about a second; builds nothing.
set -euo pipefail
cd "$(dirname "$0")/.."

features() {
    cargo tree --prefix none -f '{p} [{f}]' "$@" |
        sed -n 's/^\([^ ]*\) v\([^ ]*\).*\[\(.*\)\]$/\1 \2 \3/p' | sort -u
}
test_build=$(features --workspace -e features,normal,build,dev)
run_build=$(features -p hyperpbd -e features,normal,build)

python3 - "$test_build" "$run_build" <<'PY'
import sys
def table(text):
    t = {}
    for line in text.splitlines():
        name, version, feats = (line.split(" ", 2) + [""])[:3]
        t.setdefault((name, version), set()).update(f for f in feats.split(",") if f)
    return t
test, run = table(sys.argv[1]), table(sys.argv[2])
bad = [(k, sorted(test[k] - run[k]), sorted(run[k] - test[k]))
       for k in sorted(run) if k in test and test[k] != run[k]]
for (name, version), t_only, r_only in bad:
    print(f"feature-diff: {name} {version}: test build only {t_only}, run build only {r_only}")
if bad:
    print(f"feature-diff: {len(bad)} crate(s) resolve different features; "
          "`cargo run --release -- demo` would rebuild after scripts/test.sh")
    sys.exit(1)
print(f"feature-diff: the test build and the demo build resolve the same features "
      f"({len(run)} crates in the demo build)")
PY
