"""Shared helpers: the repository, the `hyperpbd` CLI, GPU availability.

GPU tests run on whatever adapter wgpu finds (lavapipe in CI). Without one
they skip with the reason printed (pytest -rs), unless
HYPERPBD_REQUIRE_GPU=1, where a missing adapter fails, as in the Rust suite.
"""

import json
import os
import pathlib
import re
import subprocess

import pytest

import hyperpbd as hp

REPO = pathlib.Path(__file__).resolve().parents[2]
SCENES = sorted((REPO / "scenes").glob("*.json"))


def cli_path() -> pathlib.Path:
    """The CLI binary: $HYPERPBD_CLI, else target/release/hyperpbd."""
    path = pathlib.Path(os.environ.get("HYPERPBD_CLI", REPO / "target" / "release" / "hyperpbd"))
    if not path.exists():
        pytest.fail(f"{path} not found: build it with `cargo build --release` (or set HYPERPBD_CLI)")
    return path


def cli(*args: str) -> subprocess.Popen:
    """Starts `hyperpbd ARGS` (stdout and stderr captured as text)."""
    return subprocess.Popen(
        [str(cli_path()), *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def finish(process: subprocess.Popen) -> str:
    """Waits for a CLI run; its stdout, or a failure with its stderr."""
    out, err = process.communicate()
    assert process.returncode == 0, f"hyperpbd failed ({process.returncode}): {err}"
    return out


def printed_hash(stdout: str) -> str:
    """The `state hash X` line of `hyperpbd run`."""
    match = re.search(r"state hash ([0-9a-f]{16})", stdout)
    assert match, stdout
    return match.group(1)


def read_out(path: pathlib.Path) -> dict:
    """A `--out` state record."""
    return json.loads(path.read_text())


def require_gpu() -> bool:
    return os.environ.get("HYPERPBD_REQUIRE_GPU") == "1"


@pytest.fixture(scope="session")
def gpu_f64():
    """Skips (or, with HYPERPBD_REQUIRE_GPU=1, fails) without an f64 adapter."""
    try:
        sim = hp.Simulation(hp.Scene.builtin("chain2d"), backend="gpu-f64")
    except hp.GpuError as e:
        if require_gpu():
            pytest.fail(f"HYPERPBD_REQUIRE_GPU=1 but no gpu-f64 adapter: {e}")
        pytest.skip(f"SKIPPED: no adapter with SHADER_F64 ({e})")
    sim.close()
    return "gpu-f64"
