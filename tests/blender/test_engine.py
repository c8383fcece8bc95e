"""The Dürer engine inside Blender: the Render button's operator, passes, the image datablock,
progress, cancel, errors and batch rendering (the extension package: test_extension.py)."""

from __future__ import annotations

import inspect
import os
import subprocess
import signal
import sys
import threading
import time

import numpy as np
import pytest
from helpers.blender import (
    aim_camera,
    ball_scene,
    cube,
    light,
    link,
    pointcloud_object,
    quad,
    render_passes,
)

from helpers.blender_import import blender_module

bpy = blender_module("bpy")

import durer
import durer.blender
from durer.blender import batch, engine
from durer.distributed import frames

pytestmark = pytest.mark.blender


def test_register_is_idempotent_and_reversible(scene):
    assert durer.blender.is_registered()
    durer.blender.register()
    panels = (
        bpy.types.RENDER_PT_format,
        bpy.types.DATA_PT_EEVEE_light,
        bpy.types.DATA_PT_lens,
        bpy.types.VIEWLAYER_PT_layer_passes,
        bpy.types.EEVEE_MATERIAL_PT_surface,
    )
    assert all("DURER" in p.COMPAT_ENGINES for p in panels)
    durer.blender.unregister()
    assert not any("DURER" in p.COMPAT_ENGINES for p in panels)
    assert not hasattr(bpy.types.Scene, "durer")
    with pytest.raises(TypeError):
        scene.render.engine = "DURER"
    durer.blender.register()
    scene.render.engine = "DURER"
    assert scene.render.engine == "DURER"


def test_render_button_fills_image_datablock(scene):
    ball_scene(scene)
    scene.durer.samples = 2
    assert bpy.ops.render.render() == {"FINISHED"}
    info = engine.last_render
    assert info.error is None and not info.cancelled
    assert (info.width, info.height, info.samples, info.spheres) == (64, 48, 2, 1)
    assert info.stats["mrays_per_s"] > 0 and info.stats["spp"] == 2
    image = bpy.data.images[engine.IMAGE_NAME]
    assert tuple(image.size) == (64, 48) and image.is_float
    assert image.colorspace_settings.name == "Linear Rec.709"
    pixels = np.empty(64 * 48 * 4, np.float32)
    image.pixels.foreach_get(pixels)
    pixels = pixels.reshape(48, 64, 4)[::-1]  # Blender's rows are bottom first
    centre = pixels[24, 32]
    assert centre[0] > 0.05 and centre[0] > 5 * centre[1] and centre[3] == 1.0
    np.testing.assert_allclose(pixels[0, 0, :3], 0.05, rtol=1e-6)  # the world colour
    # The same as the core renders the exported scene.
    from durer.blender import build
    from durer.blender.export.depsgraph import export_depsgraph

    data = export_depsgraph(bpy.context.evaluated_depsgraph_get())
    sc = build.make_scene(data)
    direct = durer.render(sc, build.make_camera(data.camera), 64, 48, spp=2, passes=("color",)).color
    np.testing.assert_allclose(pixels, direct, atol=1e-6)


def test_write_still_png_and_percentage(scene, tmp_path):
    ball_scene(scene, 80, 60)
    scene.render.resolution_percentage = 50
    scene.render.image_settings.file_format = "PNG"
    scene.render.filepath = str(tmp_path / "still.png")
    assert bpy.ops.render.render(write_still=True) == {"FINISHED"}
    img = bpy.data.images.load(str(tmp_path / "still.png"))
    assert tuple(img.size) == (40, 30)


