"""The depth pass: t along the ray, or planar (distance along the view axis, as Blender's Depth)."""

from __future__ import annotations

import numpy as np
import pytest

import durer


def wall(distance: float) -> durer.Scene:
    """A plane facing the camera at z = -distance (the camera sits at the origin looking down -z)."""
    scene = durer.Scene()
    scene.add_plane((0, 0, 1), -distance)
    return scene


@pytest.mark.parametrize("precision", ["float", "double"])
def test_planar_depth_of_a_wall_facing_a_perspective_camera_is_its_distance(precision):
    camera = durer.PerspectiveCamera((0, 0, 0), (0, 0, -1), (0, 1, 0), fov_degrees=90)
    planar = durer.render(wall(5.0), camera, 33, 21, passes=("depth",), depth="planar", precision=precision).depth
    ray = durer.render(wall(5.0), camera, 33, 21, passes=("depth",), precision=precision).depth
    np.testing.assert_allclose(planar, 5.0, rtol=4e-7 if precision == "float" else 1e-7)
    # Along the ray the wall is 5 / cos(angle to the axis): at the image's left edge centre the
    # pixel centre sits at x = -(1 - 1/33) on the plane at distance 1 (fov 90 spans [-1, 1]).
    x = -(1 - 1 / 33)
    np.testing.assert_allclose(ray[10, 0], 5.0 * np.sqrt(1 + x * x), rtol=1e-6)
    np.testing.assert_allclose(ray * _cosines(camera, 33, 21), planar, rtol=1e-6)


def _cosines(camera, width, height):
    _, directions = camera.rays(width, height)
    return directions @ np.asarray(camera.direction, dtype=np.float64)


def test_planar_depth_is_ray_depth_exactly_for_an_orthographic_camera():
    scene = durer.Scene()
    scene.add_spheres([[0.2, 0.1, -3.0]], 0.7)
    scene.add_plane((0, 0.3, 1), -6.0)
    camera = durer.OrthographicCamera((0, 0, 0), (0, 0, -1), (0, 1, 0), size=3.0)
    planar = durer.render(scene, camera, 24, 24, spp=4, passes=("depth",), depth="planar").depth
    ray = durer.render(scene, camera, 24, 24, spp=4, passes=("depth",), depth="ray").depth
    np.testing.assert_array_equal(planar, ray)
    assert np.isfinite(planar).all()  # the tilted plane lies behind every pixel
    # Away from the sphere the plane z = -6 - 0.3y is met at depth 6 + 0.3y, y within the pixel's
    # half-height (1/16) of its centre's (and a float32 rounding); over the sphere, nearer than its centre.
    centres, _ = camera.rays(24, 24)
    y = centres[..., 1]
    off = np.hypot(centres[..., 0] - 0.2, y - 0.1) > 0.7 + 0.1  # a pixel's half-diagonal is < 0.1
    assert off.sum() > 400
    low, high = 6 + 0.3 * (y - 1 / 16) - 1e-6, 6 + 0.3 * (y + 1 / 16) + 1e-6
    assert ((planar[off] >= low[off]) & (planar[off] <= high[off])).all()
    on = np.hypot(centres[..., 0] - 0.2, y - 0.1) < 0.7 - 0.1
    assert on.sum() > 40 and ((planar[on] >= 3 - 0.7) & (planar[on] < 3)).all()


def test_planar_depth_with_colour_and_misses():
    """Through the shaded path (colour with lights) too; a miss stays inf."""
    scene = durer.Scene()
    scene.add_plane((0, 0, 1), -2.0, bounds=((-1, -1, -2), (2, 0, 0), (0, 2, 0)))  # a 2x2 square at z = -2
    scene.add_directional_light((0, 0, -1), (1, 1, 1))
    camera = durer.PerspectiveCamera((0, 0, 0), (0, 0, -1), (0, 1, 0), fov_degrees=120)
    result = durer.render(scene, camera, 16, 16, spp=2, depth="planar")
    hit = np.isfinite(result.depth)
    assert hit.any() and (~hit).any()  # the square fills the middle of the view only
    np.testing.assert_allclose(result.depth[hit], 2.0, rtol=1e-7)
    assert result.stats["depth"] == "planar"
