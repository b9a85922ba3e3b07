#!/usr/bin/env bash
# Fails when two builds that share target/ would resolve different
# features for a shared crate, so the second rebuilds wgpu and everything
# above it: `scripts/test.sh` (the whole workspace with dev-dependencies)
# against `cargo run --release -- demo` (the root package's normal and
# build dependencies), and the demo build against the Python package's
# (scripts/test-python.sh, python/Cargo.toml). Fix a difference by naming
# the feature in the root Cargo.toml's aligned dependencies. Takes a few
# seconds; builds nothing; needs only cargo and awk.
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
# Lines "crate version: <name_b> [features], <name_a> [features]" for the
# crates both lists hold with different features.
differ() {
    awk -v a="$1" -v b="$3" 'FNR == NR { have[$1 " " $2] = $3; next }
         ($1 " " $2) in have && have[$1 " " $2] != $3 {
             print "feature-diff: " $1 " " $2 ": " b " [" $3 "], " a " [" have[$1 " " $2] "]" }' \
        <(cat <<<"$2") <(cat <<<"$4")
}
# The Python package (scripts/test-python.sh) builds into the same target/:
# the crates it shares with the demo build must resolve the same features
# too, or it rebuilds wgpu and everything above it.
python_build=$(features --manifest-path python/Cargo.toml -e features,normal,build)
diff_lines=$(differ "test build" "$test_build" "demo build" "$run_build"
             differ "demo build" "$run_build" "python build" "$python_build")
crates=$(grep -c . <<<"$run_build")
if [ -n "$diff_lines" ]; then
    echo "$diff_lines"
    echo "feature-diff: $(grep -c . <<<"$diff_lines") crate(s) resolve different features;" \
         "\`cargo run --release -- demo\` or the Python build would rebuild after scripts/test.sh"
    exit 1
fi
echo "feature-diff: the test, demo and Python builds resolve the same features ($crates crates in the demo build)"
