"""Small helpers shared by the core tests."""

from __future__ import annotations

import numpy as np

import durer


def tolerance(precision: str) -> float:
    """Relative tolerance of t for ordinary (well-conditioned) cases."""
    return 1e-5 if precision == "float" else 1e-12


def unit_sphere_scene() -> durer.Scene:
    scene = durer.Scene()
    scene.add_spheres([[0.0, 0.0, 0.0]], [1.0])
    return scene


def cast_one(scene: durer.Scene, origin, direction, **kwargs) -> durer.CastResult:
    return durer.cast(scene, np.array([origin], float), np.array([direction], float), **kwargs)