def test_passes_are_registered_and_written(scene, tmp_path):
    ball_scene(scene)
    out = render_passes(scene, tmp_path / "passes.exr")
    hit = out["depth"] < 1e9
    assert 0.05 < hit.mean() < 0.5
    assert np.all(out["depth"][~hit] == 1e10)
    # The ball (radius 1) seen from 6 units: view-axis depth 5 at the centre, more off-centre.
    assert out["depth"][hit].min() == pytest.approx(5.0, abs=0.01)
    n = out["normal"][hit]
    np.testing.assert_allclose(np.linalg.norm(n, axis=1), 1.0, atol=1e-5)
    assert np.all(out["normal"][~hit] == 0)
    # The compositor's Render Layers node offers exactly the enabled passes.
    tree = bpy.data.node_groups.new("Compositing", "CompositorNodeTree")
    scene.compositing_node_group = tree
    node = tree.nodes.new("CompositorNodeRLayers")
    node.scene = scene

    def offered(name):
        return name in node.outputs and node.outputs[name].enabled

    assert offered("Depth") and offered("Normal")
    scene.view_layers[0].use_pass_normal = False
    assert offered("Depth") and not offered("Normal")
    out = render_passes(scene, tmp_path / "nonormal.exr", normal=False)
    assert set(out) == {"color", "depth"}


def test_normal_pass_of_samples_on_opposite_faces(scene, tmp_path):
    """Shade Back off, 4 samples, 5x5 pixels over two quads: the left one at z = 0 facing up, the
    right one at z = 1 facing down (away from the camera above). The middle column's samples see two
    of each, whose normals cancel: it takes the nearest sample's, the right quad's (it was 0)."""
    scene.render.resolution_x, scene.render.resolution_y = 5, 5
    scene.durer.samples = 4
    scene.durer.shade_back = False
    quad(scene, "Up", corners=((-3, -3, 0), (0, -3, 0), (0, 3, 0), (-3, 3, 0)))
    quad(scene, "Down", corners=((0, -3, 1), (0, 3, 1), (3, 3, 1), (3, -3, 1)))
    scene.camera.data.type = "ORTHO"
    scene.camera.data.ortho_scale = 5.0
    scene.camera.location = (0, 0, 5)
    scene.camera.rotation_euler = (0, 0, 0)
    out = render_passes(scene, tmp_path / "facing.exr")
    np.testing.assert_array_equal(out["normal"], np.broadcast_to([[0, 0, 1]] * 2 + [[0, 0, -1]] * 3, (5, 5, 3)))
    np.testing.assert_array_equal(out["depth"], np.broadcast_to([5, 5, 4, 4, 4], (5, 5)))


def test_errors_are_reported_and_blender_stays_usable(scene):
    ball_scene(scene)
    scene.camera.data.type = "PANO"
    with pytest.raises(RuntimeError, match="Dürer: Camera 'Camera' is panoramic"):
        bpy.ops.render.render()
    assert "Camera 'Camera' is panoramic" in engine.last_render.error
    scene.camera.data.type = "PERSP"
    assert bpy.ops.render.render() == {"FINISHED"}
    assert engine.last_render.error is None


def test_skipped_geometry_is_reported(scene):
    ball_scene(scene)
    cube(scene, "Box", location=(3, 0, 0))  # rendered, as triangles
    link(scene, bpy.data.objects.new("Fog", bpy.data.volumes.new("Fog")))
    assert bpy.ops.render.render() == {"FINISHED"}
    assert engine.last_render.warnings == ["Dürer skipped geometry it cannot render: 1 volume"]
    assert engine.last_render.triangles == 12


def test_visibility_settings_dürer_does_not_follow_are_reported(scene):
    """Object › Visibility (Cycles' ray visibility, holdout, shadow catcher): Dürer renders those
    objects as seen by every ray, and says so once per render, naming them."""
    ball_scene(scene)
    assert bpy.ops.render.render() == {"FINISHED"} and engine.last_render.warnings == []
    ball = bpy.data.objects["Ball"]
    boxes = [cube(scene, f"Box {i}", location=(3 * i - 6, 3, 0)) for i in range(5)]
    ball.visible_shadow = False
    for box in boxes:
        box.is_shadow_catcher = True
    boxes[0].visible_camera = False
    boxes[1].durer.primitive = "IGNORE"  # not rendered at all: nothing to say of it
    assert bpy.ops.render.render() == {"FINISHED"}
    assert engine.last_render.warnings == [
        "Dürer renders every object as seen by every ray and lit by every light; it does not follow "
        "Object › Visibility or light linking for 'Ball' casting no shadows; 'Box 0' hidden from the camera; 'Box 0', 'Box 2', 'Box 3' and others a shadow catcher"
    ]
    assert engine.last_render.spheres == 1 and engine.last_render.triangles == 4 * 12


