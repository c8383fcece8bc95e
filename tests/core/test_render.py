"""Small renders with analytically known pixels in every pass, anti-aliasing, precision."""

from __future__ import annotations

import math

import numpy as np
import pytest

import durer
from durer.render import SPHERE_METHODS
from helpers.core import camera_tests

W = H = 16
SIZE = 4.0  # orthographic: pixel (i, j) centre at x = (i + 0.5 - 8)/4, y = (8 - j - 0.5)/4


def pixel_centres(width=W, height=H, size=SIZE):
    pixel = size / max(width, height)
    x = (np.arange(width) + 0.5 - width / 2) * pixel
    y = (height / 2 - np.arange(height) - 0.5) * pixel
    return np.meshgrid(x, y)


def sphere_scene(kd=(0.5, 0.25, 1.0), background=(0.1, 0.2, 0.3, 1.0)):
    scene = durer.Scene()
    scene.background = background
    material = scene.add_material(diffuse=kd)
    scene.add_spheres([[0, 0, 0]], [1.0], material=material)
    return scene


def ortho(center_z=10.0):
    return durer.OrthographicCamera(center=(0, 0, center_z), direction=(0, 0, -1), up=(0, 1, 0), size=SIZE)


def test_flat_color_depth_and_normal_passes(precision):
    result = durer.render(sphere_scene(), ortho(), W, H, precision=precision)
    x, y = pixel_centres()
    inside = x**2 + y**2 <= 1
    z = np.sqrt(np.clip(1 - x**2 - y**2, 0, None))
    assert result.color.shape == (H, W, 4) and result.color.dtype == np.float32
    assert result.depth.shape == (H, W) and result.normal.shape == (H, W, 3)
    np.testing.assert_array_equal(result.color[inside], np.broadcast_to([0.5, 0.25, 1.0, 1.0], (inside.sum(), 4)))
    np.testing.assert_array_equal(result.color[~inside], np.broadcast_to(np.float32([0.1, 0.2, 0.3, 1]), ((~inside).sum(), 4)))
    np.testing.assert_allclose(result.depth[inside], 10 - z[inside], rtol=1e-6)
    assert np.isposinf(result.depth[~inside]).all()
    np.testing.assert_allclose(result.normal[inside], np.stack([x, y, z], -1)[inside], atol=2e-6)
    np.testing.assert_array_equal(result.normal[~inside], 0)


def test_top_row_first_and_left_is_minus_x():
    scene = durer.Scene()
    red, green = scene.add_material((1, 0, 0)), scene.add_material((0, 1, 0))
    scene.add_spheres([[0, 1.5, 0], [-1.5, 0, 0]], [0.4, 0.4], material=np.array([red, green]))
    image = durer.render(scene, ortho(), W, H, passes=("color",)).color
    assert tuple(image[2, 8, :3]) == (1, 0, 0)   # y = +1.5 is near the top row
    assert tuple(image[8, 2, :3]) == (0, 1, 0)   # x = -1.5 is near the left column
    assert tuple(image[13, 8, :3]) == (0, 0, 0)


def test_lambert_shading_with_a_directional_light(precision):
    scene = sphere_scene()
    scene.ambient = (0.1, 0.1, 0.1)
    scene.add_directional_light(direction=(0, 0, -1), color=(1, 1, 1))  # travels -z: lights the +z side
    scene.add_directional_light(direction=(1, 0, 0), color=(0.5, 0.5, 0.5))  # lights the -x side
    result = durer.render(scene, ortho(), W, H, precision=precision)
    x, y = pixel_centres()
    inside = x**2 + y**2 <= 1
    z = np.sqrt(np.clip(1 - x**2 - y**2, 0, None))
    irradiance = 0.1 + np.maximum(z, 0) + 0.5 * np.maximum(-x, 0)
    expected = irradiance[..., None] * np.array([0.5, 0.25, 1.0])
    np.testing.assert_allclose(result.color[inside][:, :3], expected[inside], rtol=2e-5)


