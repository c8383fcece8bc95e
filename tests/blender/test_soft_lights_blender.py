"""Area lights and soft shadows from Blender: the export's rectangle, ellipse and intensity (Cycles'
radiance P/(π·A)), and the image against Cycles' — square, rectangle, disk and ellipse lights, tilted,
stretched by the object's scale, not normalized — with soft shadows; a Point light's Radius and a
Sun's Angle with Soft Shadows on (hard shadows from the centre with it off)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from helpers.blender import MISS, export, light, material, pointcloud_object, quad, render_passes, use_cycles, world

from helpers.blender_import import blender_module

bpy = blender_module("bpy")

pytestmark = pytest.mark.blender


def test_export_gives_the_rectangle_and_the_intensity(scene):
    lamp = light(scene, "AREA", energy=100.0, color=(1.0, 0.5, 0.25), location=(1, 2, 3), shape="RECTANGLE",
                 size=2.0, size_y=0.5)
    lamp.scale = (1.5, 2.0, 1.0)
    bpy.context.view_layer.update()
    (data,) = export(scene).lights
    assert data.kind == "area" and not data.ellipse and data.shadows
    u, v = data.edges
    np.testing.assert_allclose(data.position, (1, 2, 3))
    np.testing.assert_allclose(np.abs(u), (3.0, 0, 0), atol=1e-12)  # size × scale x
    np.testing.assert_allclose(np.abs(v), (0, 1.0, 0), atol=1e-12)  # size_y × scale y
    np.testing.assert_allclose(np.cross(u, v) / 3.0, (0, 0, -1), atol=1e-12)  # shines along -Z
    # Radiance P/(π·A) over A: intensity P/π along the normal, and Dürer's colour drops Cycles' kd/π.
    np.testing.assert_allclose(data.color, np.array([1.0, 0.5, 0.25]) * 100.0 / math.pi**2, rtol=1e-6)
    lamp.data.normalize = False  # radiance P/π: intensity P·A/π
    lamp.data.shape = "ELLIPSE"
    bpy.context.view_layer.update()
    (data,) = export(scene).lights
    assert data.ellipse
    np.testing.assert_allclose(data.color, np.array([1.0, 0.5, 0.25]) * 100.0 * (3.0 * math.pi / 4) / math.pi**2,
                               rtol=1e-6)


def test_a_mirrored_light_shines_where_cycles_does(scene):
    # Turned over (180° about X) and mirrored in Z: its -Z column points down again, as Cycles shines.
    lamp = light(scene, "AREA", energy=10.0, location=(0, 0, 2), rotation=(math.pi, 0, 0), size=1.0)
    lamp.scale = (1, 1, -1)
    bpy.context.view_layer.update()
    u, v = export(scene).lights[0].edges
    assert np.cross(u, v)[2] == pytest.approx(-1.0)


def test_a_sheared_area_light_is_told(scene):
    parent = bpy.data.objects.new("Stretch", None)
    scene.collection.objects.link(parent)
    parent.scale = (2, 1, 1)
    lamp = light(scene, "AREA", name="Skewed", energy=10.0, location=(0, 0, 2), rotation=(0, 0, math.radians(40)))
    lamp.parent = parent
    light(scene, "AREA", name="Square", energy=10.0, location=(0, 0, 2), rotation=(0, 0, math.radians(40)))
    bpy.context.view_layer.update()
    notes = " ".join(export(scene).notes)
    assert "'Skewed' is sheared" in notes and "Square" not in notes


def test_lights_without_area_spread_and_portals_are_told(scene):
    light(scene, "AREA", name="Flat", energy=10.0, size=0.0)
    light(scene, "AREA", name="Grid", energy=10.0, spread=math.radians(60))
    portal = light(scene, "AREA", name="Window", energy=10.0)
    portal.data.cycles.is_portal = True
    data = export(scene)
    assert [light.name for light in data.lights] == ["Grid"]
    notes = " ".join(data.notes)
    assert "'Flat' has no area" in notes and "'Grid' has a Spread of 60°" in notes and "Window" not in notes


def floor_scene(s, lamp_kwargs, occluder=False, size=(48, 36), kind="AREA"):
    """A grey floor under one light of `kind` (an area light by default), seen from above at an
    angle; Cycles direct light only."""
    world(s, (0, 0, 0))
    floor = quad(s, "Floor", scale=(4, 3, 1))
    floor.data.materials.append(material("Floor", (0.8, 0.8, 0.8)))
    if occluder:  # a point cloud's point: an exact sphere in Cycles too (a mesh's facets shrink its shadow)
        ball = pointcloud_object(s, "Ball", [(0.2, -0.1, 0.7)], radius=0.35)
        ball.data.materials.append(material("Ball", (0.8, 0.8, 0.8)))
        ball.pass_index = 1
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    s.collection.objects.link(cam)
    s.camera = cam
    cam.location = (0, -3.5, 5)
    cam.rotation_euler = (math.radians(35), 0, 0)
    cam.data.type = "ORTHO"
    cam.data.ortho_scale = 6.0
    s.render.resolution_x, s.render.resolution_y = size
    s.render.resolution_percentage = 100
    light(s, kind, **lamp_kwargs)
    s.durer.light_samples = 256


CASES = {
    "square": {"energy": 60.0, "location": (0.3, 0.2, 1.5), "size": 1.2},
    "rectangle tilted": {"energy": 80.0, "location": (-0.5, 0.4, 1.2), "rotation": (0.5, -0.3, 0.4), "shape": "RECTANGLE",
                         "size": 2.0, "size_y": 0.6},
    "disk": {"energy": 50.0, "location": (0.0, 0.0, 1.0), "shape": "DISK", "size": 1.5, "color": (1.0, 0.7, 0.4)},
    "ellipse not normalized": {"energy": 30.0, "location": (0.4, -0.2, 1.3), "rotation": (0.3, 0.2, 0), "shape": "ELLIPSE",
                               "size": 1.6, "size_y": 0.8, "normalize": False},
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_floor_lit_as_in_cycles(scene, tmp_path, case):
    floor_scene(scene, CASES[case])
    use_cycles(scene, samples=512)
    c = render_passes(scene, tmp_path / "cycles.exr", normal=False)
    scene.render.engine = "DURER"
    d = render_passes(scene, tmp_path / "durer.exr", normal=False)
    lit = (c["depth"] < MISS) & (c["color"][..., :3].mean(axis=-1) > 0.02 * c["color"][..., :3].mean(axis=-1).max())
    assert lit.mean() > 0.3
    cc, dd = c["color"][lit][:, :3], d["color"][lit][:, :3]
    ratio = dd.sum() / cc.sum()
    assert ratio == pytest.approx(1.0, abs=2e-3), ratio  # measured: within 4e-5
    # Per pixel (Cycles at 512 samples, Dürer at 256 points a pixel): measured medians 1.4e-4 to
    # 6.4e-4, 99th percentiles 8.8e-4 to 4.4e-3.
    assert np.median(np.abs(dd - cc) / cc) < 3e-3
    assert np.percentile(np.abs(dd - cc) / cc, 99) < 0.015


def test_soft_shadow_as_in_cycles(scene, tmp_path):
    floor_scene(scene, CASES["square"], occluder=True)
    use_cycles(scene, samples=512)
    c = render_passes(scene, tmp_path / "cycles.exr", normal=False, indexes=True)
    scene.render.engine = "DURER"
    d = render_passes(scene, tmp_path / "durer.exr", normal=False, indexes=True)
    floor = floor_pixels(c, d)  # its shadow's included
    lum_c, lum_d = c["color"][..., :3].mean(axis=-1), d["color"][..., :3].mean(axis=-1)
    bright = lum_c.max()
    penumbra = floor & (lum_c > 0.15 * bright) & (lum_c < 0.8 * bright)
    assert penumbra.sum() >= 20, "the compared pixels should include a penumbra"
    assert np.abs(lum_d - lum_c)[floor].max() < 0.02 * bright  # measured: 5.2e-3
    assert np.abs(lum_d - lum_c)[penumbra].mean() < 5e-3 * bright  # measured: 6.3e-4


def ball_shadow(scene, tmp_path, kind, **lamp):
    """Cycles' and Dürer's luminance of the floor around a ball's shadow, and its brightest value."""
    floor_scene(scene, lamp, occluder=True, kind=kind)
    use_cycles(scene, samples=1024)
    c = render_passes(scene, tmp_path / "cycles.exr", normal=False, indexes=True)
    scene.render.engine = "DURER"
    d = render_passes(scene, tmp_path / "durer.exr", normal=False, indexes=True)
    return c["color"][..., :3].mean(axis=-1), d["color"][..., :3].mean(axis=-1), floor_pixels(c, d)


