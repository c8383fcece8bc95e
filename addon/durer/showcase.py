"""The showcase scene: spheres of several sizes and colours on a ground plane, lit by a sun, seen by
an orthographic camera. The default render and the benchmarks use it."""

from __future__ import annotations

import numpy as np

from . import _checks
from .camera import OrthographicCamera
from .scene import Scene


def showcase_scene(small_spheres: int = 60, seed: int = 7) -> tuple[Scene, OrthographicCamera]:
    """The scene and its camera; `small_spheres` pebbles scattered with a fixed `seed` (both integers >= 0)."""
    small_spheres = _checks.integer(small_spheres, "small_spheres", 0)
    seed = _checks.integer(seed, "seed", 0)  # numpy's generators take no negative seed
    scene = Scene()
    scene.background = (0.55, 0.7, 0.9, 1.0)
    scene.ambient = (0.18, 0.2, 0.24)
    ground = scene.add_material(diffuse=(0.7, 0.68, 0.62))
    palette = [scene.add_material(diffuse=c) for c in
               ((0.85, 0.2, 0.15), (0.2, 0.45, 0.85), (0.95, 0.75, 0.2), (0.25, 0.7, 0.35), (0.6, 0.3, 0.75))]
    scene.add_plane((0, 1, 0), 0.0, material=ground)
    big = np.array([[0.0, 1.5, 0.0], [-2.6, 0.9, 0.8], [2.4, 1.1, -0.6], [-0.9, 0.5, 2.3], [1.3, 0.6, 2.0]])
    radii = np.array([1.5, 0.9, 1.1, 0.5, 0.6])
    scene.add_spheres(big, radii, material=np.array(palette, dtype=np.int32))
    rng = np.random.default_rng(seed)
    angle = rng.uniform(0, 2 * np.pi, small_spheres)
    distance = rng.uniform(3.0, 5.5, small_spheres)
    r = rng.uniform(0.08, 0.25, small_spheres)
    centers = np.stack([distance * np.cos(angle), r, distance * np.sin(angle) * 0.6], axis=1)
    scene.add_spheres(centers, r, material=rng.choice(palette, small_spheres).astype(np.int32))
    scene.add_directional_light((-0.5, -1.0, -0.4), (0.95, 0.92, 0.85))
    camera = OrthographicCamera(center=(0.0, 4.0, 10.0), direction=(0.0, -0.4, -1.0), up=(0, 1, 0), size=12.0)
    return scene, camera
