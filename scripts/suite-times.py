#!/usr/bin/env python3
"""Where the suite's time goes: runs every test and bench executable of
`cargo test --release --workspace --all-targets` one after another, the way
cargo does (working directory and CARGO_MANIFEST_DIR = its package root,
benches without `--bench`: criterion's test mode), with
HYPERPBD_REQUIRE_GPU=1 and NODEVICE_SELECT=1, and writes one line per
executable: wall seconds, CPU seconds (user + sys of it and its children),
exit code, kind, package folder/target. The last line is the wall total.

    python3 scripts/suite-times.py OUT.tsv [VAR=VALUE ...]

The build (`--no-run`) comes first and is not timed. CPU seconds are the
figure to compare on a shared machine: wall time grows with the other
jobs' load, CPU time much less. The integration tests are a few binaries
by subject (tests/gpu/, tests/cpu/, …; docs/testing.md), one line each;
one module's time: `time cargo test --release --test gpu -- kernels::`.
Not part of the suite.
"""

import json
import os
import resource
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def executables() -> list[tuple[str, str, str, str]]:
    """(executable, package root, kind, package folder/target) of every test and
    bench target, in cargo's order."""
    out = subprocess.run(
        ["cargo", "test", "--release", "--workspace", "--all-targets", "--no-run",
         "--message-format=json"],
        cwd=ROOT, capture_output=True, text=True, check=True,
    ).stdout
    found = []
    for line in out.splitlines():
        try:
            msg = json.loads(line)
        except json.JSONDecodeError:
            continue
        if msg.get("reason") == "compiler-artifact" and msg.get("executable") and msg["profile"]["test"]:
            package = Path(msg["manifest_path"]).parent
            found.append((msg["executable"], str(package), msg["target"]["kind"][0],
                          f"{package.relative_to(ROOT)}/{msg['target']['name']}"))
    return found


def main() -> None:
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    env = dict(os.environ, HYPERPBD_REQUIRE_GPU="1", NODEVICE_SELECT="1")
    env.update(a.split("=", 1) for a in sys.argv[2:])
    total = 0.0
    with open(sys.argv[1], "w") as out:
        for exe, package, kind, name in executables():
            before = resource.getrusage(resource.RUSAGE_CHILDREN)
            started = time.time()
            run = subprocess.run([exe], cwd=package, env=dict(env, CARGO_MANIFEST_DIR=package),
                                 capture_output=True, text=True)
            wall = time.time() - started
            after = resource.getrusage(resource.RUSAGE_CHILDREN)
            cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
            total += wall
            out.write(f"{wall:.2f}\t{cpu:.2f}\t{run.returncode}\t{kind}\t{name}\n")
            out.flush()
            if run.returncode:
                sys.stderr.write(f"FAILED {name}\n{run.stdout[-3000:]}{run.stderr[-3000:]}\n")
        out.write(f"{total:.2f}\t-\t-\ttotal\n")


if __name__ == "__main__":
    main()
