"""A keyframed .blend for the frame tests, built with the real bpy (Blender 5.0 from PyPI)."""

from __future__ import annotations

from pathlib import Path

from helpers.blender_import import blender_module

bpy = blender_module("bpy")
bmesh = blender_module("bmesh")

import durer.blender
from helpers.blender import aim_camera, light, world


def _ball(s, name, radius, color, location):
    bm = bmesh.new()
    bmesh.ops.create_uvsphere(bm, u_segments=24, v_segments=12, radius=radius)
    mesh = bpy.data.meshes.new(name)
    bm.to_mesh(mesh)
    bm.free()
    mat = bpy.data.materials.new(name)
    mat.node_tree.nodes["Principled BSDF"].inputs["Base Color"].default_value = (*color, 1.0)
    mesh.materials.append(mat)
    obj = bpy.data.objects.new(name, mesh)
    obj.location = location
    s.collection.objects.link(obj)
    return obj


def animated_blend(path: Path, frames: int = 12, width: int = 32, height: int = 24, samples: int = 4) -> Path:
    """Two balls and a camera, all keyframed over frames 1..`frames`, lit by a sun: each frame differs."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    durer.blender.register()
    s = bpy.context.scene
    s.render.engine = "DURER"
    s.render.resolution_x, s.render.resolution_y, s.render.resolution_percentage = width, height, 100
    s.durer.samples = samples
    s.frame_start, s.frame_end = 1, frames
    world = bpy.data.worlds.new("World")
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.05, 0.05, 0.08, 1.0)
    s.world = world
    red = _ball(s, "Red", 1.0, (0.8, 0.1, 0.1), (-1.5, 0, 0))
    blue = _ball(s, "Blue", 0.6, (0.1, 0.2, 0.8), (1.5, 0, 0))
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sun.rotation_euler = (0.6, 0.2, 0.3)
    s.collection.objects.link(sun)
    camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    s.collection.objects.link(camera)
    s.camera = camera
    camera.rotation_euler = (1.5708, 0, 0)
    for frame, t in ((1, 0.0), (frames, 1.0)):
        red.location = (-1.5 + 2 * t, 0, 0.5 * t)
        blue.location = (1.5, 0, -1 + 2 * t)
        camera.location = (t, -8 + t, 0)
        for obj in (red, blue, camera):
            obj.keyframe_insert("location", frame=frame)
    bpy.ops.wm.save_as_mainfile(filepath=str(path))
    return path


def falling_particles_blend(path: Path, frames: int = 8) -> Path:
    """`animated_blend`'s camera and sun over a particle system, not baked: balls born over the
    first frames fall under gravity, so each frame's particles are where the frames before left them."""
    animated_blend(path, frames=frames, width=48, height=36, samples=1)
    s = bpy.context.scene
    for name in ("Red", "Blue"):
        bpy.data.objects.remove(bpy.data.objects[name])
    bm = bmesh.new()
    bmesh.ops.create_grid(bm, x_segments=4, y_segments=4, size=1.5)
    mesh = bpy.data.meshes.new("Emitter")
    bm.to_mesh(mesh)
    bm.free()
    emitter = bpy.data.objects.new("Emitter", mesh)
    emitter.location, emitter.rotation_euler = (0, 0, 1.5), (1.2, 0, 0)
    emitter.show_instancer_for_render = emitter.show_instancer_for_viewport = False
    s.collection.objects.link(emitter)
    ball = _ball(s, "Ball", 0.12, (0.8, 0.6, 0.1), (0, 0, -30))
    emitter.modifiers.new("Particles", "PARTICLE_SYSTEM")
    part = emitter.particle_systems[0].settings
    part.count, part.frame_start, part.frame_end, part.lifetime = 60, 1, frames // 2, 50
    part.render_type, part.instance_object, part.particle_size, part.normal_factor = "OBJECT", ball, 1.0, 2.0
    part.factor_random = 1.0  # random initial speeds: each frame's state is its own history
    bpy.ops.wm.save_as_mainfile(filepath=str(path))
    return path


def falling_points(s) -> None:
    """Ten points (spheres of radius 0.1) made at z = 5 by a geometry-nodes Simulation Zone that
    moves them down 0.05 a frame, not baked: each frame is where the frames before left them."""
    tree = bpy.data.node_groups.new("Falling", "GeometryNodeTree")
    tree.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
    tree.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    nodes, links = tree.nodes, tree.links
    points = nodes.new("GeometryNodePoints")
    points.inputs["Count"].default_value, points.inputs["Position"].default_value = 10, (0, 0, 5)
    start, end = nodes.new("GeometryNodeSimulationInput"), nodes.new("GeometryNodeSimulationOutput")
    start.pair_with_output(end)
    move = nodes.new("GeometryNodeSetPosition")
    move.inputs["Offset"].default_value = (0, 0, -0.05)
    links.new(points.outputs[0], start.inputs["Geometry"])
    links.new(start.outputs["Geometry"], move.inputs["Geometry"])
    links.new(move.outputs[0], end.inputs["Geometry"])
    links.new(end.outputs["Geometry"], nodes.new("NodeGroupOutput").inputs[0])
    obj = bpy.data.objects.new("Sim", bpy.data.meshes.new("Sim"))
    s.collection.objects.link(obj)
    obj.modifiers.new("Falling", "NODES").node_group = tree
    s.render.resolution_x, s.render.resolution_y = 32, 32
    world(s, (0.05, 0.05, 0.05))
    light(s, "SUN", energy=3.0)
    aim_camera(s, (0, -2, 4.8), (0, 0, 4.8))
    s.frame_start, s.frame_end = 1, 6
    s.frame_set(1)
