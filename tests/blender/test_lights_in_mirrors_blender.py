"""Lights seen in near-mirror materials, against Cycles: a chrome ball's glint of a Sun and of a
Point light (a Phong highlight of the roughness, the lights being directions and points no mirror
ray meets) holds Cycles' energy; a mirror floor shows an Area light at its radiance."""

from __future__ import annotations

import math

import numpy as np
import pytest
from helpers.blender import DEG, aim_camera, light, pointcloud_object, quad, render_passes, use_cycles, world

from helpers.blender_import import blender_module

bpy = blender_module("bpy")

pytestmark = pytest.mark.blender

SIZE = 96
ORTHO = 2.3
BASE = 0.8


def chrome(name: str, roughness: float):
    mat = bpy.data.materials.new(name)
    bsdf = mat.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (BASE, BASE, BASE, 1.0)
    bsdf.inputs["Metallic"].default_value = 1.0
    bsdf.inputs["Roughness"].default_value = roughness
    return mat


def lit_ball(s, roughness: float, kind: str, radius: float = 0.0):
    """An exact unit ball of chrome before a black world, seen orthographically along +Y; the
    light 30° above the view axis (a Sun, or a Point light of `radius` six units away)."""
    world(s, (0.0, 0.0, 0.0))
    s.render.resolution_x = s.render.resolution_y = SIZE
    aim_camera(s, (0, -6, 0))
    s.camera.data.type = "ORTHO"
    s.camera.data.ortho_scale = ORTHO
    ball = pointcloud_object(s, "Ball", [(0.0, 0.0, 0.0)], radius=1.0)
    ball.location = (0.5 * ORTHO / SIZE, 0.0, 0.0)  # the glint in a pixel's middle
    ball.data.materials.append(chrome("Chrome", roughness))
    toward = np.array([0.0, -math.cos(30 * DEG), math.sin(30 * DEG)])
    if kind == "SUN":
        light(s, "SUN", energy=3.0, rotation=(60 * DEG, 0, 0))
    else:
        light(s, "POINT", energy=1000.0, location=tuple(6.0 * toward), shadow_soft_size=radius)


def glint(s, path, engine: str) -> np.ndarray:
    if engine == "CYCLES":
        use_cycles(s, samples=256, max_bounces=0)
        s.cycles.pixel_filter_type, s.cycles.filter_width = "BOX", 1.0  # the pixel's mean, as Dürer's
        s.cycles.sample_clamp_direct = 0.0
    else:
        s.render.engine = "DURER"
        s.durer.samples = 64
    return render_passes(s, path, depth=False, normal=False)["color"][..., :3].mean(axis=-1)


@pytest.mark.parametrize("kind, roughness", [("SUN", 0.1), ("SUN", 0.2), ("POINT", 0.1), ("POINT", 0.2)])
def test_a_chrome_ball_glints_with_cycles_energy(scene, tmp_path, kind, roughness):
    # Measured at 200x200 (Cycles 4096 samples): 0.94-0.97 of Cycles' energy at roughness 0-0.3,
    # under a Sun of Angle 0.526° or 5° and a Point light; peaks within 3 % from roughness 0.15.
    lit_ball(scene, roughness, kind)
    durer_glint = glint(scene, tmp_path / "durer.exr", "DURER")
    cycles_glint = glint(scene, tmp_path / "cycles.exr", "CYCLES")
    ratio = durer_glint.sum() / cycles_glint.sum()
    assert 0.9 < ratio < 1.0, ratio
    # Where: the brightest pixel the same, the normal halving the light's and the camera's directions.
    assert np.unravel_index(durer_glint.argmax(), durer_glint.shape) == np.unravel_index(
        cycles_glint.argmax(), cycles_glint.shape)
    if roughness >= 0.15:
        assert durer_glint.max() == pytest.approx(cycles_glint.max(), rel=0.1)


def test_a_large_lights_glint_spreads_over_it_like_cycles(scene, tmp_path):
    # A Point light of Radius 0.5 six units off: Cycles' glint is the sphere's image, 7.7 px across
    # at 200 x 200 (measured: Dürer's 7.65 px, its peak 0.66-0.9 of Cycles' for roughness 0-0.3,
    # where a glint as narrow as the material's lobe peaked 11x above it at roughness 0.1).
    lit_ball(scene, 0.1, "POINT", radius=0.5)
    durer_glint = glint(scene, tmp_path / "durer.exr", "DURER")
    cycles_glint = glint(scene, tmp_path / "cycles.exr", "CYCLES")
    assert 0.9 < durer_glint.sum() / cycles_glint.sum() < 1.0
    assert 0.5 < durer_glint.max() / cycles_glint.max() < 1.1
    spread = [(image > image.max() / 2).sum() for image in (durer_glint, cycles_glint)]
    assert spread[0] == pytest.approx(spread[1], rel=0.4)


def test_a_mirror_floor_shows_an_area_light_at_its_radiance_like_cycles(scene, tmp_path):
    """A 1 m square Area light of 100 W at height 2 over a chrome floor, the camera looking at its
    mirror image: Cycles shows base × P/(π·A) there (radiance P/(π·A)); Dürer the same, exactly."""
    world(scene, (0.0, 0.0, 0.0))
    scene.render.resolution_x, scene.render.resolution_y = 64, 48
    floor = quad(scene, "Floor", scale=(10, 10, 1))
    floor.data.materials.append(chrome("Floor", 0.0))
    lamp = light(scene, "AREA", energy=100.0, location=(0, 0, 2), size=1.0)
    lamp.visible_camera = False
    aim_camera(scene, (0.0, -5.0, 1.5), target=(0, 0, -2))
    scene.durer.samples = 4
    expected = BASE * 100.0 / math.pi
    durer_image = render_passes(scene, tmp_path / "durer.exr", depth=False, normal=False)["color"][..., 0]
    use_cycles(scene, samples=64, max_bounces=0)
    cycles_image = render_passes(scene, tmp_path / "cycles.exr", depth=False, normal=False)["color"][..., 0]
    # The reflection, away from its edges (Cycles' ray through a pixel's centre, Dürer's box filter).
    seen = cycles_image > 0.9 * expected
    inside, near = seen.copy(), seen.copy()
    for axis in (0, 1):
        for step in (1, -1):
            inside &= np.roll(seen, step, axis=axis)
            near |= np.roll(seen, step, axis=axis)
    assert inside.sum() > 30
    np.testing.assert_allclose(cycles_image[inside], expected, rtol=0.03)
    np.testing.assert_allclose(durer_image[inside], expected, rtol=1e-5)
    # Outside it both show the black world (Dürer: the light's highlight left to the mirror).
    dark = (cycles_image < 1e-3) & ~near
    assert dark.sum() > 2000
    np.testing.assert_array_equal(durer_image[dark], 0.0)