def test_camera_and_light_settings_dürer_does_not_simulate_are_reported(scene):
    """Motion blur and light linking (set in Cycles, say): rendered without them, and said once per
    render; depth of field is rendered (nothing said), its panels shown for Dürer."""
    ball_scene(scene)
    assert "DURER" in bpy.types.DATA_PT_camera_dof.COMPAT_ENGINES
    assert "DURER" in bpy.types.DATA_PT_camera_dof_aperture.COMPAT_ENGINES
    scene.camera.data.dof.use_dof = True
    scene.render.use_motion_blur = True
    sun = next(obj for obj in scene.objects if obj.type == "LIGHT")
    sun.light_linking.receiver_collection = bpy.data.collections.new("Lit")
    assert bpy.ops.render.render() == {"FINISHED"}
    assert engine.last_render.warnings == [
        "Dürer renders every object as seen by every ray and lit by every light; it does not follow "
        f"Object › Visibility or light linking for '{sun.name}' linking lights or shadows",
        "Motion blur is on: Dürer renders each frame at one instant",
    ]


def test_view_layer_settings_dürer_does_not_follow_are_reported_and_its_panels_shown(scene):
    """A material override, a filtered-out environment, passes Dürer does not write: said, naming
    the view layer; the Particles and Physics tabs' panels and Color Management's curves are shown
    for Dürer, its own panels carry the Blender settings it reads that no shown panel does."""
    ball_scene(scene)
    layer = scene.view_layers[0]
    layer.material_override = bpy.data.materials.new("Clay")
    layer.use_sky = False
    layer.use_pass_mist = layer.use_pass_vector = True
    # And those a file set up for Cycles' compositing asks for (they went unsaid).
    layer.use_pass_diffuse_direct = layer.use_pass_glossy_color = layer.use_pass_cryptomatte_object = True
    layer.use_pass_cryptomatte_accurate = True  # a setting of the cryptomatte passes, no pass of its own
    layer.cycles.use_pass_shadow_catcher = True
    layer.aovs.add().name = "Wear"
    layer.lightgroups.add(name="Key")
    layer.use_pass_z = layer.use_pass_normal = layer.use_pass_object_index = True  # written: not said
    assert bpy.ops.render.render() == {"FINISHED"}
    assert engine.last_render.warnings == [
        f"View layer '{layer.name}' overrides every material with 'Clay': Dürer renders each with its own",
        f"View layer '{layer.name}' filters out Environment: Dürer renders them",
        f"View layer '{layer.name}' asks for passes Dürer does not write: Cryptomatte Object, Vector, Mist, "
        "Diffuse Direct, Glossy Color, Shadow Catcher, AOV 'Wear', Light Group 'Key'",
    ]
    for panel in ("PARTICLE_PT_emission", "PHYSICS_PT_field", "RENDER_PT_color_management_curves",
                  "RENDER_PT_simplify"):
        assert "DURER" in getattr(bpy.types, panel).COMPAT_ENGINES, panel
    for panel in ("DATA_PT_curves_surface", "DATA_PT_cone"):
        assert "DURER" not in getattr(bpy.types, panel).COMPAT_ENGINES, panel
    from durer.blender import ui

    drawn = inspect.getsource(ui.DURER_PT_render.draw) + inspect.getsource(ui.DURER_PT_light.draw)
    for setting in ('"film_transparent"', '"use_persistent_data"', '"distance"', '"use_shadow"'):
        assert setting in drawn, setting


