#!/usr/bin/env python3
"""Mutation harness for the GPU kernels and their Rust dispatch.

Reads a mutant list (scripts/mutants.toml: file, an exact snippet that
occurs exactly once in that file, its replacement, a class, a note), then
for each mutant, one at a time, in a scratch copy of the repository:

    apply the replacement           (refused if the snippet is missing or ambiguous)
    build + run the test targets    in the list's order, stopping at the first failing target
    restore the file byte for byte  (verified by SHA-256)
    record killed / survived / build-failed / invalid / timeout and the killing tests

The developer's tree is never written: the scratch copy lives in
--scratch (default /tmp/hyperpbd-mutants/repo) with its own CARGO_TARGET_DIR
(…/target), seeded once from this tree's target/release so the dependency
build (wgpu, naga, …) is reused. Results accumulate in
scripts/mutants-results.json (committed; seeded from docs/mutation.md's
table where it is missing), so a long list can be run in batches (--only,
--from, --limit) and on another machine; --report writes docs/mutation.md
from the list and the results.

    scripts/mutants.sh --check            every snippet unique? (no build)
    scripts/mutants.sh --baseline         unmutated scratch copy: all targets pass, their times
    scripts/mutants.sh --only M07,M12     run these mutants
    scripts/mutants.sh --from M20 --limit 10
    scripts/mutants.sh --only M13 --targets stability   only these targets
    scripts/mutants.sh --report           write docs/mutation.md

Not in CI: each mutant rebuilds hyperpbd-gpu (the WGSL is embedded with
include_str!) and the test binaries it runs.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import time
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
DEFAULT_LIST = ROOT / "scripts" / "mutants.toml"
DEFAULT_SCRATCH = Path("/tmp/hyperpbd-mutants")
REPORT = ROOT / "docs" / "mutation.md"

ENV = {
    "HYPERPBD_REQUIRE_GPU": "1",
    "NODEVICE_SELECT": "1",
    "CARGO_TERM_COLOR": "never",
}


def binary_env(env: dict, exe: str) -> dict:
    """`env` for running the test binary `exe`: as scripts/test.sh, the
    `gpu` binary (hundreds of short-lived pipelines) runs lavapipe without
    LLVM's passes (GALLIVM_PERF=nopt, unless set: the same bits, faster
    there), the others with them."""
    if Path(exe).name.rsplit("-", 1)[0] != "gpu" or "GALLIVM_PERF" in env:
        return env
    return {**env, "GALLIVM_PERF": "nopt"}


def sha256(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def load_list(path: Path) -> dict:
    with open(path, "rb") as f:
        data = tomllib.load(f)
    mutants = data.get("mutant", [])
    seen = set()
    for m in mutants:
        for key in ("id", "file", "find", "replace", "class"):
            if key not in m:
                sys.exit(f"{path}: mutant {m.get('id', '?')} lacks `{key}`")
        if m["id"] in seen:
            sys.exit(f"{path}: duplicate mutant id {m['id']}")
        if m["find"] == m["replace"]:
            sys.exit(f"{path}: mutant {m['id']} replaces its snippet by itself")
        seen.add(m["id"])
    return data


def locate(root: Path, m: dict) -> tuple[int | None, str]:
    """Line of the snippet's one occurrence, or (None, why)."""
    path = root / m["file"]
    if not path.is_file():
        return None, f"{m['file']}: no such file"
    text = path.read_text()
    count = text.count(m["find"])
    if count == 0:
        return None, f"{m['file']}: snippet not found"
    if count > 1:
        return None, f"{m['file']}: snippet occurs {count} times (ambiguous)"
    return text[: text.index(m["find"])].count("\n") + 1, ""


def split_target(target: str) -> tuple[str, str]:
    """`BINARY` (every test of tests/BINARY) or `BINARY::MODULE` (the tests
    of one top-level module of it, e.g. `gpu::kernels`): (binary, module or
    "")."""
    binary, _, module = target.partition("::")
    return binary, module


def existing(root: Path, targets: list[str]) -> list[str]:
    """The targets that exist in the tree at `root`: the binary
    (tests/BINARY.rs or tests/BINARY/main.rs) and, when named, its module
    (tests/BINARY/MODULE.rs or tests/BINARY/MODULE/mod.rs)."""
    found = []
    for t in targets:
        binary, module = split_target(t)
        tests = root / "tests"
        if not ((tests / f"{binary}.rs").is_file() or (tests / binary / "main.rs").is_file()):
            continue
        if module and not (
            (tests / binary / f"{module}.rs").is_file()
            or (tests / binary / module / "mod.rs").is_file()
        ):
            continue
        found.append(t)
    return found