def test_point_light_has_no_falloff_and_uses_the_direction_to_it():
    scene = sphere_scene(kd=(1, 1, 1))
    scene.add_point_light(position=(0, 0, 3), color=(0.8, 0.6, 0.4))
    result = durer.render(scene, ortho(), W, H)
    x, y = pixel_centres()
    inside = x**2 + y**2 <= 1
    z = np.sqrt(np.clip(1 - x**2 - y**2, 0, None))
    points = np.stack([x, y, z], -1)
    to_light = np.array([0, 0, 3]) - points
    cosine = np.sum(points * to_light, -1) / np.linalg.norm(to_light, axis=-1)
    expected = np.maximum(cosine, 0)[..., None] * np.array([0.8, 0.6, 0.4])
    np.testing.assert_allclose(result.color[inside][:, :3], expected[inside], rtol=1e-5, atol=1e-6)
    assert (result.color[inside][:, 3] == 1).all()


@pytest.mark.parametrize("shading, sampler", [("lit", "stratified"), ("flat", "stratified"), ("lit", "adaptive")])
def test_a_partly_transparent_background_is_premultiplied_in_pixels_and_whole_in_mirrors(shading, sampler):
    """Background (r, g, b, a): a pixel that sees nothing is (r·a, g·a, b·a, a); a mirror shows
    (r, g, b) times its reflectance, whatever a is (a transparent film still reflects the world)."""
    scene = durer.Scene()
    scene.background = (0.2, 0.4, 0.6, 0.25)
    scene.shading = shading
    if shading == "lit":
        mirror = scene.add_material((0, 0, 0), reflective=(0.5, 0.5, 0.5))
        scene.add_plane((0, 1, 0), 0.0, material=mirror, bounds=((-1, 0, -1), (2, 0, 0), (0, 0, 2)))
        scene.add_directional_light((0, -1, 0), (1, 1, 1))  # lights nothing a mirror shows
    else:
        scene.add_plane((0, 1, 0), 0.0, bounds=((-1, 0, -1), (2, 0, 0), (0, 0, 2)))
    camera = durer.OrthographicCamera(center=(0, 5, 0), direction=(0, -1, 0), up=(0, 0, -1), size=SIZE)
    color = durer.render(scene, camera, W, H, max_bounces=1, sampler=sampler, spp=4).color
    x, y = pixel_centres()
    inside = (np.abs(x) <= 1) & (np.abs(y) <= 1)
    np.testing.assert_allclose(color[~inside], np.broadcast_to([0.05, 0.1, 0.15, 0.25], ((~inside).sum(), 4)),
                               rtol=1e-6)
    # lit: the mirror shows half the world; flat: the plane's own colour (the default 0.8 grey)
    seen = [0.1, 0.2, 0.3, 1.0] if shading == "lit" else [0.8, 0.8, 0.8, 1.0]
    np.testing.assert_allclose(color[inside], np.broadcast_to(seen, (inside.sum(), 4)), rtol=1e-6)


def test_background_alpha_and_plane_pixels():
    scene = durer.Scene()
    scene.background = (0, 0, 0, 0)
    floor = scene.add_material((0.2, 0.4, 0.6))
    scene.add_plane((0, 1, 0), 0.0, material=floor, bounds=((-1, 0, -1), (2, 0, 0), (0, 0, 2)))
    camera = durer.OrthographicCamera(center=(0, 5, 0), direction=(0, -1, 0), up=(0, 0, -1), size=SIZE)
    result = durer.render(scene, camera, W, H)
    x, y = pixel_centres()
    inside = (np.abs(x) <= 1) & (np.abs(y) <= 1)
    assert inside.sum() == 64
    np.testing.assert_array_equal(result.color[inside], np.broadcast_to(np.float32([0.2, 0.4, 0.6, 1]), (64, 4)))
    np.testing.assert_array_equal(result.color[~inside], 0)
    np.testing.assert_array_equal(result.depth[inside], 5)
    np.testing.assert_array_equal(result.normal[inside], np.broadcast_to([0, 1, 0], (64, 3)))


def test_orthographic_sees_behind_its_centre_perspective_does_not():
    scene = sphere_scene()
    behind = ortho(center_z=-5)  # looking -z from z = -5: the sphere is behind the centre
    result = durer.render(scene, behind, W, H)
    assert result.color[8, 8, 2] == 1.0
    # t of the hit at pixel (8, 8)'s centre x = 0.125, y = -0.125, on the sphere's +z side
    assert result.depth[8, 8] == pytest.approx(-(5 + math.sqrt(1 - 2 * 0.125**2)), rel=1e-6)
    persp = durer.PerspectiveCamera(center=(0, 0, -5), direction=(0, 0, -1), up=(0, 1, 0), fov_degrees=40)
    assert (durer.render(scene, persp, W, H).color[..., :3] == np.float32([0.1, 0.2, 0.3])).all()


