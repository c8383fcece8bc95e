"""Depth of field from Blender's camera (its Depth of Field panel, as Cycles reads it): the export's
aperture, blades and focus distance (a Focus Object's, a Focus Bone's), the camera Dürer gets, the
viewport's camera view, and the image against Cycles' — a bright sphere far behind the plane of
focus blurred to a disc or an anamorphic pentagon, and one on the plane staying sharp."""

from __future__ import annotations

import math
from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pytest
from helpers.blender import aim_camera, export, material, pointcloud_object, render_passes, use_cycles, world

from helpers.blender_import import blender_module

bpy = blender_module("bpy")

import durer  # noqa: E402
from durer.blender import build, viewport  # noqa: E402
from durer.blender.export import LensData  # noqa: E402
from durer.blender.export.camera import camera_data  # noqa: E402

pytestmark = pytest.mark.blender


def dof_camera(scene, kind="PERSP", fstop=2.8, focus=3.0, blades=0, rotation=0.0, ratio=1.0):
    """The scene camera at the origin looking along +Y (up +Z), with Depth of Field on."""
    cam = aim_camera(scene, (0, 0, 0), (0, 10, 0)).data
    cam.type = kind
    dof = cam.dof
    dof.use_dof = True
    dof.focus_distance, dof.aperture_fstop = focus, fstop
    dof.aperture_blades, dof.aperture_rotation, dof.aperture_ratio = blades, rotation, ratio
    return cam


# --- the export ------------------------------------------------------------------------------------


def test_the_aperture_is_cycles_focal_length_over_twice_the_f_stop(scene):
    cam = dof_camera(scene, fstop=2.8, focus=4.5, blades=6, rotation=0.3, ratio=1.5)
    cam.lens = 85.0
    lens = export(scene).camera.lens
    assert lens == LensData(aperture_radius=pytest.approx(0.085 / 5.6), focus_distance=pytest.approx(4.5),
                            aperture_blades=6, aperture_rotation=pytest.approx(0.3), aperture_ratio=pytest.approx(1.5))
    camera = build.make_camera(camera_data(scene, scene.camera))
    assert isinstance(camera, durer.PerspectiveCamera)
    assert camera.aperture_radius == pytest.approx(0.0151786, rel=1e-5) and camera.focus_distance == pytest.approx(4.5)
    assert (camera.aperture_blades, camera.aperture_rotation, camera.aperture_ratio) == (6, pytest.approx(0.3), 1.5)
    cam.type = "ORTHO"  # no focal length: 1 / (2 F-Stop), whatever the lens
    camera = build.make_camera(camera_data(scene, scene.camera))
    assert isinstance(camera, durer.OrthographicCamera)
    assert camera.aperture_radius == pytest.approx(1.0 / 5.6) and camera.focus_distance == pytest.approx(4.5)


@pytest.mark.parametrize("blades", [0, 3, 16])
def test_blades_are_passed_on(scene, blades):
    dof_camera(scene, blades=blades)
    assert export(scene).camera.lens.aperture_blades == blades
    assert build.make_camera(camera_data(scene, scene.camera)).aperture_blades == blades


def test_blender_never_holds_one_or_two_blades(scene):
    """Its setter steps over them as its spinner does (up from 0 to 3, down from 3 or more to 0): the
    export's disc for fewer than 3 (Cycles') is for an old file's 1 or 2, which Dürer's camera refuses."""
    dof = dof_camera(scene).dof
    for start, asked, held in ((0, 1, 3), (0, 2, 3), (5, 1, 0), (3, 2, 0)):
        dof.aperture_blades = start
        dof.aperture_blades = asked
        assert dof.aperture_blades == held
    with pytest.raises(ValueError):
        durer.PerspectiveCamera((0, 0, 0), (0, 1, 0), (0, 0, 1), aperture_radius=0.1, focus_distance=3.0,
                                aperture_blades=2)


def test_an_f_stop_and_focus_distance_of_zero_are_clamped_as_cycles_does(scene):
    cam = dof_camera(scene, fstop=0.0, focus=0.0)
    cam.lens = 50.0
    lens = export(scene).camera.lens
    assert lens.aperture_radius == pytest.approx(0.05 / 2e-5) and lens.focus_distance == pytest.approx(1e-5)
    assert build.make_camera(camera_data(scene, scene.camera)).focus_distance == pytest.approx(1e-5)


