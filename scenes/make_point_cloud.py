"""Build a point-cloud .blend: a million small spheres in a slab over a ground plane, lit by a sun
casting shadows, seen at 45° by an orthographic camera (issue 13's "1M slab" workload in Blender).
With `--light point`, a point light above the slab casts them instead (Blender's default light).

The cloud is made the way most users make one: a mesh of loose vertices through a geometry-nodes
"Mesh to Points" modifier (`durer.blender.point_cloud`). Points: uniform in x, y in [-10, 10] and
z in [0, 4] (Blender's z-up; the core benchmarks' y-up slab), radius 0.02 (about 3 pixels across at
1920 wide). Dürer and Cycles both render each point as a sphere; the ground is a quad that Dürer
renders as an infinite plane and Cycles as an 80 x 80 quad, which fills the view either way. 1 spp in
both engines, 1920x1080; `bench/showcase_vs_cycles.py` renders it with each.

With `--made-by particles` the same slab is filled the older way: a particle system emitting from
the volume of a slab-shaped box (hidden: Show Emitter off) at random, every particle an instance of a
UV sphere of radius 0.02 (Blender's own random positions, so not the same points). Dürer renders each
instance as that sphere, Cycles as the UV sphere's 960 triangles.

    python scenes/make_point_cloud.py [OUTPUT.blend] [--points 1000000] [--seed 7] [--light point]
                                      [--made-by particles]  # bpy + durer
"""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Sequence
from pathlib import Path

import bpy
import durer.blender
import numpy as np
from durer.blender.point_cloud import point_cloud_object
from mathutils import Vector

HERE = Path(__file__).resolve().parent
POINTS = 1_000_000
RADIUS = 0.02
SLAB = ((-10.0, -10.0, 0.0), (10.0, 10.0, 4.0))  # Blender coordinates, z up
SUN_TRAVEL = (-1.0, 1.0, -2.0)  # the way the light travels: the core benchmarks' (-1, -2, -1), y up
AMBIENT = (0.18, 0.2, 0.24)


def diffuse_material(name: str, color) -> bpy.types.Material:
    mat = bpy.data.materials.new(name)
    bsdf = mat.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (*color, 1.0)
    bsdf.inputs["Roughness"].default_value = 1.0
    bsdf.inputs["Specular IOR Level"].default_value = 0.0
    mat.diffuse_color = (*color, 1.0)  # viewport colour
    return mat


def aimed(obj: bpy.types.Object, direction) -> bpy.types.Object:
    """`obj` turned so that its -Z axis (where cameras look and lights shine) points along `direction`."""
    obj.rotation_euler = Vector(direction).to_track_quat("-Z", "Y").to_euler()
    return obj


def particle_cloud(coll, points: int, seed: int) -> None:
    """`points` particles born at once at random in the slab's volume (no physics), each an
    instance of a hidden UV sphere of radius RADIUS; the emitter box hidden in renders."""
    import bmesh  # only once bpy is loaded

    low, high = np.array(SLAB[0]), np.array(SLAB[1])
    box = bpy.data.meshes.new("Slab")
    corners = [(x, y, z) for x in (low[0], high[0]) for y in (low[1], high[1]) for z in (low[2], high[2])]
    box.from_pydata(corners, [], [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)])
    emitter = bpy.data.objects.new("Emitter", box)
    emitter.show_instancer_for_render = emitter.show_instancer_for_viewport = False
    coll.objects.link(emitter)
    ball = bpy.data.meshes.new("Ball")
    bm = bmesh.new()
    bmesh.ops.create_uvsphere(bm, u_segments=32, v_segments=16, radius=RADIUS)
    bm.to_mesh(ball)
    bm.free()
    instanced = bpy.data.objects.new("Ball", ball)
    instanced.location = (0.0, 0.0, -50.0)  # out of view; hidden in renders too
    instanced.hide_render = instanced.hide_viewport = True
    coll.objects.link(instanced)
    emitter.modifiers.new("Particles", "PARTICLE_SYSTEM")
    system = emitter.particle_systems[0]
    system.seed = seed
    part = system.settings
    part.count, part.frame_start, part.frame_end, part.physics_type = points, 1, 1, "NO"
    part.emit_from, part.distribution, part.use_emit_random = "VOLUME", "RAND", True
    part.render_type, part.instance_object, part.particle_size, part.size_random = "OBJECT", instanced, 1.0, 0.0
    part.display_percentage = 1  # the viewport draws 1 % of them; renders draw all


