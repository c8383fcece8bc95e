"""Effects on demand (issue 6): Phong specular, shadows, mirror reflection, refraction with total
internal reflection, bounce limits and back-face shading, against hand-computed pixels and exact
ray counters. The expected values follow the 6.837 ray-tracing assignments:

    lit:  c = emission + ambient·kd + Σ_unblocked [max(N·L, 0)·Lc·kd + (N·L > 0) ks·Lc·max(N·H, 0)^exponent]
              + reflective·trace(R) + transparent·trace(T)
    flat: c = kd + emission + reflective·trace(R) + transparent·trace(T)
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import durer
from helpers.core import camera_tests

BACKGROUND = np.array([0.1, 0.2, 0.3])
COUNTERS = (
    "shadow_rays", "reflection_rays", "refraction_rays", "ao_rays", "shading_evaluations",
    "bounces_cut_by_depth", "bounces_cut_by_weight", "total_internal_reflections",
)


# --- helpers ------------------------------------------------------------------------------------
def camera_hits(scene: durer.Scene, camera, width: int, height: int):
    """The pixel-centre rays (flattened, unit directions) and what each hits first."""
    origins, directions = camera.rays(width, height)
    o, d = origins.reshape(-1, 3), directions.reshape(-1, 3)
    return o, d, durer.cast(scene, o, d, t_min=camera.t_min, t_max=camera.t_max)


def unit(v) -> np.ndarray:
    v = np.asarray(v, float)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.sum(a * b, axis=-1)


def silhouette_margin(o: np.ndarray, d: np.ndarray, center, radius: float) -> np.ndarray:
    """|distance from the sphere's centre to the line o + s·d (unit d)| − radius|: near 0 the ray grazes."""
    f = o - np.asarray(center, float)
    b = dot(f, d)
    return np.abs(np.sqrt(np.maximum(dot(f, f) - b * b, 0)) - radius)


def refract(d: np.ndarray, n: np.ndarray, eta) -> tuple[np.ndarray, np.ndarray]:
    """T = η·d + (η·cos_i − √k)·n, k = 1 − η²(1 − cos_i²), for unit d and n facing the incoming ray."""
    eta = np.asarray(eta, float)
    cos_i = -dot(d, n)
    k = 1 - eta**2 * (1 - cos_i**2)
    t = eta[..., None] * d + (eta * cos_i - np.sqrt(np.maximum(k, 0)))[..., None] * n
    return t, k


def phong(points, normals, view, kd, ks, exponent, lights, ambient, emission=(0, 0, 0)) -> np.ndarray:
    """The lit colour at points; lights: (kind, vector, colour, attenuation) with kind "directional"
    (vector: the direction the light travels) or "point" (vector: its position); no shadows."""
    kd, ks = np.asarray(kd, float), np.asarray(ks, float)
    c = np.asarray(emission, float) + np.asarray(ambient, float) * kd + np.zeros_like(points)
    for kind, vector, color, attenuation in lights:
        if kind == "directional":
            to_light = np.broadcast_to(-unit(vector), points.shape)
            arriving = np.broadcast_to(np.asarray(color, float), points.shape)
        else:
            offset = np.asarray(vector, float) - points
            distance = np.linalg.norm(offset, axis=-1)
            to_light = offset / distance[:, None]
            c0, c1, c2 = attenuation
            arriving = np.asarray(color, float) / (c0 + c1 * distance + c2 * distance**2)[:, None]
        cosine = dot(normals, to_light)
        half = unit(to_light + view)
        highlight = np.where(cosine > 0, np.maximum(dot(normals, half), 0) ** exponent, 0.0)
        c += np.maximum(cosine, 0)[:, None] * arriving * kd + highlight[:, None] * arriving * ks
    return c


def tolerance(precision: str) -> dict:
    return {"rtol": 1e-5, "atol": 1e-7} if precision == "double" else {"rtol": 3e-5, "atol": 1e-6}


def assert_no_secondary_rays(stats: dict) -> None:
    for name in COUNTERS[1:]:
        if name != "shading_evaluations":
            assert stats[name] == 0, name


# --- counters -----------------------------------------------------------------------------------
def sphere_and_floor(reflective=(0, 0, 0), specular=(0, 0, 0)) -> durer.Scene:
    """A unit sphere at the origin (object 0, with the given reflective/specular colour) on a plain
    grey floor y = −1 (object 1)."""
    scene = durer.Scene()
    scene.background = BACKGROUND
    ball = scene.add_material((0.25, 0.5, 0.75), reflective=reflective, specular=specular, exponent=10.0)
    floor = scene.add_material((0.5, 0.5, 0.5))
    scene.add_spheres([[0, 0, 0]], [1.0], material=ball)
    scene.add_plane((0, 1, 0), -1.0, material=floor)
    return scene


SIDE_CAMERA = durer.PerspectiveCamera((0, 1, 5), (0, -0.3, -1), (0, 1, 0), 45.0)


def test_no_lights_means_no_shadow_rays_and_no_shading():
    scene = sphere_and_floor()
    result = durer.render(scene, SIDE_CAMERA, 32, 32)
    stats = result.stats
    assert stats["effects"] == ("flat",)
    assert stats["rays"] == 32 * 32
    for name in COUNTERS:
        assert stats[name] == 0, name
    assert stats["intersection_tests"] == camera_tests(scene, SIDE_CAMERA, 32, 32)
    # Every ray tests the floor; the rows the ball's footprint covers test the ball too.
    assert stats["rays"] < stats["intersection_tests"] < stats["rays"] * 2


