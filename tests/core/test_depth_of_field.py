"""Depth of field: the cameras' thin lens (aperture_radius, focus_distance, aperture_blades,
aperture_rotation, aperture_ratio), against the geometry of a thin lens."""

from __future__ import annotations

import math
import pickle

import numpy as np
import pytest

import durer

# A tiny glowing sphere on the view axis, far behind the plane of focus: its blurred image is the
# aperture's shape, scaled by aperture · |1/focus − 1/distance| on the image plane at unit distance
# (a perspective camera), and convolved with the sphere's own disc.
DISTANCE, FOCUS, APERTURE, RADIUS = 10.0, 5.0, 0.2, 0.02
FOV, SIDE = 4.0, 101


def glowing_sphere(center=(0.0, 0.0, -DISTANCE), radius=RADIUS) -> durer.Scene:
    scene = durer.Scene()
    glow = scene.add_material((0, 0, 0), emission=(1, 1, 1))
    scene.add_spheres(np.array([center]), radius, glow)
    return scene


def lens_camera(**lens) -> durer.PerspectiveCamera:
    return durer.PerspectiveCamera((0, 0, 0), (0, 0, -1), (0, 1, 0), fov_degrees=FOV, aperture_radius=APERTURE,
                                   focus_distance=FOCUS, **lens)


def bokeh(camera, spp=256, precision="double") -> np.ndarray:
    """The red channel: each pixel's share of rays that meet the glowing sphere."""
    return durer.render(glowing_sphere(), camera, SIDE, SIDE, spp=spp, passes=("color",), precision=precision).color[..., 0]


PIXEL = 2 * math.tan(math.radians(FOV / 2)) / SIDE  # a pixel's width at unit distance
BLUR = APERTURE * abs(1 / FOCUS - 1 / DISTANCE)     # the blur's radius at unit distance
OWN = RADIUS / math.sqrt(DISTANCE**2 - RADIUS**2)   # the sphere's own radius there (tan of its half-angle)


def extent(image: np.ndarray) -> tuple[float, float, float, float]:
    """The lit pixels' centres farthest left, right, down and up, in blur radii from the centre."""
    ys, xs = np.nonzero(image > 0)
    c = SIDE // 2
    return ((xs.min() - c) * PIXEL / BLUR, (xs.max() - c) * PIXEL / BLUR,
            (c - ys.max()) * PIXEL / BLUR, (c - ys.min()) * PIXEL / BLUR)


