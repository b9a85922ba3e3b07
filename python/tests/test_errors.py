"""Every exception class, with the Rust error's words and its path."""

import json

import numpy as np
import pytest

import hyperpbd as hp
from conftest import REPO


def chain_document() -> dict:
    return json.loads(hp.Scene.builtin("chain2d").to_json())


def test_scene_error_is_a_value_error_naming_the_field():
    document = chain_document()
    document["particles"][3]["mass"] = -1.0
    with pytest.raises(hp.SceneError) as caught:
        hp.Scene.from_json(json.dumps(document))
    assert isinstance(caught.value, ValueError)
    assert caught.value.path == "particles[3].mass"
    assert str(caught.value).startswith("particles[3].mass: mass must be > 0, got -1")


def test_scene_error_paths_of_schema_and_validation_errors():
    cases = [
        (lambda d: d.update(dt=0.0), "dt"),
        (lambda d: d["particles"][2].update(position=[0.0]), "particles[2].position"),
        (lambda d: d["particles"][1].update(colour=1), "particles[1].colour"),
        (lambda d: d["constraints"][0].update(compliance=-1.0), "constraints[0].compliance"),
    ]
    for edit, path in cases:
        document = chain_document()
        edit(document)
        with pytest.raises(hp.SceneError) as caught:
            hp.Scene.from_json(json.dumps(document))
        assert caught.value.path == path, str(caught.value)
        assert str(caught.value).startswith(path + ":")


def test_scene_error_from_a_file_names_the_file_and_the_field(tmp_path):
    document = chain_document()
    document["particles"][0]["velocity"] = [1.0, float("nan")]
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(document).replace("NaN", "1e999"))
    with pytest.raises(hp.SceneError) as caught:
        hp.Scene.load(path)
    assert str(path) in str(caught.value)
    assert caught.value.path is not None and caught.value.path.startswith("particles[0].velocity")


def test_unreadable_file_is_a_scene_error_without_a_path(tmp_path):
    with pytest.raises(hp.SceneError, match="cannot read scene file") as caught:
        hp.Scene.load(tmp_path / "missing.json")
    assert caught.value.path is None


def test_unknown_builtin_lists_the_names():
    with pytest.raises(ValueError, match="built-in scenes: cloth, tesseract, chain2d"):
        hp.Scene.builtin("nope")


def exploding_scene() -> hp.Scene:
    """One particle whose first predicted position overflows to +inf."""
    return hp.Scene.from_json(
        json.dumps(
            {
                "dim": 2,
                "dt": 1.0,
                "substeps": 1,
                "gravity": [0.0, 0.0],
                "particles": [
                    {"position": [1.79e308, 0.0], "velocity": [1e308, 0.0], "mass": 1.0},
                    {"position": [0.0, 0.0], "mass": 1.0},
                ],
            }
        )
    )


def test_step_error_is_a_runtime_error_and_leaves_the_state_as_before():
    sim = hp.Simulation(exploding_scene(), backend="cpu")
    before = sim.positions
    with pytest.raises(hp.StepError) as caught:
        sim.step(frames=3)
    assert isinstance(caught.value, RuntimeError)
    assert caught.value.frame == 1
    assert "particle 0 became non-finite; state rolled back" in str(caught.value)
    assert str(caught.value).startswith("frame 1: step aborted")
    assert sim.positions.tobytes() == before.tobytes()
    assert sim.frames == 0


def test_step_error_after_good_frames_keeps_them(tmp_path):
    sim = hp.Simulation(hp.Scene.builtin("chain2d"), backend="cpu")
    sim.step(frames=2)
    x = sim.positions
    x[5] = [1.7e308, 0.0]
    v = sim.velocities
    v[5] = [1e308, 0.0]
    sim.write_state(x, v)
    before = sim.state_hash()
    with pytest.raises(hp.StepError) as caught:
        sim.step(frames=4)
    assert caught.value.frame == 1
    assert sim.frames == 2 and sim.state_hash() == before


def test_gpu_error_for_a_scene_the_gpu_kernels_cannot_run():
    """dim 9 is above the GPU kernels' limit: a GpuError whatever the
    adapter (or the lack of one), never a fallback to the CPU."""
    scene = hp.Scene.from_json(
        json.dumps({"dim": 9, "dt": 0.01, "particles": [{"position": [0.0] * 9, "mass": 1.0}]})
    )
    with pytest.raises(hp.GpuError) as caught:
        hp.Simulation(scene, backend="gpu-f64")
    assert isinstance(caught.value, RuntimeError)
    assert str(caught.value).startswith("backend gpu-f64: ")
    # auto never fails for it: it says why it picked the CPU
    sim = hp.Simulation(scene, backend="auto")
    assert sim.backend == "cpu-f64" and "cpu-f64" in sim.notice


def test_exception_classes_are_exported():
    assert issubclass(hp.SceneError, ValueError)
    assert issubclass(hp.StepError, RuntimeError)
    assert issubclass(hp.GpuError, RuntimeError)
    assert hp.SceneError.__module__ == "hyperpbd"


def test_example_scene_file_loads():
    assert hp.Scene.load(REPO / "scenes" / "example.json").dim == 3
    assert np.isfinite(hp.Simulation(hp.Scene.load(REPO / "scenes" / "example.json"), backend="cpu").positions).all()