def test_light_and_world_settings_dürer_does_not_follow_are_reported(scene):
    """Lights' ray visibility and shader nodes, a negative light (left out: Dürer cannot take light
    away), a world hidden from the camera: each said, naming it (an unnormalized light is converted)."""
    ball_scene(scene)
    sun = next(obj for obj in scene.objects if obj.type == "LIGHT")
    sun.visible_diffuse = False
    lamp = light(scene, "POINT", name="Lamp", energy=100.0, location=(0, -3, 2))
    lamp.data.use_nodes, lamp.data.normalize = True, False
    light(scene, "POINT", name="Dark", energy=-50.0, location=(2, -3, 0))
    scene.world.cycles_visibility.camera = False
    assert bpy.ops.render.render() == {"FINISHED"}
    assert engine.last_render.warnings == [
        "Light 'Lamp' uses shader nodes: Dürer takes its colour and power alone",
        "Light 'Dark' has a negative power or colour: Dürer leaves it out (Cycles takes its light away)",
        "Dürer renders every object as seen by every ray and lit by every light; it does not follow "
        f"Object › Visibility or light linking for '{sun.name}' lighting no diffuse surface",
        f"World '{scene.world.name}' is hidden from the camera: Dürer shows it behind the objects",
    ]
    assert engine.last_render.stats["rays"] > 0


def test_a_scene_camera_that_is_no_camera_is_a_clear_error(scene):
    ball_scene(scene)
    scene.camera = link(scene, bpy.data.objects.new("Pointer", None))
    with pytest.raises(RuntimeError, match="The scene's camera 'Pointer' is an object of type EMPTY, not a camera"):
        bpy.ops.render.render()


def test_progress_hooks_see_the_render(scene):
    ball_scene(scene)
    seen = []
    engine.progress_hooks.append(seen.append)
    try:
        bpy.ops.render.render()
    finally:
        engine.progress_hooks.remove(seen.append)
    assert seen and seen[-1] == 1.0 and seen == sorted(seen)


class _CancellingEngine(engine.DurerEngineMixin, bpy.types.RenderEngine):
    """The Dürer engine with Esc pressed `after` seconds into the render (bpy has no keyboard)."""

    bl_idname = "DURER_TEST_CANCEL"
    bl_label = "Dürer (cancel test)"
    after = 0.3
    started = 0.0
    pressed = None

    def break_requested(self):
        now = time.perf_counter()
        if now - type(self).started >= self.after:
            if type(self).pressed is None:
                type(self).pressed = now
            return True
        return False

    def render(self, depsgraph):
        type(self).started = time.perf_counter()
        type(self).pressed = None
        super().render(depsgraph)


def test_escape_cancels_quickly_and_blender_stays_usable(scene):
    rng = np.random.default_rng(0)
    pointcloud_object(scene, "Many", rng.uniform(-3, 3, (50, 3)), radius=0.3)
    aim_camera(scene, (0, -12, 0))
    light(scene, "SUN", rotation=(0.4, 0.3, 0))  # a shadow ray per sample too
    scene.render.resolution_x, scene.render.resolution_y = 640, 480
    scene.durer.samples = 4096  # over 10 s at 250 Mrays/s: far longer than the 0.3 s before "Esc"
    bpy.utils.register_class(_CancellingEngine)
    try:
        for panel in engine._compatible_panels():
            panel.COMPAT_ENGINES.add(_CancellingEngine.bl_idname)
        scene.render.engine = _CancellingEngine.bl_idname
        t0 = time.perf_counter()
        assert bpy.ops.render.render() == {"FINISHED"}
        done = time.perf_counter()
    finally:
        scene.render.engine = "DURER"
        for panel in engine._compatible_panels():
            panel.COMPAT_ENGINES.discard(_CancellingEngine.bl_idname)
        bpy.utils.unregister_class(_CancellingEngine)
    assert engine.last_render.cancelled and engine.last_render.error is None
    assert _CancellingEngine.pressed is not None
    assert done - _CancellingEngine.pressed < 0.2, f"cancel took {done - _CancellingEngine.pressed:.3f} s"
    assert done - t0 < 5
    assert threading.active_count() == 1 or not any(t.name == "durer-render" for t in threading.enumerate())
    scene.durer.samples = 1
    assert bpy.ops.render.render() == {"FINISHED"} and not engine.last_render.cancelled


# --- batch -----------------------------------------------------------------------------------------


def saved_blend(s, path):
    ball_scene(s, 40, 30)
    s.frame_start, s.frame_end = 1, 3
    ball = bpy.data.objects["Ball"]
    ball.location = (-1, 0, 0)
    ball.keyframe_insert("location", frame=1)
    ball.location = (1, 0, 0)
    ball.keyframe_insert("location", frame=3)
    bpy.ops.wm.save_as_mainfile(filepath=str(path))
    return path