def test_a_focus_object_is_focused_on_along_the_view_axis(scene):
    """Its distance along the view axis (5 m), not its Euclidean distance (6.16 m); the camera's
    scale leaves the axis a unit vector (Cycles clears the scale)."""
    dof_camera(scene, focus=1.0)
    scene.camera.scale = (2.0, 0.5, 3.0)
    target = bpy.data.objects.new("Target", None)
    scene.collection.objects.link(target)
    target.location = (3.0, 5.0, -2.0)
    scene.camera.data.dof.focus_object = target
    bpy.context.view_layer.update()
    assert export(scene).camera.lens.focus_distance == pytest.approx(5.0, rel=1e-6)
    target.location = (0.0, -2.0, 1.0)  # behind the camera: the distance is still positive
    bpy.context.view_layer.update()
    assert export(scene).camera.lens.focus_distance == pytest.approx(2.0, rel=1e-6)


def test_a_focus_bone_is_focused_on_at_its_posed_head(scene):
    """An armature object at (1, 4, 0) whose bone's head lies at (0, 3, 0) in its space, posed 2
    along the bone's -Z (the world's +Y): the head is at (1, 9, 0), 9 m along the view axis. A bone
    name the armature lacks: its origin, 4 m (as Cycles)."""
    dof_camera(scene, focus=1.0)
    rig = bpy.data.objects.new("Rig", bpy.data.armatures.new("Rig"))
    scene.collection.objects.link(rig)
    bpy.context.view_layer.objects.active = rig
    assert bpy.ops.object.mode_set(mode="EDIT") == {"FINISHED"}
    bone = rig.data.edit_bones.new("Head")
    bone.head, bone.tail = (0, 3, 0), (0, 3, 1)
    assert bpy.ops.object.mode_set(mode="OBJECT") == {"FINISHED"}
    rig.location = (1, 4, 0)
    rig.pose.bones["Head"].location = (0, 0, -2)
    dof = scene.camera.data.dof
    dof.focus_object, dof.focus_subtarget = rig, "Head"
    bpy.context.view_layer.update()
    assert export(scene).camera.lens.focus_distance == pytest.approx(9.0, rel=1e-6)
    dof.focus_subtarget = "Tail"
    assert export(scene).camera.lens.focus_distance == pytest.approx(4.0, rel=1e-6)


def test_without_depth_of_field_the_camera_is_a_pinhole_and_nothing_is_said(scene):
    dof_camera(scene, fstop=1.0, blades=5)
    scene.render.use_motion_blur = True
    data = export(scene)
    assert data.camera.lens.aperture_radius == pytest.approx(0.05 / 2.0)
    assert data.notes == ["Motion blur is on: Dürer renders each frame at one instant"]
    scene.camera.data.dof.use_dof = False
    assert export(scene).camera.lens == LensData()
    camera = build.make_camera(camera_data(scene, scene.camera))
    assert (camera.aperture_radius, camera.focus_distance, camera.aperture_blades) == (0.0, None, 0)


# --- the viewport ----------------------------------------------------------------------------------


def glow(scene, name, center, radius):
    """A sphere (a point cloud's point: exact in Cycles too) of white emission 1."""
    obj = pointcloud_object(scene, name, [center], radius=radius)
    obj.data.materials.append(material(name, emission=((1.0, 1.0, 1.0), 1.0)))
    return obj