@pytest.mark.parametrize("precision", ["double", "float"])
def test_a_point_out_of_focus_spreads_over_the_aperture_disc(precision):
    image = bokeh(lens_camera(), precision=precision)
    # The light is conserved: the image holds the sphere's own disc (MC noise of 256 samples a pixel).
    assert image.sum() * PIXEL**2 == pytest.approx(math.pi * OWN**2, rel=0.02)
    # Lit pixels lie within the blur's radius plus the sphere's own and half a pixel's diagonal, and
    # reach it: the disc's radius is BLUR, 29 pixels here where the sphere alone covers one.
    reach = (BLUR + OWN + PIXEL * math.sqrt(0.5)) / BLUR
    left, right, down, up = extent(image)
    for end in (-left, right, -down, up):
        assert 1 - 1.5 * PIXEL / BLUR <= end <= reach
    # Inside, each pixel sees the sphere through (own / blur)² of the lens: 1 % here.
    inner = image[SIDE // 2 - 10:SIDE // 2 + 11, SIDE // 2 - 10:SIDE // 2 + 11]
    assert inner.mean() == pytest.approx((OWN / BLUR) ** 2, rel=0.1)


def test_blades_make_the_polygon_turned_as_cycles_turns_it():
    # Three blades: corners at -60°, 60° and 180° (the first edge's corners at ±180°/blades, as in
    # Cycles' regular_polygon_sample): a point on the left, an edge at x = cos 60° on the right.
    left, right, down, up = extent(bokeh(lens_camera(aperture_blades=3)))
    margin = (OWN + PIXEL) / BLUR
    assert -1 - margin <= left <= -1 + margin
    assert 0.5 - margin <= right <= 0.5 + margin
    assert math.sin(math.radians(60)) - margin <= up <= math.sin(math.radians(60)) + margin
    assert down == pytest.approx(-up, abs=1.5 * PIXEL / BLUR)  # sampled: an edge pixel may stay dark
    # Turned by 90° counter-clockwise: the point down, the edge above.
    left, right, down, up = extent(bokeh(lens_camera(aperture_blades=3, aperture_rotation=math.pi / 2)))
    assert -1 - margin <= down <= -1 + margin
    assert 0.5 - margin <= up <= 0.5 + margin
    # Four blades: a square of half-side cos 45°, light conserved.
    image = bokeh(lens_camera(aperture_blades=4))
    for end in extent(image):
        assert abs(end) == pytest.approx(math.cos(math.radians(45)), abs=margin)
    assert image.sum() * PIXEL**2 == pytest.approx(math.pi * OWN**2, rel=0.02)


def test_aperture_ratio_narrows_the_bokeh_horizontally():
    left, right, down, up = extent(bokeh(lens_camera(aperture_ratio=2)))
    margin = (OWN + PIXEL) / BLUR
    assert right == pytest.approx(0.5, abs=margin) and left == pytest.approx(-0.5, abs=margin)
    assert up == pytest.approx(1, abs=margin) and down == pytest.approx(-1, abs=margin)


def test_the_plane_of_focus_is_sharp():
    # A sphere at the focus distance: every lens point sees it where the pinhole does, so its image is
    # the pinhole's but for its silhouette's depth (it is no point): the same coverage to 1 %.
    scene = durer.Scene()
    scene.add_spheres(np.array([[0.0, 0.0, -FOCUS]]), 0.05)
    pinhole = durer.PerspectiveCamera((0, 0, 0), (0, 0, -1), (0, 1, 0), fov_degrees=FOV)
    sharp = durer.render(scene, lens_camera(), SIDE, SIDE, spp=64, passes=("color",)).color[..., 3]
    still = durer.render(scene, pinhole, SIDE, SIDE, spp=64, passes=("color",)).color[..., 3]
    assert np.abs(sharp.sum() - still.sum()) < 0.01 * still.sum()
    assert np.array_equal(sharp > 0.5, still > 0.5)


def test_orthographic_blur_grows_with_the_distance_from_the_plane_of_focus():
    # Orthographic: rays leave the pixel's origin moved across the lens, toward origin + focus along
    # the axis; a point at distance d blurs over aperture · |1 − d / focus| in world units.
    size, side = 2.0, 101
    camera = durer.OrthographicCamera((0, 0, 0), (0, 0, -1), (0, 1, 0), size=size, aperture_radius=0.2,
                                      focus_distance=FOCUS)
    image = durer.render(glowing_sphere(), camera, side, side, spp=256, passes=("color",)).color[..., 0]
    pixel = size / side
    blur = 0.2 * abs(1 - DISTANCE / FOCUS)
    assert image.sum() * pixel**2 == pytest.approx(math.pi * RADIUS**2, rel=0.02)
    ys, xs = np.nonzero(image > 0)
    assert (xs.max() - side // 2) * pixel == pytest.approx(blur, abs=RADIUS + pixel)
    assert (side // 2 - ys.min()) * pixel == pytest.approx(blur, abs=RADIUS + pixel)


@pytest.mark.parametrize("camera", [
    durer.PerspectiveCamera((0, 0, 0), (0, 0, -1), (0, 1, 0), fov_degrees=60, aperture_radius=0.5, focus_distance=2.0),
    durer.OrthographicCamera((0, 0, 0), (0, 0, -1), (0, 1, 0), size=4.0, aperture_radius=0.5, focus_distance=2.0),
], ids=["perspective", "orthographic"])
def test_planar_depth_of_a_plane_across_the_axis_is_exact_through_the_lens(camera):
    # Every ray leaves the lens's plane, so a plane parallel to it lies at the same distance along
    # the axis from all of them, whatever the lens point: Blender's Depth is exact, not blurred;
    # t along the leaning rays is longer (an orthographic lens's rays lean too).
    scene = durer.Scene()
    scene.add_plane((0, 0, 1), -7.0)
    planar = durer.render(scene, camera, 40, 30, spp=4, passes=("depth",), depth="planar")
    along = durer.render(scene, camera, 40, 30, spp=4, passes=("depth",))
    np.testing.assert_allclose(planar.depth, 7.0, rtol=1e-6)
    assert along.depth.max() > 7.01  # 1 / cos of their lean


@pytest.mark.parametrize("precision", ["double", "float"])
def test_far_clip_plane_holds_for_rays_tilted_by_the_lens(precision):
    # A wide aperture focused near tilts the corner rays well beyond the window's corner: the search's
    # range along each ray must still reach the far plane, so a plane just before it fills the image
    # and one just beyond it is clipped everywhere.
    camera = dict(fov_degrees=90, t_min=0.1, t_max=10.0, clip_planes=True, aperture_radius=2.0, focus_distance=1.0)
    for distance, seen in ((9.99, True), (10.01, False)):
        scene = durer.Scene()
        scene.add_plane((0, 0, 1), -distance)
        cam = durer.PerspectiveCamera((0, 0, 0), (0, 0, -1), (0, 1, 0), **camera)
        res = durer.render(scene, cam, 32, 32, spp=16, passes=("depth",), precision=precision, depth="planar")
        assert np.all(np.isfinite(res.depth) == seen)


def test_the_render_meets_the_nearest_sphere_along_each_lens_ray():
    # Spheres overlapping in depth, a wide lens: the camera's view, its footprints widened by 2.2
    # pixels on average, for rays that share neither origin nor direction. Each pixel's one sample at its centre (sampler "center") aims at the
    # pinhole ray's point on the plane of focus; from the hit point the normal gives, the ray's origin
    # is where the line through the two meets the lens's plane. It lies within the aperture, and a
    # cast of that ray meets the same sphere at the same t (to the normal pass's float rounding).
    rng = np.random.default_rng(5)
    centers = rng.uniform(-3, 3, (400, 3)) + (0, 0, -12)
    radii = rng.uniform(0.1, 0.5, 400)
    scene = durer.Scene()
    scene.add_spheres(centers, radii)
    focus = 8.0
    camera = durer.PerspectiveCamera((0, 0, 0), (0, 0, -1), (0, 1, 0), fov_degrees=40, aperture_radius=0.6,
                                     focus_distance=focus)
    res = durer.render(scene, camera, 64, 64, spp=1, sampler="center", passes=("depth", "normal", "object_id"))
    _, pinhole = camera.rays(64, 64)
    hit = res.object_id >= 0
    ids = res.object_id[hit]
    point = centers[ids] + radii[ids, None] * res.normal[hit]
    aim = pinhole[hit] * (focus / -pinhole[hit][:, 2:3])  # on the plane of focus
    origin = point + (aim - point) * (point[:, 2:3] / (point[:, 2:3] - aim[:, 2:3]))  # where z = 0
    assert np.all(np.hypot(origin[:, 0], origin[:, 1]) <= 0.6 * (1 + 1e-3) + 1e-3)
    direction = aim - origin
    cast = durer.cast(scene, origin, direction / np.linalg.norm(direction, axis=1, keepdims=True))
    same = cast.object_id == ids
    assert same.mean() > 0.99  # a few grazing rays may pass the other side of a silhouette
    np.testing.assert_allclose(cast.t[same], res.depth[hit][same], rtol=1e-4)
    assert hit.mean() > 0.3


def test_lens_renders_are_deterministic_and_regions_are_the_whole_renders_pixels():
    scene, _ = durer.showcase_scene()
    camera = durer.PerspectiveCamera((0, 1, 6), (0, -0.2, -1), (0, 1, 0), fov_degrees=40, aperture_radius=0.15,
                                     focus_distance=5.0, aperture_blades=6)
    whole = durer.render(scene, camera, 48, 40, spp=8, threads=2)
    again = durer.render(scene, camera, 48, 40, spp=8, threads=1)
    region = durer.render(scene, camera, 48, 40, spp=8, threads=2, region=(13, 7, 20, 17))
    np.testing.assert_array_equal(whole.color, again.color)
    np.testing.assert_array_equal(region.color, whole.color[7:24, 13:33])
    for sampler in ("adaptive", "sobol", "random", "center"):
        one = durer.render(scene, camera, 48, 40, spp=8, sampler=sampler, threads=2)
        two = durer.render(scene, camera, 48, 40, spp=8, sampler=sampler, threads=1)
        np.testing.assert_array_equal(one.color, two.color)


def test_a_lens_of_radius_zero_is_the_pinhole():
    scene = glowing_sphere(radius=0.5)
    pinhole = durer.PerspectiveCamera((0, 0, 0), (0, 0, -1), (0, 1, 0), fov_degrees=FOV)
    closed = durer.PerspectiveCamera((0, 0, 0), (0, 0, -1), (0, 1, 0), fov_degrees=FOV, aperture_radius=0.0,
                                     focus_distance=3.0, aperture_blades=5)
    a = durer.render(scene, pinhole, 33, 33, spp=4)
    b = durer.render(scene, closed, 33, 33, spp=4)
    for name in ("color", "depth", "normal"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))


def test_lens_cameras_are_values():
    camera = lens_camera(aperture_blades=5, aperture_rotation=0.3, aperture_ratio=1.5)
    again = pickle.loads(pickle.dumps(camera))
    assert again == camera
    np.testing.assert_array_equal(bokeh(again, spp=16), bokeh(camera, spp=16))


def test_a_camera_inside_a_cloud_keeps_its_view_through_a_small_lens():
    # Spheres all around the eye: those behind the lens's plane cannot be met, those across it list
    # everywhere; a lens blurring the rest by a fraction of a pixel still searches the camera's view,
    # testing what the pinhole tests (not the hierarchy's walk: 9x more here).
    rng = np.random.default_rng(3)
    centers = rng.uniform(-10, 10, (50_000, 3))
    scene = durer.Scene()
    scene.add_spheres(centers, 0.05)
    walked = durer.Scene()
    walked.add_spheres(centers / 2, 0.025, transform=np.hstack([2 * np.eye(3), np.zeros((3, 1))]))
    pinhole = durer.PerspectiveCamera((0, 0, 0), (0, 0, -1), (0, 1, 0), fov_degrees=60)
    lens = durer.PerspectiveCamera((0, 0, 0), (0, 0, -1), (0, 1, 0), fov_degrees=60, aperture_radius=1e-5,
                                   focus_distance=5.0)
    tests = {name: durer.render(s, c, 160, 120, passes=("depth",)).stats["intersection_tests"]
             for name, s, c in (("pinhole", scene, pinhole), ("lens", scene, lens), ("walk", walked, lens))}
    assert tests["lens"] < 1.5 * tests["pinhole"] and tests["walk"] > 3 * tests["lens"]


@pytest.mark.parametrize(("fields", "message"), [
    ({"aperture_radius": -0.1, "focus_distance": 1.0}, "aperture_radius"),
    ({"aperture_radius": math.nan, "focus_distance": 1.0}, "aperture_radius"),
    ({"aperture_radius": 0.1}, "focus_distance"),
    ({"aperture_radius": 0.1, "focus_distance": 0.0}, "focus_distance"),
    ({"aperture_radius": 0.1, "focus_distance": math.inf}, "focus_distance"),
    ({"aperture_blades": 2}, "aperture_blades"),
    ({"aperture_blades": -3}, "aperture_blades"),
    ({"aperture_blades": 101}, "aperture_blades"),
    ({"aperture_blades": 2**40}, "aperture_blades"),
    ({"aperture_rotation": math.inf}, "aperture_rotation"),
    ({"aperture_ratio": 0.0}, "aperture_ratio"),
])
def test_bad_lenses_are_named(fields, message):
    with pytest.raises(ValueError, match=message):
        durer.PerspectiveCamera((0, 0, 0), (0, 0, -1), (0, 1, 0), **fields)
    with pytest.raises(ValueError, match=message):
        durer.OrthographicCamera((0, 0, 0), (0, 0, -1), (0, 1, 0), **fields)


@pytest.mark.parametrize(("fields", "message"), [
    ({"aperture_radius": "wide"}, "aperture_radius"),
    ({"aperture_blades": 5.5}, "aperture_blades"),
    ({"aperture_ratio": None}, "aperture_ratio"),
])
def test_lens_fields_of_the_wrong_type_are_named(fields, message):
    with pytest.raises(TypeError, match=message):
        durer.PerspectiveCamera((0, 0, 0), (0, 0, -1), (0, 1, 0), **fields)


def test_a_lens_beyond_float_coordinates_is_refused_for_float_renders():
    camera = durer.PerspectiveCamera((0, 0, 0), (0, 0, -1), (0, 1, 0), aperture_radius=1e30, focus_distance=1.0)
    with pytest.raises(ValueError, match="aperture_radius"):
        durer.render(glowing_sphere(), camera, 8, 8, precision="float")
    camera = durer.PerspectiveCamera((0, 0, 0), (0, 0, -1), (0, 1, 0), aperture_radius=1.0, focus_distance=1e39)
    with pytest.raises(ValueError, match="focus_distance"):
        durer.render(glowing_sphere(), camera, 8, 8, precision="float")