def test_parse_frames():
    assert batch.parse_frames("1-3,7, 9-10") == [1, 2, 3, 7, 9, 10]
    assert batch.parse_frames("-2--1") == [-2, -1]
    assert batch.parse_frames(5) == [5] and batch.parse_frames(None) is None
    for bad in ("", "3-1", "a", "1-"):
        with pytest.raises(ValueError, match="frames must look like"):
            batch.parse_frames(bad)


def test_parse_frames_checks_each_frame_and_renders_it_once():
    low, high = batch.frame_range()
    assert (low, high) == (-1048574, 1048574)  # Blender 5.0's; frame_set clamps beyond them
    assert batch.parse_frames("2,2") == [2] and batch.parse_frames("1-3,2,1") == [1, 2, 3]
    assert batch.parse_frames([3, 1, 3]) == [3, 1] and batch.parse_frames(f"{low},{high}") == [low, high]
    # a range's ends are checked before it is expanded (no list of 10**11 frames first)
    for spec, message in (("1-99999999999", r"^frames must be <= 1048574, got 99999999999$"),
                          (f"{low - 1}", r"^frames must be >= -1048574, got -1048575$"),
                          (high + 1, r"^frames must be <= 1048574, got 1048575$")):
        with pytest.raises(ValueError, match=message):
            batch.parse_frames(spec)
    for spec, message in (([1.7, 2.2], r"^frames\[0\] must be an integer, got float$"),
                          (True, r"^frames must be an integer, got bool$"),
                          (["a"], r"^frames\[0\] must be an integer, got str$"),
                          (1.5, r"^frames must be a string such as 1-48, an integer or integers, got float$")):
        with pytest.raises(TypeError, match=message):
            batch.parse_frames(spec)


def test_an_interrupted_batch_leaves_no_empty_frame_and_resumes(scene, tmp_path, monkeypatch, capsys):
    """Ctrl-C during a frame (a KeyboardInterrupt where Blender would swallow it: here from the
    progress callback, on the thread that polls the render): the render stops, no empty image is
    left for the frame, the batch stops; --resume renders that frame next. The command says so in
    one line, exit code 130."""
    blend = saved_blend(scene, tmp_path / "anim.blend")
    out = tmp_path / "out" / "f_####.png"

    def interrupt(frame, fraction):
        if frame == 2:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        batch.render_file(blend, frames="1-3", output=out, progress=interrupt)
    assert engine.last_render.interrupted and sorted(p.name for p in out.parent.iterdir()) == ["f_0001.png"]
    assert not any(t.name == "durer-render" for t in threading.enumerate())
    files = batch.render_file(blend, frames="1-3", output=out, resume=True)
    assert [f.name for f in files] == ["f_0002.png", "f_0003.png"]
    monkeypatch.setattr(batch, "render_file", lambda *a, **k: (_ for _ in ()).throw(KeyboardInterrupt))
    assert batch.main([str(blend), "--frames", "1-3", "-o", str(out)]) == 130
    assert capsys.readouterr().err.strip().endswith("interrupted: the frames written so far are complete; "
                                                    "run again with --resume to go on")


@pytest.mark.parametrize("ext", ["png", "exr"])
def test_ctrl_c_stops_a_batch_at_the_render_s_next_poll(scene, tmp_path, ext):
    """A real SIGINT during a frame: the batch's handler flags it, the render stops at its next poll
    and the frame ends interrupted, no file written for it (Blender's EXR writer crashed on an
    interrupted frame's empty result; a KeyboardInterrupt raised inside Blender's own calls into
    the engine was printed and ignored, and a blank frame written); Ctrl-C is Python's again after."""
    blend = saved_blend(scene, tmp_path / "anim.blend")
    out = tmp_path / "out" / f"f_####.{ext}"
    handler = signal.getsignal(signal.SIGINT)

    def interrupt(frame, fraction):
        if frame == 2:
            os.kill(os.getpid(), signal.SIGINT)

    with pytest.raises(KeyboardInterrupt):
        batch.render_file(blend, frames="1-3", output=out, progress=interrupt)
    assert engine.last_render.interrupted and sorted(p.name for p in out.parent.iterdir()) == [f"f_0001.{ext}"]
    assert signal.getsignal(signal.SIGINT) is handler and not engine.interrupt.is_set()
    assert not any(t.name == "durer-render" for t in threading.enumerate())


