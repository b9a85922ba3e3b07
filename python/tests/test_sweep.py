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
