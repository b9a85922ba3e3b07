"""hp.sweep: the worlds of `hyperpbd sweep`, bit for bit."""

import json

import numpy as np
import pytest

import hyperpbd as hp
from conftest import REPO, cli, finish

FRAMES = 20


def cli_sweep(path, sets, backend, tmp_path):
    out = tmp_path / "sweep.jsonl"
    args = ["sweep", str(path), "--frames", str(FRAMES), "--backend", backend, "--out", str(out)]
    for s in sets:
        args += ["--set", s]
    finish(cli(*args))
    return [json.loads(line) for line in out.read_text().splitlines()]


def same_bits(actual, expected):
    return actual.tobytes() == np.asarray(expected, dtype=np.float64).reshape(actual.shape).tobytes()


@pytest.mark.parametrize("threads", [1, 2])
def test_sweep_equals_the_cli_sweep(tmp_path, threads):
    path = REPO / "scenes" / "chain2d.json"
    lines = cli_sweep(path, ["damping.rate=0:1:3", "gravity[1]=-9.81:-1:2"], "cpu", tmp_path)
    rows = hp.sweep(
        hp.Scene.load(path),
        {"damping.rate": [0.0, 0.5, 1.0], "gravity[1]": "-9.81:-1:2"},
        frames=FRAMES,
        backend="cpu",
        threads=threads,
    )
    assert len(rows) == len(lines) == 6
    for row, line in zip(rows, lines):
        assert row["world"] == line["world"]
        assert row["set"] == line["set"]
        assert same_bits(row["positions"], line["positions"])
        assert same_bits(row["velocities"], line["velocities"])
        assert row["report"]["max_violation"] == line["report"]["max_violation"]
        assert row["backend"] == "cpu-f64"


def test_sweep_world_equals_a_simulation_of_that_scene():
    scene = hp.Scene.builtin("cloth")
    rows = hp.sweep(scene, {"obstacles[0].friction": [0.0, 0.8]}, frames=10, backend="cpu")
    document = json.loads(scene.to_json())
    for row, friction in zip(rows, [0.0, 0.8]):
        document["obstacles"][0]["friction"] = friction
        sim = hp.Simulation(hp.Scene.from_json(json.dumps(document)), backend="cpu")
        sim.step(frames=10)
        assert sim.positions.tobytes() == row["positions"].tobytes()


def test_sweep_refuses_bad_worlds_before_running():
    scene = hp.Scene.builtin("chain2d")
    with pytest.raises(hp.SceneError) as caught:
        hp.sweep(scene, {"particles[2].mass": [1.0, -1.0]}, frames=1, backend="cpu")
    assert caught.value.path == "particles[2].mass"
    assert str(caught.value).startswith("worlds[1] (particles[2].mass=-1): ")
    with pytest.raises(hp.SceneError) as caught:
        hp.sweep(scene, {"particles[99].mass": [1.0]}, frames=1, backend="cpu")
    assert caught.value.path == "particles[99].mass"
    with pytest.raises(ValueError, match="no values"):
        hp.sweep(scene, {"damping.rate": []}, frames=1, backend="cpu")
    with pytest.raises(ValueError, match="COUNT"):
        hp.sweep(scene, {"damping.rate": "0:1:0"}, frames=1, backend="cpu")


@pytest.mark.parametrize(
    "scene, sets, worlds",
    [
        # XPBD chains, damping swept from 0: one batch in the same dispatches.
        ("chain2d.json", {"damping.rate": "0:1:3", "gravity[1]": "-9.81:-1:2"}, 6),
        # The implicit chain (coupled step): one batch, the worlds in lockstep.
        ("chain2d_implicit.json", {"gravity[1]": "-12:-6:3"}, 3),
    ],
)
def test_a_gpu_sweep_is_one_batch_equal_to_the_cli_and_the_cpu(tmp_path, gpu_f64, scene, sets, worlds):
    path = REPO / "scenes" / scene
    axes = [f"{p}={v}" for p, v in sets.items()]
    cpu = cli_sweep(path, axes, "cpu", tmp_path)
    gpu = cli_sweep(path, axes, "gpu-f64", tmp_path)
    rows = hp.sweep(hp.Scene.load(path), sets, frames=FRAMES, backend=gpu_f64)
    assert len(rows) == len(cpu) == len(gpu) == worlds
    for row, c, g in zip(rows, cpu, gpu):
        assert row["backend"] == f"gpu-f64, {worlds} worlds per batch"
        # gpu-f64 on lavapipe is the golden path bit for bit; the batch is
        # the CLI's batch on any adapter.
        assert same_bits(row["positions"], g["positions"])
        assert same_bits(row["velocities"], g["velocities"])
        assert same_bits(row["positions"], c["positions"])
        assert row["report"]["max_violation"] == c["report"]["max_violation"]


def test_a_gpu_sweep_of_another_topology_warns_and_runs_one_backend_each(gpu_f64):
    scene = hp.Scene.builtin("chain2d")
    with pytest.warns(UserWarning, match=r"one GPU backend each: worlds\[1\]\.particles\[1\]\.mass"):
        rows = hp.sweep(scene, {"particles[1].mass": [1.0, 2.0]}, frames=5, backend=gpu_f64)
    cpu = hp.sweep(scene, {"particles[1].mass": [1.0, 2.0]}, frames=5, backend="cpu")
    assert [r["backend"] for r in rows] == ["gpu-f64", "gpu-f64"]
    for row, c in zip(rows, cpu):
        assert row["positions"].tobytes() == c["positions"].tobytes()
