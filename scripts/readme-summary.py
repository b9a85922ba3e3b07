#!/usr/bin/env python3
"""Rewrites the README's headline table from the docs' own tables.

    scripts/readme-summary.py           rewrites the block between
                                        <!-- summary:begin … --> and
                                        <!-- summary:end --> in README.md
    scripts/readme-summary.py --check   exits 1 when the block is stale

Every figure is read from a generated or measured table in docs/ (never
typed here): docs/bounds.md (bounds-all and materials blocks, written by
scripts/bounds-table.py), docs/mutation.md (the mutants block, written by
scripts/mutants.sh --report), docs/accuracy.md (written by
scripts/accuracy.sh) and docs/performance-log.md (criterion runs). A row
that cannot be found is an error, so the table cannot silently go stale
when a source table changes shape.
"""

import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
BEGIN = "<!-- summary:begin"
END = "<!-- summary:end -->"


def read(name: str) -> str:
    return (ROOT / "docs" / name).read_text()


def block(text: str, marker: str) -> str:
    start = text.index(f"<!-- {marker}:begin")
    return text[start : text.index(f"<!-- {marker}:end -->", start)]


def rows(table_text: str) -> list[list[str]]:
    out = []
    for line in table_text.splitlines():
        if line.startswith("|") and not set(line) <= set("|-: "):
            out.append([c.strip() for c in line.strip().strip("|").split("|")])
    return out[1:]  # drop the header


def row(table: list[list[str]], first: str) -> list[str]:
    for r in table:
        if r[0] == first:
            return r
    sys.exit(f"readme-summary: no row {first!r}")


def need(pattern: str, text: str, what: str) -> re.Match:
    m = re.search(pattern, text)
    if not m:
        sys.exit(f"readme-summary: {what} not found")
    return m


def exact(cell: str) -> bool:
    """A cell that says bit-identical: `0 (exact)`, or a zero difference
    held to a zero bound (`0 / 0`, `0.000e0 / 0`; active contacts `0 / -`)."""
    return cell == "0 (exact)" or re.fullmatch(r"0(\.0+e0)? / (0|-)", cell) is not None


def whole_steps() -> list[str]:
    table = rows(block(read("bounds.md"), "bounds-all"))
    scenes = sorted({r[0] for r in table})
    f64_all = {s for s in scenes if all(exact(r[4]) for r in table if r[0] == s)}
    f32_ref = {s for s in scenes
               if all("(= f32 reference)" in r[3] or exact(r[3]) for r in table if r[0] == s)}
    ratios = [float(x) for r in table for x in re.findall(r"model [^;|]*? / [^ ]+ \(([0-9.e+-]+)\)", r[3])]
    if not scenes or not ratios:
        sys.exit("readme-summary: empty bounds-all table")
    link = "[bounds](docs/bounds.md#whole-step-table)"
    return [
        f"| XPBD whole steps, gpu-f64 on lavapipe | bit-identical to the golden path in {len(f64_all)} of {len(scenes)} scenes (every metric, every frame) | {link} |",
        f"| XPBD whole steps, gpu-f32 on lavapipe | bit-identical to the f32 reference in {len(f32_ref)} of {len(scenes)} scenes | {link} |",
        f"| XPBD whole steps, f32 model for other adapters | worst measured / bound {max(ratios):.2g} | {link} |",
    ]


def materials() -> str:
    table = rows(block(read("bounds.md"), "materials"))
    exact = [r for r in table if r[-1] == "0 (exact), 0 (exact), 0 (exact)"]
    return (f"| material families (StVK, Neo-Hookean), gpu-f64 | bit-identical to the golden path in "
            f"{len(exact)} of {len(table)} scenes | [bounds](docs/bounds.md#materials-on-the-gpu) |")


def mutation() -> str:
    m = need(r"\*\*(\d+) of (\d+) non-equivalent mutants killed \(([\d.]+) %\)\*\*",
             block(read("mutation.md"), "mutants"), "the mutation tally")
    return (f"| mutants of kernels, dispatch and golden path | {m[1]} of {m[2]} non-equivalent killed "
            f"({m[3]} %) | [mutation](docs/mutation.md) |")


