"""hyperpbd: N-dimensional particle physics, numpy in and out.

An f64 CPU golden path (deterministic, the same bytes for any thread count)
and wgpu compute kernels (f32, and f64 where the adapter offers it), over
scenes in R^N: XPBD constraint families, contacts, barriers.

    import hyperpbd as hp
    scene = hp.Scene.builtin("chain2d")
    with hp.Simulation(scene, backend="cpu") as sim:
        report = sim.step(frames=60)      # GIL released while it steps
        x = sim.positions                 # numpy float64, (particles, dim)

See docs/python.md in the repository.
"""

from ._native import (
    GpuError,
    Scene,
    SceneError,
    Simulation,
    StepError,
    __version__,
    sweep,
)

__all__ = [
    "GpuError",
    "Scene",
    "SceneError",
    "Simulation",
    "StepError",
    "__version__",
    "sweep",
]