def test_light_without_shadows_adds_no_shadow_rays():
    scene = sphere_and_floor()
    scene.add_directional_light((1, -2, -1), (1, 1, 1), shadows=False)
    _, _, hit = camera_hits(scene, SIDE_CAMERA, 32, 32)
    hits = int((hit.object_id >= 0).sum())
    assert 200 < hits < 32 * 32
    stats = durer.render(scene, SIDE_CAMERA, 32, 32).stats
    assert stats["effects"] == ("diffuse",)
    assert stats["shadow_rays"] == 0
    assert stats["shading_evaluations"] == hits  # every lit camera hit, nothing else
    assert_no_secondary_rays(stats)
    assert stats["intersection_tests"] == camera_tests(scene, SIDE_CAMERA, 32, 32)
    # The same light casting shadows: one shadow ray per hit that faces it.
    shadowed = sphere_and_floor()
    to_light = -unit([1, -2, -1])
    shadowed.add_directional_light((1, -2, -1), (1, 1, 1), shadows=True)
    stats = durer.render(shadowed, SIDE_CAMERA, 32, 32).stats
    assert stats["effects"] == ("diffuse", "shadows")
    facing = (hit.object_id >= 0) & (hit.normal @ to_light > 0)
    assert stats["shadow_rays"] == facing.sum()
    assert stats["shading_evaluations"] == hits
    assert stats["intersection_tests"] == camera_tests(shadowed, SIDE_CAMERA, 32, 32) + stats["shadow_rays"] * 2


def test_flat_shading_mode_ignores_lights_and_specular():
    scene = sphere_and_floor(specular=(1, 1, 1))
    scene.add_directional_light((1, -2, -1), (1, 1, 1), shadows=True)
    scene.shading = "flat"
    result = durer.render(scene, SIDE_CAMERA, 16, 16)
    assert result.stats["effects"] == ("flat",)
    for name in COUNTERS:
        assert result.stats[name] == 0, name


@pytest.mark.parametrize("spp", [1, 4])
def test_reflection_rays_come_only_from_the_reflective_sphere(spp):
    scene = sphere_and_floor(reflective=(0.5, 0.25, 0.125))
    if spp == 1:
        _, _, hit = camera_hits(scene, SIDE_CAMERA, 32, 32)
        on_sphere = int((hit.object_id == 0).sum())
        camera = SIDE_CAMERA
        assert 100 < on_sphere < 32 * 32 - 100
    else:  # jittered samples: a view that sees nothing but the sphere, so every sample hits it
        camera = durer.OrthographicCamera((0, 0, 5), (0, 0, -1), (0, 1, 0), 1.0, t_min=0.0)
        on_sphere = 32 * 32
    stats = durer.render(scene, camera, 32, 32, spp=spp, max_bounces=1).stats
    assert stats["effects"] == ("flat", "reflection")
    assert stats["rays"] == 32 * 32 * spp
    assert stats["reflection_rays"] == on_sphere * spp
    for name in ("shadow_rays", "refraction_rays", "shading_evaluations", "bounces_cut_by_depth",
                 "bounces_cut_by_weight", "total_internal_reflections"):
        assert stats[name] == 0, name  # the sphere's reflections hit the plain floor or nothing
    assert stats["intersection_tests"] == camera_tests(scene, camera, 32, 32, spp=spp) + stats["reflection_rays"] * 2


def test_no_bounces_allowed_simulates_no_reflection():
    # max_bounces 0 leaves reflection out of the effect set: nothing is traced, and nothing is
    # counted as cut either (the bounce stage does not run at all: it costs nothing).
    scene = sphere_and_floor(reflective=(0.5, 0.5, 0.5))
    _, _, hit = camera_hits(scene, SIDE_CAMERA, 32, 32)
    assert int((hit.object_id == 0).sum()) > 50  # the reflective sphere is in view
    stats = durer.render(scene, SIDE_CAMERA, 32, 32, max_bounces=0).stats
    assert stats["effects"] == ("flat",)
    assert stats["reflection_rays"] == 0
    assert stats["bounces_cut_by_depth"] == 0
    assert stats["bounces_cut_by_weight"] == 0
    assert stats["intersection_tests"] == camera_tests(scene, SIDE_CAMERA, 32, 32)


def test_a_faint_mirror_is_cut_by_weight():
    scene = sphere_and_floor(reflective=(2**-8, 2**-9, 0.0))  # weight 2^-8, exact in float and double
    _, _, hit = camera_hits(scene, SIDE_CAMERA, 32, 32)
    on_sphere = int((hit.object_id == 0).sum())
    result = durer.render(scene, SIDE_CAMERA, 32, 32, min_weight=0.01)
    stats = result.stats
    assert stats["effects"] == ("flat", "reflection")
    assert stats["reflection_rays"] == 0
    assert stats["bounces_cut_by_weight"] == on_sphere
    assert stats["bounces_cut_by_depth"] == 0
    # Nothing was added for the cut rays: the sphere shows its flat colour.
    sphere_pixels = (hit.object_id == 0).reshape(32, 32)
    np.testing.assert_allclose(result.color[sphere_pixels, :3], np.broadcast_to([0.25, 0.5, 0.75], (on_sphere, 3)),
                               rtol=1e-6)
    # With the threshold at the weight itself, the rays are spawned (weight >= min_weight).
    stats = durer.render(scene, SIDE_CAMERA, 32, 32, min_weight=2**-8).stats
    assert stats["reflection_rays"] == on_sphere
    assert stats["bounces_cut_by_weight"] == 0


# Two facing mirrors, z = 0 (object 0, seen first) and z = 10 (object 1): a camera ray bounces
# between them until depth or weight stops it. Both mirrors' weights are 0.5 per bounce.
KD_A, KD_B = np.array([1.0, 0.0, 0.5]), np.array([0.0, 1.0, 0.25])
REFLECT_A, REFLECT_B = np.array([0.5, 0.25, 0.5]), np.array([0.5, 0.5, 0.25])


