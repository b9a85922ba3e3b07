#!/usr/bin/env python3
"""The device check's report: reads what scripts/device-check.sh left in
OUT (steps.tsv, logs/*.log) and writes OUT/report.json and OUT/report.md.

    info       `hyperpbd info`: adapter line, passthrough, shader path
    compare    per shader path, precision and scene: frames, frames that
               differ (f64: max |dx| or |dv| > 0 against the golden path;
               f32: not bit-identical to the f32 reference), largest
               difference, exit code (3: over the bound or, with --exact,
               off the f32 reference)
    plan       compute dispatches per step of each scene
    bench      the JSON lines of src/bin/device_bench.rs
    cupy       scripts/cupy_baseline.py's JSON (or its skip)

Usage: device_report.py OUT [--dry]
"""
import json
import os
import re
import sys


def read(path):
    try:
        with open(path, encoding="utf-8", errors="replace") as f:
            return f.read()
    except OSError:
        return None


def steps(out):
    rows = {}
    for line in (read(os.path.join(out, "steps.tsv")) or "").splitlines():
        parts = line.split("\t")
        if len(parts) == 3:
            rows[parts[0]] = {"rc": parts[1], "ms": int(parts[2]) if parts[2].isdigit() else None}
    return rows


FRAME = re.compile(r"^\s*(\d+)\s+(\S+)\s+(\S+)\s+(\S+)\s+(\S+)\s+(\S+)\s+(ok|OVER)\s*$")


def compare(text, precision):
    """Frames, differing frames and the largest difference of one run."""
    frames = differing = 0
    largest = 0.0
    over = 0
    referenced = False
    for line in text.splitlines():
        m = FRAME.match(line)
        if not m:
            continue
        frames += 1
        dx, dv, ref = float(m.group(2)), float(m.group(4)), m.group(6)
        over += m.group(7) == "OVER"
        if precision == "f64":
            diff = max(dx, dv)
        elif ref == "exact":
            diff = 0.0
        elif ref == "-":
            diff = None
        else:
            diff = float(ref)
        if diff is None:
            continue
        referenced = True
        if diff != 0.0:
            differing += 1
        largest = max(largest, diff)
    if precision == "f32" and frames > 0 and not referenced:
        # No f32 reference for this plan: only the bound against the golden
        # path was checked (rc), bit-identity does not apply.
        return {"frames": frames, "differing": None, "largest": None, "over": over,
                "note": "no f32 reference (bound only)"}
    return {"frames": frames, "differing": differing, "largest": largest, "over": over}


def main():
    if len(sys.argv) < 2:
        print(__doc__, file=sys.stderr)
        return 2
    out = sys.argv[1]
    dry = "--dry" in sys.argv[2:]
    logs = os.path.join(out, "logs")
    table = steps(out)
    report = {"dry": dry, "steps": table}

    info = read(os.path.join(logs, "info.log")) or ""
    report["info"] = info.strip().splitlines()
    report["passthrough"] = "passthrough: yes" in info
    path = re.search(r"shader path: (\w+)", info)
    report["shader_path"] = path.group(1) if path else None

    report["compare"] = []
    report["plan"] = {}
    for name in sorted(table):
        text = read(os.path.join(logs, name + ".log")) or ""
        if name.startswith("compare-"):
            _, shader, precision, scene = name.split("-", 3)
            row = {"path": shader, "precision": precision, "scene": scene,
                   "rc": table[name]["rc"], "ms": table[name]["ms"]}
            row.update(compare(text, precision))
            if row["frames"] == 0:
                row["error"] = (text.strip().splitlines() or ["no output"])[-1]
            report["compare"].append(row)
        elif name.startswith("plan-"):
            m = re.search(r"(\d+) compute dispatches per step", text)
            report["plan"][name[5:]] = int(m.group(1)) if m else None

    bench = []
    for line in (read(os.path.join(logs, "bench.log")) or "").splitlines():
        line = line.strip()
        if line.startswith("{"):
            try:
                bench.append(json.loads(line))
            except json.JSONDecodeError:
                pass
    report["bench"] = bench

    cupy = (read(os.path.join(logs, "cupy.log")) or "").strip().splitlines()
    try:
        report["cupy"] = json.loads(cupy[-1]) if cupy else {"skipped": "no output"}
    except json.JSONDecodeError:
        report["cupy"] = {"skipped": "unreadable output: " + cupy[-1]}

    with open(os.path.join(out, "report.json"), "w", encoding="utf-8") as f:
        json.dump(report, f, indent=1)
        f.write("\n")
    with open(os.path.join(out, "report.md"), "w", encoding="utf-8") as f:
        f.write(markdown(report))
    return 0


def fmt(x, unit=""):
    if x is None:
        return "-"
    if isinstance(x, float):
        return f"{x:.3e}{unit}"
    return f"{x}{unit}"


def markdown(r):
    lines = ["# hyperpbd device check" + (" (dry run)" if r["dry"] else ""), ""]
    lines += ["## Adapter", "", "```"] + r["info"] + ["```", ""]
    lines += ["## Differential (frames that differ / frames; largest difference)", "",
              "f64: against the golden path (max |dx|, |dv|); f32: against the f32 "
              "reference (`--exact`). rc 3: over the bound or off the reference.", "",
              "| path | precision | scene | differing / frames | largest | rc |",
              "|---|---|---|---:|---:|---:|"]
    for c in r["compare"]:
        tail = f" ({c['error']})" if "error" in c else (f" ({c['note']})" if "note" in c else "")
        lines.append(f"| {c['path']} | {c['precision']} | {c['scene']} | "
                     f"{fmt(c['differing'])} / {c['frames']} | {fmt(c['largest'])} | {c['rc']}{tail} |")
    lines += ["", "## Dispatches per step (hyperpbd plan)", "", "| scene | dispatches |", "|---|---:|"]
    for scene, n in r["plan"].items():
        lines.append(f"| {scene} | {fmt(n)} |")
    lines += ["", "## Timings (src/bin/device_bench.rs, median s)", ""]
    for row in r["bench"]:
        kind = row.get("kind")
        rest = ", ".join(f"{k} {fmt(v)}" for k, v in row.items() if k != "kind")
        lines.append(f"- **{kind}**: {rest}")
    lines += ["", "## CUDA floor (CuPy)", ""]
    lines += [f"- {k}: {fmt(v)}" for k, v in r["cupy"].items()]
    lines += ["", "## Steps (rc, ms)", "", "| step | rc | ms |", "|---|---:|---:|"]
    for name, s in r["steps"].items():
        lines.append(f"| {name} | {s['rc']} | {fmt(s['ms'])} |")
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    sys.exit(main())