def test_the_camera_view_shows_the_cameras_depth_of_field(scene):
    """The camera view's passes go through the scene camera's lens (the F12 camera's, the view's
    zoom aside); another view of the same matrices is a pinhole; a new F-Stop restarts the image."""
    w = h = 32
    scene.render.resolution_x, scene.render.resolution_y = w, h
    world(scene, (0, 0, 0))
    glow(scene, "Far", (0, 10, 0), 0.15)  # of radius 2.7 px
    dof_camera(scene, fstop=0.75, focus=3.0).lens = 200.0
    scene.durer.samples = 16
    depsgraph = bpy.context.evaluated_depsgraph_get()
    window = scene.camera.evaluated_get(depsgraph).calc_matrix_camera(depsgraph, x=w, y=h)
    view = scene.camera.matrix_world.normalized().inverted()
    f12 = build.make_camera(camera_data(scene, scene.camera))
    zoomed = window.copy()
    zoomed[0][0] *= 2.0
    zoomed[1][1] *= 2.0
    in_zoom = viewport.region_camera(SimpleNamespace(view_matrix=view, window_matrix=zoomed, is_perspective=True),
                                     w, h, viewport.camera_lens(scene.camera, depsgraph))
    assert in_zoom.aperture_radius == f12.aperture_radius == pytest.approx(0.2 / 1.5)
    assert in_zoom.focus_distance == f12.focus_distance == pytest.approx(3.0)
    core = build.make_scene(export(scene))
    kwargs = viewport.pass_kwargs(scene.durer)
    seed = int(scene.durer.seed)
    session = viewport.ViewportSession()
    session.update(depsgraph)

    def shown(perspective):
        region = SimpleNamespace(view_matrix=view, window_matrix=window, is_perspective=True,
                                 view_perspective=perspective)
        assert session.view(region, w, h) and session.image.wait(30) and session.image.passes == 16
        return session.image.mean()[..., 0]

    sharp = shown("PERSP")
    pinhole = replace(f12, aperture_radius=0.0, focus_distance=None)
    np.testing.assert_allclose(sharp, direct_mean(core, pinhole, w, h, 16, seed, **kwargs), atol=1e-3)
    assert (sharp > 0.02).sum() < 45 and sharp.max() == 1.0
    blurred = shown("CAMERA")
    # Its blur radius: 0.133 m · (1/3 - 1/10) · 177.8 px per unit at unit distance = 5.5 px.
    np.testing.assert_allclose(blurred, direct_mean(core, f12, w, h, 16, seed, **kwargs), atol=1e-3)
    # measured: 138 pixels lit, the brightest 0.44 (the sharp sphere's 32, at 1)
    assert (blurred > 0.02).sum() > 100 and blurred.max() < 0.6
    assert blurred.sum() == pytest.approx(sharp.sum(), rel=0.1)  # the lens moves light, keeps it: 23.0, 22.2
    # A 3D view's Local Camera (view_draw passes its lens), here one without depth of field: in focus.
    region = SimpleNamespace(view_matrix=view, window_matrix=window, is_perspective=True, view_perspective="CAMERA")
    assert session.view(region, w, h, viewport.LensData()) and session.image.wait(30)
    assert session.image.mean()[..., 0].max() == 1.0
    scene.camera.data.dof.aperture_fstop = 8.0
    session.update(bpy.context.evaluated_depsgraph_get())
    assert shown("CAMERA").max() > 0.9  # the same view restarted at f/8: a blur of 0.5 px
    session.image.stop()


def direct_mean(core, camera, w, h, passes, seed, **kwargs):
    """The mean of the viewport's one-sample passes, rendered here one by one."""
    colors = [durer.render(core, camera, w, h, spp=1, seed=seed + k, sampler=viewport.PASS_SAMPLER,
                           passes=("color",), **kwargs).color[..., 0] for k in range(passes)]
    return np.mean(np.asarray(colors, np.float64), axis=0)


# --- against Cycles --------------------------------------------------------------------------------

SIZE = 96
#: Per projection: the camera, the far sphere's radius, and the in-focus sphere's centre and radius
#: (in a corner, clear of the blur). Perspective: 200 mm at f/0.75, an aperture radius of 0.133 m and
#: 533 px per unit at unit distance; orthographic: ortho scale 2 (48 px/m) at f/3.5, 0.143 m.
BOKEH_CASES = {
    "perspective": ({"type": "PERSP", "lens": 200.0}, 0.75, 0.05, (-0.2, 3.0, 0.2), 0.03),
    "orthographic": ({"type": "ORTHO", "ortho_scale": 2.0}, 3.5, 0.04, (-0.7, 3.0, 0.7), 0.07),
}
#: The far sphere's blur radius (px) by the thin lens: perspective 0.133 · (1/3 - 1/10) · 533.3;
#: orthographic (1/7) · (10/3 - 1) · 48.
BLUR_RADIUS = {"perspective": 0.2 / 1.5 * (1 / 3 - 1 / 10) * SIZE / 0.18, "orthographic": (10 / 3 - 1) / 7 * 48}