def two_mirrors() -> durer.Scene:
    scene = durer.Scene()
    scene.background = BACKGROUND
    a = scene.add_material(KD_A, reflective=REFLECT_A)
    b = scene.add_material(KD_B, reflective=REFLECT_B)
    scene.add_plane((0, 0, 1), 0.0, material=a)
    scene.add_plane((0, 0, 1), 10.0, material=b)  # its normal points away from the first: turned to face the ray
    return scene


def mirror_chain(bounces: int) -> np.ndarray:
    """The colour of a camera ray meeting mirror A after `bounces` reflections were spawned."""
    colours, reflectives = (KD_A, KD_B), (REFLECT_A, REFLECT_B)
    c = colours[bounces % 2].copy()
    for i in range(bounces - 1, -1, -1):
        c = colours[i % 2] + reflectives[i % 2] * c
    return c


@pytest.mark.parametrize(
    ("max_bounces", "min_weight", "spawned", "cut_by"),
    [
        (3, 0.01, 3, "depth"),   # weights 0.5, 0.25, 0.125; the 4th bounce is too deep
        (0, 0.01, 0, "depth"),
        (10, 0.3, 1, "weight"),  # 0.25 < 0.3
        (10, 0.25, 2, "weight"),  # 0.25 >= 0.25 is spawned, 0.125 is not
        (10, 0.0, 10, "depth"),
    ],
)
def test_bounce_depth_and_weight_between_two_mirrors(max_bounces, min_weight, spawned, cut_by):
    camera = durer.OrthographicCamera((0, 0, 5), (0, 0, -1), (0, 1, 0), 2.0, t_min=0.0)
    result = durer.render(two_mirrors(), camera, 8, 8, max_bounces=max_bounces, min_weight=min_weight)
    stats = result.stats
    n = 64
    assert stats["reflection_rays"] == spawned * n
    # max_bounces 0 simulates no reflection at all, so nothing is counted as cut by depth there.
    assert stats["bounces_cut_by_depth"] == (n if cut_by == "depth" and max_bounces > 0 else 0)
    assert stats["bounces_cut_by_weight"] == (n if cut_by == "weight" else 0)
    assert stats["shading_evaluations"] == 0
    assert stats["intersection_tests"] == (stats["rays"] + stats["reflection_rays"]) * 2
    np.testing.assert_allclose(result.color[..., :3], np.broadcast_to(mirror_chain(spawned), (8, 8, 3)), rtol=1e-6)
    np.testing.assert_array_equal(result.color[..., 3], 1)


# --- Phong and shadows --------------------------------------------------------------------------
PHONG_LIGHTS = [
    ("directional", (-1.0, -0.5, -1.0), (1.0, 0.9, 0.8), None),
    ("point", (-2.0, 1.0, 1.5), (0.6, 0.7, 0.8), (1.0, 0.1, 0.05)),
]


@pytest.mark.parametrize("exponent", [12.5, 64.0])
def test_phong_highlight_on_a_sphere(precision, exponent):
    kd, ks, emission, ambient = (0.25, 0.5, 0.75), (0.5, 0.4, 0.3), (0.01, 0.02, 0.03), (0.1, 0.05, 0.2)
    scene = durer.Scene()
    scene.background = BACKGROUND
    scene.ambient = ambient
    scene.add_spheres([[0, 0, 0]], [1.0], material=scene.add_material(kd, emission=emission, specular=ks,
                                                                       exponent=exponent))
    scene.add_directional_light(PHONG_LIGHTS[0][1], PHONG_LIGHTS[0][2])
    scene.add_point_light(PHONG_LIGHTS[1][1], PHONG_LIGHTS[1][2], attenuation=PHONG_LIGHTS[1][3])
    camera = durer.PerspectiveCamera((0, 0, 4), (0, 0, -1), (0, 1, 0), 35.0)
    result = durer.render(scene, camera, 32, 32, precision=precision)
    assert result.stats["effects"] == ("diffuse", "specular")
    o, d, hit = camera_hits(scene, camera, 32, 32)
    on = hit.object_id == 0
    assert result.stats["shading_evaluations"] == on.sum()
    assert result.stats["shadow_rays"] == 0
    points = o[on] + hit.t[on, None] * d[on]
    normals = unit(points)
    expected = phong(points, normals, -d[on], kd, ks, exponent, PHONG_LIGHTS, ambient, emission)
    clear = silhouette_margin(o[on], d[on], (0, 0, 0), 1.0) > 1e-4
    got = result.color[..., :3].reshape(-1, 3)[on]
    np.testing.assert_allclose(got[clear], expected[clear], **tolerance(precision))
    # The test means something: a highlight, and points facing away from a light whose half vector still
    # faces them (no highlight there).
    highlight = np.max(got - phong(points, normals, -d[on], kd, (0, 0, 0), 1.0, PHONG_LIGHTS, ambient, emission))
    assert highlight > 0.1
    to_light = -unit(PHONG_LIGHTS[0][1])
    half = unit(to_light + (-d[on]))
    assert ((normals @ to_light <= 0) & (dot(normals, half) > 0)).sum() > 5
    np.testing.assert_allclose(result.color.reshape(-1, 4)[~on], np.broadcast_to([*BACKGROUND, 1], ((~on).sum(), 4)),
                               rtol=1e-6)


