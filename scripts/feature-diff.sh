#!/usr/bin/env bash
# Fails when `scripts/test.sh` and `cargo run --release -- demo` would
# resolve different features for a shared crate (then the second command
# rebuilds wgpu and everything above it). Compares the features Cargo
# resolves for the whole workspace with dev-dependencies (the test build)
# against the root package's normal and build dependencies (the binary).
# Fix a difference by naming the feature in the root Cargo.toml's aligned
# dependencies. Takes about a second; builds nothing; needs only cargo and awk.
set -euo pipefail
cd "$(dirname "$0")/.."

# One line per crate version: "name version feature,feature,…" (features
# merged over every line cargo tree prints for that crate, sorted).
features() {
    cargo tree --prefix none -f '{p} [{f}]' "$@" |
        sed -n 's/^\([^ ]*\) v\([^ ]*\).*\[\(.*\)\]$/\1 \2 \3/p' |
        awk '{ key = $1 " " $2; n = split($3, f, ",");
               for (i = 1; i <= n; i++) if (f[i] != "") have[key, f[i]] = 1; seen[key] = 1 }
             END { for (k in seen) { list = "";
                     for (kf in have) { split(kf, p, SUBSEP); if (p[1] == k) list = list "," p[2] }
                     print k, list } }' |
        while read -r name version list; do
            printf '%s %s %s\n' "$name" "$version" "$(tr ',' '\n' <<<"$list" | sed '/^$/d' | sort | paste -sd, -)"
        done | sort
}
test_build=$(features --workspace -e features,normal,build,dev)
run_build=$(features -p hyperpbd -e features,normal,build)

# Crates in the demo build whose features differ in the test build.
diff_lines=$(awk 'FNR == NR { test[$1 " " $2] = $3; next }
                  ($1 " " $2) in test && test[$1 " " $2] != $3 {
                      print "feature-diff: " $1 " " $2 ": demo build [" $3 "], test build [" test[$1 " " $2] "]" }' \
             <(cat <<<"$test_build") <(cat <<<"$run_build"))
crates=$(grep -c . <<<"$run_build")
if [ -n "$diff_lines" ]; then
    echo "$diff_lines"
    echo "feature-diff: $(grep -c . <<<"$diff_lines") crate(s) resolve different features;" \
         "\`cargo run --release -- demo\` would rebuild after scripts/test.sh"
    exit 1
fi
echo "feature-diff: the test build and the demo build resolve the same features ($crates crates in the demo build)"
