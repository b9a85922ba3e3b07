"""A scene authored as a Python dict: a 2D pendulum of 8 links on a fixed
pivot, swinging onto a floor (json.dumps → hp.Scene.from_json). A mistake
in the dict is a SceneError naming the field."""

import json
import math

import hyperpbd as hp

links = 8
scene = {
    "dim": 2,
    "dt": 1 / 60,
    "substeps": 20,
    "iterations": 2,
    "gravity": [0.0, -9.81],
    "particles": [{"position": [0.0, 2.0], "fixed": True}]
    + [{"position": [0.2 * k, 2.0], "mass": 0.1, "radius": 0.02} for k in range(1, links + 1)],
    "constraints": [
        {"type": "distance", "compliance": 0.0, "elements": [[k, k + 1] for k in range(links)]},
    ],
    "obstacles": [{"type": "hyperplane", "normal": [0.0, 1.0], "offset": 0.5, "friction": 0.3}],
}

try:
    bad = json.loads(json.dumps(scene))
    bad["particles"][3]["mass"] = 0.0
    hp.Scene.from_json(json.dumps(bad))
except hp.SceneError as e:
    print(f"refused as expected: {e.path}: {e}")

with hp.Simulation(hp.Scene.from_json(json.dumps(scene)), backend="cpu") as sim:
    for second in range(1, 4):
        report = sim.step(frames=60)
        tip = sim.positions[-1]
        angle = math.degrees(math.atan2(tip[0], 2.0 - tip[1]))
        print(
            f"t = {sim.time:.1f} s: tip at ({tip[0]:+.3f}, {tip[1]:+.3f}), {angle:+.1f}° from the vertical, "
            f"max |C| {report['max_violation']:.2e}, {report['active_contacts']} contacts"
        )
