"""Animations in Blender: with Persistent Data on (and always in batch frame renders) a frame whose
spheres only moved reuses the last frame's core scene, refitting its hierarchy, and renders exactly
what a fresh export renders."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest
from helpers.blend import falling_particles_blend, falling_points
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
    assert "last frame's scene reused" in engine.last_render.stats_line
    for (a, _), (b, _) in zip(fresh, kept):
        np.testing.assert_array_equal(a, b)
    assert not np.array_equal(fresh[0][0], fresh[2][0])  # the points moved
    sphere_scene = engine.persistent[scene.name, scene.view_layers[0].name][1]
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


def test_each_view_layer_keeps_its_own_scene_between_frames(scene):
    """Two view layers with Persistent Data (a render renders both): each refits its own kept core
    scene on the next frame (one was kept per scene, so each layer rebuilt over the other's: 0 of
    20 frames refitted)."""
    exploding_cloud(scene, 500)
    scene.view_layers.new("Second")
    scene.render.use_persistent_data = True
    scene.frame_set(1)
    assert bpy.ops.render.render() == {"FINISHED"} and engine.last_render.error is None
    kept = {key: core for key, (_, core) in engine.persistent.items()}
    assert set(kept) == {(scene.name, "ViewLayer"), (scene.name, "Second")}
    scene.frame_set(2)
    assert bpy.ops.render.render() == {"FINISHED"} and engine.last_render.reused_scene
    assert all(engine.persistent[key][1] is core for key, core in kept.items())
    engine.persistent.clear()


def test_an_unbaked_simulation_renders_the_frames_an_unbroken_batch_renders_in_any_order(scene, tmp_path):
    """A Simulation Zone, not baked: a batch stopped after frame 3 and resumed, a frame alone, frames
    out of order render as the whole batch does (the batch bakes the simulation in memory first, as a
    cluster's copy is baked; one process started it again at the first frame asked for)."""
    falling_points(scene)
    blend = tmp_path / "falling.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend))
    out = tmp_path / "out" / "f_####.png"
    whole = batch.render_file(blend, frames="1-6", output=out)
    kept = [pixels(p) for p in whole]  # the pixels: the files' metadata stamp the time
    assert len(set(kept)) == 6  # each frame its own
    for path in whole[3:]:
        path.unlink()
    assert batch.simulation_zones()
    resumed = batch.render_file(blend, frames="1-6", output=out, resume=True)
    assert [p.name for p in resumed] == ["f_0004.png", "f_0005.png", "f_0006.png"]
    assert [pixels(p) for p in resumed] == kept[3:]
    shuffled = batch.render_file(blend, frames="5,1,3", output=tmp_path / "shuffled" / "f_####.png")
    assert [pixels(p) for p in shuffled] == [kept[4], kept[0], kept[2]]
    (alone,) = batch.render_file(blend, frames="4", output=tmp_path / "alone.png")
    assert pixels(alone) == kept[3]


def pixels(path: Path) -> bytes:
    """An 8-bit image file's pixels, without its metadata."""
    from PIL import Image

    with Image.open(path) as image:
        return image.tobytes()


def test_frames_are_written_whole_under_their_own_name(scene, tmp_path):
    """Blender writes each frame under a hidden name and the batch renames it once whole: no frame
    file exists half written (a process killed mid-write left one that --resume took as done)."""
    exploding_cloud(scene, 100)
    blend = tmp_path / "cloud.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend))
    (tmp_path / "out").mkdir()
    stale = tmp_path / "out" / f".f_0002.exr.{os.getpid()}.part"
    stale.write_bytes(b"v/1\x01 cut short")  # left by a killed run of this process id: never promoted
    seen = []

    @bpy.app.handlers.persistent  # kept through the batch's opening of the file
    def written(*_):
        seen.append(sorted(p.name for p in (tmp_path / "out").iterdir()))

    bpy.app.handlers.render_write.append(written)
    try:
        batch.render_file(blend, frames="1-2", output=tmp_path / "out" / "f_####.exr")
    finally:
        bpy.app.handlers.render_write.remove(written)
    part = f"exr.{os.getpid()}.part"
    assert seen == [sorted([f".f_0001.{part}", stale.name]), [f".f_0002.{part}", "f_0001.exr"]]
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["f_0001.exr", "f_0002.exr"]
    assert (tmp_path / "out" / "f_0002.exr").stat().st_size > 1000


def test_a_file_writing_video_needs_an_image_output(scene, tmp_path):
    exploding_cloud(scene, 100)
    scene.render.image_settings.media_type, scene.render.image_settings.file_format = "VIDEO", "FFMPEG"
    blend = tmp_path / "video.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend))
    for output in (None, tmp_path / "frames", tmp_path / "f_####"):  # the file's format names the frames
        with pytest.raises(ValueError, match=r"^The file writes a video \(FFMPEG\), which a batch of frames "
                                             r"cannot: give --output with an image extension"):
            batch.render_file(blend, frames="1-2", output=output)
    assert len(batch.render_file(blend, frames="1-2", output=tmp_path / "f_####.png")) == 2


@pytest.mark.parametrize("pattern", ["f_####", "f_##", "take#1/f_###"])
def test_frame_numbers_are_blender_s_negative_ones_included(scene, tmp_path, pattern):
    """The batch's file names are Blender's own (RenderSettings.frame_path), minus sign included:
    frame -1 of f_#### is f_-0001 (it was f_-001)."""
    scene.render.image_settings.file_format = "PNG"
    scene.render.filepath = str(tmp_path / pattern)
    explicit = str(tmp_path / (pattern + ".png"))
    for frame in (-123, -1, 0, 7, 12345):
        assert batch.frame_target(scene, explicit, frame) == Path(scene.render.frame_path(frame=frame))


def test_a_batch_bakes_a_simulation_only_up_to_its_last_frame(tmp_path):
    """Frames 1-3 of a 40-frame particle simulation: baked up to frame 3, not the whole range (the
    scene's end, lowered for the bake, is restored)."""
    blend = falling_particles_blend(tmp_path / "particles.blend", frames=40)
    batch.render_file(blend, frames="1-3", output=tmp_path / "out" / "f_####.png")
    cache = bpy.data.objects["Emitter"].particle_systems[0].point_cache
    assert cache.is_baked and cache.info.startswith("3 frames in memory")
    assert bpy.context.scene.frame_end == 40
