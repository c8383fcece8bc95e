"""Ambient occlusion through Blender (issue 14 item 2): scene.durer's setting, on from Cycles' Fast
GI Approximation or by hand, at the World's AO distance or its own, reaches durer.render and
darkens the ambient light where a ball rests on a floor."""

from __future__ import annotations

import numpy as np
import pytest
from helpers.blender import aim_camera, export, material, quad, render_passes, uv_sphere, world

from helpers.blender_import import blender_module

bpy = blender_module("bpy")

from durer.blender import engine

pytestmark = pytest.mark.blender


def test_the_setting_exports_samples_and_distance(scene):
    w = world(scene, (1, 1, 1))
    assert scene.durer.ambient_occlusion == "AUTO" and not scene.cycles.use_fast_gi
    assert export(scene).ambient_occlusion is None  # Fast GI off: no AO
    scene.cycles.use_fast_gi = True
    assert export(scene).ambient_occlusion == (16, pytest.approx(10.0))  # the World's default distance
    w.light_settings.distance = 2.5
    scene.durer.ao_samples = 64
    assert export(scene).ambient_occlusion == (64, 2.5)
    scene.durer.use_world_ao_distance = False
    scene.durer.ao_distance = 0.75
    assert export(scene).ambient_occlusion == (64, pytest.approx(0.75))
    scene.durer.ambient_occlusion = "OFF"
    assert export(scene).ambient_occlusion is None
    scene.cycles.use_fast_gi = False
    scene.durer.ambient_occlusion = "ON"
    scene.durer.use_world_ao_distance = True
    assert export(scene).ambient_occlusion == (64, 2.5)
    w.light_settings.distance = 0.0  # Blender allows 0, durer.render does not: its smallest stands in
    assert export(scene).ambient_occlusion == (64, 1e-6)
    scene.world = None  # no World: Dürer's own distance
    assert export(scene).ambient_occlusion == (64, pytest.approx(0.75))


def ball_on_floor(scene):
    """A white world lighting a grey ball (radius 1) resting on a grey floor, seen from straight
    above by an orthographic camera 8 units across 64 pixels."""
    world(scene, (1, 1, 1))
    grey = material("Grey", (0.8, 0.8, 0.8))
    uv_sphere(scene, "Ball", location=(0, 0, 1)).data.materials.append(grey)
    quad(scene, "Floor", scale=(6, 6, 1)).data.materials.append(grey)
    cam = aim_camera(scene, (0, 0, 10)).data
    cam.type = "ORTHO"
    cam.ortho_scale = 8.0
    cam.clip_start, cam.clip_end = 0.1, 100.0


def floor_distance_from_foot(scene) -> np.ndarray:
    """Each pixel centre's horizontal distance from the ball's foot (top row first)."""
    w, h = scene.render.resolution_x, scene.render.resolution_y
    x = (np.arange(w) + 0.5 - w / 2) * 8.0 / w
    y = (h / 2 - np.arange(h) - 0.5) * 8.0 / w
    return np.hypot(x[None, :], y[:, None])


def test_ao_darkens_the_contact_region(scene, tmp_path):
    ball_on_floor(scene)
    scene.durer.ambient_occlusion = "OFF"
    off = render_passes(scene, tmp_path / "off.exr", normal=False)
    assert engine.last_render.stats["ao_rays"] == 0
    scene.durer.ambient_occlusion = "ON"
    scene.durer.ao_samples = 32
    on = render_passes(scene, tmp_path / "on.exr", normal=False)
    stats = engine.last_render.stats
    assert "ambient_occlusion" in stats["effects"] and "AO 32" in engine.last_render.stats_line
    assert stats["ao_rays"] == 32 * scene.render.resolution_x * scene.render.resolution_y
    floor = np.abs(off["depth"] - 10) < 1e-4
    d = floor_distance_from_foot(scene)
    np.testing.assert_allclose(off["color"][..., 0][floor], 0.8, rtol=1e-6)  # world × kd, unoccluded
    # The floor next to the ball (a plane under a sphere touching it: 1 − 1/D³ at D² = d² + 1)
    # loses about a third of its ambient light; far from it, almost none.
    contact = floor & (d < 1.25)
    far = floor & (d > 3.5)
    expected = 0.8 * (1 - 1 / (d**2 + 1) ** 1.5)
    assert contact.sum() > 20 and far.sum() > 100
    assert np.mean(on["color"][..., 0][contact]) == pytest.approx(np.mean(expected[contact]), abs=0.02)
    assert np.mean(on["color"][..., 0][contact]) < 0.6
    assert np.mean(on["color"][..., 0][far]) == pytest.approx(np.mean(expected[far]), abs=0.01)