def bokeh_renders(scene, tmp_path, case, **aperture):
    """Cycles' and Dürer's red channel, then Dürer's without depth of field: a white sphere 10 m away
    blurred by a lens focused at 3 m, and one on the plane of focus."""
    camera, fstop, far_radius, near, near_radius = BOKEH_CASES[case]
    scene.render.resolution_x = scene.render.resolution_y = SIZE
    world(scene, (0, 0, 0))
    glow(scene, "Far", (0, 10, 0), far_radius)
    glow(scene, "Near", near, near_radius)
    cam = dof_camera(scene, fstop=fstop, focus=3.0, **aperture)
    for name, value in camera.items():
        setattr(cam, name, value)
    # Every sample through the pixel centre, as Cycles' tiny filter: only the lens spreads them.
    scene.durer.samples, scene.durer.sampler = 1024, "CENTER"
    use_cycles(scene, samples=1024)
    images = [render_passes(scene, tmp_path / "cycles.exr", depth=False, normal=False)["color"][..., 0]]
    scene.render.engine = "DURER"
    images.append(render_passes(scene, tmp_path / "durer.exr", depth=False, normal=False)["color"][..., 0])
    cam.dof.use_dof = False
    images.append(render_passes(scene, tmp_path / "pinhole.exr", depth=False, normal=False)["color"][..., 0])
    return images


def blur_of(image):
    """The far sphere's blur (the pixels within 0.35 of the width of the centre: the in-focus sphere
    lies beyond): its total, and its shape, where it is brighter than half its inside's median."""
    h, w = image.shape
    near_centre = np.hypot(*np.mgrid[:h, :w] - (np.array([h, w])[:, None, None] - 1) / 2) < 0.35 * w
    blur = np.where(near_centre, image, 0.0)
    inside = np.median(blur[blur > 0.3 * blur.max()])
    return float(blur.sum()), blur > 0.5 * inside, ~near_centre


def extents(mask):
    ys, xs = np.nonzero(mask)
    return int(xs.max() - xs.min() + 1), int(ys.max() - ys.min() + 1)


def iou(a, b):
    return (a & b).sum() / (a | b).sum()


@pytest.mark.parametrize("case", sorted(BOKEH_CASES))
def test_a_disc_of_blur_as_in_cycles(scene, tmp_path, case):
    cycles, dürer, pinhole = bokeh_renders(scene, tmp_path, case)
    (c_sum, c_disc, corner), (d_sum, d_disc, _) = blur_of(cycles), blur_of(dürer)
    # measured: the totals within 0.2 % (perspective 22.31 and 22.31, orthographic 11.61 and 11.59)
    assert d_sum == pytest.approx(c_sum, rel=0.02)
    # The disc's radius (of its area): measured 16.46 / 16.50 px (thin lens 16.59), 15.95 / 15.96 (16.0).
    radius_c, radius_d = math.sqrt(c_disc.sum() / math.pi), math.sqrt(d_disc.sum() / math.pi)
    assert radius_d == pytest.approx(radius_c, abs=0.5)
    assert radius_d == pytest.approx(BLUR_RADIUS[case], abs=0.5)
    assert np.abs(np.subtract(extents(d_disc), extents(c_disc))).max() <= 1  # measured 32-34 px, within 1
    assert iou(c_disc, d_disc) > 0.93  # measured 0.972, 0.977
    # The sphere on the plane of focus: sharp in both, as without depth of field (measured: within
    # 0.018 of it in Cycles, 0.001 in Dürer, on 91 and 37 pixels).
    assert (pinhole[corner] > 0.5).sum() > 30
    assert np.abs(cycles - pinhole)[corner].max() < 0.05 and np.abs(dürer - pinhole)[corner].max() < 0.05


def test_an_anamorphic_pentagon_of_blur_as_in_cycles(scene, tmp_path):
    """Five blades turned 27° (no mirror axis of the pentagon along x or y: the shape tells the turn's
    sense), 1.5 times narrower than high."""
    cycles, dürer, _ = bokeh_renders(scene, tmp_path, "perspective", blades=5, rotation=math.radians(27),
                                     ratio=1.5)
    (c_sum, c_shape, _), (d_sum, d_shape, _) = blur_of(cycles), blur_of(dürer)
    assert d_sum == pytest.approx(c_sum, rel=0.02)  # measured: 22.36 and 22.37
    # measured: 21 x 29 px in Cycles, 20 x 29 in Dürer (a disc's 33 x 34 narrowed by 1.5, cut by the blades)
    assert np.abs(np.subtract(extents(d_shape), extents(c_shape))).max() <= 1
    assert extents(c_shape)[1] >= 28 and extents(c_shape)[0] <= 22
    # measured 0.975; Dürer's shape mirrored left-right or top-bottom, or turned 180°: 0.85 to 0.88
    assert iou(c_shape, d_shape) > 0.93
