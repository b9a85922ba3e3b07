#!/usr/bin/env python3
"""Regenerates the CPU/GPU bounds tables from the tests' own BOUND lines.

    scripts/bounds-table.py            runs the modules differential, kernels
                                       and materials of tests/gpu/ (lavapipe)
                                       and rewrites the tables between the
                                       markers <!-- bounds-all:begin … -->,
                                       <!-- kernels:begin … --> and
                                       <!-- materials:begin … --> in docs/bounds.md
                                       (the README's summary table is built from these
                                       by scripts/readme-summary.py)
    scripts/bounds-table.py FILE       the same from saved test output (all three modules')

A BOUND line of tests/common/differential.rs reads
    BOUND | scene | metric | frames | measured | bound | precision
with measured and bound of the frame with the largest measured / bound, one
frame from the GPU's previous state; a bound of `exact` means bit-identical
to its reference, asserted on llvmpipe every frame from the start (f64: the
golden path; f32: the f32 reference, hyperpbd_cpu::f32_reference), measured
then the largest over the frames. Exact f32 rows come with `position model`
and `velocity model` rows: the per-frame model bound any other adapter is
held to (asserted on llvmpipe too).
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
# The modules of tests/gpu/ whose lines the tables hold; their tests are
# listed and run with `--exact` (a plain filter `kernels::` would also run
# `barrier::kernels::…`, and `materials::` `coupled::materials::…`).
MODULES = ("differential", "kernels", "materials")
CARGO = ["cargo", "test", "--release", "--test", "gpu", "--"]


def command(env: dict) -> list[str]:
    """The cargo command that runs every test of MODULES and no other."""
    listing = subprocess.run(
        CARGO + ["--list", "--format=terse"], cwd=ROOT, env=env, capture_output=True,
        text=True, check=True,
    ).stdout
    names = [
        line[: -len(": test")]
        for line in listing.splitlines()
        if line.endswith(": test") and line.split("::")[0] in MODULES
    ]
    if not names:
        sys.exit(f"no tests of {MODULES} in tests/gpu/")
    return CARGO + ["--exact", *names, "--nocapture", "--test-threads", "2"]


def bound_lines(text: str) -> list[list[str]]:
    rows = []
    for line in text.splitlines():
        if line.startswith("BOUND | "):
            parts = [p.strip() for p in line.split("|")[1:]]
            if len(parts) == 6:
                rows.append(parts)
    return rows


def kernel_table(text: str) -> str:
    """`KERNEL | case | kernel metric | measured | bound | precision` lines
    (tests/gpu/kernels/) as one row per (case, kernel metric)."""
    rows: dict[tuple[str, str], dict[str, tuple[str, str]]] = {}
    for line in text.splitlines():
        if not line.startswith("KERNEL | "):
            continue
        parts = [p.strip() for p in line.split("|")[1:]]
        if len(parts) != 5:
            continue
        case, metric, measured, bound, precision = parts
        rows.setdefault((case, metric), {})[precision] = (measured, bound)
    out = [
        "| case | kernel, metric | f32 measured / bound (ratio) | f64 |",
        "|---|---|---:|---|",
    ]
    for (case, metric), by in sorted(rows.items()):
        if metric.endswith(" model"):
            continue  # beside its exact row
        f32, f64 = by.get("f32"), by.get("f64")
        model = rows.get((case, f"{metric} model"), {}).get("f32")
        zero = lambda m: float(m) == 0.0
        if f32 and f64 and zero(f32[0]) and f32[1] in ("0", "0.000e0", "exact") and zero(f64[0]):
            continue  # both zero: asserted equal, measured 0 (see the text)
        out.append(
            f"| {case} | {metric} | {with_model(f32, model)} | {cell(*f64) if f64 else '—'} |"
        )
    return "\n".join(out)


def ratio(measured: str, bound: str) -> str:
    try:
        m, b = float(measured), float(bound)
    except ValueError:
        return ""
    if b == 0.0:
        return ""
    return f"{m / b:.2g}"


def cell(measured: str, bound: str) -> str:
    if bound == "exact":
        return f"{measured} (exact)" if float(measured) != 0.0 else "0 (exact)"
    r = ratio(measured, bound)
    return f"{measured} / {bound}" + (f" (**{r}**)" if r else "")


def with_model(row, model) -> str:
    """An f32 cell: the row, and where it is exact the model's bound for
    other adapters beside it."""
    if not row:
        return "—"
    if model and row[1] == "exact":
        r = ratio(*model)
        return f"{f32_cell(row)}; model {model[0]} / {model[1]}" + (f" ({r})" if r else "")
    return f32_cell(row)


def f32_cell(row) -> str:
    """An f32 row: exact rows are the f32 reference's value, bit for bit."""
    if row[1] == "exact":
        return f"{row[0] if float(row[0]) != 0.0 else '0'} (= f32 reference)"
    return cell(*row)


def by_scene(rows: list[list[str]]) -> dict[str, dict]:
    """Per scene: its frames, and (metric, precision) → (measured, bound)."""
    scenes: dict[str, dict] = {}
    for scene, metric, frames, measured, bound, precision in rows:
        s = scenes.setdefault(scene, {"frames": frames})
        s[(metric, precision)] = (measured, bound)
    return scenes