def test_shadowed_points_lose_diffuse_and_specular(precision):
    # A shiny floor y = 0 (object 1) under a ball at (0, 1, 0) of radius 0.5 (object 0); one light with shadows.
    kd_floor, ks_floor, exponent = np.array([0.4, 0.5, 0.6]), np.array([0.3, 0.3, 0.3]), 8.0
    kd_ball, ambient, light_colour = np.array([1.0, 0.75, 0.5]), np.array([0.2, 0.2, 0.2]), np.array([1.0, 0.9, 0.8])
    direction = np.array([-1.0, -2.0, -0.5])
    scene = durer.Scene()
    scene.ambient = ambient
    scene.add_spheres([[0, 1, 0]], [0.5], material=scene.add_material(kd_ball))
    scene.add_plane((0, 1, 0), 0.0, material=scene.add_material(kd_floor, specular=ks_floor, exponent=exponent))
    scene.add_directional_light(direction, light_colour, shadows=True)
    camera = durer.PerspectiveCamera((0, 3, 5), (0, -0.6, -1), (0, 1, 0), 40.0)
    result = durer.render(scene, camera, 32, 32, precision=precision)
    assert result.stats["effects"] == ("diffuse", "shadows", "specular")
    o, d, hit = camera_hits(scene, camera, 32, 32)
    to_light = -unit(direction)
    assert result.stats["shadow_rays"] == ((hit.object_id >= 0) & (hit.normal @ to_light > 0)).sum()
    assert result.stats["shading_evaluations"] == (hit.object_id >= 0).sum()
    got = result.color[..., :3].reshape(-1, 3)
    floor = hit.object_id == 1
    points = o[floor] + hit.t[floor, None] * d[floor]
    points[:, 1] = 0
    lights = [("directional", direction, light_colour, None)]
    lit = phong(points, np.array([[0.0, 1, 0]]), -d[floor], kd_floor, ks_floor, exponent, lights, ambient)
    f = points - np.array([0, 1, 0])
    b = f @ to_light
    blocked = (b < 0) & (np.sum(f * f, -1) - b * b < 0.25)
    clear = np.abs(np.sqrt(np.maximum(np.sum(f * f, -1) - b * b, 0)) - 0.5) > 1e-4
    expected = np.where(blocked[:, None], ambient * kd_floor, lit)
    assert (blocked & clear).sum() > 10 and (~blocked & clear).sum() > 200
    np.testing.assert_allclose(got[floor][clear], expected[clear], **tolerance(precision))
    # The ball itself: Lambert only (its material has no specular), never shadowed by the floor below it.
    ball = (hit.object_id == 0) & (silhouette_margin(o, d, (0, 1, 0), 0.5) > 1e-4)
    points = o[ball] + hit.t[ball, None] * d[ball]
    expected = phong(points, unit(points - np.array([0, 1, 0])), -d[ball], kd_ball, (0, 0, 0), 1.0, lights, ambient)
    np.testing.assert_allclose(got[ball], expected, **tolerance(precision))


# --- mirrors ------------------------------------------------------------------------------------
def mirror_floor_scene(lit: bool) -> durer.Scene:
    """A black mirror floor y = 0 (object 0) and a red ball at (0, 1, 0), radius 0.75 (object 1)."""
    scene = durer.Scene()
    scene.background = BACKGROUND
    scene.add_plane((0, 1, 0), 0.0, material=scene.add_material((0, 0, 0), reflective=(0.5, 0.75, 0.875)))
    scene.add_spheres([[0, 1, 0]], [0.75], material=scene.add_material((1.0, 0.25, 0.125)))
    if lit:
        scene.ambient = (0.1, 0.1, 0.1)
        scene.add_directional_light((1, -1, -2), (0.9, 0.8, 1.0))
    return scene


@pytest.mark.parametrize("lit", [False, True])
def test_mirror_floor_shows_the_ball_and_the_background(precision, lit):
    scene = mirror_floor_scene(lit)
    camera = durer.PerspectiveCamera((0, 1.5, 5), (0, -0.35, -1), (0, 1, 0), 40.0)
    result = durer.render(scene, camera, 32, 32, precision=precision)
    o, d, hit = camera_hits(scene, camera, 32, 32)
    kd_ball, reflective = np.array([1.0, 0.25, 0.125]), np.array([0.5, 0.75, 0.875])
    lights = [("directional", (1, -1, -2), (0.9, 0.8, 1.0), None)] if lit else []

    def ball_colour(points, view):
        if not lit:
            return np.broadcast_to(kd_ball, points.shape)
        return phong(points, unit(points - np.array([0, 1, 0])), view, kd_ball, (0, 0, 0), 1.0, lights, (0.1,) * 3)

    expected = np.broadcast_to(BACKGROUND, d.shape).copy()
    clear = silhouette_margin(o, d, (0, 1, 0), 0.75) > 1e-4
    ball = hit.object_id == 1
    expected[ball] = ball_colour(o[ball] + hit.t[ball, None] * d[ball], -d[ball])
    floor = hit.object_id == 0
    points = o[floor] + (-o[floor, 1] / d[floor, 1])[:, None] * d[floor]
    points[:, 1] = 0
    mirrored = d[floor] * np.array([1, -1, 1])  # R = d − 2(d·n)n, n = (0, 1, 0)
    seen = durer.cast(scene, points, mirrored, t_min=1e-9)
    assert (seen.object_id != 0).all()
    sees_ball = seen.object_id == 1
    reflected = np.broadcast_to(BACKGROUND, mirrored.shape).copy()
    reflected[sees_ball] = ball_colour(points[sees_ball] + seen.t[sees_ball, None] * mirrored[sees_ball],
                                       -mirrored[sees_ball])
    expected[floor] = reflective * reflected
    clear[floor] &= silhouette_margin(points, mirrored, (0, 1, 0), 0.75) > 1e-4
    assert sees_ball.sum() > 30 and (~sees_ball).sum() > 30 and ball.sum() > 30
    got = result.color[..., :3].reshape(-1, 3)
    np.testing.assert_allclose(got[clear], expected[clear], **tolerance(precision))
    stats = result.stats
    assert stats["effects"] == (("diffuse",) if lit else ("flat",)) + ("reflection",)
    assert stats["reflection_rays"] == floor.sum()
    assert stats["shading_evaluations"] == (((hit.object_id >= 0).sum() + sees_ball.sum()) if lit else 0)
    assert stats["intersection_tests"] == (camera_tests(scene, camera, 32, 32, precision=precision)
                                           + stats["reflection_rays"] * 2)