def test_perspective_depth_is_distance_along_the_ray():
    scene = sphere_scene()
    camera = durer.PerspectiveCamera(center=(0, 0, 5), direction=(0, 0, -1), up=(0, 1, 0), fov_degrees=30)
    result = durer.render(scene, camera, 31, 31)
    origins, directions = camera.rays(31, 31)
    hits = durer.cast(scene, origins.reshape(-1, 3), directions.reshape(-1, 3))
    np.testing.assert_allclose(result.depth.ravel(), hits.t, rtol=1e-6)
    assert result.depth[15, 15] == pytest.approx(4.0)


def test_only_requested_passes_are_computed():
    result = durer.render(sphere_scene(), ortho(), W, H, passes=("depth",))
    assert result.color is None and result.normal is None and result.depth.shape == (H, W)
    assert result.stats["passes"] == ("depth",)
    result = durer.render(sphere_scene(), ortho(), W, H, passes="normal")
    assert result.color is None and result.depth is None and result.normal.shape == (H, W, 3)


@pytest.mark.parametrize("sampler, spp", [("stratified", 1), ("stratified", 4), ("sobol", 4)])
def test_each_pass_is_the_same_with_or_without_the_others(sampler, spp):
    # A render clears only the per-pixel sums its passes read: depth, normals and ids made alone equal
    # those made beside the colour (and each other), bit for bit. (Adaptive's are not: it samples
    # where the colour needs it.)
    scene, camera = durer.showcase_scene(small_spheres=20)
    options = {"spp": spp, "sampler": sampler, "seed": 4}
    every = durer.render(scene, camera, 40, 24, passes=("color", "depth", "normal", "object_id"), **options)
    for passes in [("depth",), ("normal",), ("object_id",), ("depth", "normal"), ("color", "depth")]:
        some = durer.render(scene, camera, 40, 24, passes=passes, **options)
        for name in passes:
            assert np.array_equal(getattr(some, name), getattr(every, name)), (passes, name)


def test_stats_count_rays_and_tests():
    scene = sphere_scene()
    scene.add_plane((0, 1, 0), -3.0)
    result = durer.render(scene, ortho(), 10, 7, spp=3)
    stats = result.stats
    assert stats["rays"] == 10 * 7 * 3 == stats["requested_rays"]
    # Each camera ray tests the plane, and the sphere where the rows of its tile meet its footprint.
    assert stats["intersection_tests"] == camera_tests(scene, ortho(), 10, 7, spp=3)
    assert stats["rays"] < stats["intersection_tests"] < stats["rays"] * 2
    assert stats["milliseconds"] > 0 and stats["mrays_per_s"] > 0
    # The threads that ran: the image's two 8x8 tiles keep at most two busy, whatever was asked.
    assert stats["threads"] == min(durer._core.default_thread_count(), 2)
    assert durer.render(scene, ortho(), 10, 7, threads=2**31 - 1).stats["threads"] == 2
    assert (stats["width"], stats["height"], stats["spp"]) == (10, 7, 3)
    assert stats["precision"] == "double" and stats["sphere_method"] == "robust" and stats["cancelled"] is False


def test_tiles_cover_odd_sizes():
    # 1x1, and sizes that are not multiples of the 8x8 tile.
    for width, height in [(1, 1), (9, 3), (17, 23)]:
        result = durer.render(sphere_scene(), durer.OrthographicCamera((0, 0, 10), (0, 0, -1), (0, 1, 0), 4.0),
                              width, height)
        x, y = pixel_centres(width, height, 4.0)
        np.testing.assert_array_equal(np.isfinite(result.depth), x**2 + y**2 <= 1)


def edge_scene(edge_x: float) -> durer.Scene:
    """White rectangle covering x >= edge_x on black."""
    scene = durer.Scene()
    white = scene.add_material((1, 1, 1))
    scene.add_plane((0, 0, 1), 0.0, material=white, bounds=((edge_x, -10, 0), (20, 0, 0), (0, 20, 0)))
    return scene