def tables(rows: list[list[str]]) -> tuple[str, str]:
    scenes = by_scene(rows)
    head = [
        "| scene | frames | position f32, one frame (model: other adapters) | velocity f32, one frame | f64 position, velocity |",
        "|---|---:|---:|---:|---|",
    ]
    short = []
    for scene in sorted(scenes):
        s = scenes[scene]
        pos = s.get(("position", "f32"))
        vel = s.get(("velocity", "f32"))
        pos_model = s.get(("position model", "f32"))
        vel_model = s.get(("velocity model", "f32"))
        f64p = s.get(("position", "f64"))
        f64v = s.get(("velocity", "f64"))
        f64 = "—"
        if f64p and f64v:
            f64 = f"{cell(*f64p)}, {cell(*f64v)}"
        elif f64p:
            f64 = cell(*f64p)
        short.append(
            f"| {scene} | {s['frames']} | {with_model(pos, pos_model)} | "
            f"{with_model(vel, vel_model)} | {f64} |"
        )
    full = [
        "| scene | metric | frames | f32 measured / bound (ratio); or = f32 reference (bit-identical) and the model bound of other adapters | f64 |",
        "|---|---|---:|---:|---|",
    ]
    for scene in sorted(scenes):
        s = scenes[scene]
        order = {"position": 0, "velocity": 1}
        metrics = sorted(
            {k[0] for k in s if isinstance(k, tuple) and not k[0].endswith(" model")},
            key=lambda m: (order.get(m, 2), m),
        )
        for metric in metrics:
            f32 = s.get((metric, "f32"))
            f64 = s.get((metric, "f64"))
            model = s.get((f"{metric} model", "f32"))
            full.append(
                f"| {scene} | {metric} | {s['frames']} | "
                f"{with_model(f32, model)} | {cell(*f64) if f64 else '—'} |"
            )
    return "\n".join(head + short), "\n".join(full)


MATERIAL_LAWS = (" stvk", " neo_hookean")


def material_residual(metrics) -> str | None:
    """The residual metric of a scene's material family, if it has one."""
    for metric in metrics:
        if metric.startswith("residual ") and metric.endswith(MATERIAL_LAWS):
            return metric
    return None


def split_materials(rows: list[list[str]]) -> tuple[list[list[str]], list[list[str]]]:
    """(rows of scenes without a material family, rows of those with one:
    tests/gpu/materials.rs)."""
    material = {r[0] for r in rows if material_residual([r[1]])}
    return [r for r in rows if r[0] not in material], [r for r in rows if r[0] in material]


def materials_table(rows: list[list[str]]) -> str:
    """One row per material scene: f32 position, velocity and the material
    family's residual (= f32 reference, model beside), f64."""
    scenes = by_scene(rows)
    out = [
        "| scene | frames | position f32, one frame (model: other adapters) | velocity f32, one frame | residual f32 of the material family | f64 position, velocity, residual |",
        "|---|---:|---:|---:|---:|---|",
    ]
    for scene in sorted(scenes):
        s = scenes[scene]
        residual = material_residual(k[0] for k in s if isinstance(k, tuple))
        f32 = [
            with_model(s.get((m, "f32")), s.get((f"{m} model", "f32")))
            for m in ("position", "velocity", residual)
        ]
        f64 = [s.get((m, "f64")) for m in ("position", "velocity", residual)]
        f64_cell = ", ".join(cell(*c) for c in f64 if c) or "—"
        out.append(f"| {scene} | {s['frames']} | {' | '.join(f32)} | {f64_cell} |")
    return "\n".join(out)


def replace(path: Path, marker: str, body: str) -> None:
    text = path.read_text()
    begin = f"<!-- {marker}:begin"
    end = f"<!-- {marker}:end -->"
    if begin not in text or end not in text:
        sys.exit(f"{path}: no {begin} … {end} markers")
    head = text[: text.index(begin)]
    tail = text[text.index(end) + len(end):]
    block = (
        f"{begin} (generated by scripts/bounds-table.py from the tests' BOUND / KERNEL "
        f"lines; edits here are overwritten) -->\n{body}\n{end}"
    )
    path.write_text(head + block + tail)


def main() -> None:
    if len(sys.argv) > 1:
        text = Path(sys.argv[1]).read_text()
    else:
        env = dict(os.environ, HYPERPBD_REQUIRE_GPU="1", NODEVICE_SELECT="1")
        out = subprocess.run(command(env), cwd=ROOT, env=env, capture_output=True, text=True)
        if out.returncode != 0:
            sys.exit(out.stdout[-3000:] + out.stderr[-3000:])
        text = out.stdout
    rows = bound_lines(text)
    if not rows:
        sys.exit("no BOUND lines")
    rows, material_rows = split_materials(rows)
    _short, full = tables(rows)
    replace(ROOT / "docs" / "bounds.md", "bounds-all", full)
    replace(ROOT / "docs" / "bounds.md", "kernels", kernel_table(text))
    if material_rows:
        materials = materials_table(material_rows)
        replace(ROOT / "docs" / "bounds.md", "materials", materials)
    print(f"{len(rows)} BOUND lines → docs/bounds.md")


if __name__ == "__main__":
    main()
