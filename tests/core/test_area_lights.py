"""Area lights: the irradiance a floor receives from a rectangle, a parallelogram or an ellipse
(against quadrature over the surface, and the closed form on a disc's axis), soft shadows (against
the visibility-weighted quadrature), the far field (a point light of colour color·cos θ), the
sampling's determinism, the light seen in mirrors (its radiance π·color/area where a mirror direction
meets it), and bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest

import durer

HEIGHT = 1.0
CAMERA = durer.OrthographicCamera((0, 0, 5), (0, 0, -1), (0, 1, 0), 4.0)  # the floor z = 0, x and y in [-2, 2]
N = 33


def floor_points(n: int = N) -> np.ndarray:
    origins, _ = CAMERA.rays(n, n)
    points = origins.copy()
    points[..., 2] = 0
    return points


def scene_with(*, ellipse: bool, u=(1.0, 0, 0), v=(0, -1.0, 0), color=(1.0, 1.0, 1.0), samples: int = 256,
               shadows: bool = False, occluder: tuple[tuple[float, float, float], float] | None = None) -> durer.Scene:
    """A white floor z = 0 under an area light centred at height HEIGHT (u × v pointing down)."""
    scene = durer.Scene()
    white = scene.add_material((1, 1, 1))
    scene.add_plane((0, 0, 1), 0.0, material=white)
    if occluder is not None:
        scene.add_spheres([occluder[0]], occluder[1], material=white)
    scene.add_area_light((0, 0, HEIGHT), u, v, color, ellipse=ellipse, samples=samples, shadows=shadows)
    return scene


def quadrature(points: np.ndarray, *, ellipse: bool, u, v, occluder=None, n: int = 400) -> np.ndarray:
    """∫ cosθ_light·cosθ_floor / d² dA / area over the light (radiance 1/area: intensity 1 along the
    normal), by the midpoint rule over (a, b) in [0, 1]², for each floor point; with an occluding
    sphere, only the surface points the segment to it misses."""
    u, v = np.asarray(u, float), np.asarray(v, float)
    a = (np.arange(n) + 0.5) / n
    aa, bb = [g.ravel() for g in np.meshgrid(a, a)]
    if ellipse:  # polar: radius √a (uniform in area), angle 2πb
        x, y = np.sqrt(aa) * np.cos(2 * np.pi * bb) / 2, np.sqrt(aa) * np.sin(2 * np.pi * bb) / 2
    else:
        x, y = aa - 0.5, bb - 0.5
    surface = np.array([0, 0, HEIGHT]) + x[:, None] * u + y[:, None] * v
    normal = np.cross(u, v) / np.linalg.norm(np.cross(u, v))
    out = np.empty(points.shape[:-1])
    for index in np.ndindex(out.shape):
        p = points[index]
        w = surface - p
        d2 = (w * w).sum(axis=1)
        cos_light = np.maximum(-(w @ normal), 0) / np.sqrt(d2)
        cos_floor = np.maximum(w[:, 2], 0) / np.sqrt(d2)
        seen = np.ones(len(w), bool)
        if occluder is not None:
            oc = p - np.asarray(occluder[0], float)
            b = w @ oc
            disc = b * b - d2 * (oc @ oc - occluder[1] ** 2)
            t = (-b - np.sqrt(np.maximum(disc, 0))) / d2
            seen = ~((disc > 0) & (t > 0) & (t < 1))
        out[index] = (cos_light * cos_floor / d2 * seen).mean()
    return out


@pytest.mark.parametrize("ellipse", [False, True])
def test_floor_irradiance_matches_quadrature(precision, ellipse):
    u, v = (1.2, 0.0, 0.0), (0.0, -0.8, 0.0)
    image = durer.render(scene_with(ellipse=ellipse, u=u, v=v), CAMERA, N, N, precision=precision).color[..., 0]
    expected = quadrature(floor_points(), ellipse=ellipse, u=u, v=v)
    np.testing.assert_allclose(image, expected, rtol=2e-3, atol=1e-5)  # measured: 256 samples, < 4e-4


def test_disc_on_its_axis_is_the_closed_form():
    # A disc of radius R at height h, intensity I along its normal: E = I / (h² + R²) below its centre.
    radius = 0.5
    scene = scene_with(ellipse=True, u=(2 * radius, 0, 0), v=(0, -2 * radius, 0), color=(2.0, 2.0, 2.0), samples=1024)
    centre = durer.render(scene, CAMERA, N, N, precision="double").color[N // 2, N // 2, 0]
    assert centre == pytest.approx(2.0 / (HEIGHT**2 + radius**2), rel=2e-4)


def test_a_parallelogram_is_lit_uniformly_over_its_area():
    u, v = (1.0, 0.3, 0.0), (0.4, -0.9, 0.1)  # sheared and tilted: still u × v downward
    assert np.cross(u, v)[2] < 0
    image = durer.render(scene_with(ellipse=False, u=u, v=v), CAMERA, N, N).color[..., 0]
    np.testing.assert_allclose(image, quadrature(floor_points(), ellipse=False, u=u, v=v), rtol=2e-3, atol=1e-5)


@pytest.mark.parametrize(
    "ellipse, height, rmse, bias",
    [(False, 0.2, 0.06, 0.01), (False, 0.05, 0.06, 0.01), (False, 0.01, 0.06, 0.01),
     (True, 0.2, 0.16, 0.04), (True, 0.05, 0.25, 0.04), (True, 0.01, 0.35, 0.04)],
)
def test_a_light_near_a_surface_is_sampled_by_solid_angle(ellipse, height, rmse, bias):
    # Uniform over the area, 16 points under a 1 m square gave 27 % / 109 % / 635 % relative RMSE
    # at these heights: by the solid angle they fill, each carries the same weight (measured 1.3 % /
    # 2.3 % / 2.9 %). Under the disc inscribed in it 21 % / 76 % / 82 % by area; by the solid angle
    # of the square around it, points outside the disc carrying nothing, 12 % / 14 % / 22 % (farther
    # than 0.6 of its radius, by area: 1.1 % at height 1).
    global HEIGHT
    saved, HEIGHT = HEIGHT, height
    try:
        camera = durer.OrthographicCamera((0, 0, 5), (0, 0, -1), (0, 1, 0), 1.6)  # |x|, |y| <= 0.8
        image = durer.render(scene_with(ellipse=ellipse, samples=16), camera, 9, 9, precision="double").color[..., 0]
        origins, _ = camera.rays(9, 9)
        points = origins.copy()
        points[..., 2] = 0
        exact = quadrature(points, ellipse=ellipse, u=(1.0, 0, 0), v=(0, -1.0, 0), n=1000)
    finally:
        HEIGHT = saved
    relative = image / exact - 1
    assert np.sqrt((relative**2).mean()) < rmse
    assert abs(relative.mean()) < bias


def test_far_away_it_is_a_point_light_of_colour_times_cosine():
    # A 10 µm square 3 m off the floor, tilted: the light of a point light whose colour is I·cos θ.
    u, v = np.array([1e-5, 0, 0]), np.array([0, -1e-5 * math.cos(0.6), 1e-5 * math.sin(0.6)])
    scene = durer.Scene()
    scene.add_plane((0, 0, 1), 0.0, material=scene.add_material((1, 1, 1)))
    scene.add_area_light((0, 0, 3.0), u, v, (5.0, 5.0, 5.0), samples=4)
    image = durer.render(scene, CAMERA, N, N, precision="double").color[..., 0]
    points = floor_points()
    to_light = np.array([0, 0, 3.0]) - points
    d = np.linalg.norm(to_light, axis=-1)
    normal = np.cross(u, v) / np.linalg.norm(np.cross(u, v))
    cos_light = -(to_light @ normal) / d
    expected = 5.0 * cos_light * (to_light[..., 2] / d) / d**2
    np.testing.assert_allclose(image, expected, rtol=1e-5)


def test_nothing_is_lit_behind_it():
    up = scene_with(ellipse=False, u=(1.0, 0, 0), v=(0, 1.0, 0))  # u × v up, away from the floor
    np.testing.assert_array_equal(durer.render(up, CAMERA, N, N).color[..., :3], 0.0)
    down = scene_with(ellipse=False, u=(1.0, 0, 0), v=(0, -1.0, 0))  # the same light turned over
    assert (durer.render(down, CAMERA, N, N).color[..., 0] > 0).all()


@pytest.mark.parametrize("ellipse", [False, True])
def test_soft_shadows_match_the_visible_part_of_the_light(ellipse):
    occluder = ((0.0, 0.0, 0.5), 0.2)
    scene = scene_with(ellipse=ellipse, samples=1024, shadows=True, occluder=occluder)
    camera = durer.OrthographicCamera((0, 0, 5), (0, 0, -1), (0, 1, 0), 2.0)  # x and y in [-1, 1]
    image = durer.render(scene, camera, 17, 17, precision="double").color[..., 0]
    origins, _ = camera.rays(17, 17)
    floor = np.hypot(origins[..., 0], origins[..., 1]) > 0.21  # pixels that see the floor, not the ball
    points = origins[floor]
    points[:, 2] = 0
    expected = quadrature(points, ellipse=ellipse, u=(1.0, 0, 0), v=(0, -1.0, 0), occluder=occluder, n=300)
    unshadowed = quadrature(points, ellipse=ellipse, u=(1.0, 0, 0), v=(0, -1.0, 0), n=300)
    penumbra = (expected < 0.97 * unshadowed) & (expected > 0.03 * unshadowed)
    assert penumbra.sum() >= 40, "the compared pixels should include a penumbra"
    np.testing.assert_allclose(image[floor], expected, rtol=1.5e-2)  # measured: < 9e-3


def test_without_shadows_occluders_do_not_block_it():
    occluder = ((0.0, 0.0, 0.5), 0.2)
    camera = durer.OrthographicCamera((0, 0, 5), (0, 0, -1), (0, 1, 0), 2.0)
    free = durer.render(scene_with(ellipse=False), camera, 17, 17).color
    blocked = durer.render(scene_with(ellipse=False, occluder=occluder), camera, 17, 17).color
    origins, _ = camera.rays(17, 17)
    floor = np.hypot(origins[..., 0], origins[..., 1]) > 0.21
    np.testing.assert_array_equal(blocked[floor], free[floor])


def test_samples_are_fixed_by_the_seed_and_new_for_each_pixel_sample():
    occluder = ((0.0, 0.0, 0.5), 0.2)
    scene = scene_with(ellipse=True, samples=2, shadows=True, occluder=occluder)
    camera = durer.OrthographicCamera((0, 0, 5), (0, 0, -1), (0, 1, 0), 2.0)
    render = lambda **kw: durer.render(scene, camera, 17, 17, precision="double", **kw).color[..., 0]  # noqa: E731
    one = render(seed=7, threads=1)
    np.testing.assert_array_equal(one, render(seed=7, threads=2))
    assert (one != render(seed=8)).mean() > 0.5
    # 64 pixel samples of 2 light samples each converge as 128 light samples would: each pixel
    # sample draws its own points (its hits differ, so do their scrambles). Against the quadrature
    # averaged over 4x4 points of each pixel (the 8x8 strata's mean), away from the ball.
    origins, _ = camera.rays(68, 68)
    points = origins.copy()
    points[..., 2] = 0
    exact = quadrature(points, ellipse=True, u=(1.0, 0, 0), v=(0, -1.0, 0), occluder=occluder, n=120)
    exact = exact.reshape(17, 4, 17, 4).mean(axis=(1, 3))
    many = render(seed=7, spp=64, sampler="stratified")
    floor = np.hypot(*origins[1::4, 1::4, :2].transpose(2, 0, 1)) > 0.3
    rmse = lambda image: np.sqrt(((image - exact)[floor] ** 2).mean())  # noqa: E731
    assert rmse(many) < rmse(one) / 6, (rmse(one), rmse(many))  # 64 independent estimates: 1/8


def test_highlight_of_a_small_area_light_is_a_point_lights():
    def image(add_light):
        scene = durer.Scene()
        scene.add_plane((0, 0, 1), 0.0, material=scene.add_material((0.2, 0.2, 0.2), specular=(1, 1, 1), exponent=20))
        add_light(scene)
        camera = durer.PerspectiveCamera((0, -3, 2), (0, 3, -2), (0, 0, 1), 50.0)
        return durer.render(scene, camera, 33, 33, precision="double").color[..., 0]

    u, v = (1e-6, 0, 0), (0, -1e-6, 0)
    area = image(lambda s: s.add_area_light((0.3, 0.5, 2.0), u, v, (3.0, 3.0, 3.0), samples=1))
    # Straight below the light, cos θ_light = the floor's cosine: the point light's colour carries it.
    points = np.array([0.3, 0.5, 2.0])
    assert area.max() > 0.3
    point = image(lambda s: s.add_point_light((0.3, 0.5, 2.0), (3.0, 3.0, 3.0), attenuation=(0, 0, 1)))
    # The point light lacks the cos θ_light factor: the two agree where it is ~1, under the light.
    origins, directions = durer.PerspectiveCamera((0, -3, 2), (0, 3, -2), (0, 0, 1), 50.0).rays(33, 33)
    t = -origins[..., 2] / directions[..., 2]
    hits = origins + t[..., None] * directions
    to_light = points - hits
    cos_light = to_light[..., 2] / np.linalg.norm(to_light, axis=-1)
    np.testing.assert_allclose(area, point * cos_light, rtol=1e-4, atol=1e-7)


REFLECTIVE = np.array([0.5, 0.25, 1.0])


def mirror_floor(*, ellipse: bool = False, u=(1.0, 0, 0), v=(0, -0.5, 0), color=(1.0, 2.0, 3.0), shadows=False,
                 occluder=None, **material) -> durer.Scene:
    """A black mirror floor z = 0 under an area light at height 2 (u × v pointing down)."""
    scene = durer.Scene()
    mirror = scene.add_material((0, 0, 0), reflective=tuple(REFLECTIVE), **material)
    scene.add_plane((0, 0, 1), 0.0, material=mirror)
    if occluder is not None:
        scene.add_spheres([occluder[0]], occluder[1], material=scene.add_material((0, 0, 0)))
    scene.add_area_light((0, 0, 2.0), u, v, color, ellipse=ellipse, samples=4, shadows=shadows)
    return scene


def mirrored_inside(camera, size: int, *, ellipse: bool, u, v, margin: float):
    """Which pixels' mirror ray (off the floor z = 0) meets the light at height 2 inside its shape,
    which outside, each by more than `margin` in the light's coordinates (the rest: neither)."""
    origins, directions = camera.rays(size, size)
    t = -origins[..., 2] / directions[..., 2]
    floor = origins + t[..., None] * directions
    mirrored = directions * np.array([1, 1, -1])
    n = np.cross(u, v)
    w = floor - np.array([0, 0, 2.0])
    w = w - ((w @ n) / (mirrored @ n))[..., None] * mirrored  # in the light's plane
    a = np.cross(w, v) @ n / (n @ n)
    b = np.cross(u, w) @ n / (n @ n)
    radius = np.hypot(a, b) if ellipse else np.maximum(abs(a), abs(b))
    return (t > 0) & (radius < 0.5 - margin), (t > 0) & (radius > 0.5 + margin)


