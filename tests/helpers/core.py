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


def camera_tests(scene: durer.Scene, camera, width: int, height: int, **options) -> int:
    """The ray-primitive tests a render's camera rays make: those of a depth render of the same
    samples, which traces nothing else. Camera rays search a scene's own spheres through the camera's
    view (SphereView), which skips each sphere on the tiles and pixel rows it does not cover, so the
    count is the renderer's own; a secondary ray tests each primitive of a small scene once."""
    return durer.render(scene, camera, width, height, passes=("depth",), **options).stats["intersection_tests"]
