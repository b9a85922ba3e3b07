"""Obstacles that move (a "motion" list, docs/scene-format.md): a ball
dropped on a triangulated belt (a simplex mesh translating at 1 m/s, μ =
0.5) is dragged up to the belt's speed after u/(μ g) ≈ 0.2 s and rides
it; the belt's contact force holds the ball's weight and its power is
the work friction does. Then the built-in drape3d: a cloth on a dome
that rises and turns at 1 rad/s, its top turning with the dome."""

import json
import math

import hyperpbd as hp

BELT_SPEED, MU, G = 1.0, 0.5, 9.81
belt = {
    "type": "simplex_mesh",
    "vertices": [[-3.0, 0.0, -1.0], [3.0, 0.0, -1.0], [-3.0, 0.0, 1.0], [3.0, 0.0, 1.0]],
    "simplices": [[0, 1, 2], [1, 3, 2]],
    "friction": MU,
    "motion": [{"type": "translate", "velocity": [BELT_SPEED, 0.0, 0.0]}],
}
scene = {
    "dim": 3,
    "dt": 1 / 60,
    "substeps": 20,
    "gravity": [0.0, -G, 0.0],
    "particles": [{"position": [0.0, 0.1, 0.0], "mass": 2.0, "radius": 0.1}],
    "obstacles": [belt],
}

with hp.Simulation(hp.Scene.from_json(json.dumps(scene)), backend="cpu") as sim:
    sim.request_contact_forces()
    for frame in range(1, 31):
        report = sim.step()
        if frame % 6 == 0:
            forces = report["contact_forces"]
            print(
                f"t = {sim.time:.2f} s: ball v_x = {sim.velocities[0][0]:.3f} m/s "
                f"(belt {BELT_SPEED}), belt force {forces['obstacles'][0][1]:.2f} N up "
                f"(m g = {2.0 * G:.2f}), belt power {forces['obstacle_power'][0]:.2f} W"
            )
    riding = abs(sim.velocities[0][0] - BELT_SPEED)
    print(f"catches the belt after u/(μ g) = {BELT_SPEED / (MU * G):.3f} s; |v − u| now {riding:.1e} m/s")
    assert riding < 1e-6

drape = hp.Scene.builtin("drape3d")
with hp.Simulation(drape, backend="cpu") as sim:
    sim.step(frames=60)
    node = 12 * 24 + 8  # a node of the cloth over the dome, off its axis
    before = math.atan2(sim.positions[node][0], sim.positions[node][2])
    sim.step(frames=60)
    turned = math.atan2(sim.positions[node][0], sim.positions[node][2]) - before
    print(f"drape3d: the cloth's top turned {turned:.3f} rad in 1 s with the dome (1 rad/s)")
    assert abs(turned - 1.0) < 0.05
