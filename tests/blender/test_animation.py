"""Animations in Blender: with Persistent Data on (and always in batch frame renders) a frame whose
spheres only moved reuses the last frame's core scene, refitting its hierarchy, and renders exactly
what a fresh export renders."""

from __future__ import annotations

import numpy as np
import pytest
from helpers.blender import DEG, aim_camera, light, material, quad, world

from helpers.blender_import import blender_module

bpy = blender_module("bpy")

from durer.blender import batch, engine, point_cloud

pytestmark = pytest.mark.blender


def exploding_cloud(s, n=2000):
    """A geometry-nodes point cloud whose points fly outward with the frame (Set Position, offset
    = position x frame x 0.1), over a floor, lit by a sun with shadows."""
    s.render.resolution_x, s.render.resolution_y = 48, 36
    world(s, (0.05, 0.05, 0.05))
    obj = point_cloud.point_cloud_object(s.collection, "Cloud", np.random.default_rng(5).uniform(-1, 1, (n, 3)), 0.04)
    obj.location = (0, 0, 1.2)
    obj.data.materials.append(material("Orange", (0.8, 0.3, 0.05)))
    tree = obj.modifiers["Points"].node_group
    nodes, links = tree.nodes, tree.links
    to_points = next(node for node in nodes if node.bl_idname == "GeometryNodeMeshToPoints")
    output = next(node for node in nodes if node.bl_idname == "NodeGroupOutput")
    set_position = nodes.new("GeometryNodeSetPosition")
    frame_scale = nodes.new("ShaderNodeMath")
    frame_scale.operation, frame_scale.inputs[1].default_value = "MULTIPLY", 0.1
    offset = nodes.new("ShaderNodeVectorMath")
    offset.operation = "SCALE"
    links.new(nodes.new("GeometryNodeInputSceneTime").outputs["Frame"], frame_scale.inputs[0])
    links.new(nodes.new("GeometryNodeInputPosition").outputs["Position"], offset.inputs[0])
    links.new(frame_scale.outputs[0], offset.inputs["Scale"])
    links.new(to_points.outputs[0], set_position.inputs["Geometry"])
    links.new(offset.outputs["Vector"], set_position.inputs["Offset"])
    links.new(set_position.outputs[0], output.inputs[0])
    quad(s, "Floor", corners=((-4, -4, -0.5), (4, -4, -0.5), (4, 4, -0.5), (-4, 4, -0.5)))
    light(s, "SUN", energy=3.0, rotation=(30 * DEG, 10 * DEG, 0))
    aim_camera(s, (0, -7, 3), (0, 0, 1))
    s.frame_start, s.frame_end = 1, 3


def render_frame(s, frame):
    s.frame_set(frame)
    assert bpy.ops.render.render() == {"FINISHED"} and engine.last_render.error is None
    image = bpy.data.images[engine.IMAGE_NAME]
    pixels = np.empty(len(image.pixels), np.float32)
    image.pixels.foreach_get(pixels)
    return pixels, engine.last_render.reused_scene


def test_moving_points_reuse_the_scene_and_render_as_a_fresh_export(scene):
    exploding_cloud(scene)
    scene.render.use_persistent_data = False
    fresh = [render_frame(scene, f) for f in (1, 2, 3)]
    assert not any(reused for _, reused in fresh) and not engine.persistent
    scene.render.use_persistent_data = True
    kept = [render_frame(scene, f) for f in (1, 2, 3)]
    assert [reused for _, reused in kept] == [False, True, True]
    assert "last frame's scene refitted" in engine.last_render.stats_line
    for (a, _), (b, _) in zip(fresh, kept):
        np.testing.assert_array_equal(a, b)
    assert not np.array_equal(fresh[0][0], fresh[2][0])  # the points moved
    sphere_scene = engine.persistent[scene.name][1]
    assert sphere_scene.hierarchy_counts["refitted"] == 2 and sphere_scene.hierarchy_counts["built"] == 1


def test_anything_else_changing_makes_a_new_scene(scene):
    exploding_cloud(scene)
    scene.render.use_persistent_data = True
    sun = bpy.data.objects["Sun"].data
    sun.energy = 3.0
    sun.keyframe_insert("energy", frame=1)
    sun.energy = 1.0
    sun.keyframe_insert("energy", frame=2)
    assert [render_frame(scene, f)[1] for f in (1, 2, 2, 3)] == [False, False, True, True]  # 2 -> 3: held
    scene.render.use_persistent_data = False
    assert not render_frame(scene, 3)[1] and not engine.persistent  # off: nothing kept


def test_batch_frames_reuse_the_scene_and_leave_the_setting_alone(scene, tmp_path):
    exploding_cloud(scene)
    scene.render.use_persistent_data = False
    blend = tmp_path / "cloud.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend))
    reused = []
    files = batch.render_file(blend, frames="1-3", output=tmp_path / "f_####.png", samples=1,
                              progress=lambda frame, fraction: reused.append((frame, engine.last_render.reused_scene)))
    assert len(files) == 3 and dict(reused) == {1: False, 2: True, 3: True}
    assert not engine.persistent  # let go after the last frame
    assert bpy.context.scene.render.use_persistent_data is False
