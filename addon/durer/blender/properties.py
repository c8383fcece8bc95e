"""Dürer's settings in Blender: ``scene.durer`` (render settings) and ``object.durer``."""

from __future__ import annotations

import bpy
from bpy.props import BoolProperty, EnumProperty, FloatProperty, IntProperty, PointerProperty

PRIMITIVE_ITEMS = [
    ("AUTO", "Auto", "Detect: sphere meshes, flat quads, point clouds, sphere empties, metaball balls"),
    (
        "SPHERE",
        "Sphere",
        "Render as a sphere: through the vertices if they are equidistant from their centroid, else the sphere fitting the bounding box",
    ),
    ("PLANE", "Plane", "Render as the flat rectangle of the object's bounding box (thinnest axis is the normal)"),
    ("IGNORE", "Ignore", "Do not render this object"),
]


class DurerSceneSettings(bpy.types.PropertyGroup):
    samples: IntProperty(name="Samples", description="Camera rays per pixel", default=1, min=1, soft_max=64, max=4096)
    seed: IntProperty(name="Seed", description="Seed of the pixel sampler", default=0, min=0)
    sampler: EnumProperty(
        name="Sampler",
        description="Where a pixel's rays go",
        items=[
            (
                "STRATIFIED",
                "Stratified",
                "Jittered-stratified positions, deterministic for the seed (1 sample: the pixel centre)",
            ),
        ],
        default="STRATIFIED",
    )
    precision: EnumProperty(
        name="Precision",
        description="Floating-point precision of the intersection arithmetic",
        items=[
            ("DOUBLE", "Double", "64-bit: exact for large or far-away scenes"),
            ("FLOAT", "Single", "32-bit: faster, may show acne on huge or distant spheres"),
        ],
        default="DOUBLE",
    )
    sphere_method: EnumProperty(
        name="Sphere Method",
        description="How ray-sphere intersections are solved",
        items=[
            ("ROBUST", "Robust", "Numerically careful quadratic (no cancellation, exact far from the origin)"),
            ("GEOMETRIC", "Geometric", "Geometric (projection) solution"),
            ("ALGEBRAIC", "Algebraic", "Textbook quadratic formula (for comparison: loses precision)"),
        ],
        default="ROBUST",
    )
    threads: IntProperty(name="Threads", description="Render threads (0: all cores)", default=0, min=0, max=1024)
    max_bounces: IntProperty(
        name="Max Bounces",
        description="Reflection and refraction rays followed from a camera ray at most "
        "(0: direct lighting only). Only mirror-like and transmissive materials spawn them",
        default=4,
        min=0,
        soft_max=16,
        max=1024,
    )
    min_weight: FloatProperty(
        name="Min Weight",
        description="A reflection or refraction ray is not traced when its contribution to the pixel "
        "(the product of reflective/transparent colours along the path, largest channel) is below this",
        default=0.01,
        min=0.0,
        max=1.0,
        precision=4,
        step=0.1,
    )
    use_world_lighting: BoolProperty(
        name="World Lighting",
        description="Light diffuse surfaces with the world colour as ambient light "
        "(like Cycles' uniform world, without occlusion)",
        default=True,
    )


class DurerObjectSettings(bpy.types.PropertyGroup):
    primitive: EnumProperty(
        name="Primitive",
        description="How Dürer renders this object",
        items=PRIMITIVE_ITEMS,
        default="AUTO",
    )
    infinite_plane: BoolProperty(
        name="Infinite Plane",
        description="When this object is rendered as a plane, extend it to infinity",
        default=False,
    )


CLASSES = (DurerSceneSettings, DurerObjectSettings)


def register() -> None:
    for cls in CLASSES:
        bpy.utils.register_class(cls)
    bpy.types.Scene.durer = PointerProperty(type=DurerSceneSettings, name="Dürer")
    bpy.types.Object.durer = PointerProperty(type=DurerObjectSettings, name="Dürer")


def unregister() -> None:
    del bpy.types.Object.durer
    del bpy.types.Scene.durer
    for cls in reversed(CLASSES):
        bpy.utils.unregister_class(cls)