def targets_for(data: dict, m: dict, root: Path) -> list[str]:
    """The test targets of a mutant: its own `tests`, else the first
    [[order]] entry whose `files` pattern matches, then the defaults
    (`--targets` narrows all of these to the targets it names)."""
    if data.get("only_targets"):
        return existing(root, data["only_targets"])
    default = existing(root, data["targets"]["default"])
    first: list[str] = list(m.get("tests", []))
    if not first:
        for rule in data.get("order", []):
            if re.search(rule["files"], m["file"]):
                first = list(rule["tests"])
                break
    return existing(root, first) + [t for t in default if t not in first]


# ---------------------------------------------------------------- scratch


def tracked_files() -> list[str]:
    out = subprocess.run(
        ["git", "ls-files", "-z", "--cached", "--others", "--exclude-standard"],
        cwd=ROOT,
        check=True,
        capture_output=True,
    ).stdout
    return [f for f in out.decode().split("\0") if f and (ROOT / f).is_file()]


def sync_scratch(scratch: Path) -> Path:
    """Copies the working tree into scratch/repo, writing only files whose
    bytes differ (unchanged files keep their mtimes: no rebuild)."""
    repo = scratch / "repo"
    repo.mkdir(parents=True, exist_ok=True)
    files = tracked_files()
    changed = 0
    for f in files:
        src, dst = ROOT / f, repo / f
        data = src.read_bytes()
        if not dst.is_file() or dst.read_bytes() != data:
            dst.parent.mkdir(parents=True, exist_ok=True)
            dst.write_bytes(data)
            shutil.copymode(src, dst)
            changed += 1
    manifest = scratch / "files.txt"
    if manifest.is_file():
        for f in set(manifest.read_text().split("\n")) - set(files):
            if f and (repo / f).is_file():
                (repo / f).unlink()
    manifest.write_text("\n".join(files))
    target = scratch / "target"
    if not (target / "release").is_dir():
        print(f"seeding {target}/release from {ROOT}/target/release (dependencies)")
        (target / "release").mkdir(parents=True)
        for part in ("deps", "build", ".fingerprint"):
            src = ROOT / "target" / "release" / part
            if src.is_dir():
                subprocess.run(
                    ["cp", "-a", str(src), str(target / "release" / part)], check=True
                )
    print(f"scratch {repo}: {changed} of {len(files)} files updated")
    return repo


def cargo_env(scratch: Path) -> dict:
    env = dict(os.environ)
    env.update(ENV)
    env["CARGO_TARGET_DIR"] = str(scratch / "target")
    return env


def build_target(repo: Path, env: dict, target: str, timeout: float) -> tuple[str, str]:
    """('ok', executable) or ('build-failed'/'timeout', log tail) of the
    test binary `target` (a binary's name, without `::MODULE`)."""
    cmd = [
        "cargo", "test", "--release", "--test", target, "--no-run",
        "--message-format=json-render-diagnostics",
    ]
    try:
        out = subprocess.run(
            cmd, cwd=repo, env=env, capture_output=True, text=True, timeout=timeout
        )
    except subprocess.TimeoutExpired:
        return "timeout", f"build of {target} over {timeout:.0f} s"
    if out.returncode != 0:
        return "build-failed", out.stderr[-2000:]
    for line in out.stdout.splitlines():
        try:
            msg = json.loads(line)
        except json.JSONDecodeError:
            continue
        if (
            msg.get("reason") == "compiler-artifact"
            and msg.get("executable")
            and msg["target"]["name"] == target
            and msg["profile"]["test"]
        ):
            return "ok", msg["executable"]
    return "build-failed", f"no executable for {target}"


FAILED = re.compile(r"^test (\S+) \.\.\. FAILED$", re.M)
PANIC = re.compile(r"^thread '([^']+)' panicked at [^\n]*\n(.*)$", re.M)


