"""A 32×32 cloth dropped onto a ground plane with friction (the built-in
`cloth`), drawn at four times with matplotlib: cloth_on_plane.png."""

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

import hyperpbd as hp
from _common import out_dir

scene = hp.Scene.builtin("cloth")
times = [0, 20, 45, 90]
fig = plt.figure(figsize=(12, 3.4))
with hp.Simulation(scene, backend="cpu") as sim:
    for k, frame in enumerate(times):
        if frame > sim.frames:
            report = sim.step(frames=frame - sim.frames)
        x = sim.positions
        ax = fig.add_subplot(1, len(times), k + 1, projection="3d")
        ax.scatter(x[:, 0], x[:, 2], x[:, 1], s=1.5, c=x[:, 1], cmap="viridis", vmin=0.0, vmax=1.0)
        ax.set_xlim(-0.7, 0.7)
        ax.set_ylim(-0.7, 0.7)
        ax.set_zlim(0.0, 1.0)
        ax.set_title(f"t = {sim.time:.2f} s")
        ax.set_xticks([])
        ax.set_yticks([])
    print(f"{sim.frames} frames on {sim.backend}: {report['active_contacts']} contacts, state hash {sim.state_hash()}")
fig.suptitle("hyperpbd: a cloth dropped on a plane (friction 0.4)")
path = out_dir() / "cloth_on_plane.png"
fig.savefig(path, dpi=110, bbox_inches="tight")
print(f"wrote {path}")