# --- refraction ---------------------------------------------------------------------------------
GLASS_TRANSPARENT = np.array([0.9, 0.8, 0.7])
PATCH_KD = np.array([0.2, 0.5, 1.0])


def glass_ball_scene(lit: bool) -> durer.Scene:
    """A clear glass ball (kd 0, ior 1.5) at the origin (object 0) before a backdrop patch on z = −4,
    x in [−0.5, 3], y in [−3, 3] (object 1)."""
    scene = durer.Scene()
    scene.background = BACKGROUND
    glass = scene.add_material((0, 0, 0), transparent=GLASS_TRANSPARENT, ior=1.5)
    scene.add_spheres([[0, 0, 0]], [1.0], material=glass)
    patch = scene.add_material(PATCH_KD)
    scene.add_plane((0, 0, 1), -4.0, material=patch, bounds=((-0.5, -3, -4), (3.5, 0, 0), (0, 6, 0)))
    if lit:
        scene.ambient = (0.25, 0.25, 0.25)
        scene.add_directional_light((0, -1, -1), (0.5, 0.5, 0.5))
    return scene


@pytest.mark.parametrize("lit", [False, True])
def test_glass_ball_refracts_twice_and_the_axis_ray_goes_straight(lit):
    scene = glass_ball_scene(lit)
    camera = durer.OrthographicCamera((0, 0, 5), (0, 0, -1), (0, 1, 0), 1.2, t_min=0.0)
    result = durer.render(scene, camera, 33, 33)
    o, d, hit = camera_hits(scene, camera, 33, 33)
    assert (hit.object_id == 0).all()
    patch_colour = PATCH_KD * (0.25 + 0.5 * math.sqrt(0.5)) if lit else PATCH_KD  # N·L = (0, 0, 1)·(0, 1, 1)/√2
    # Entering: n = N (outward), η = 1/1.5.
    p1 = o + hit.t[:, None] * d
    t1, k1 = refract(d, unit(p1), 1 / 1.5)
    # Leaving at the far side: n = −N, η = 1.5.
    b = dot(p1, t1)
    p2 = p1 + (-b + np.sqrt(b * b - (dot(p1, p1) - 1)))[:, None] * t1
    t2, k2 = refract(t1, -unit(p2), 1.5)
    assert (k1 > 0.1).all() and (k2 > 0.1).all() and (t2[:, 2] < 0).all()
    landing = p2 + ((-4 - p2[:, 2]) / t2[:, 2])[:, None] * t2
    x, y = landing[:, 0], landing[:, 1]
    on_patch = (x >= -0.5) & (x <= 3) & (np.abs(y) <= 3)
    clear = (np.abs(x + 0.5) > 1e-6) & (np.abs(x - 3) > 1e-6) & (np.abs(np.abs(y) - 3) > 1e-6)
    assert on_patch.sum() > 100 and (~on_patch).sum() > 100  # the ball lens flips the image: half sees the patch
    expected = GLASS_TRANSPARENT**2 * np.where(on_patch[:, None], patch_colour, BACKGROUND)
    got = result.color[..., :3].reshape(-1, 3)
    np.testing.assert_allclose(got[clear], expected[clear], rtol=1e-5)
    # The centre pixel's ray is the axis: undeviated through both surfaces onto the patch.
    np.testing.assert_array_equal(camera.rays(33, 33)[0][16, 16], [0, 0, 5])
    np.testing.assert_allclose(result.color[16, 16, :3], GLASS_TRANSPARENT**2 * patch_colour, rtol=1e-6)
    stats = result.stats
    assert stats["effects"] == (("diffuse",) if lit else ("flat",)) + ("refraction",)
    assert stats["refraction_rays"] == 2 * 33 * 33
    assert stats["total_internal_reflections"] == 0
    assert stats["reflection_rays"] == 0
    assert stats["bounces_cut_by_depth"] == stats["bounces_cut_by_weight"] == 0
    assert stats["shading_evaluations"] == ((2 * 33 * 33 + on_patch.sum()) if lit else 0)
    assert stats["intersection_tests"] == (stats["rays"] + stats["refraction_rays"]) * 2


def test_glass_ball_one_bounce_allowed():
    stats = durer.render(glass_ball_scene(False), durer.OrthographicCamera((0, 0, 5), (0, 0, -1), (0, 1, 0), 1.2,
                                                                           t_min=0.0), 16, 16, max_bounces=1).stats
    assert stats["refraction_rays"] == 256
    assert stats["bounces_cut_by_depth"] == 256  # the exit refraction would be the second bounce