def test_a_batch_takes_ctrl_c_only_where_it_is_python_s_to_take():
    """Ctrl-C ignored (a batch started in the background) stays ignored; Python's handler is
    replaced for the batch and put back after."""
    before = signal.getsignal(signal.SIGINT)
    try:
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        restore = batch._catch_interrupts()
        assert signal.getsignal(signal.SIGINT) is signal.SIG_IGN
        restore()
        signal.signal(signal.SIGINT, signal.default_int_handler)
        restore = batch._catch_interrupts()
        assert signal.getsignal(signal.SIGINT) is not signal.default_int_handler
        restore()
        assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    finally:
        signal.signal(signal.SIGINT, before)


def test_a_failed_frame_does_not_stop_the_others(scene, tmp_path, capsys):
    """A frame that cannot render (the camera keyed panoramic on frame 2): frames 1 and 3 are
    written, each named as soon as it is in place, the error names frame 2 and why, once; its empty
    image is not left behind."""
    blend = saved_blend(scene, tmp_path / "anim.blend")
    bpy.ops.wm.open_mainfile(filepath=str(blend))
    camera = bpy.context.scene.camera.data
    for frame, kind in ((1, "PERSP"), (2, "PANO"), (3, "PERSP")):
        camera.type = kind
        camera.keyframe_insert("type", frame=frame)
    bpy.ops.wm.save_as_mainfile(filepath=str(blend))
    out = tmp_path / "out" / "f_####.png"
    events = []  # frames as they start rendering, files as they are put in place
    with pytest.raises(batch.BatchRenderError) as failure:
        batch.render_file(blend, frames="1-3", output=out, on_written=lambda f: events.append(f.name),
                          progress=lambda frame, fraction: events.append(frame) if frame not in events else None)
    assert events == [1, "f_0001.png", 3, "f_0003.png"]  # each named before the next starts (2 fails at export)
    assert [f.name for f in failure.value.written] == ["f_0001.png", "f_0003.png"]
    assert str(failure.value).startswith(f"1 of 3 frames failed: 2 (Frame 2 of {blend} failed: ValueError: Camera")
    assert sorted(p.name for p in out.parent.iterdir()) == ["f_0001.png", "f_0003.png"]
    bpy.context.scene.view_layers[0].use_pass_diffuse_color = True  # a pass Dürer does not write
    bpy.ops.wm.save_as_mainfile(filepath=str(blend))
    capsys.readouterr()
    assert batch.main([str(blend), "--frames", "1-3", "-o", str(out), "-q"]) == 1
    printed = capsys.readouterr()
    assert printed.out.count("image written to") == 2 and printed.err.count("Frame 2") == 1
    # The renders' warnings, which Blender shows only in its window: once for the batch.
    assert printed.err.count("warning: View layer 'ViewLayer' asks for passes Dürer does not write: Diffuse Color") == 1


def test_output_format_from_the_extension_whatever_the_file_writes(scene, tmp_path):
    """A file set to write video or multilayer EXR, rendered to x.png: PNG images (Blender 5 sorts
    formats by medium); to x.exr from a multilayer file: multilayer, its passes kept; the last "#"
    run of the file name is the frame, as Blender's frame_path numbers it."""
    from helpers.exr import read_exr

    blend = saved_blend(scene, tmp_path / "anim.blend")
    bpy.ops.wm.open_mainfile(filepath=str(blend))
    settings = bpy.context.scene.render.image_settings
    settings.media_type, settings.file_format = "VIDEO", "FFMPEG"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend))
    (png,) = batch.render_file(blend, frames="2", output=tmp_path / "take#1" / "f_##_v##.png")
    assert png == tmp_path / "take#1" / "f_##_v02.png" and png.read_bytes()[:4] == b"\x89PNG"
    bpy.ops.wm.open_mainfile(filepath=str(blend))
    bpy.context.scene.render.image_settings.media_type = "MULTI_LAYER_IMAGE"
    bpy.context.scene.render.image_settings.exr_codec = "NONE"  # what helpers.exr reads
    bpy.context.scene.view_layers[0].use_pass_z = True
    bpy.ops.wm.save_as_mainfile(filepath=str(blend))
    (exr,) = batch.render_file(blend, frames="2", output=tmp_path / "f_####.exr")
    assert any(name.endswith("Depth.Z") for name in read_exr(exr))


