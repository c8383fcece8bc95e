"""Soft shadows of a point or spot light's sphere (radius) and a sun's disc (angle): the light's own
term, times the fraction of its shadow rays — spread uniformly over the cone of directions the light
fills — that nothing blocks; against that fraction computed in numpy, and bit for bit the hard
light's image where nothing is in the way; hard shadows of a light of some size (soft_shadows=False);
highlights spread over the light's size, keeping their light."""

from __future__ import annotations

import math

import numpy as np
import pytest

import durer

BALL = (np.array([0.0, 0.0, 0.6]), 0.25)
CAMERA = durer.OrthographicCamera((0, 0, 5), (0, 0, -1), (0, 1, 0), 2.4)  # the floor z = 0, |x|, |y| <= 1.2
N = 25


def floor_points() -> tuple[np.ndarray, np.ndarray]:
    """The floor point each pixel sees and whether it is the floor (not the ball)."""
    origins, _ = CAMERA.rays(N, N)
    points = origins.copy()
    points[..., 2] = 0
    return points, np.hypot(points[..., 0], points[..., 1]) > BALL[1] * 1.02


def scene_with(add_light) -> durer.Scene:
    scene = durer.Scene()
    white = scene.add_material((1, 1, 1))
    scene.add_plane((0, 0, 1), 0.0, material=white)
    scene.add_spheres([BALL[0]], BALL[1], material=white)
    add_light(scene)
    return scene


def unblocked(origins: np.ndarray, axes: np.ndarray, cos_alpha: np.ndarray, n: int = 20000) -> np.ndarray:
    """The fraction of directions uniform over each cone (axis, half angle α) that miss the ball."""
    rng = np.random.default_rng(5)
    cos_t = 1 - rng.random(n)[None] * (1 - cos_alpha[:, None])
    sin_t = np.sqrt(1 - cos_t**2)
    phi = 2 * np.pi * rng.random(n)[None]
    helper = np.where(np.abs(axes[:, :1]) < 0.9, [[1.0, 0, 0]], [[0, 1.0, 0]])
    t = np.cross(axes, helper)
    t /= np.linalg.norm(t, axis=1, keepdims=True)
    b = np.cross(axes, t)
    w = (sin_t * np.cos(phi))[..., None] * t[:, None] + (sin_t * np.sin(phi))[..., None] * b[:, None] \
        + cos_t[..., None] * axes[:, None]
    oc = origins[:, None] - BALL[0]
    proj = (w * oc).sum(-1)
    disc = proj**2 - ((oc * oc).sum(-1) - BALL[1] ** 2)
    hit = (disc > 0) & (-proj - np.sqrt(np.maximum(disc, 0)) > 0)
    return 1 - hit.mean(axis=1)


@pytest.mark.parametrize("precision", ["double", "float"])
def test_point_light_of_some_radius(precision):
    position, radius = np.array([0.3, -0.2, 1.6]), 0.4
    soft = durer.render(scene_with(lambda s: s.add_point_light(position, (3, 3, 3), attenuation=(0, 0, 1),
                                                                shadows=True, radius=radius, samples=256)),
                        CAMERA, N, N, precision=precision).color[..., 0]
    hard = durer.render(scene_with(lambda s: s.add_point_light(position, (3, 3, 3), attenuation=(0, 0, 1))),
                        CAMERA, N, N, precision=precision).color[..., 0]
    points, floor = floor_points()
    p = points[floor]
    to_centre = position - p
    d = np.linalg.norm(to_centre, axis=1)
    fraction = unblocked(p, to_centre / d[:, None], np.sqrt(1 - (radius / d) ** 2))
    expected = hard[floor] * fraction
    penumbra = (fraction > 0.05) & (fraction < 0.95)
    assert penumbra.sum() >= 30 and (fraction == 1).sum() >= 100
    assert np.abs(soft[floor] - expected).max() < 0.015 * hard.max()  # measured: 256 rays, 3.8e-3 / 4.0e-3
    np.testing.assert_array_equal(soft[floor][fraction == 1], hard[floor][fraction == 1])


def test_sun_of_some_angle():
    direction, angle = np.array([0.3, 0.2, -1.0]), 24.0
    soft = durer.render(scene_with(lambda s: s.add_directional_light(direction, (1, 1, 1), shadows=True,
                                                                      angle_degrees=angle, samples=1024)),
                        CAMERA, N, N, precision="double").color[..., 0]
    hard = durer.render(scene_with(lambda s: s.add_directional_light(direction, (1, 1, 1))), CAMERA, N, N,
                        precision="double").color[..., 0]
    points, floor = floor_points()
    p = points[floor]
    toward = -direction / np.linalg.norm(direction)
    fraction = unblocked(p, np.tile(toward, (len(p), 1)), np.full(len(p), math.cos(math.radians(angle / 2))))
    penumbra = (fraction > 0.05) & (fraction < 0.95)
    assert penumbra.sum() >= 20
    # measured: 7.6e-3 (1.6e-2 at 256 rays, 6.9e-3 at 4096: the reference's own noise)
    assert np.abs(soft[floor] - hard[floor] * fraction).max() < 0.02 * hard.max()
    np.testing.assert_array_equal(soft[floor][fraction == 1], hard[floor][fraction == 1])