def test_total_internal_reflection_under_a_glass_surface():
    # Below the glass half-space z > 0 (a transparent plane z = 0, normal +z, object 0), a camera looks up.
    # Rays steeper than the critical angle asin(1/1.5) leave into the air and see a ceiling patch on z = 3
    # with y >= 0 (object 1) or the background; the others are reflected totally onto a floor patch on
    # z = −3 with x >= 0 (object 2) or the background.
    transparent, ceiling, floor = np.array([0.5, 0.75, 1.0]), np.array([0.25, 1.0, 0.5]), np.array([1.0, 0.5, 0.25])
    scene = durer.Scene()
    scene.background = BACKGROUND
    scene.add_plane((0, 0, 1), 0.0, material=scene.add_material((0, 0, 0), transparent=transparent, ior=1.5))
    scene.add_plane((0, 0, -1), -3.0, material=scene.add_material(ceiling),
                    bounds=((-50, 0, 3), (100, 0, 0), (0, 50, 0)))
    scene.add_plane((0, 0, 1), -3.0, material=scene.add_material(floor), bounds=((0, -50, -3), (50, 0, 0), (0, 100, 0)))
    camera = durer.PerspectiveCamera((0, 0, -1), (0, 0, 1), (0, 1, 0), 120.0)
    result = durer.render(scene, camera, 32, 32)
    o, d, hit = camera_hits(scene, camera, 32, 32)
    assert (hit.object_id == 0).all()
    points = o + hit.t[:, None] * d
    points[:, 2] = 0
    # Leaving the glass (d·N > 0): η = 1.5, n = −N.
    n = np.array([[0.0, 0, -1]])
    refracted, k = refract(d, n, 1.5)
    total = k < 0
    assert np.abs(k).min() > 1e-6  # no ray within rounding of the critical angle
    assert total.sum() > 100 and (~total).sum() > 100
    reflected = d * np.array([1, 1, -1])
    away = np.where(total[:, None], reflected, refracted)
    landing = points + ((np.where(total, -3.0, 3.0) - points[:, 2]) / away[:, 2])[:, None] * away
    x, y = landing[:, 0], landing[:, 1]
    on_ceiling = ~total & (y >= 0) & (y <= 50) & (np.abs(x) <= 50)
    on_floor = total & (x >= 0) & (x <= 50) & (np.abs(y) <= 50)
    edge = np.where(total, np.minimum(np.abs(x), np.abs(np.abs(y) - 50)), np.minimum(np.abs(y), np.abs(np.abs(x) - 50)))
    clear = (edge > 1e-6) & (np.abs(x - 50) > 1e-6) & (np.abs(y - 50) > 1e-6)
    assert on_ceiling.sum() > 20 and on_floor.sum() > 20
    assert (~on_ceiling & ~total).sum() > 20 and (~on_floor & total).sum() > 20
    expected = transparent * np.where(on_ceiling[:, None], ceiling, np.where(on_floor[:, None], floor, BACKGROUND))
    got = result.color[..., :3].reshape(-1, 3)
    np.testing.assert_allclose(got[clear], expected[clear], rtol=1e-5)
    stats = result.stats
    assert stats["effects"] == ("flat", "refraction")
    assert stats["refraction_rays"] == 32 * 32  # the totally reflected ones included
    assert stats["total_internal_reflections"] == total.sum()
    assert stats["reflection_rays"] == 0
    assert stats["bounces_cut_by_depth"] == stats["bounces_cut_by_weight"] == 0


@pytest.mark.parametrize("max_bounces", [1, 3])
def test_total_internal_reflection_inside_a_glass_ball(max_bounces):
    # The camera sits inside a glass ball and looks at its far side along −z: a ray at distance ρ from
    # the axis meets the surface at sin(incidence) = ρ, beyond the critical angle for ρ > 2/3. Those
    # rays are trapped: every later hit is at the same angle, until the depth limit.
    kd, transparent, backdrop = np.array([0.125, 0.25, 0.0625]), np.array([0.5, 0.5, 0.5]), np.array([1.0, 0.5, 0.25])
    scene = durer.Scene()
    scene.add_spheres([[0, 0, 0]], [1.0], material=scene.add_material(kd, transparent=transparent, ior=1.5))
    scene.add_plane((0, 0, 1), -3.0, material=scene.add_material(backdrop))
    camera = durer.OrthographicCamera((0, 0, 0), (0, 0, -1), (0, 1, 0), 1.3, t_min=0.0)
    result = durer.render(scene, camera, 24, 24, max_bounces=max_bounces)
    o, _, hit = camera_hits(scene, camera, 24, 24)
    assert (hit.object_id == 0).all()
    rho2 = o[:, 0] ** 2 + o[:, 1] ** 2
    k = 1 - 2.25 * rho2
    assert np.abs(k).min() > 1e-6
    total = k < 0
    n_total = int(total.sum())
    assert 50 < n_total < 24 * 24 - 50
    trapped = kd * sum(transparent**i for i in range(max_bounces + 1))  # kd + t·(kd + t·(… kd + 0))
    expected = np.where(total[:, None], trapped, kd + transparent * backdrop)
    np.testing.assert_allclose(result.color[..., :3].reshape(-1, 3), expected, rtol=1e-6)
    stats = result.stats
    assert stats["effects"] == ("flat", "refraction")
    assert stats["total_internal_reflections"] == n_total * max_bounces
    assert stats["refraction_rays"] == 24 * 24 + n_total * (max_bounces - 1)
    assert stats["bounces_cut_by_depth"] == n_total
    assert stats["reflection_rays"] == 0


def axis_tree(max_bounces: int, min_weight: float, reflective: np.ndarray, transparent: np.ndarray):
    """The colour and counters of the ray along the axis of `glass_ball_scene` (kd 0, both a mirror and
    transparent), by following every child: on the axis every ray meets the ball head on, reflected
    rays come straight back, transmitted rays go straight on (no total internal reflection)."""
    counts = dict.fromkeys(("reflection_rays", "refraction_rays", "bounces_cut_by_depth", "bounces_cut_by_weight"), 0)

    def spawn(depth, weight, factor, kind, follow):
        w = weight * factor.max()
        if depth + 1 > max_bounces:
            counts["bounces_cut_by_depth"] += 1
            return np.zeros(3)
        if w < min_weight:
            counts["bounces_cut_by_weight"] += 1
            return np.zeros(3)
        counts[kind] += 1
        return factor * follow(depth + 1, w)

    def hit(depth, weight, inside, downward):
        """A ray meeting the ball (from inside or not) travelling down (−z) or up the axis."""
        def reflected(d, w):
            return hit(d, w, True, not downward) if inside else BACKGROUND  # outside: back up, to the sky

        def transmitted(d, w):
            if inside:  # out of the ball: onto the patch below, or up into the background
                return PATCH_KD if downward else BACKGROUND
            return hit(d, w, True, downward)

        return (spawn(depth, weight, reflective, "reflection_rays", reflected)
                + spawn(depth, weight, transparent, "refraction_rays", transmitted))

    return hit(0, 1.0, False, True), counts