def test_anti_aliasing_converges_to_the_covered_fraction():
    # One pixel spanning x in [-0.5, 0.5]; the edge at 0.2 leaves 30 % covered.
    scene, camera = edge_scene(0.2), durer.OrthographicCamera((0, 0, 1), (0, 0, -1), (0, 1, 0), 1.0)
    errors = {}
    for spp in (1, 4, 16, 64, 256):
        values = np.array([durer.render(scene, camera, 1, 1, spp=spp, seed=s, passes="color").color[0, 0, 0]
                           for s in range(32)])
        errors[spp] = np.sqrt(np.mean((values - 0.3) ** 2))
        if spp > 1:
            # Stratification: only the column of strata the edge crosses varies.
            nx = int(math.isqrt(spp))
            assert np.abs(values - 0.3).max() <= 1 / nx + 1e-6
            assert np.mean(values) == pytest.approx(0.3, abs=0.5 / nx / math.sqrt(32) * 3)  # unbiased
    assert errors[1] == pytest.approx(0.3, abs=1e-6)  # the centre sample (x = 0) misses: all or nothing
    assert errors[4] > errors[16] > errors[64] > errors[256]
    assert errors[256] < 0.01


def test_anti_aliased_edge_image_matches_coverage():
    # A tilted edge across an image: each pixel's mean approaches its exact covered area.
    scene = durer.Scene()
    white = scene.add_material((1, 1, 1))
    scene.add_spheres([[0, 0, -100]], [80.0], material=white)  # a big disc: locally a straight edge
    camera = durer.OrthographicCamera((80 * math.cos(0.3), 80 * math.sin(0.3), 0), (0, 0, -1), (0, 1, 0), 8.0)
    image = durer.render(scene, camera, 8, 8, spp=400, passes="color").color[..., 0]
    # Exact coverage by supersampling the disc analytically.
    fine = 200
    offsets = (np.arange(fine) + 0.5) / fine - 0.5
    covered = np.empty((8, 8))
    for j in range(8):
        for i in range(8):
            xs = camera.center[0] + (i + 0.5 - 4) + offsets
            ys = camera.center[1] + (4 - j - 0.5) + offsets
            gx, gy = np.meshgrid(xs, ys)
            covered[j, i] = np.mean(gx**2 + gy**2 <= 80**2)
    assert ((covered > 0.05) & (covered < 0.95)).sum() >= 6  # the edge crosses the image
    np.testing.assert_allclose(image, covered, atol=0.03)


def test_same_seed_same_image_any_threads():
    scene, camera = durer.showcase_scene(small_spheres=20)
    a = durer.render(scene, camera, 40, 30, spp=4, seed=5, threads=1)
    b = durer.render(scene, camera, 40, 30, spp=4, seed=5, threads=2)
    c = durer.render(scene, camera, 40, 30, spp=4, seed=6, threads=2)
    np.testing.assert_array_equal(a.color, b.color)
    np.testing.assert_array_equal(a.normal, b.normal)
    assert not np.array_equal(a.color, c.color)


def test_depth_is_the_nearest_sample_with_anti_aliasing():
    scene = sphere_scene()
    result = durer.render(scene, ortho(), W, H, spp=16)
    single = durer.render(scene, ortho(), W, H)
    hit = np.isfinite(single.depth)
    assert (result.depth[hit] <= single.depth[hit] + 1e-6).all()
    np.testing.assert_allclose(np.linalg.norm(result.normal[np.isfinite(result.depth)], axis=-1), 1, rtol=1e-5)


def test_float_and_double_agree_on_the_showcase():
    scene, camera = durer.showcase_scene()
    f = durer.render(scene, camera, 160, 90, precision="float")
    d = durer.render(scene, camera, 160, 90, precision="double")
    close = np.all(np.abs(f.color - d.color) <= 1e-5, axis=-1)
    assert close.mean() >= 0.998  # a pixel centre within rounding of a silhouette may flip
    both = np.isfinite(f.depth) & np.isfinite(d.depth)
    np.testing.assert_allclose(f.depth[both], d.depth[both], rtol=1e-5)


