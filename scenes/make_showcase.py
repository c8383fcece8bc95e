"""Build scenes/showcase.blend: Dürer's showcase scene (`durer.showcase_scene()`) as a Blender file.

Spheres of several sizes and colours (UV-sphere meshes, which Dürer detects as exact spheres, and
a point cloud of pebbles), a ground plane (a quad rendered as an infinite plane), a Sun and an
orthographic camera; the render engine is Dürer. It mirrors `durer.showcase_scene()` (Dürer's
y-up coordinates become Blender's z-up ones) with Blender's radiometric units: a Dürer light colour
c is a Sun of strength c·pi.

    python scenes/make_showcase.py [OUTPUT.blend]      # needs bpy==5.0.1 and durer installed
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import bpy
import durer.blender
import numpy as np
from mathutils import Vector

HERE = Path(__file__).resolve().parent

PALETTE = [
    ("Red", (0.85, 0.2, 0.15)),
    ("Blue", (0.2, 0.45, 0.85)),
    ("Yellow", (0.95, 0.75, 0.2)),
    ("Green", (0.25, 0.7, 0.35)),
    ("Purple", (0.6, 0.3, 0.75)),
]
AMBIENT = (0.18, 0.2, 0.24)
# (x, y, z) in Dürer's y-up showcase -> Blender (x, -z, y)
BIG = [
    ((0.0, 1.5, 0.0), 1.5),
    ((-2.6, 0.9, 0.8), 0.9),
    ((2.4, 1.1, -0.6), 1.1),
    ((-0.9, 0.5, 2.3), 0.5),
    ((1.3, 0.6, 2.0), 0.6),
]


def to_blender(p) -> tuple[float, float, float]:
    x, y, z = p
    return (x, -z, y)


def diffuse_material(name: str, color) -> bpy.types.Material:
    mat = bpy.data.materials.new(name)
    bsdf = mat.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (*color, 1.0)
    bsdf.inputs["Roughness"].default_value = 1.0
    bsdf.inputs["Specular IOR Level"].default_value = 0.0
    mat.diffuse_color = (*color, 1.0)  # viewport colour
    return mat


def uv_sphere(name: str, center, radius: float, mat) -> bpy.types.Object:
    import bmesh

    bm = bmesh.new()
    bmesh.ops.create_uvsphere(bm, u_segments=48, v_segments=24, radius=1.0)
    me = bpy.data.meshes.new(name)
    bm.to_mesh(me)
    bm.free()
    me.shade_smooth()
    me.materials.append(mat)
    obj = bpy.data.objects.new(name, me)
    obj.location = center
    obj.scale = (radius, radius, radius)
    return obj


def pebbles(collection, materials, count: int = 60, seed: int = 7) -> bpy.types.Object:
    """The scattered small spheres as one point cloud (radius and material_index per point)."""
    rng = np.random.default_rng(seed)
    angle = rng.uniform(0, 2 * np.pi, count)
    distance = rng.uniform(3.0, 5.5, count)
    r = rng.uniform(0.08, 0.25, count)
    centers = np.stack([distance * np.cos(angle), r, distance * np.sin(angle) * 0.6], axis=1)
    index = rng.choice(len(materials), count)
    blender = np.stack([centers[:, 0], -centers[:, 2], centers[:, 1]], axis=1).astype(np.float32)
    me = bpy.data.meshes.new("Pebbles")
    me.vertices.add(count)
    me.vertices.foreach_set("co", blender.ravel())
    obj = bpy.data.objects.new("Pebbles", me)
    collection.objects.link(obj)
    view_layer = bpy.context.view_layer
    for other in view_layer.objects:
        other.select_set(False)
    view_layer.objects.active = obj
    obj.select_set(True)
    if bpy.ops.object.convert(target="POINTCLOUD") != {"FINISHED"}:
        raise RuntimeError("could not convert the pebbles to a point cloud")
    obj = view_layer.objects.active
    pc = obj.data
    for mat in materials:
        pc.materials.append(mat)
    radius = pc.attributes.get("radius") or pc.attributes.new("radius", "FLOAT", "POINT")
    radius.data.foreach_set("value", r.astype(np.float32))
    mi = pc.attributes.new("material_index", "INT", "POINT")
    mi.data.foreach_set("value", index.astype(np.int32))
    return obj


def build() -> bpy.types.Scene:
    bpy.ops.wm.read_factory_settings(use_empty=True)
    durer.blender.register()
    scene = bpy.context.scene
    scene.name = "Showcase"
    coll = scene.collection

    # The world lights diffuse surfaces as Dürer's ambient light (Cycles: with occlusion); the
    # ground plane hides it from the camera.
    world = bpy.data.worlds.new("Sky")
    bg = world.node_tree.nodes["Background"]
    bg.inputs["Color"].default_value = (*AMBIENT, 1.0)
    bg.inputs["Strength"].default_value = 1.0
    world.color = AMBIENT
    scene.world = world

    ground_mat = diffuse_material("Ground", (0.7, 0.68, 0.62))
    me = bpy.data.meshes.new("Ground")
    me.from_pydata([(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], [], [(0, 1, 2, 3)])
    me.materials.append(ground_mat)
    ground = bpy.data.objects.new("Ground", me)
    ground.scale = (40, 40, 1)
    ground.durer.infinite_plane = True
    coll.objects.link(ground)

    materials = [diffuse_material(n, c) for n, c in PALETTE]
    for i, ((center, radius), mat) in enumerate(zip(BIG, materials)):
        coll.objects.link(uv_sphere(f"Sphere.{i + 1}", to_blender(center), radius, mat))
    pebbles(coll, materials)

    sun = bpy.data.lights.new("Sun", "SUN")
    sun.energy = math.pi  # the Dürer showcase's light colour ~1: irradiance pi on a white diffuse = 1
    sun.color = (0.95, 0.92, 0.85)
    sun.angle = 0.0
    sun_obj = bpy.data.objects.new("Sun", sun)
    travel = Vector(to_blender((-0.5, -1.0, -0.4)))  # the way the light travels
    sun_obj.rotation_euler = travel.to_track_quat("-Z", "Y").to_euler()
    sun_obj.location = (0, 0, 8)
    coll.objects.link(sun_obj)

    cam = bpy.data.cameras.new("Camera")
    cam.type = "ORTHO"
    cam.ortho_scale = 12.0
    cam.clip_start, cam.clip_end = 0.1, 100.0
    cam_obj = bpy.data.objects.new("Camera", cam)
    cam_obj.location = to_blender((0.0, 4.0, 10.0))
    direction = Vector(to_blender((0.0, -0.4, -1.0)))
    cam_obj.rotation_euler = direction.to_track_quat("-Z", "Y").to_euler()
    coll.objects.link(cam_obj)
    scene.camera = cam_obj

    scene.render.engine = "DURER"
    scene.render.resolution_x, scene.render.resolution_y = 1920, 1080
    scene.render.resolution_percentage = 50
    scene.render.image_settings.file_format = "PNG"
    scene.view_settings.view_transform = "Standard"  # plain sRGB, like durer.save_image
    scene.render.filepath = "//render/showcase_####"
    scene.durer.samples = 4
    scene.cycles.samples = 64
    scene.frame_start = scene.frame_end = scene.frame_current = 1
    return scene


def main(argv: list[str]) -> int:
    out = Path(argv[0]).resolve() if argv else HERE / "showcase.blend"
    build()
    bpy.ops.wm.save_as_mainfile(filepath=str(out), compress=True)
    print(out)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