def selection(repo: Path, env: dict, exe: str, module: str) -> list[str]:
    """The libtest arguments that run the tests of `module` (top-level
    module of the binary `exe`) and no other: `--exact` and every test name
    under `module::` (a plain filter would also match a nested module of
    that name elsewhere, e.g. `barrier::kernels::` for `kernels::`). No
    module: no arguments (the whole binary)."""
    if not module:
        return []
    listing = subprocess.run(
        [exe, "--list", "--format=terse"], cwd=repo, env=env, capture_output=True, text=True,
        check=True,
    ).stdout
    names = [
        line[: -len(": test")]
        for line in listing.splitlines()
        if line.endswith(": test") and line.startswith(f"{module}::")
    ]
    if not names:
        sys.exit(f"{exe}: no test under {module}:: (a target naming a module that has no tests)")
    return ["--exact", *names]


def run_target(
    repo: Path, env: dict, exe: str, threads: int, timeout: float, module: str = ""
) -> tuple[str, list[str], str]:
    """('pass'|'fail'|'timeout', failing tests, first panic message) of the
    tests of `module` in the binary `exe` (all of them without one)."""
    try:
        out = subprocess.run(
            [exe, f"--test-threads={threads}", *selection(repo, env, exe, module)],
            cwd=repo,
            env=binary_env(env, exe),
            capture_output=True,
            text=True,
            timeout=timeout,
        )
    except subprocess.TimeoutExpired:
        return "timeout", [], f"over {timeout:.0f} s"
    text = out.stdout + out.stderr
    failed = FAILED.findall(text)
    panic = PANIC.search(text)
    why = f"{panic.group(1)}: {panic.group(2)[:300]}" if panic else ""
    if out.returncode == 0:
        return "pass", [], ""
    if not failed:
        # A crash (abort, device loss) outside a test's own report.
        failed = ["(binary crashed: exit %d)" % out.returncode]
        why = why or text[-300:]
    return "fail", failed, why


# ---------------------------------------------------------------- runs


RESULTS = ROOT / "scripts" / "mutants-results.json"


def load_results(scratch: Path) -> dict:
    """The committed results (scripts/mutants-results.json; `scratch` is
    not read: a new machine keeps them). Without that file, they are seeded
    from docs/mutation.md's table: a row counts only where its mutation
    text is the list entry's current find → replace."""
    if RESULTS.is_file():
        return json.loads(RESULTS.read_text())
    return seed_from_table(load_list(DEFAULT_LIST))


def save_results(scratch: Path, results: dict) -> None:
    tmp = RESULTS.with_suffix(".tmp")
    tmp.write_text(json.dumps(results, indent=1, sort_keys=True) + "\n")
    tmp.replace(RESULTS)


def seed_from_table(data: dict) -> dict:
    """Results read back from the generated table of docs/mutation.md."""
    if not REPORT.is_file():
        return {}
    entries = {m["id"]: m for m in data["mutant"]}
    results = {}
    for row in REPORT.read_text().splitlines():
        if not row.startswith("| ") or row.startswith("| id "):
            continue
        cells = [c.strip() for c in re.split(r"(?<!\\)\|", row)[1:-1]]
        if len(cells) != 7 or cells[0] not in entries:
            continue
        m = entries[cells[0]]
        if cells[3] != f"`{cell(m['find'])}` → `{cell(m['replace'])}`":
            continue
        result = cells[4].strip("*")
        if result == "equivalent":
            result = "survived"
        if result not in ("killed", "survived", "timeout"):
            continue
        killers = re.findall(r"`([^`]+)`", cells[5])
        binary = killers[0].split("::")[0] if killers else ""
        line = cells[1].strip("`").rpartition(":")[2]
        results[m["id"]] = {
            "result": result,
            "find": m["find"],
            "replace": m["replace"],
            "line": int(line) if line.isdigit() else "?",
            "target": binary,
            "killers": [k.split("::", 1)[1] for k in killers if "::" in k],
            "detail": "seeded from docs/mutation.md",
        }
    return results


def baseline(data: dict, scratch: Path, threads: int) -> None:
    repo = sync_scratch(scratch)
    env = cargo_env(scratch)
    times = {}
    for target in existing(repo, data["targets"]["default"]):
        binary, module = split_target(target)
        t0 = time.time()
        status, exe = build_target(repo, env, binary, 3600)
        if status != "ok":
            sys.exit(f"baseline: {target}: {status}\n{exe}")
        t1 = time.time()
        status, failed, why = run_target(repo, env, exe, threads, 1800, module)
        t2 = time.time()
        print(f"baseline {target}: build {t1 - t0:.0f} s, run {t2 - t1:.1f} s: {status} {failed} {why}")
        if status != "pass":
            sys.exit("baseline fails: fix the tree before mutating it")
        times[target] = t2 - t1
    results = load_results(scratch)
    if data.get("only_targets"):
        # --targets: the other targets keep their recorded times.
        times = {**results.get("_baseline", {}).get("times", {}), **times}
    results["_baseline"] = {"times": times, "when": time.strftime("%Y-%m-%d %H:%M")}
    save_results(scratch, results)