@pytest.mark.parametrize(("max_bounces", "min_weight"), [(4, 0.01), (2, 0.0), (6, 0.05), (8, 0.002)])
def test_a_glass_mirror_ball_along_its_axis(max_bounces, min_weight):
    reflective, transparent = np.array([0.25, 0.125, 0.25]), np.array([0.5, 0.75, 0.625])
    scene = durer.Scene()
    scene.background = BACKGROUND
    glass = scene.add_material((0, 0, 0), reflective=reflective, transparent=transparent, ior=1.5)
    scene.add_spheres([[0, 0, 0]], [1.0], material=glass)
    scene.add_plane((0, 0, 1), -4.0, material=scene.add_material(PATCH_KD),
                    bounds=((-0.5, -3, -4), (3.5, 0, 0), (0, 6, 0)))
    camera = durer.OrthographicCamera((0, 0, 5), (0, 0, -1), (0, 1, 0), 0.01, t_min=0.0)  # one pixel: the axis
    np.testing.assert_array_equal(camera.rays(1, 1)[0][0, 0], [0, 0, 5])
    result = durer.render(scene, camera, 1, 1, max_bounces=max_bounces, min_weight=min_weight)
    colour, counts = axis_tree(max_bounces, min_weight, reflective, transparent)
    np.testing.assert_allclose(result.color[0, 0, :3], colour, rtol=1e-6)
    stats = result.stats
    assert stats["effects"] == ("flat", "reflection", "refraction")
    assert {name: stats[name] for name in counts} == counts
    assert counts["reflection_rays"] > 0 and counts["refraction_rays"] > 0
    assert stats["total_internal_reflections"] == 0
    assert stats["intersection_tests"] == (1 + counts["reflection_rays"] + counts["refraction_rays"]) * 2


# --- back faces ---------------------------------------------------------------------------------
def test_shade_back_lights_a_plane_seen_from_behind(precision):
    # The plane y = 0 has its normal up; the camera and the light are below it.
    kd, ks, exponent, ambient = np.array([0.5, 0.6, 0.7]), np.array([0.25, 0.25, 0.25]), 5.0, np.array([0.1, 0.2, 0.1])
    direction, colour = np.array([0.3, 1.0, 0.2]), np.array([1.0, 0.9, 0.8])  # travels upward
    scene = durer.Scene()
    scene.ambient = ambient
    scene.add_plane((0, 1, 0), 0.0, material=scene.add_material(kd, specular=ks, exponent=exponent))
    scene.add_directional_light(direction, colour)
    camera = durer.PerspectiveCamera((0, -3, 1), (0, 1, -0.3), (0, 0, 1), 50.0)
    o, d, hit = camera_hits(scene, camera, 32, 32)
    assert (hit.object_id == 0).all()
    plain = durer.render(scene, camera, 32, 32, precision=precision)
    np.testing.assert_allclose(plain.color[..., :3], np.broadcast_to(ambient * kd, (32, 32, 3)), rtol=1e-6)
    np.testing.assert_array_equal(plain.normal, np.broadcast_to(np.float32([0, 1, 0]), (32, 32, 3)))
    flipped = durer.render(scene, camera, 32, 32, precision=precision, shade_back=True)
    points = o + hit.t[:, None] * d
    lights = [("directional", direction, colour, None)]
    expected = phong(points, np.array([[0.0, -1, 0]]), -d, kd, ks, exponent, lights, ambient)
    np.testing.assert_allclose(flipped.color[..., :3].reshape(-1, 3), expected, **tolerance(precision))
    np.testing.assert_array_equal(flipped.normal, np.broadcast_to(np.float32([0, -1, 0]), (32, 32, 3)))
    assert flipped.stats["shading_evaluations"] == plain.stats["shading_evaluations"] == 32 * 32
    # Seen from the front, the mirrored set-up gives the same colours as the back face with shade_back.
    front = durer.Scene()
    front.ambient = ambient
    front.add_plane((0, -1, 0), 0.0, material=front.add_material(kd, specular=ks, exponent=exponent))
    front.add_directional_light(direction, colour)
    np.testing.assert_allclose(durer.render(front, camera, 32, 32, precision=precision).color, flipped.color,
                               rtol=1e-6, atol=1e-7)


@pytest.mark.parametrize("lit", [False, True])
def test_shade_back_inside_a_sphere(lit):
    # From the centre of a sphere every hit is a back face; a point light at the centre lights the
    # inside only when the normals are turned toward it.
    kd = np.array([0.5, 0.25, 0.75])
    scene = durer.Scene()
    scene.add_spheres([[1, 2, 3]], [2.0], material=scene.add_material(kd))
    if lit:
        scene.add_point_light((1, 2, 3), (0.8, 0.8, 0.8))
    camera = durer.PerspectiveCamera((1, 2, 3), (1, -1, 0.5), (0, 0, 1), 90.0)
    o, d, hit = camera_hits(scene, camera, 16, 16)
    assert (hit.object_id == 0).all()
    outward = hit.normal.reshape(16, 16, 3)
    np.testing.assert_allclose(outward, d.reshape(16, 16, 3), atol=1e-9)
    plain = durer.render(scene, camera, 16, 16)
    flipped = durer.render(scene, camera, 16, 16, shade_back=True)
    np.testing.assert_allclose(plain.normal, outward, atol=1e-6)
    np.testing.assert_allclose(flipped.normal, -outward, atol=1e-6)
    if lit:
        np.testing.assert_array_equal(plain.color[..., :3], 0)  # ambient 0, facing away from the light
        np.testing.assert_allclose(flipped.color[..., :3], np.broadcast_to(0.8 * kd, (16, 16, 3)), rtol=1e-6)
    else:
        np.testing.assert_array_equal(flipped.color, plain.color)  # flat colour does not depend on N


