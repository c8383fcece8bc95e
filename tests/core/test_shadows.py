"""Shadow rays and the epsilon policy, end to end: no acne, no leaks, clean horizons."""

from __future__ import annotations

import math

import numpy as np
import pytest

import durer
from helpers.core import camera_tests


def sphere_on_plane(shadows: bool = True) -> tuple[durer.Scene, np.ndarray]:
    scene = durer.Scene()
    white = scene.add_material((1, 1, 1))
    scene.add_spheres([[0, 1, 0]], [1.0], material=white)
    scene.add_plane((0, 1, 0), 0.0, material=white)
    to_light = np.array([1.0, 2.0, 0.5]) / np.linalg.norm([1.0, 2.0, 0.5])
    scene.add_directional_light(-to_light, (1, 1, 1), shadows=shadows)
    return scene, to_light


def analytic_shading(points: np.ndarray, normals: np.ndarray, to_light: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Lambert term and whether the sphere (centre (0,1,0), r 1) blocks the light, per point."""
    cosine = np.maximum(normals @ to_light, 0)
    f = points - np.array([0, 1, 0])
    b = f @ to_light
    c = np.sum(f * f, -1) - 1
    disc = b * b - c
    far = -b + np.sqrt(np.maximum(disc, 0))
    blocked = (disc > 0) & (far > 1e-9) & (c > 1e-9)  # points outside the sphere with the sphere toward the light
    return cosine, blocked


@pytest.mark.parametrize("camera_kind", ["orthographic", "perspective"])
def test_lit_sphere_on_plane_has_no_acne(precision, camera_kind):
    scene, to_light = sphere_on_plane()
    if camera_kind == "orthographic":
        camera = durer.OrthographicCamera((0, 3, 6), (0, -0.5, -1), (0, 1, 0), 6.0)
    else:
        camera = durer.PerspectiveCamera((0, 3, 6), (0, -0.5, -1), (0, 1, 0), 50.0)
    result = durer.render(scene, camera, 160, 120, precision=precision)
    origins, directions = camera.rays(160, 120)
    hit = durer.cast(scene, origins.reshape(-1, 3), directions.reshape(-1, 3), t_min=camera.t_min)
    points = origins.reshape(-1, 3) + hit.t[:, None] * directions.reshape(-1, 3)
    cosine, blocked = analytic_shading(points, hit.normal, to_light)
    expected = np.where(blocked, 0.0, cosine).reshape(120, 160)
    got = result.color[..., 0]
    on_sphere = (hit.object_id == 0).reshape(120, 160)
    # Acne: a lit point of the sphere (clearly facing the light) rendered in shadow.
    lit_sphere = on_sphere & (cosine.reshape(120, 160) > 1e-3)
    assert lit_sphere.sum() > 1500
    np.testing.assert_allclose(got[lit_sphere], expected[lit_sphere], atol=1e-5)
    # The plane: shadowed exactly where the sphere blocks the light, away from the shadow's edge.
    on_plane = (hit.object_id == 1).reshape(120, 160)
    f = points - np.array([0, 1, 0])
    b = f @ to_light
    margin = np.abs(np.sum(f * f, -1) - b * b - 1).reshape(120, 160) > 2e-2  # not within the penumbra line
    check = on_plane & margin
    assert (expected[check] == 0).sum() > 200 and (expected[check] > 0).sum() > 2000
    np.testing.assert_allclose(got[check], expected[check], atol=1e-5)
    assert result.stats["shadow_rays"] > 0


def test_shadow_rays_only_for_lights_that_cast_them():
    camera = durer.OrthographicCamera((0, 3, 6), (0, -0.5, -1), (0, 1, 0), 6.0)
    off, _ = sphere_on_plane(shadows=False)
    result = durer.render(off, camera, 64, 48)
    assert result.stats["shadow_rays"] == 0
    on, to_light = sphere_on_plane(shadows=True)
    result = durer.render(on, camera, 64, 48)
    origins, directions = camera.rays(64, 48)
    hit = durer.cast(on, origins.reshape(-1, 3), directions.reshape(-1, 3), t_min=-math.inf)
    facing = (hit.object_id >= 0) & (hit.normal @ to_light > 0)
    assert result.stats["shadow_rays"] == facing.sum()  # one per lit-facing camera hit
    assert result.stats["intersection_tests"] == camera_tests(on, camera, 64, 48) + result.stats["shadow_rays"] * 2


def test_nested_spheres_with_a_tiny_gap_leak_no_light(precision):
    # A shell of radius 1 + 4e-5 around a unit sphere; the light is outside. The camera's rays start
    # in the gap (t_min = 0 from its centre there) and see the inner sphere's top, which the shell
    # shadows: any lit pixel is light leaking through the shell.
    gap = 4e-5
    scene = durer.Scene()
    white = scene.add_material((1, 1, 1))
    scene.add_spheres([[0, 0, 0], [0, 0, 0]], [1.0, 1.0 + gap], material=white)
    scene.add_directional_light((0.2, -1, 0.1), (1, 1, 1), shadows=True)
    scene.ambient = (0.05, 0.05, 0.05)
    camera = durer.OrthographicCamera((0, 1 + gap / 2, 0), (0, -1, 0), (0, 0, -1), 0.008, t_min=0.0)
    result = durer.render(scene, camera, 32, 32, precision=precision)
    origins, directions = camera.rays(32, 32)
    hit = durer.cast(scene, origins.reshape(-1, 3), directions.reshape(-1, 3))
    assert (hit.object_id == 0).all()  # every pixel sees the inner sphere
    np.testing.assert_allclose(result.color[..., :3], 0.05, rtol=1e-6)
    assert result.stats["shadow_rays"] == 32 * 32


def test_point_light_shadow_stops_at_the_light(precision):
    # Plane y = 0 lit by a point light at (0, 4, 0). A small sphere at (0, 2, 0) shadows the plane
    # below it; a sphere at (1.5, 6, 0) beyond the light shadows nothing (only t in [0, 1) counts),
    # though the lines from the plane through the light around (-3, 0, 0) go on to meet it.
    scene = durer.Scene()
    white = scene.add_material((1, 1, 1))
    scene.add_plane((0, 1, 0), 0.0, material=white)
    far = np.array([1.5, 6.0, 0.0])
    scene.add_spheres([[0, 2, 0], far], [0.5, 0.5], material=white)
    light = np.array([0.0, 4, 0])
    scene.add_point_light(light, (1, 1, 1), shadows=True)
    camera = durer.OrthographicCamera((0, -5, 0), (0, 1, 0), (0, 0, 1), 8.0, t_min=0.0)  # from below
    image = durer.render(scene, camera, 41, 41, precision=precision, passes="color").color[..., 0]
    origins, _ = camera.rays(41, 41)
    points = origins.copy()
    points[..., 1] = 0  # every camera ray meets the plane first, from below
    to_light = light - points
    cosine = to_light[..., 1] / np.linalg.norm(to_light, axis=-1)
    lateral = np.hypot(points[..., 0], points[..., 2])
    # The segment from (x, 0, z) to the light passes the sphere's centre at distance lateral·2/... :
    # at height 2 the segment is at lateral/2, its distance to the centre is (lateral/2)·cos(angle).
    distance = lateral / 2 * 4 / np.sqrt(16 + lateral**2)
    blocked = distance < 0.5
    # The plane's normal (0, 1, 0) faces the light from below too: the 6.837 shading does not flip
    # normals, so the lit side is the plane's top even though the camera looks at its bottom.
    clear = np.abs(distance - 0.5) > 0.02
    expected = np.where(blocked, 0.0, cosine)
    assert blocked[clear].sum() > 20 and (~blocked[clear]).sum() > 1000
    along = to_light / np.linalg.norm(to_light, axis=-1, keepdims=True)
    beyond = np.linalg.norm(np.cross(far - points, along), axis=-1) < 0.5 - 0.02  # the far sphere's, were it counted
    assert (beyond & clear & ~blocked).sum() > 20
    np.testing.assert_allclose(image[clear], expected[clear], rtol=1e-5, atol=1e-6)


@pytest.mark.parametrize("precision", ["double"])
def test_huge_ground_sphere_gives_a_clean_horizon(precision):
    # Earth-sized ground: radius 1e6, eye 1 unit above it, looking at the horizon. Each column must
    # go from sky to ground exactly once, at the analytic dip angle acos(R / (R + h)).
    radius, height = 1e6, 1.0
    scene = durer.Scene()
    scene.background = (0, 0, 1, 1)
    scene.add_spheres([[0, -radius, 0]], [radius], material=scene.add_material((0, 1, 0)))
    fov = 0.5  # degrees: the dip is 0.081 degrees, so the horizon sits well inside the image
    camera = durer.PerspectiveCamera((0, height, 0), (0, 0, -1), (0, 1, 0), fov)
    image = durer.render(scene, camera, 64, 256, precision=precision, passes="color").color
    ground = image[..., 1] == 1
    transitions = np.abs(np.diff(ground.astype(int), axis=0)).sum(axis=0)
    assert (transitions == 1).all()  # one clean step per column: no speckles
    dip = math.acos(radius / (radius + height))
    _, directions = camera.rays(64, 256)
    elevation = np.arcsin(directions[:, 32, 1])
    expected_ground = elevation < -dip
    # Rows within a pixel's angular size of the horizon are allowed either way.
    pixel_angle = math.radians(fov) / 256
    clear = np.abs(elevation + dip) > pixel_angle
    np.testing.assert_array_equal(ground[clear, 32], expected_ground[clear])