def floor_pixels(c, d):
    """Pixels where both see the floor, and so do their eight neighbours (a pixel beside the ball's
    outline sees the floor just behind it, where the shadow changes fastest)."""
    floor = (c["IndexOB"] == 0) & (d["IndexOB"] == 0) & (c["depth"] < MISS) & (d["depth"] < MISS)
    padded = np.pad(floor, 1)
    h, w = floor.shape
    return np.logical_and.reduce([padded[i:i + h, j:j + w] for i in range(3) for j in range(3)])


SOFT_CASES = {
    # Cycles' soft falloff changes a sphere light's light near it: off, it is the point light's.
    "point": ("POINT", {"energy": 300.0, "location": (0.6, -0.4, 2.5), "shadow_soft_size": 0.6,
                        "use_soft_falloff": False}),
    "sun": ("SUN", {"energy": 3.0, "rotation": (0.35, -0.25, 0), "angle": math.radians(30)}),
}


@pytest.mark.parametrize("case", sorted(SOFT_CASES))
def test_soft_shadows_as_in_cycles(scene, tmp_path, case):
    kind, lamp = SOFT_CASES[case]
    scene.durer.soft_shadows = True
    lum_c, lum_d, floor = ball_shadow(scene, tmp_path, kind, **lamp)
    bright = lum_c[floor].max()
    penumbra = floor & (lum_c > 0.1 * bright) & (lum_c < 0.9 * bright)
    assert penumbra.sum() >= 10, "the compared pixels should include a penumbra"
    # measured (Cycles 1024 samples, Dürer 256 rays): max 8.7e-3 / 1.4e-2, penumbra mean 1.5e-4 / 4.2e-3
    assert np.abs(lum_d - lum_c)[floor].max() < 0.03 * bright
    assert np.abs(lum_d - lum_c)[penumbra].mean() < 0.01 * bright


