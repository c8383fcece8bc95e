"""Scenes the reports and bench/ measure: an edge-heavy scene for anti-aliasing, and the showcase's
geometry with chosen effects switched on (one row of EFFECT_ROWS per effect added)."""

from __future__ import annotations

import numpy as np

from ..camera import OrthographicCamera
from ..scene import Scene
from ..showcase import showcase_scene


def edge_scene(spheres: int = 2000, seed: int = 3, specular: float = 0.0, sun: bool = True) -> tuple[Scene, OrthographicCamera]:
    """Many small spheres (radius 0.02-0.08, under one to three pixels at 160 wide) on a plane, one
    sun without shadows, seen from above: nearly every pixel has an edge in it. With `specular`, the
    spheres' highlights (Phong, exponent 30) of that weight; without `sun`, a white ambient light alone
    (every surface its diffuse colour: a render without the strata's controls)."""
    scene = Scene()
    scene.background = (0.55, 0.7, 0.9, 1.0)
    scene.ambient = (0.18, 0.2, 0.24)
    ground = scene.add_material(diffuse=(0.7, 0.68, 0.62))
    palette = np.array([scene.add_material(diffuse=c, specular=(specular,) * 3, exponent=30.0) for c in
                        ((0.85, 0.2, 0.15), (0.2, 0.45, 0.85), (0.95, 0.75, 0.2), (0.25, 0.7, 0.35),
                         (0.6, 0.3, 0.75), (0.05, 0.05, 0.05), (0.95, 0.95, 0.95))], dtype=np.int32)
    scene.add_plane((0, 1, 0), 0.0, material=ground)
    rng = np.random.default_rng(seed)
    r = rng.uniform(0.02, 0.08, spheres)
    centers = np.stack([rng.uniform(-4.4, 4.4, spheres), r, rng.uniform(-2.6, 2.6, spheres)], axis=1)
    scene.add_spheres(centers, r, material=palette[rng.integers(0, palette.size, spheres)])
    if sun:
        scene.add_directional_light((-0.5, -1.0, -0.4), (0.95, 0.92, 0.85))
    else:
        scene.ambient = (1.0, 1.0, 1.0)
    # Slightly off straight down, so that no ray direction component is exactly 0 (kept for comparable figures).
    camera = OrthographicCamera(center=(0.0, 5.0, 0.0), direction=(0.02, -1.0, -0.05), up=(0.0, 0.0, -1.0), size=8.0)
    return scene, camera


def effect_scene(lights: bool, shadows: bool, specular: bool, reflective: bool, transparent: bool) -> Scene:
    """The showcase's geometry with the asked-for effects switched on (also bench/effects.py's scene)."""
    base, _ = showcase_scene()
    scene = Scene()
    scene.background = base.background
    scene.ambient = base.ambient
    palette = [scene.add_material(
        diffuse=c,
        specular=(0.5, 0.5, 0.5) if specular else (0, 0, 0), exponent=40.0,
        reflective=(0.4, 0.4, 0.4) if reflective and i == 0 else (0, 0, 0),
        transparent=(0.9, 0.9, 0.9) if transparent and i == 1 else (0, 0, 0), ior=1.5,
    ) for i, c in enumerate(((0.85, 0.2, 0.15), (0.2, 0.45, 0.85), (0.95, 0.75, 0.2), (0.25, 0.7, 0.35)))]
    scene.add_plane((0, 1, 0), 0.0, material=scene.add_material((0.7, 0.68, 0.62)))
    centers = np.array([[0.0, 1.5, 0.0], [-2.6, 0.9, 0.8], [2.4, 1.1, -0.6], [-0.9, 0.5, 2.3]])
    scene.add_spheres(centers, [1.5, 0.9, 1.1, 0.5], material=np.array(palette, dtype=np.int32))
    rng = np.random.default_rng(7)
    angle = rng.uniform(0, 2 * np.pi, 60)
    distance = rng.uniform(3.0, 5.5, 60)
    r = rng.uniform(0.08, 0.25, 60)
    scene.add_spheres(np.stack([distance * np.cos(angle), r, distance * np.sin(angle) * 0.6], 1), r,
                      material=np.array(palette, dtype=np.int32)[rng.integers(0, 4, 60)])
    if lights:
        scene.add_directional_light((-0.5, -1.0, -0.4), (0.95, 0.92, 0.85), shadows=shadows)
    return scene


EFFECT_ROWS: tuple[tuple[str, dict[str, bool], tuple[str, ...]], ...] = (
    ("depth only", dict(lights=False, shadows=False, specular=False, reflective=False, transparent=False), ("depth",)),
    ("flat colour (no lights)", dict(lights=False, shadows=False, specular=False, reflective=False, transparent=False),
     ("color",)),
    ("+ diffuse light", dict(lights=True, shadows=False, specular=False, reflective=False, transparent=False), ("color",)),
    ("+ shadows", dict(lights=True, shadows=True, specular=False, reflective=False, transparent=False), ("color",)),
    ("+ Phong specular", dict(lights=True, shadows=True, specular=True, reflective=False, transparent=False), ("color",)),
    ("+ reflection", dict(lights=True, shadows=True, specular=True, reflective=True, transparent=False), ("color",)),
    ("+ refraction", dict(lights=True, shadows=True, specular=True, reflective=True, transparent=True), ("color",)),
)
FLAT_ROW = 1
