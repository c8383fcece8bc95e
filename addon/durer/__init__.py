"""Dürer: a fast, numerically careful analytic ray caster (C++ core, numpy API, Blender engine).

    import durer
    scene = durer.Scene()
    red = scene.add_material(diffuse=(1, 0, 0))
    scene.add_spheres([[0, 0, 0]], [1.0], material=red)
    camera = durer.OrthographicCamera(center=(0, 0, 10), direction=(0, 0, -1), up=(0, 1, 0), size=3)
    image = durer.render(scene, camera, 64, 64).color   # (64, 64, 4) float32, top row first

The Blender render engine lives in `durer.blender` (imported only on demand: it needs bpy), the
MIT 6.837 scene-file reader and `raytracer` command in `durer.course`, and the generators of the
measured pages in docs/ in `durer.reports` (which nothing here imports). docs/architecture.md
maps the layers.
"""

from __future__ import annotations

from .camera import OrthographicCamera, PerspectiveCamera
from .cast import CastResult, cast, occluded
from .distributed import render_many, render_tiles
from .presets import PRESETS, preset
from .render import RenderCancelled, RenderResult, render
from .scene import Scene
from .showcase import showcase_scene
from .visualize import depth_to_gray, linear_to_srgb, normal_to_rgb, save_image

__version__ = "0.1.0"

__all__ = [
    "CastResult",
    "OrthographicCamera",
    "PRESETS",
    "PerspectiveCamera",
    "RenderCancelled",
    "RenderResult",
    "Scene",
    "cast",
    "depth_to_gray",
    "linear_to_srgb",
    "normal_to_rgb",
    "occluded",
    "preset",
    "render",
    "render_many",
    "render_tiles",
    "save_image",
    "showcase_scene",
]