@pytest.mark.parametrize("method", [m for m in SPHERE_METHODS if m != "robust"])
def test_sphere_methods_agree_on_the_showcase(method):
    scene, camera = durer.showcase_scene()
    reference = durer.render(scene, camera, 160, 90, sphere_method="robust")
    result = durer.render(scene, camera, 160, 90, sphere_method=method)
    assert np.mean(np.all(result.color == reference.color, axis=-1)) >= 0.999
    both = np.isfinite(result.depth) & np.isfinite(reference.depth)
    np.testing.assert_allclose(result.depth[both], reference.depth[both], rtol=1e-9)


def test_out_reuses_buffers():
    scene = sphere_scene()
    first = durer.render(scene, ortho(), W, H)
    fresh = durer.render(scene, ortho(), W, H)
    first.color.fill(np.nan), first.depth.fill(np.nan)  # a render that wrote nothing would leave these
    again = durer.render(scene, ortho(), W, H, out=first)
    assert again.color is first.color and again.depth is first.depth
    np.testing.assert_array_equal(again.color, fresh.color)
    np.testing.assert_array_equal(again.depth, fresh.depth)
    with pytest.raises(ValueError, match="out.color has the wrong shape"):
        durer.render(scene, ortho(), W + 1, H, out=first)


def test_visualisations():
    depth = np.array([[1.0, 2.0, 3.0, np.inf, 0.5]], np.float32)
    np.testing.assert_allclose(durer.depth_to_gray(depth, 1.0, 3.0), [[1, 0.5, 0, 0, 1]])
    normal = np.array([[[-0.6, 0.0, 0.8]]], np.float32)
    np.testing.assert_allclose(durer.normal_to_rgb(normal), [[[0.6, 0, 0.8]]])
    with pytest.raises(ValueError, match="^near must be < far"):
        durer.depth_to_gray(depth, 3.0, 1.0)
    for near, error, message in (("a", TypeError, "^near must be a real number, got str"),
                                 (None, TypeError, "^near must be a real number, got NoneType"),
                                 (10**400, ValueError, "^near must be within the range of a float"),
                                 (-math.inf, ValueError, "^near must be finite")):
        with pytest.raises(error, match=message):
            durer.depth_to_gray(depth, near, 3.0)
    with pytest.raises(TypeError, match="^far must be a real number"):
        durer.depth_to_gray(depth, 1.0, [3.0])


def test_save_image_roundtrip(tmp_path):
    from PIL import Image

    rgba = np.zeros((2, 3, 4), np.float32)
    rgba[0, 0] = (1, 0.5, 0, 1)
    rgba[1, 2] = (0.21586, 0.21586, 0.21586, 0.5)  # sRGB 128/255
    path = durer.save_image(tmp_path / "x.png", rgba)
    pixels = np.asarray(Image.open(path))
    assert pixels.shape == (2, 3, 4)
    assert tuple(pixels[0, 0]) == (255, 188, 0, 255)  # linear 0.5 is sRGB 188
    assert tuple(pixels[1, 2]) == (128, 128, 128, 128)


def test_save_image_refuses_nan_pixels_and_a_non_boolean_srgb(tmp_path):
    pixels = np.zeros((2, 3, 3))
    pixels[1, 2, 0] = np.nan  # a bug upstream: it was written as black, with only a RuntimeWarning
    with pytest.raises(ValueError, match=r"^pixels must not be NaN, got NaN at index \(1, 2, 0\)"):
        durer.save_image(tmp_path / "nan.png", pixels)
    with pytest.raises(TypeError, match="^srgb must be True or False, got str"):
        durer.save_image(tmp_path / "x.png", np.zeros((2, 2)), srgb="no")  # "no" was truthy: encoded
    with pytest.raises(TypeError, match=r"^pixels must be floats in \[0, 1\], got an array of uint8 \(bytes"):
        durer.save_image(tmp_path / "x.png", np.full((2, 2, 3), 128, np.uint8))  # was written 0 or 255
    assert not (tmp_path / "nan.png").exists() and not (tmp_path / "x.png").exists()
    durer.save_image(tmp_path / "list.png", [[0, 1], [1, 0]], srgb=False)  # whole numbers of a list: 0 and 1