def test_spot_light_keeps_its_cone_and_traces_only_inside_it():
    spot = dict(half_angle_degrees=35.0, blend=0.3, attenuation=(0, 0, 1))
    soft = durer.render(scene_with(lambda s: s.add_spot_light((0.2, 0.1, 1.5), (0, 0, -1), (2, 2, 2), shadows=True,
                                                               radius=0.3, samples=64, **spot)), CAMERA, N, N)
    hard = durer.render(scene_with(lambda s: s.add_spot_light((0.2, 0.1, 1.5), (0, 0, -1), (2, 2, 2), **spot)),
                        CAMERA, N, N).color[..., 0]
    points, floor = floor_points()
    lit = hard > 0
    outside = floor & ~lit  # beyond the cone: dark in both
    assert outside.sum() > 20 and not soft.color[..., 0][outside].any()
    # Inside it, where the light's sphere is in sight of the floor past the ball, the hard light's value.
    p = points[floor & lit]
    to_centre = np.array([0.2, 0.1, 1.5]) - p
    d = np.linalg.norm(to_centre, axis=1)
    clear = unblocked(p, to_centre / d[:, None], np.sqrt(1 - (0.3 / d) ** 2)) == 1
    assert clear.sum() > 100
    np.testing.assert_array_equal(soft.color[..., 0][floor & lit][clear], hard[floor & lit][clear])
    # Rays only where the light reaches: 64 for each pixel the cone lights (the ball's included).
    assert soft.stats["shadow_rays"] == 64 * lit.sum()


def test_a_cone_across_the_horizon_keeps_the_light():
    # A sun 3° above the floor's horizon and 60° wide: some pixels' one sample falls below it.
    def image(**kw):
        scene = durer.Scene()
        scene.add_plane((0, 0, 1), 0.0, material=scene.add_material((1, 1, 1)))
        scene.add_directional_light((1, 0, -0.05), (1, 1, 1), shadows=True, **kw)
        return durer.render(scene, CAMERA, N, N, seed=2).color

    np.testing.assert_array_equal(image(angle_degrees=60.0, samples=1), image())  # 45 % black before


def test_radius_zero_or_no_shadows_is_the_hard_light_bit_for_bit():
    def image(**kw):
        return durer.render(scene_with(lambda s: s.add_point_light((0.3, -0.2, 1.6), (3, 3, 3), attenuation=(0, 0, 1),
                                                                    **kw)), CAMERA, N, N).color

    hard = image(shadows=True)
    np.testing.assert_array_equal(image(shadows=True, radius=0.0, samples=64), hard)
    np.testing.assert_array_equal(image(radius=0.4, samples=64), image())  # nothing blocks it: no rays
    assert durer.render(scene_with(lambda s: s.add_point_light((0.3, -0.2, 1.6), (3, 3, 3), shadows=True,
                                                               radius=0.4, samples=8)),
                        CAMERA, N, N).stats["shadow_rays"] == 8 * durer.render(
        scene_with(lambda s: s.add_point_light((0.3, -0.2, 1.6), (3, 3, 3), shadows=True)), CAMERA, N, N
    ).stats["shadow_rays"]


def test_soft_shadows_off_casts_the_hard_lights_shadows():
    def render(**kw):
        return durer.render(scene_with(lambda s: s.add_point_light((0.3, -0.2, 1.6), (3, 3, 3), attenuation=(0, 0, 1),
                                                                    shadows=True, **kw)), CAMERA, N, N)

    hard = render()
    sized = render(radius=0.4, samples=8, soft_shadows=False)
    np.testing.assert_array_equal(sized.color, hard.color)  # diffuse: the size only spreads highlights
    assert sized.stats["shadow_rays"] == hard.stats["shadow_rays"]
    assert render(radius=0.4, samples=8).stats["shadow_rays"] == 8 * hard.stats["shadow_rays"]
    with pytest.raises(TypeError, match="soft_shadows"):
        durer.Scene().add_point_light((0, 0, 1), (1, 1, 1), soft_shadows="no")