@pytest.mark.parametrize("ellipse", [False, True])
def test_a_mirror_shows_it_with_its_radiance(precision, ellipse):
    # Straight down, orthographic: the mirror ray goes straight up; the light's radiance is π·color
    # over its area, so that its cosine-weighted integral is the irradiance the samples give.
    camera = durer.OrthographicCamera((0, 0, 1), (0, 0, -1), (0, 1, 0), 2.0)
    image = durer.render(mirror_floor(ellipse=ellipse), camera, 64, 64, precision=precision).color[..., :3]
    area = 0.5 * (math.pi / 4 if ellipse else 1.0)
    inside, outside = mirrored_inside(camera, 64, ellipse=ellipse, u=(1.0, 0, 0), v=(0, -0.5, 0), margin=0)
    assert inside.sum() == (404 if ellipse else 512)
    np.testing.assert_allclose(image[inside], np.broadcast_to(REFLECTIVE * [1, 2, 3] * math.pi / area, (inside.sum(), 3)),
                               rtol=1e-6)
    np.testing.assert_array_equal(image[outside], 0.0)


def test_a_tilted_sheared_light_in_a_mirror_seen_in_perspective():
    u, v = np.array([1.0, 0.3, 0.2]), np.array([0.4, -0.9, 0.1])  # u × v points down
    assert np.cross(u, v)[2] < 0
    camera = durer.PerspectiveCamera((0, -3, 1), (0, 3, -2.5), (0, 0, 1), 50.0)
    image = durer.render(mirror_floor(u=u, v=v), camera, 96, 96, precision="double").color[..., 0]
    inside, outside = mirrored_inside(camera, 96, ellipse=False, u=u, v=v, margin=0.02)
    assert inside.sum() > 400 and outside.sum() > 4000
    area = np.linalg.norm(np.cross(u, v))
    np.testing.assert_allclose(image[inside], REFLECTIVE[0] * math.pi / area, rtol=1e-6)
    np.testing.assert_array_equal(image[outside], 0.0)