def run_mutant(data: dict, m: dict, repo: Path, env: dict, threads: int, times: dict) -> dict:
    path = repo / m["file"]
    original = path.read_bytes()
    digest = sha256(original)
    line, why = locate(repo, m)
    if line is None:
        return {"result": "refused", "detail": why}
    text = original.decode()
    mutated = text.replace(m["find"], m["replace"], 1).encode()
    record = {"line": line, "killers": [], "detail": "", "target": ""}
    started = time.time()
    try:
        path.write_bytes(mutated)
        result = "survived"
        built: dict[str, str] = {}  # binary → executable: one build per mutant
        for target in targets_for(data, m, repo):
            binary, module = split_target(target)
            if binary not in built:
                status, exe = build_target(repo, env, binary, 1800)
                if status != "ok":
                    result = status
                    record["detail"] = exe[-600:]
                    record["target"] = target
                    break
                built[binary] = exe
            limit = max(120.0, 6.0 * times.get(target, 60.0))
            status, failed, why = run_target(repo, env, built[binary], threads, limit, module)
            if status == "pass":
                continue
            result = "killed" if status == "fail" else "timeout"
            record["target"] = target
            record["killers"] = failed
            record["detail"] = why
            if target == "gpu::shaders" and status == "fail":
                # Rejected by naga before any GPU ran: not a behaviour test.
                result = "invalid"
            break
        record["result"] = result
    finally:
        path.write_bytes(original)
        if sha256(path.read_bytes()) != digest:
            sys.exit(f"RESTORE FAILED for {path}: scratch copy differs from the original")
    record["seconds"] = round(time.time() - started, 1)
    record["when"] = time.strftime("%Y-%m-%d %H:%M")
    return record


def stop_on_signals() -> None:
    """SIGTERM / SIGHUP end the run like Ctrl-C: as an exception, so the
    `finally` of the mutant under test restores its file (and verifies it)
    before the harness exits. (A SIGKILL cannot be caught: the next run's
    sync rewrites every scratch file that differs from the tree.)"""

    def handler(signum, _frame):
        raise KeyboardInterrupt(f"signal {signum}")

    for sig in (signal.SIGTERM, signal.SIGHUP):
        signal.signal(sig, handler)


def run(data: dict, scratch: Path, ids: list[str], threads: int, budget: float) -> None:
    results = load_results(scratch)
    if "_baseline" not in results:
        sys.exit("run --baseline first (it also records the per-target times)")
    times = results["_baseline"]["times"]
    repo = sync_scratch(scratch)
    env = cargo_env(scratch)
    mutants = {m["id"]: m for m in data["mutant"]}
    started = time.time()
    stop_on_signals()
    stop_file = scratch / "STOP"
    for n, mid in enumerate(ids):
        if stop_file.exists():
            stop_file.unlink()
            print(f"{stop_file} found: stopping between mutants; {len(ids) - n} left")
            break
        if time.time() - started > budget:
            print(f"time budget of {budget / 60:.0f} min spent; {len(ids) - n} mutants left")
            break
        m = mutants[mid]
        print(f"[{n + 1}/{len(ids)}] {mid} {m['file']} ({m['class']}) ...", flush=True)
        record = run_mutant(data, m, repo, env, threads, times)
        record["find"], record["replace"] = m["find"], m["replace"]
        results[mid] = record
        save_results(scratch, results)
        killers = ", ".join(record.get("killers", []))
        print(
            f"    {record['result']} ({record.get('target', '')}: {killers}) "
            f"in {record.get('seconds', 0)} s",
            flush=True,
        )


# ---------------------------------------------------------------- report