def accuracy() -> str:
    r = row(rows(read("accuracy.md").split("## Headline answers", 1)[1].split("\n## ", 1)[0]), "cloth")
    cost = re.sub(r"\*\*", "", r[2])
    return (f"| hanging cloth 16×16 to 1e-3 relative error, cpu-f64 | {cost} per simulated second "
            f"| [accuracy](docs/accuracy.md#headline-answers) |")


def performance() -> list[str]:
    log = read("performance-log.md")
    cloth = row(rows(log), "256²")
    free = row(rows(log), "run 1: 2 threads vs Taichi 1 thread")
    busy = row(rows(log), "run 2: 2 threads vs Taichi 1 thread")
    again = row(rows(log), "run 3: 2 threads vs Taichi 1 thread")
    return [
        f"| 256² hanging cloth step, cpu-f64 one thread / gpu-f32 lavapipe | {cloth[2]} / {cloth[3]} "
        f"| [performance log](docs/performance-log.md#whole-steps-cpu-and-gpu) |",
        f"| peer cloth 128², two threads against Taichi's one (Taichi's time / ours, median batch) "
        f"| {again[3].replace('**', '')}–{free[3].replace('**', '')} with both cores free (two runs), "
        f"{busy[3].replace('**', '')} with one busy "
        f"| [performance log](docs/performance-log.md#the-cpu-golden-path-on-every-core) |",
    ]


def batches() -> str:
    sweeps, log = rows(read("sweeps.md")), rows(read("performance-log.md"))
    plain = lambda cell: cell.replace("**", "").split(" (")[0]
    damping = plain(row(sweeps, "batch ratio after: batch / (256 × one world of the round)")[4])
    pits = [r for r in log if r[0] == "gpu-f64" and "16 224 balls" in r[1]]
    if not pits:
        sys.exit("readme-summary: no 16k pit batch row")
    pit = plain(pits[-1][6])
    guarded = {(r[0], r[1]): plain(r[4]) for r in sweeps if r[1:2] == ["in lockstep"]}
    landing = guarded.get(("12 (landing)", "in lockstep"))
    resting = guarded.get(("60 (then resting)", "in lockstep"))
    if landing is None or resting is None:
        sys.exit("readme-summary: no guarded batch rows")
    implicit = plain(row(sweeps, "batch / 16 single runs")[4])
    waits = row(sweeps, "host waits per 30 frames")[4].split(" (")[0]
    return (f"| GPU batch / its worlds' single GPU runs, lavapipe (medians) | chains, damping swept "
            f"from 0, 256 worlds: {damping}; 16k-ball pit's friction, 8 worlds: {pit} (gpu-f64); "
            f"guarded material drop, 16 worlds: {landing} landing, {resting} resting; implicit "
            f"chain, 16 worlds: {implicit}, host waits {waits} "
            f"| [sweeps](docs/sweeps.md#on-the-gpu) |")


def table() -> str:
    lines = ["| what | figure | source |", "|---|---|---|"]
    lines += whole_steps()
    lines.append(materials())
    lines.append(mutation())
    lines.append(accuracy())
    lines += performance()
    lines.append(batches())
    return "\n".join(lines)


def main() -> None:
    path = ROOT / "README.md"
    text = path.read_text()
    if BEGIN not in text or END not in text:
        sys.exit(f"{path}: no {BEGIN} … {END} markers")
    head = text[: text.index(BEGIN)]
    begin_line = text[text.index(BEGIN) :].split("\n", 1)[0]
    tail = text[text.index(END) + len(END) :]
    new = f"{head}{begin_line}\n{table()}\n{END}{tail}"
    if "--check" in sys.argv[1:]:
        if new != text:
            sys.exit("readme-summary: README.md's summary is stale; run scripts/readme-summary.py")
        return
    path.write_text(new)
    print("README.md summary rewritten")


if __name__ == "__main__":
    main()
