"""A 4D scene's energy over time: the built-in `tesseract` (a hypercube of
springs dropped onto a hyperplane in R^4), kinetic + gravitational energy
per frame (energy_4d.png)."""

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

import hyperpbd as hp
from _common import energies, masses_and_gravity, out_dir

scene = hp.Scene.builtin("tesseract")
assert scene.dim == 4
mass, scale, gravity = masses_and_gravity(scene)
t, kinetic, potential = [], [], []
with hp.Simulation(scene, backend="cpu") as sim:
    for _ in range(180):
        sim.step()
        x, v = sim.state()
        k, u = energies(mass, scale, gravity, x, v)
        t.append(sim.time)
        kinetic.append(k)
        potential.append(u)
total = [k + u for k, u in zip(kinetic, potential)]
fig, ax = plt.subplots(figsize=(7, 4))
ax.plot(t, kinetic, label="kinetic")
ax.plot(t, potential, label="gravitational")
ax.plot(t, total, label="total", color="black")
ax.set_xlabel("time (s)")
ax.set_ylabel("energy (J)")
ax.set_title(f"tesseract in R^4: {scene.particle_count} particles")
ax.legend()
path = out_dir() / "energy_4d.png"
fig.savefig(path, dpi=110, bbox_inches="tight")
print(f"total energy {total[0]:.4f} J -> {total[-1]:.4f} J; wrote {path}")