# --- the effect set -----------------------------------------------------------------------------
def effects_scene(*, lights=0, shadows=False, specular=False, reflective=False, transparent=False, shading="auto"):
    scene = durer.Scene()
    scene.add_spheres([[0, 0, 0]], [1.0], material=scene.add_material(
        (0.5, 0.5, 0.5), specular=(0.5, 0.5, 0.5) if specular else (0, 0, 0),
        reflective=(0.5, 0.5, 0.5) if reflective else (0, 0, 0),
        transparent=(0.5, 0.5, 0.5) if transparent else (0, 0, 0), ior=1.5))
    for _ in range(lights):
        scene.add_point_light((0, 3, 3), (1, 1, 1), shadows=shadows)
    scene.shading = shading
    return scene


@pytest.mark.parametrize(
    ("scene_kwargs", "render_kwargs", "effects"),
    [
        ({}, {}, ("flat",)),
        ({"specular": True, "shadows": True}, {}, ("flat",)),  # no lights: no specular, no shadows
        ({"lights": 1}, {}, ("diffuse",)),
        ({"lights": 2, "shadows": True}, {}, ("diffuse", "shadows")),
        ({"lights": 1, "specular": True}, {}, ("diffuse", "specular")),
        ({"specular": True, "shading": "lit"}, {}, ("diffuse", "specular")),
        ({"lights": 1, "shadows": True, "specular": True, "shading": "flat"}, {}, ("flat",)),
        ({"reflective": True}, {}, ("flat", "reflection")),
        ({"transparent": True}, {}, ("flat", "refraction")),
        ({"lights": 1, "shadows": True, "specular": True, "reflective": True, "transparent": True}, {},
         ("diffuse", "reflection", "refraction", "shadows", "specular")),
        ({"lights": 1, "reflective": True, "transparent": True}, {"max_bounces": 0}, ("diffuse",)),
        ({"lights": 1, "shadows": True, "reflective": True}, {"passes": ("depth",)}, ()),
        ({"lights": 1, "shadows": True, "transparent": True}, {"passes": ("depth", "normal")}, ()),
        ({"reflective": True}, {"passes": ("color",)}, ("flat", "reflection")),
    ],
)
def test_effect_set(scene_kwargs, render_kwargs, effects):
    camera = durer.OrthographicCamera((0, 0, 5), (0, 0, -1), (0, 1, 0), 3.0)
    stats = durer.render(effects_scene(**scene_kwargs), camera, 8, 8, **render_kwargs).stats
    assert stats["effects"] == effects
    assert isinstance(stats["effects"], tuple)
    if "color" not in render_kwargs.get("passes", ("color",)):
        for name in COUNTERS:
            assert stats[name] == 0, name


# --- bad input ----------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"specular": (-0.1, 0, 0)}, "specular"),
        ({"specular": (0, math.inf, 0)}, "specular"),
        ({"reflective": (0, 0, math.nan)}, "reflective"),
        ({"reflective": (1, 1)}, "reflective"),
        ({"transparent": (-1, 0, 0)}, "transparent"),
        ({"transparent": (0, math.inf, 0)}, "transparent"),
        ({"exponent": -1.0}, "exponent"),
        ({"exponent": math.inf}, "exponent"),
        ({"exponent": math.nan}, "exponent"),
        ({"ior": 0.0}, "ior"),
        ({"ior": -1.5}, "ior"),
        ({"ior": math.inf}, "ior"),
        ({"ior": math.nan}, "ior"),
    ],
)
def test_bad_material_fields(kwargs, field):
    scene = durer.Scene()
    before = scene.material_count
    with pytest.raises(ValueError, match=field):
        scene.add_material((0.5, 0.5, 0.5), **kwargs)
    assert scene.material_count == before  # an add that raises changes nothing


def test_good_material_fields_are_accepted():
    scene = durer.Scene()
    first = scene.add_material((0.5, 0.5, 0.5), specular=(1, 1, 1), exponent=0.0, reflective=(2, 0, 0),
                               transparent=(0, 0, 0), ior=1.0)
    second = scene.add_material(ior=0.5, exponent=1000)
    assert (first, second) == (1, 2) and scene.material_count == 3


@pytest.mark.parametrize(
    ("kwargs", "error", "field"),
    [
        ({"max_bounces": -1}, ValueError, "max_bounces"),
        ({"max_bounces": 1.5}, TypeError, "max_bounces"),  # not an integer
        ({"min_weight": -0.01}, ValueError, "min_weight"),
        ({"min_weight": math.inf}, ValueError, "min_weight"),
        ({"min_weight": math.nan}, ValueError, "min_weight"),
        ({"shade_back": "yes"}, TypeError, "shade_back"),  # not a bool
    ],
)
def test_bad_render_arguments(kwargs, error, field):
    scene = durer.Scene()
    scene.add_spheres([[0, 0, 0]], [1.0])
    camera = durer.OrthographicCamera((0, 0, 5), (0, 0, -1), (0, 1, 0), 3.0)
    with pytest.raises(error, match=f"^{field} must "):
        durer.render(scene, camera, 4, 4, **kwargs)