def test_a_white_mirror_and_a_white_floor_agree_as_the_light_fills_the_sky():
    # A square of half side R at height h over a white floor: the floor below its centre receives
    # (π·I/area)·F, F the square's form factor from there (four quadrants of a parallel rectangle
    # seen from below its corner; 1 for the whole sky); a white mirror shows the radiance π·I/area.
    half, intensity = 30.0, 2.0
    shown = {}
    for name, material in (("diffuse", {"diffuse": (1, 1, 1)}), ("mirror", {"diffuse": (0, 0, 0), "reflective": (1, 1, 1)})):
        scene = durer.Scene()
        scene.add_plane((0, 0, 1), 0.0, material=scene.add_material(**material))
        scene.add_area_light((0, 0, HEIGHT), (2 * half, 0, 0), (0, -2 * half, 0), (intensity,) * 3, samples=4096)
        shown[name] = durer.render(scene, CAMERA, N, N, precision="double").color[N // 2, N // 2, 0]
    radiance = math.pi * intensity / (2 * half) ** 2
    assert shown["mirror"] == pytest.approx(radiance, rel=1e-6)  # float32 pixels
    a = half / HEIGHT
    quadrant = (a / math.hypot(1, a) * math.atan(a / math.hypot(1, a))) / math.pi  # both terms of Howell's C-11
    assert 4 * quadrant == pytest.approx(1, abs=2e-3)
    assert shown["diffuse"] == pytest.approx(radiance * 4 * quadrant, rel=5e-3)


def distance_to_segments(point, starts, ends):
    """The distance from `point` to each segment starts[i]–ends[i]."""
    along = ends - starts
    t = np.clip(((point - starts) * along).sum(-1) / (along * along).sum(-1), 0, 1)
    return np.linalg.norm(starts + t[..., None] * along - point, axis=-1)


@pytest.mark.parametrize("shadows", [True, False])
def test_what_stands_in_the_mirror_rays_way_hides_it(shadows):
    # Seen at a slant, a ball above the floor stands in the way of some mirror rays to the light
    # but in front of no pixel whose mirror ray reaches it. Whether or not the light casts shadows:
    # a mirror sees what it faces (as Cycles' mirrors do).
    ball, radius = np.array([0.1, -0.4, 1.2]), 0.2
    camera = durer.OrthographicCamera((0, -2.5, 3), (0, 0.5, -1), (0, 1, 0.5), 3.0)
    image = durer.render(mirror_floor(shadows=shadows, occluder=(tuple(ball), radius)), camera, 64, 64).color[..., 0]
    inside, _ = mirrored_inside(camera, 64, ellipse=False, u=(1.0, 0, 0), v=(0, -0.5, 0), margin=0.02)
    origins, directions = camera.rays(64, 64)
    floor = origins + (-origins[..., 2] / directions[..., 2])[..., None] * directions
    assert distance_to_segments(ball, origins, floor)[inside].min() > radius  # the camera sees the floor there
    mirrored = directions * [1, 1, -1]
    gap = distance_to_segments(ball, floor, floor + (2 / mirrored[..., 2:]) * mirrored)  # up to the light's height
    behind, beside = inside & (gap < radius - 0.01), inside & (gap > radius + 0.01)
    assert behind.sum() > 50 and beside.sum() > 100
    lit = REFLECTIVE[0] * math.pi / 0.5
    np.testing.assert_allclose(image[beside], lit, rtol=1e-6)
    np.testing.assert_array_equal(image[behind], 0.0)


def test_a_mirror_shows_it_by_its_direction_not_its_glint_nor_its_bounces():
    # A mirror's glint (a Phong lobe of exponent >= MIRROR_GLINT_EXPONENT) would meet the light
    # only where a sample point falls in it (a speckle): area lights are left to the mirror
    # direction, the other lights keep their glint; a broader highlight sees area lights too.
    camera = durer.PerspectiveCamera((0, -3, 1), (0, 3, -2.5), (0, 0, 1), 50.0)
    render = lambda scene, **kw: durer.render(scene, camera, 48, 48, precision="double", **kw).color[..., :3]  # noqa: E731
    plain = render(mirror_floor())
    glint = {"specular": (1, 1, 1), "exponent": durer._core.MIRROR_GLINT_EXPONENT}
    np.testing.assert_array_equal(render(mirror_floor(**glint)), plain)
    assert (render(mirror_floor(specular=(1, 1, 1), exponent=50)) > plain).any(axis=2).sum() > 200
    # Direct light, as a highlight: no bounce needed (max_bounces 0 traces no mirror ray).
    np.testing.assert_array_equal(render(mirror_floor(), max_bounces=0), plain)
    spot = mirror_floor(**glint)
    spot.add_point_light((0.5, 1.0, 2.0), (1, 1, 1))
    assert (render(spot) > plain).any(axis=2).sum() > 5
    facing_up = render(mirror_floor(u=(1.0, 0, 0), v=(0, 0.5, 0)))  # u × v up: its back faces the floor
    np.testing.assert_array_equal(facing_up, 0.0)


def test_without_bounces_or_shadows_its_mirror_rays_search_the_spheres_hierarchy():
    # Camera rays search the spheres through a view; the mirrors' rays toward the light go through
    # the hierarchy, which a render without bounces or shadow rays would otherwise not prepare (they
    # would then test every sphere: the same image, ~3,000 tests a ray). Seen at a slant, spheres
    # hide the light from some mirrors whose floor the camera sees.
    rng = np.random.default_rng(5)
    centres = np.column_stack([rng.uniform(-1, 1, (3000, 2)), rng.uniform(0.2, 1.8, 3000)])
    camera = durer.PerspectiveCamera((0, -3, 1), (0, 3, -2.5), (0, 0, 1), 50.0)
    render = lambda scene, **kw: durer.render(scene, camera, 64, 64, passes=("color", "depth"), **kw)  # noqa: E731
    bare = render(mirror_floor(), max_bounces=0)
    scene = mirror_floor()
    scene.add_spheres(centres, 0.02, material=scene.add_material((0, 0, 0)))
    crowded = render(scene, max_bounces=0)
    floor = crowded.depth == bare.depth  # no sphere before the floor
    shown = floor & (bare.color[..., 0] > 0)
    blocked = shown & (crowded.color[..., 0] == 0)
    assert blocked.sum() > 20 and (shown & ~blocked).sum() > 20
    np.testing.assert_array_equal(crowded.color[shown & ~blocked], bare.color[shown & ~blocked])
    assert crowded.stats["shadow_rays"] == shown.sum()  # one ray from each mirror that faces the light
    # Measured: ~4,400 tests more than the bare floor's; each of the ~100 rays testing every sphere: ~300,000.
    assert crowded.stats["intersection_tests"] - bare.stats["intersection_tests"] < 50_000
    # Its black spheres add nothing that bounces would see.
    np.testing.assert_array_equal(crowded.color, render(scene, max_bounces=4).color)


def test_nearly_perpendicular_edges_are_sampled_as_a_rectangle():
    # Edges from a float32 matrix (Blender's) are perpendicular to ~1e-8: the same samples by solid
    # angle as exact ones (by area, 16 samples at 5 cm: noise of ~100 %).
    global HEIGHT
    saved, HEIGHT = HEIGHT, 0.05
    try:
        images = [durer.render(scene_with(ellipse=ellipse, samples=16, v=v), CAMERA, N, N, precision="double").color
                  for ellipse in (False, True) for v in ((0, -1.0, 0), (2e-8, -1.0, 0))]
    finally:
        HEIGHT = saved
    np.testing.assert_allclose(images[1], images[0], rtol=1e-4)
    np.testing.assert_allclose(images[3], images[2], rtol=1e-4)


def test_it_casts_shadows_in_the_effect_set():
    scene = scene_with(ellipse=False, samples=4, shadows=True)
    assert "shadows" in durer.render(scene, CAMERA, 9, 9).stats["effects"]
    assert "shadows" not in durer.render(scene_with(ellipse=False, samples=4), CAMERA, 9, 9).stats["effects"]


def test_counts_as_a_light_and_survives_pickling():
    import pickle

    scene = scene_with(ellipse=True, samples=8, shadows=True, occluder=((0.0, 0.0, 0.5), 0.2))
    assert scene.light_count == 1
    copy = pickle.loads(pickle.dumps(scene))
    np.testing.assert_array_equal(durer.render(copy, CAMERA, 9, 9).color, durer.render(scene, CAMERA, 9, 9).color)


@pytest.mark.parametrize(
    "kwargs, error, field",
    [
        ({"u": (1, 0, 0), "v": (2, 0, 0)}, ValueError, "u and v"),
        ({"u": (0, 0, 0)}, ValueError, "u and v"),
        ({"u": (math.nan, 0, 0)}, ValueError, "u"),
        ({"v": (0, math.inf, 0)}, ValueError, "v"),
        ({"position": (0, 0, 2e36)}, ValueError, "position"),
        ({"u": (3e36, 0, 0)}, ValueError, "u and v"),
        ({"color": (1, -1, 1)}, ValueError, "color"),
        ({"samples": 0}, ValueError, "samples"),
        ({"samples": durer._core.RENDER_LIMITS["rays_per_hit"] + 1}, ValueError, "samples"),
        ({"samples": 1.5}, TypeError, "samples"),
        ({"ellipse": "yes"}, TypeError, "ellipse"),
        ({"shadows": 1}, TypeError, "shadows"),
        ({"u": (1, 0)}, ValueError, "u"),
    ],
)
def test_bad_input_names_the_field(kwargs, error, field):
    arguments = {"position": (0, 0, 1), "u": (1, 0, 0), "v": (0, 1, 0), "color": (1, 1, 1)} | kwargs
    extra = {k: arguments.pop(k) for k in ("ellipse", "samples", "shadows") if k in arguments}
    scene = durer.Scene()
    with pytest.raises(error, match=field):
        scene.add_area_light(arguments["position"], arguments["u"], arguments["v"], arguments["color"], **extra)
    assert scene.light_count == 0
    durer.Scene().add_area_light((0, 0, 1), (1, 0, 0), (0, 1, 0), (1, 1, 1),
                                 samples=durer._core.RENDER_LIMITS["rays_per_hit"])