@pytest.mark.parametrize("passes", [True, False])
def test_exr_output_from_a_file_writing_png_keeps_the_passes_asked_for(scene, tmp_path, passes):
    """--output x.exr from a file set to PNG: a multilayer EXR with the passes its view layer asks
    for (a single-layer EXR dropped Depth and Normal without a word), single-layer without."""
    from helpers.exr import read_exr_headers

    layer = scene.view_layers[0]
    layer.use_pass_z = layer.use_pass_normal = passes
    scene.render.image_settings.file_format = "PNG"
    blend = saved_blend(scene, tmp_path / "png.blend")
    (exr,) = batch.render_file(blend, frames="1", output=tmp_path / "f_####.exr")
    channels = {name for header in read_exr_headers(exr) for name, _ in header["channels"]}
    if passes:
        assert {"ViewLayer.Depth.Z", "ViewLayer.Normal.X", "ViewLayer.Combined.R"} <= channels
    else:
        assert channels == {"R", "G", "B", "A"}


def test_render_file_frames_and_output(scene, tmp_path):
    blend = saved_blend(scene, tmp_path / "anim.blend")
    bpy.ops.wm.read_factory_settings(use_empty=True)
    seen = []
    files = batch.render_file(
        blend,
        frames="1-3",
        output=tmp_path / "out" / "frame_####.png",
        samples=2,
        progress=lambda f, x: seen.append((f, x)),
    )
    assert [f.name for f in files] == ["frame_0001.png", "frame_0002.png", "frame_0003.png"]
    assert all(f.is_file() for f in files)
    assert {f for f, _ in seen} == {1, 2, 3} and (3, 1.0) in seen
    assert engine.last_render.samples == 2
    first, last = (np.array(Image_pixels(f)) for f in (files[0], files[2]))
    assert not np.array_equal(first, last)  # the ball moved


def test_a_frame_given_twice_is_rendered_once_under_the_plain_name(scene, tmp_path):
    blend = saved_blend(scene, tmp_path / "twice.blend")
    bpy.ops.wm.read_factory_settings(use_empty=True)
    files = batch.render_file(blend, frames="2,2", output=tmp_path / "still.png", samples=1)
    assert files == [tmp_path / "still.png"]  # not still_0002.png, written twice
    assert sorted(p.name for p in tmp_path.iterdir()) == ["still.png", "twice.blend"]


def test_threads_reach_the_renders_in_this_process(scene, tmp_path):
    blend = saved_blend(scene, tmp_path / "threads.blend")
    bpy.ops.wm.read_factory_settings(use_empty=True)
    batch.render_file(blend, frames=1, output=tmp_path / "one.png", samples=1, threads=3)
    assert engine.last_render.stats["threads"] == 3
    assert batch.main([str(blend), "-q", "-f", "1", "-o", str(tmp_path / "two.png"), "--threads", "1"]) == 0
    assert engine.last_render.stats["threads"] == 1
    with pytest.raises(ValueError, match=r"^threads must be >= 1, got 0$"):
        batch.render_file(blend, threads=0)


def test_an_output_that_cannot_be_made_is_one_line_and_exit_code_2(scene, tmp_path, capsys):
    blend = saved_blend(scene, tmp_path / "out.blend")
    (tmp_path / "a_file").write_text("")
    assert batch.main([str(blend), "-q", "-f", "1", "-o", str(tmp_path / "a_file" / "x.png")]) == 2
    assert capsys.readouterr().err == ("python -m durer render: error: [Errno 20] "
                                       f"'{tmp_path / 'a_file'}' is a file, not a folder\n")
    assert batch.main([str(blend), "-q", "--threads", "0"]) == 2
    assert capsys.readouterr().err == "python -m durer render: error: --threads must be >= 1, got 0\n"


