"""Simulation: threads, state in and out, forces, lifetime, the GIL."""

import json
import re
import threading
import time

import numpy as np
import pytest

import hyperpbd as hp
from conftest import REPO


def test_one_and_two_threads_give_the_same_bytes():
    for name in ["cloth", "sandpile2d", "ballpit4d", "jelly4d"]:
        scene = hp.Scene.builtin(name)
        states = []
        for threads in (1, 2):
            with hp.Simulation(scene, backend="cpu", threads=threads) as sim:
                assert sim.threads == threads
                report = sim.step(frames=10)
                assert report["threads"] == threads
                positions, velocities = sim.state()
                states.append((positions.tobytes(), velocities.tobytes(), sim.state_hash()))
        assert states[0] == states[1], f"{name}: 1 and 2 threads differ"


def test_report_has_the_step_numbers():
    sim = hp.Simulation(hp.Scene.builtin("cloth"), backend="cpu")
    report = sim.step(frames=60)
    assert set(report) == {
        "max_violation",
        "residuals",
        "active_contacts",
        "threads",
        "retries",
        "kernel_calls",
        "minimisation",
    }
    assert report["max_violation"] == max(report["residuals"].values())
    assert "constraints[0]" in report["residuals"]
    assert report["active_contacts"] > 0  # the cloth lies on the plane after 1 s
    assert report["kernel_calls"]["project"] > 0


def test_arrays_are_float64_copies_of_shape_particles_by_dim():
    scene = hp.Scene.builtin("tesseract")
    sim = hp.Simulation(scene, backend="cpu")
    x = sim.positions
    assert x.dtype == np.float64 and x.shape == (scene.particle_count, 4)
    x[:] = 1e9  # a copy: the simulation does not see it
    assert not np.array_equal(sim.positions, x)
    assert sim.velocities.shape == (scene.particle_count, 4)


def test_write_state_round_trips_and_steps_like_the_original():
    scene = hp.Scene.builtin("chain2d")
    a = hp.Simulation(scene, backend="cpu")
    a.step(frames=5)
    b = hp.Simulation(scene, backend="cpu")
    b.write_state(a.positions, a.velocities)
    assert b.state_hash() == a.state_hash()
    a.step(frames=5)
    b.step(frames=5)
    assert b.state_hash() == a.state_hash()
    # velocities omitted: they stay
    v = b.velocities
    b.write_state(b.positions.tolist())
    assert np.array_equal(b.velocities, v)


@pytest.mark.parametrize(
    "positions, velocities, words",
    [
        (np.zeros((20, 2)), None, "positions: expected shape (21, 2)"),
        (np.zeros((21, 3)), None, "positions: expected shape (21, 2)"),
        (np.zeros(42), None, "positions: expected shape (21, 2)"),
        ("not numbers", None, "positions"),
        (None, np.zeros((21, 1)), "velocities: expected shape (21, 2)"),
        (np.full((21, 2), np.nan), None, "positions[0][0]: value NaN is not finite"),
        (None, np.where(np.eye(21, 2) > 0, np.inf, 0.0), "velocities[0][0]: value inf is not finite"),
    ],
)
def test_write_state_refuses_bad_input_and_changes_nothing(positions, velocities, words):
    sim = hp.Simulation(hp.Scene.builtin("chain2d"), backend="cpu")
    sim.step(frames=3)
    before = sim.state_hash()
    good = sim.positions
    with pytest.raises(ValueError, match=re.escape(words)):
        sim.write_state(good if positions is None else positions, velocities)
    assert sim.state_hash() == before


def test_a_nan_in_the_last_row_changes_nothing():
    sim = hp.Simulation(hp.Scene.builtin("chain2d"), backend="cpu")
    before = sim.state_hash()
    x = sim.positions + 0.5
    x[-1, 1] = np.nan
    with pytest.raises(ValueError, match=r"positions\[20\]\[1\]"):
        sim.write_state(x)
    assert sim.state_hash() == before


def forced_scene() -> hp.Scene:
    """scenes/example.json with a small force authored on its dynamic
    particles (a plan has a force term only when a force is authored)."""
    document = json.loads((REPO / "scenes" / "example.json").read_text())
    for particle in document["particles"]:
        if not particle.get("fixed", False):
            particle["force"] = [0.0, 0.0, 0.01]
    return hp.Scene.from_json(json.dumps(document))


def test_set_forces_changes_the_motion_by_the_force():
    scene = forced_scene()
    free = hp.Simulation(scene, backend="cpu")
    pushed = hp.Simulation(scene, backend="cpu")
    forces = np.zeros((scene.particle_count, scene.dim))
    forces[:, 0] = 3.0
    pushed.set_forces(forces)
    free.step(frames=10)
    pushed.step(frames=10)
    dx = pushed.positions[:, 0] - free.positions[:, 0]
    assert np.all(dx[pushed_dynamic(scene)] > 0)


def pushed_dynamic(scene):
    document = json.loads(scene.to_json())
    return np.array([not p.get("fixed", False) for p in document["particles"]])


def test_set_forces_is_checked():
    scene = forced_scene()
    sim = hp.Simulation(scene, backend="cpu")
    with pytest.raises(ValueError, match="forces: expected shape"):
        sim.set_forces(np.zeros((scene.particle_count + 1, scene.dim)))
    with pytest.raises(ValueError, match=r"forces\[0\]\[2\]: value NaN"):
        sim.set_forces(np.array([[0.0, 0.0, np.nan]] * scene.particle_count))
    # a scene without a force term refuses forces, in the Rust error's words
    chain = hp.Simulation(hp.Scene.builtin("chain2d"), backend="cpu")
    with pytest.raises(ValueError, match="invalid call"):
        chain.set_forces(np.zeros((21, 2)))