@pytest.mark.parametrize("kind", ["point", "sun"])
def test_a_highlight_spreads_over_the_lights_size_keeping_its_light(kind):
    # A glossy floor (a normalised lobe, exponent 1000) seen from above: the highlight of a light of
    # angular radius α spreads (the half vector's variance 1/n + α²/(8 ln 2)) and dims as the
    # normalised lobe's peak does, its light kept (the sum over the floor: measured +1.0 % / +3.3 %,
    # the (n + 8)/8 normalisation being approximate).
    def image(size):
        scene = durer.Scene()
        n = 1000.0
        scene.add_plane((0, 0, 1), 0.0, material=scene.add_material((0, 0, 0), specular=(0.05 * (n + 8) / 8,) * 3,
                                                                     exponent=n))
        if kind == "point":
            scene.add_point_light((0, 0, 3.0), (9, 9, 9), attenuation=(0, 0, 1), radius=size, soft_shadows=False)
        else:
            scene.add_directional_light((0, 0, -1), (1, 1, 1), angle_degrees=math.degrees(2 * size))
        camera = durer.PerspectiveCamera((0, 0, 3.0), (0, 0, -1), (0, 1, 0), 60.0)  # the whole highlight
        return durer.render(scene, camera, 161, 161, precision="double", spp=4).color[..., 0]

    alpha = 0.1  # radians: a 0.3 m sphere 3 m off, or a sun 11.5° across
    sharp, spread = image(0.0), image(0.3 if kind == "point" else alpha)
    assert spread.sum() == pytest.approx(sharp.sum(), rel=0.05)
    n_spread = 1000.0 / (1 + 1000.0 * alpha**2 / (8 * math.log(2)))
    assert spread.max() / sharp.max() == pytest.approx((n_spread + 8) / 1008, rel=0.05)
    assert (spread > spread.max() / 2).sum() > 2 * (sharp > sharp.max() / 2).sum()  # measured: 2.7x / 2.8x


def test_a_point_inside_the_lights_sphere_is_lit_as_by_the_hard_light():
    # The floor reaches into a big light's sphere: from there no shadow ray can be blocked.
    def image(**kw):
        return durer.render(scene_with(lambda s: s.add_point_light((0.9, 0.9, 0.2), (1, 1, 1), shadows=True, **kw)),
                            CAMERA, N, N).color[..., 0]

    points, _ = floor_points()
    inside = np.linalg.norm(points - np.array([0.9, 0.9, 0.2]), axis=-1) < 0.5
    assert inside.sum() >= 10
    np.testing.assert_array_equal(image(radius=0.5, samples=16)[inside], image()[inside])


def test_a_render_with_soft_shadows_prepares_the_spheres_once():
    scene = durer.Scene()
    scene.add_spheres(np.random.default_rng(1).uniform(-1, 1, (2000, 3)), 0.02)
    scene.add_directional_light((0.3, 0.2, -1.0), (1, 1, 1), shadows=True, angle_degrees=5.0, samples=4)
    durer.render(scene, CAMERA, N, N)
    assert scene.hierarchy_counts["built"] == 1  # not first without the hierarchy, then with it


@pytest.mark.parametrize(
    "add, error, field",
    [
        (lambda s: s.add_point_light((0, 0, 1), (1, 1, 1), radius=-0.1), ValueError, "radius"),
        (lambda s: s.add_point_light((0, 0, 1), (1, 1, 1), radius=math.inf), ValueError, "radius"),
        (lambda s: s.add_point_light((0, 0, 1), (1, 1, 1), radius=2e36), ValueError, "radius"),
        (lambda s: s.add_point_light((0, 0, 1), (1, 1, 1), radius="big"), TypeError, "radius"),
        (lambda s: s.add_point_light((0, 0, 1), (1, 1, 1), samples=0), ValueError, "samples"),
        (lambda s: s.add_spot_light((0, 0, 1), (0, 0, -1), (1, 1, 1), half_angle_degrees=20, radius=-1),
         ValueError, "radius"),
        (lambda s: s.add_directional_light((0, 0, -1), (1, 1, 1), angle_degrees=180.0), ValueError, "angle_degrees"),
        (lambda s: s.add_directional_light((0, 0, -1), (1, 1, 1), angle_degrees=-1.0), ValueError, "angle_degrees"),
        (lambda s: s.add_directional_light((0, 0, -1), (1, 1, 1), angle_degrees=math.nan), ValueError,
         "angle_degrees"),
        (lambda s: s.add_directional_light((0, 0, -1), (1, 1, 1), samples=1 << 17), ValueError, "samples"),
    ],
)
def test_bad_input_names_the_field(add, error, field):
    scene = durer.Scene()
    with pytest.raises(error, match=field):
        add(scene)
    assert scene.light_count == 0