def build(points: int = POINTS, seed: int = 7, light: str = "sun", made_by: str = "points") -> bpy.types.Scene:
    bpy.ops.wm.read_factory_settings(use_empty=True)
    durer.blender.register()
    scene = bpy.context.scene
    scene.name = "Point cloud"
    coll = scene.collection

    world = bpy.data.worlds.new("Sky")
    background = world.node_tree.nodes["Background"]
    background.inputs["Color"].default_value = (*AMBIENT, 1.0)
    world.color = AMBIENT
    scene.world = world

    mesh = bpy.data.meshes.new("Ground")
    mesh.from_pydata([(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], [], [(0, 1, 2, 3)])
    mesh.materials.append(diffuse_material("Ground", (0.7, 0.68, 0.62)))
    ground = bpy.data.objects.new("Ground", mesh)
    ground.scale = (40, 40, 1)
    ground.durer.infinite_plane = True
    coll.objects.link(ground)

    if made_by == "particles":
        particle_cloud(coll, points, seed)
    else:
        positions = np.random.default_rng(seed).uniform(*SLAB, size=(points, 3))
        # No material: "Mesh to Points" does not carry the mesh's, so both engines use their default surface.
        point_cloud_object(coll, "Cloud", positions, RADIUS)

    if light == "sun":
        sun = bpy.data.lights.new("Sun", "SUN")
        sun.energy = math.pi  # irradiance pi: a white diffuse surface facing the sun is 1
        sun.angle = 0.0  # a point-like sun: hard shadows, as Dürer's
        sun.use_shadow = True
        sun_obj = aimed(bpy.data.objects.new("Sun", sun), SUN_TRAVEL)
        sun_obj.location = (0, 0, 10)
        coll.objects.link(sun_obj)
    else:
        lamp = bpy.data.lights.new("Light", "POINT")
        lamp.energy = 4 * math.pi**2 * 14.0**2  # watts: about 1 on the ground below it, as the sun's
        lamp.shadow_soft_size = 0.0  # a true point: hard shadows, as Dürer's
        lamp.use_shadow = True
        lamp_obj = bpy.data.objects.new("Light", lamp)
        lamp_obj.location = (4.0, -4.0, 14.0)
        coll.objects.link(lamp_obj)

    camera = bpy.data.cameras.new("Camera")
    camera.type = "ORTHO"
    camera.ortho_scale = 24.0
    camera.clip_start, camera.clip_end = 0.1, 100.0
    camera_obj = aimed(bpy.data.objects.new("Camera", camera), (0, 1, -1))  # 45° down
    camera_obj.location = (0, -20, 20)
    coll.objects.link(camera_obj)
    scene.camera = camera_obj

    scene.render.engine = "DURER"
    scene.render.resolution_x, scene.render.resolution_y = 1920, 1080
    scene.render.resolution_percentage = 100
    scene.view_settings.view_transform = "Standard"
    scene.durer.samples = 1
    scene.cycles.samples = 1
    return scene


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("output", nargs="?", type=Path, default=HERE / "point_cloud.blend")
    parser.add_argument("--points", type=int, default=POINTS)
    parser.add_argument("--seed", type=int, default=7)
    parser.add_argument("--light", choices=("sun", "point"), default="sun")
    parser.add_argument("--made-by", choices=("points", "particles"), default="points")
    args = parser.parse_args(argv)
    build(args.points, args.seed, args.light, args.made_by)
    bpy.ops.wm.save_as_mainfile(filepath=str(args.output.resolve()))
    print(args.output.resolve())
    return 0


if __name__ == "__main__":
    sys.exit(main())
