"""The package runs the CLI's computation: every shipped scene's state
after N frames equals `hyperpbd run --out` bit for bit, and state_hash()
equals the printed `state hash`, on the CPU and on the GPU in f64."""

import numpy as np
import pytest

import hyperpbd as hp
from conftest import SCENES, cli, finish, printed_hash, read_out

CPU_FRAMES = 30
# Lavapipe compiles every pipeline at load; a few frames cover the
# per-step path while keeping the CI time of ten scenes low.
GPU_FRAMES = 5


def same_bits(actual: np.ndarray, expected: list) -> bool:
    expected = np.asarray(expected, dtype=np.float64).reshape(actual.shape)
    return actual.tobytes() == expected.tobytes()


def check_scene(path, backend, frames, tmp_path):
    out = tmp_path / "out.json"
    run = cli("run", str(path), "--backend", backend, "--frames", str(frames), "--out", str(out))
    with hp.Simulation(hp.Scene.load(path), backend=backend) as sim:
        sim.step(frames=frames)
        positions, velocities = sim.state()
        digest = sim.state_hash()
        assert sim.frames == frames
        assert sim.time == frames * sim.dt
    stdout = finish(run)
    record = read_out(out)
    assert record["frames"] == frames
    assert same_bits(positions, record["positions"]), f"{path.name}: positions differ from the CLI's"
    assert same_bits(velocities, record["velocities"]), f"{path.name}: velocities differ from the CLI's"
    assert digest == printed_hash(stdout)


@pytest.mark.parametrize("path", SCENES, ids=lambda p: p.stem)
def test_cpu_matches_cli_bit_for_bit(path, tmp_path):
    check_scene(path, "cpu", CPU_FRAMES, tmp_path)


@pytest.mark.parametrize("path", SCENES, ids=lambda p: p.stem)
def test_gpu_f64_matches_cli_bit_for_bit(path, tmp_path, gpu_f64):
    check_scene(path, gpu_f64, GPU_FRAMES, tmp_path)


def test_builtin_scene_is_the_cli_scene():
    """Scene.builtin(NAME).to_json() is `hyperpbd scene NAME`."""
    for name in ["chain2d", "cloth", "tesseract", "incline5d", "barrier4d"]:
        assert hp.Scene.builtin(name).to_json() == finish(cli("scene", name))


def test_to_json_round_trips():
    for path in SCENES:
        scene = hp.Scene.load(path)
        again = hp.Scene.from_json(scene.to_json())
        assert again.to_json() == scene.to_json()
