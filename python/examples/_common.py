"""What the examples share: where pictures go, energies from the scene JSON."""

import json
import pathlib
import sys

import numpy as np


def out_dir() -> pathlib.Path:
    """The first argument, else ./out/python (created)."""
    path = pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else "out/python")
    path.mkdir(parents=True, exist_ok=True)
    return path


def masses_and_gravity(scene):
    """Per-particle mass (0 for fixed) × gravity scale, and the gravity vector."""
    document = json.loads(scene.to_json())
    mass = np.array([0.0 if p.get("fixed", False) else p.get("mass", 0.0) for p in document["particles"]])
    scale = np.array([p.get("gravity_scale", 1.0) for p in document["particles"]])
    gravity = np.array(document.get("gravity", [0.0] * scene.dim), dtype=float)
    return mass, scale, gravity


def energies(mass, scale, gravity, positions, velocities):
    """Kinetic ½ Σ m |v|² and gravitational −Σ m s g·x (joules)."""
    kinetic = 0.5 * float(np.sum(mass * np.sum(velocities**2, axis=1)))
    potential = -float(np.sum(mass * scale * (positions @ gravity)))
    return kinetic, potential