def test_without_soft_shadows_the_shadow_is_hard(scene, tmp_path):
    kind, lamp = SOFT_CASES["point"]
    lum_c, lum_d, floor = ball_shadow(scene, tmp_path, kind, **lamp)
    bright = lum_c[floor].max()
    assert np.abs(lum_d - lum_c)[floor].max() > 0.2 * bright  # Cycles' penumbra, Dürer's hard edge
    assert export(scene).lights[0].size == pytest.approx(0.6)


def floor_lit_by(scene, tmp_path, kind, samples, **lamp):
    """Cycles' and Dürer's red channel on the floor's lit pixels under one light of `kind`."""
    floor_scene(scene, lamp, kind=kind)
    use_cycles(scene, samples=samples)
    c = render_passes(scene, tmp_path / "cycles.exr", normal=False)
    scene.render.engine = "DURER"
    d = render_passes(scene, tmp_path / "durer.exr", normal=False)
    lit = (c["depth"] < MISS) & (c["color"][..., 0] > 0.02 * c["color"][..., 0].max())
    assert lit.mean() > 0.3
    return c["color"][lit][:, 0], d["color"][lit][:, 0]


@pytest.mark.parametrize("kind, radius", [("POINT", 0.0), ("POINT", 0.5), ("SPOT", 1.0)])
def test_a_light_not_normalized_is_as_bright_as_in_cycles(scene, tmp_path, kind, radius):
    # Cycles makes its power that of each unit of its sphere's area: 4πr² times brighter (4 at r = 0).
    lamp = {"energy": 20.0, "location": (0.2, 0.3, 2.5), "shadow_soft_size": radius, "normalize": False,
            "use_soft_falloff": False}
    if kind == "SPOT":
        lamp["spot_size"] = math.radians(150)
    cc, dd = floor_lit_by(scene, tmp_path, kind, samples=64, **lamp)
    assert dd.sum() / cc.sum() == pytest.approx(1.0, abs=3e-3)


@pytest.mark.parametrize("height", [1.0, 2.5])
def test_soft_falloff_near_a_light_of_some_radius_is_as_in_cycles(scene, tmp_path, height):
    # Cycles' Soft Falloff (on by default) lights a point at d from a light of radius r as
    # 1 / (d² + r²) where the inverse square says 1 / d²: 20 % darker at 1 m from a 0.5 m light.
    cc, dd = floor_lit_by(scene, tmp_path, "POINT", samples=256, energy=50.0, location=(0.3, 0.2, height),
                          shadow_soft_size=0.5)
    assert scene.objects["Point"].data.use_soft_falloff
    # measured: totals within 7e-5, every pixel within 1.9e-3 (1 m) / 5.1e-4 (2.5 m)
    assert dd.sum() / cc.sum() == pytest.approx(1.0, abs=3e-3)
    assert np.abs(dd / cc - 1).max() < 0.01