def cell(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ")


def report(data: dict, scratch: Path, out: Path) -> None:
    results = load_results(scratch)
    rows = []
    counts: dict[str, int] = {}
    for m in data["mutant"]:
        r = results.get(m["id"])
        stale = r is not None and (r.get("find"), r.get("replace")) != (m["find"], m["replace"])
        if r is None or stale:
            result, where, killer = "not run", m["file"], ""
        else:
            result = r["result"]
            where = f"{m['file']}:{r.get('line', '?')}"
            binary = split_target(r["target"])[0]
            killer = ", ".join(f"`{binary}::{k}`" for k in r.get("killers", []))
        if result == "survived" and m.get("equivalent"):
            result = "equivalent"
        counts[result] = counts.get(result, 0) + 1
        why = m.get("note", "")
        if result == "equivalent":
            why += f" **Equivalent:** {m['equivalent']}"
        elif result == "survived":
            why += f" **Survivor:** {m.get('survivor', 'unexplained')}"
        if m.get("killed_by_new"):
            why += f" (new test: {m['killed_by_new']})"
        rows.append(
            f"| {m['id']} | `{cell(where)}` | {cell(m['class'])} | "
            f"`{cell(m['find'])}` → `{cell(m['replace'])}` | **{result}** | {killer} | {cell(why.strip())} |"
        )
    scored = sum(counts.get(k, 0) for k in ("killed", "survived", "timeout"))
    killed = counts.get("killed", 0) + counts.get("timeout", 0)
    score = f"{killed} of {scored} non-equivalent mutants killed ({100.0 * killed / scored:.1f} %)" if scored else "no mutant run"
    text = out.read_text() if out.is_file() else ""
    begin, end = "<!-- mutants:begin", "<!-- mutants:end -->"
    table = [
        f"{begin} (generated by scripts/mutants.sh --report; edits here are overwritten) -->",
        "",
        f"**{score}**; " + ", ".join(f"{v} {k}" for k, v in sorted(counts.items())) + ".",
        "",
        "| id | where | class | mutation | result | killed by | note |",
        "|---|---|---|---|---|---|---|",
        *rows,
        "",
        end,
    ]
    if begin in text and end in text:
        head = text[: text.index(begin)]
        tail = text[text.index(end) + len(end):]
        text = head + "\n".join(table) + tail
    else:
        text = text + "\n" + "\n".join(table) + "\n"
    out.write_text(text)
    print(f"{out}: {score}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--list", type=Path, default=DEFAULT_LIST)
    ap.add_argument("--scratch", type=Path, default=DEFAULT_SCRATCH)
    ap.add_argument("--check", action="store_true", help="locate every snippet; no build")
    ap.add_argument("--baseline", action="store_true", help="build and run the unmutated scratch copy")
    ap.add_argument("--report", action="store_true", help="write docs/mutation.md")
    ap.add_argument("--only", help="comma-separated mutant ids")
    ap.add_argument("--from", dest="start", help="first mutant id")
    ap.add_argument("--limit", type=int, help="at most this many mutants")
    ap.add_argument("--pending", action="store_true", help="only mutants without a current result")
    ap.add_argument("--threads", type=int, default=2, help="libtest threads per binary")
    ap.add_argument("--budget-min", type=float, default=45.0, help="stop starting mutants after this long")
    ap.add_argument(
        "--targets",
        help="comma-separated test targets: run (and, with --baseline, time) only these, in this order",
    )
    args = ap.parse_args()
    data = load_list(args.list)
    if args.targets:
        data["only_targets"] = args.targets.split(",")
        data["targets"]["default"] = data["only_targets"]

    if args.check:
        bad = 0
        for m in data["mutant"]:
            line, why = locate(ROOT, m)
            if line is None:
                bad += 1
                print(f"{m['id']}: REFUSED: {why}")
            else:
                print(f"{m['id']}: {m['file']}:{line} ({m['class']})")
        files = {m["file"] for m in data["mutant"]}
        print(f"{len(data['mutant'])} mutants over {len(files)} files; {bad} refused")
        sys.exit(1 if bad else 0)
    if args.report:
        report(data, args.scratch, REPORT)
        return
    if args.baseline:
        baseline(data, args.scratch, args.threads)
        return
    ids = [m["id"] for m in data["mutant"]]
    if args.only:
        wanted = args.only.split(",")
        unknown = [w for w in wanted if w not in ids]
        if unknown:
            sys.exit(f"unknown mutant ids: {unknown}")
        ids = wanted
    if args.start:
        ids = ids[ids.index(args.start):]
    if args.pending:
        results = load_results(args.scratch)
        byid = {m["id"]: m for m in data["mutant"]}
        ids = [
            i for i in ids
            if i not in results
            or (results[i].get("find"), results[i].get("replace")) != (byid[i]["find"], byid[i]["replace"])
        ]
    if args.limit:
        ids = ids[: args.limit]
    run(data, args.scratch, ids, args.threads, args.budget_min * 60)


if __name__ == "__main__":
    main()