def test_render_file_into_a_directory(scene, tmp_path):
    blend = saved_blend(scene, tmp_path / "dir.blend")
    bpy.ops.wm.read_factory_settings(use_empty=True)
    (tmp_path / "existing").mkdir()
    for output, folder in ((f"{tmp_path / 'new'}{os.sep}", "new"), (tmp_path / "existing", "existing")):
        files = batch.render_file(blend, frames="2", output=output, samples=1)
        assert files == [tmp_path / folder / "0002.png"] and files[0].is_file()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["dir.blend", "existing", "new"]  # nothing beside


def Image_pixels(path):
    img = bpy.data.images.load(str(path))
    px = np.empty(len(img.pixels), np.float32)
    img.pixels.foreach_get(px)
    bpy.data.images.remove(img)
    return px


def test_render_file_errors(scene, tmp_path, capsys):
    with pytest.raises(FileNotFoundError):
        batch.render_file(tmp_path / "missing.blend")
    # a name the system cannot look up (an OSError traceback before; found by the hardening fuzz)
    with pytest.raises(ValueError, match=r"^cannot open .*/x{300}: File name too long$"):
        batch.render_file(tmp_path / ("x" * 300))
    blend = saved_blend(scene, tmp_path / "bad.blend")
    bpy.ops.wm.open_mainfile(filepath=str(blend))
    bpy.context.scene.camera.data.type = "PANO"
    bpy.ops.wm.save_mainfile()
    with pytest.raises(batch.BatchRenderError, match="Frame 1 of .* failed: .*is panoramic"):
        batch.render_file(blend, frames=1, output=tmp_path / "x.png")
    # Blender would clamp these silently (to 4096 and 1024): refused, naming them, before a render
    with pytest.raises(ValueError, match=r"^samples must be <= 4096, got 5000$"):
        batch.render_file(blend, samples=5000)
    with pytest.raises(ValueError, match=r"^threads must be <= 1024, got 2147483648$"):
        frames.render_frames(blend, client=None, threads=2**31)
    assert batch.main([str(tmp_path / "missing.blend")]) == 2
    assert batch.main([str(blend), "-q", "-f", "1", "-o", str(tmp_path / "y.png")]) == 1
    # Bad input, exit code 2 (they were render errors, 1): a scene the file has not, a file not a .blend.
    capsys.readouterr()
    assert batch.main([str(blend), "-q", "--scene", "Nope"]) == 2
    assert capsys.readouterr().err == f"python -m durer render: error: {blend} has no scene named 'Nope'\n"
    (tmp_path / "notes.txt").write_text("not a .blend file")
    assert batch.main([str(tmp_path / "notes.txt"), "-q"]) == 2
    error = capsys.readouterr().err
    assert error.startswith(f"python -m durer render: error: Cannot open {tmp_path / 'notes.txt'}: ")
    assert error.count("\n") == 1  # one line, not Blender's message with its own line break


def test_batch_command_line(scene, tmp_path):
    blend = saved_blend(scene, tmp_path / "cli.blend")
    cmd = [
        sys.executable,
        "-m",
        "durer",
        "render",
        str(blend),
        "--frames",
        "2",
        "--output",
        str(tmp_path / "cli_####.png"),
        "--samples",
        "1",
    ]
    done = subprocess.run(cmd, check=False, capture_output=True, text=True, timeout=120, env=os.environ.copy())
    assert done.returncode == 0, done.stderr
    assert (tmp_path / "cli_0002.png").is_file()
    assert str(tmp_path / "cli_0002.png") in done.stdout
    assert "frame 2" in done.stderr  # the progress bar
    done = subprocess.run(cmd[:5] + ["--frames", "x"], check=False, capture_output=True, text=True, timeout=120)
    assert done.returncode == 2 and "frames must look like" in done.stderr