def test_close_and_context_manager():
    with hp.Simulation(hp.Scene.builtin("chain2d"), backend="cpu") as sim:
        sim.step()
        assert not sim.closed
    assert sim.closed
    assert sim.frames == 1  # the properties stay readable
    with pytest.raises(ValueError, match="step: the simulation is closed"):
        sim.step()
    with pytest.raises(ValueError, match="positions: the simulation is closed"):
        sim.positions
    sim.close()  # idempotent


def test_arguments_are_checked():
    scene = hp.Scene.builtin("chain2d")
    with pytest.raises(ValueError, match="unknown backend"):
        hp.Simulation(scene, backend="tpu")
    with pytest.raises(ValueError, match="threads: must be at least 1"):
        hp.Simulation(scene, backend="cpu", threads=0)
    with pytest.raises(ValueError, match="frames: must be at least 1"):
        hp.Simulation(scene, backend="cpu").step(frames=0)


def test_auto_says_what_it_picked_and_why():
    sim = hp.Simulation(hp.Scene.builtin("chain2d"), backend="auto")
    assert sim.notice is not None and sim.notice.startswith(f"backend auto -> {sim.backend}")
    assert hp.Simulation(hp.Scene.builtin("chain2d"), backend="cpu").notice is None


def test_step_releases_the_gil():
    """A counting thread keeps running while one long step call runs."""
    sim = hp.Simulation(hp.Scene.builtin("cloth"), backend="cpu", threads=1)
    stamps = []
    running = threading.Event()
    stop = threading.Event()

    def count():
        n = 0
        running.set()
        while not stop.is_set():
            n += 1
            if n % 256 == 0:
                stamps.append(time.perf_counter())

    counter = threading.Thread(target=count)
    counter.start()
    running.wait()
    start = time.perf_counter()
    sim.step(frames=300)  # ≈ 0.25 s on an idle core
    end = time.perf_counter()
    stop.set()
    counter.join()
    elapsed = end - start
    assert elapsed > 0.05, f"the step took {elapsed:.3f} s: too short to tell"
    # Holding the GIL, the step would let the counter run only around the
    # call (a switch interval, 5 ms, before it starts or after it returns),
    # never in its middle half; released, the counter runs throughout.
    middle = [t for t in stamps if start + elapsed / 4 < t < end - elapsed / 4]
    assert len(middle) >= 10, (
        f"the counter ran {len(middle)} times (x256) in the middle half of a {elapsed:.3f} s step"
    )


def test_another_thread_reads_while_a_step_runs():
    sim = hp.Simulation(hp.Scene.builtin("cloth"), backend="cpu", threads=1)
    seen = []
    worker = threading.Thread(target=lambda: sim.step(frames=30))
    worker.start()
    while worker.is_alive():
        seen.append(sim.frames)
        time.sleep(0.005)
    worker.join()
    assert sim.frames == 30
    assert sim.positions.shape == (32 * 32, 3)


RESTING = json.dumps(
    {
        "dim": 2,
        "dt": 1.0 / 60.0,
        "substeps": 10,
        "iterations": 2,
        "gravity": [0.0, -9.81],
        "particles": [{"position": [0.0, 0.1], "mass": 2.0, "radius": 0.1}],
        "obstacles": [{"type": "hyperplane", "normal": [0, 1], "offset": 0.0, "friction": 0.5}],
    }
)


def test_contact_forces_on_request():
    scene = hp.Scene.from_json(RESTING)
    sim = hp.Simulation(scene, backend="cpu")
    assert "contact_forces" not in sim.step(frames=1)
    sim.request_contact_forces()
    forces = sim.step(frames=30)["contact_forces"]
    assert forces["obstacles"].shape == (1, 2) and forces["particles"].shape == (1, 2)
    # At rest: the plane holds the particle up with m·|g| (its force on
    # the particles), which is the particle's whole contact force.
    assert abs(forces["obstacles"][0, 1] - 2.0 * 9.81) <= 1e-9 * 2.0 * 9.81
    assert np.array_equal(forces["particles"], forces["obstacles"])
    # A plane that does not move puts no power into the particles.
    assert forces["obstacle_power"].shape == (1,) and forces["obstacle_power"][0] == 0.0
    sim.request_contact_forces(False)
    assert "contact_forces" not in sim.step(frames=1)


def test_contact_forces_on_the_gpu_are_the_golden_paths(gpu_f64):
    # gpu-f64 on lavapipe (as test_cli_equality assumes): the CPU's forces
    # bit for bit (the recorder runs over the device's own states, which are
    # the golden path's there).
    scene = hp.Scene.from_json(RESTING)
    cpu, gpu = hp.Simulation(scene, backend="cpu"), hp.Simulation(scene, backend=gpu_f64)
    for sim in (cpu, gpu):
        sim.request_contact_forces()
    for _ in range(10):
        want, got = cpu.step()["contact_forces"], gpu.step()["contact_forces"]
        for key in ("obstacles", "particles", "obstacle_power"):
            assert np.array_equal(got[key], want[key]), key
    assert abs(got["obstacles"][0, 1] - 2.0 * 9.81) <= 1e-9 * 2.0 * 9.81
