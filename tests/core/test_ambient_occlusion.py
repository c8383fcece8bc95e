"""Ambient occlusion (issue 14 item 2): `render(..., ambient_occlusion=(samples, distance))` scales
the ambient term by the unoccluded fraction of the cosine-weighted hemisphere within `distance`.

The analytic reference: a point of a plane sees a sphere of radius R whose centre is at distance D,
at angle θ from the plane's normal, as a cap of half-angle a = asin(R/D). While the sphere lies
wholly above the plane's horizon (its centre at least R above the plane), the cosine-weighted
fraction of the hemisphere it covers is the form factor F = cos θ · sin² a, so the AO fraction with
an unlimited distance is 1 − F = 1 − h·R²/D³ for a centre at height h.
"""

from __future__ import annotations

import numpy as np
import pytest

import durer

RADIUS, HEIGHT = 1.0, 1.5  # a sphere floating above the plane y = 0: wholly above every point's horizon
TOP_CAMERA = durer.OrthographicCamera((0, 10, 0), (0, -1, 0), (0, 0, -1), size=8.0)  # looking straight down
SIZE = 64


def sphere_over_plane(ambient=(1.0, 1.0, 1.0), diffuse=(1.0, 1.0, 1.0)) -> durer.Scene:
    """Ambient light only (lit shading, no lights): a pixel's colour is its AO fraction × ambient × kd."""
    scene = durer.Scene()
    material = scene.add_material(diffuse)
    scene.add_plane((0, 1, 0), 0.0, material=material)
    scene.add_spheres([(0, HEIGHT, 0)], RADIUS, material=material)
    scene.shading = "lit"
    scene.ambient = ambient
    return scene


def plane_pixels(result: durer.RenderResult) -> np.ndarray:
    """Where the camera ray meets the plane (10 below the camera), not the sphere."""
    return np.abs(result.depth - 10) < 1e-6


def analytic_open_fraction() -> np.ndarray:
    """1 − h·R²/D³ at each pixel centre's point of the plane."""
    origins, _ = TOP_CAMERA.rays(SIZE, SIZE)
    distance = np.sqrt(origins[..., 0] ** 2 + origins[..., 2] ** 2 + HEIGHT**2)
    return 1 - HEIGHT * RADIUS**2 / distance**3


@pytest.mark.parametrize("precision", ["double", "float"])
def test_plane_under_sphere_matches_the_analytic_occlusion(precision):
    samples = 64
    result = durer.render(sphere_over_plane(), TOP_CAMERA, SIZE, SIZE, ambient_occlusion=(samples, np.inf),
                          precision=precision)
    plane = plane_pixels(result)
    assert plane.sum() > 3000  # every pixel but the sphere's disc
    expected = analytic_open_fraction()[plane]
    measured = result.color[..., 0][plane]
    assert np.array_equal(measured, result.color[..., 2][plane])  # white light, white surface: grey
    # Binomial noise of `samples` independent rays per pixel; the scrambled Sobol directions do better.
    sigma = np.sqrt(expected * (1 - expected) / samples)
    assert np.all(np.abs(measured - expected) <= 4 * sigma + 1e-6)
    # Unbiased: the mean error over ~3,900 independently scrambled pixels is far inside its noise.
    assert abs(np.mean(measured - expected)) < 4 * np.sqrt(np.mean(sigma**2) / plane.sum())
    # The darkest points seen (at the sphere's outline, 0.744) are resolved, not washed out.
    assert measured.min() == pytest.approx(expected.min(), abs=0.05)
    assert result.stats["effects"] == ("ambient_occlusion", "diffuse")
    assert result.stats["ao_rays"] == samples * SIZE * SIZE  # every pixel hits the plane or the sphere


def test_noise_falls_with_samples():
    expected = analytic_open_fraction()
    errors = []
    for samples in (4, 64):
        result = durer.render(sphere_over_plane(), TOP_CAMERA, SIZE, SIZE, ambient_occlusion=(samples, np.inf))
        plane = plane_pixels(result)
        errors.append(np.sqrt(np.mean((result.color[..., 0][plane] - expected[plane]) ** 2)))
    # 16x the samples: binomial noise would fall 4x; the stratified directions fall faster.
    assert errors[1] < errors[0] / 4


def test_occluders_beyond_the_distance_do_not_occlude():
    # Seen from above, the plane shows its points at d >= R from the sphere's foot, sqrt(d² + h²) − R
    # >= 0.80 from the sphere; the sphere shows its upper half, h = 1.5 or more above the plane. Within
    # 0.75 nothing occludes, and the image is the one without AO, bit for bit.
    without = durer.render(sphere_over_plane(), TOP_CAMERA, SIZE, SIZE)
    near = durer.render(sphere_over_plane(), TOP_CAMERA, SIZE, SIZE, ambient_occlusion=(16, 0.75))
    assert near.stats["ao_rays"] == 16 * SIZE * SIZE
    assert np.array_equal(near.color, without.color)
    # Within 1, the plane's points closer than sqrt((1 + R)² − h²) = 1.32 to the foot see the sphere.
    farther = durer.render(sphere_over_plane(), TOP_CAMERA, SIZE, SIZE, ambient_occlusion=(16, 1.0))
    darker = farther.color[..., 0] < without.color[..., 0]
    origins, _ = TOP_CAMERA.rays(SIZE, SIZE)
    foot = np.hypot(origins[..., 0], origins[..., 2])
    assert darker.sum() > 20
    assert np.all(plane_pixels(farther)[darker]) and np.all(foot[darker] < np.sqrt(4 - HEIGHT**2))


def test_off_traces_nothing_and_changes_nothing():
    scene = sphere_over_plane()
    scene.add_directional_light((1, -2, -1), (0.5, 0.5, 0.5), shadows=True)
    off = durer.render(scene, TOP_CAMERA, 32, 32)
    assert off.stats["ao_rays"] == 0 and "ambient_occlusion" not in off.stats["effects"]
    assert off.stats["ambient_occlusion"] is None
    explicit = durer.render(scene, TOP_CAMERA, 32, 32, ambient_occlusion=None)
    assert np.array_equal(explicit.color, off.color)
    assert explicit.stats["intersection_tests"] == off.stats["intersection_tests"]


@pytest.mark.parametrize(
    ("ambient", "shading"),
    [((0, 0, 0), "lit"),  # no ambient light to occlude
     ((1, 1, 1), "flat")],  # unlit: no ambient term at all
)
def test_nothing_to_occlude_traces_no_rays(ambient, shading):
    scene = sphere_over_plane(ambient=ambient)
    scene.shading = shading
    result = durer.render(scene, TOP_CAMERA, 16, 16, ambient_occlusion=(16, np.inf))
    assert result.stats["ao_rays"] == 0
    assert "ambient_occlusion" not in result.stats["effects"]
    assert np.array_equal(result.color, durer.render(scene, TOP_CAMERA, 16, 16).color)


def test_black_surfaces_take_no_rays():
    scene = sphere_over_plane()
    black = scene.add_material((0, 0, 0))
    scene.add_spheres([(3, 1, 3)], 1.0, material=black)
    result = durer.render(scene, TOP_CAMERA, SIZE, SIZE, ambient_occlusion=(4, np.inf))
    black_pixels = int((result.color[..., 0] == 0).sum())
    assert black_pixels > 100
    assert result.stats["ao_rays"] == 4 * (SIZE * SIZE - black_pixels)


def test_only_the_ambient_term_is_scaled():
    # A light's term is added unscaled: lit + AO = light alone + (AO fraction × ambient).
    ambient = 0.25
    occlusion = (8, np.inf)
    fraction = durer.render(sphere_over_plane(), TOP_CAMERA, 32, 32, ambient_occlusion=occlusion).color
    lit = sphere_over_plane(ambient=(0, 0, 0))
    lit.add_directional_light((1, -2, -1), (0.5, 0.5, 0.5), shadows=True)
    light_only = durer.render(lit, TOP_CAMERA, 32, 32).color
    lit.ambient = (ambient, ambient, ambient)
    both = durer.render(lit, TOP_CAMERA, 32, 32, ambient_occlusion=occlusion)
    assert both.stats["ao_rays"] == 8 * 32 * 32
    np.testing.assert_allclose(both.color[..., :3], light_only[..., :3] + ambient * fraction[..., :3], rtol=1e-6,
                               atol=1e-7)


def test_deterministic_across_threads_regions_and_seeded():
    kwargs = {"ambient_occlusion": (4, np.inf), "spp": 4, "sampler": "sobol"}
    one = durer.render(sphere_over_plane(), TOP_CAMERA, 40, 40, threads=1, **kwargs)
    two = durer.render(sphere_over_plane(), TOP_CAMERA, 40, 40, threads=2, **kwargs)
    assert np.array_equal(one.color, two.color)
    part = durer.render(sphere_over_plane(), TOP_CAMERA, 40, 40, region=(13, 5, 20, 17), **kwargs)
    assert np.array_equal(part.color, one.color[5:22, 13:33])
    other_seed = durer.render(sphere_over_plane(), TOP_CAMERA, 40, 40, seed=1, **kwargs)
    assert not np.array_equal(other_seed.color, one.color)


@pytest.mark.parametrize(
    ("value", "error", "message"),
    [((0, 1.0), ValueError, r"ambient_occlusion samples must be in \[1, 65536\], got 0"),
     ((65537, 1.0), ValueError, r"ambient_occlusion samples must be in \[1, 65536\], got 65537"),
     ((16, 0.0), ValueError, r"ambient_occlusion distance must be > 0"),
     ((16, -1.0), ValueError, r"ambient_occlusion distance must be > 0"),
     ((16, float("nan")), ValueError, r"ambient_occlusion distance must be > 0"),
     ((2.5, 1.0), TypeError, r"ambient_occlusion samples must be an integer"),
     ((16, "far"), TypeError, r"ambient_occlusion distance must be a real number"),
     # a wrong number of items is a ValueError, as for every tuple-valued argument (region, shift, colours)
     ((16,), ValueError, r"ambient_occlusion must be \(samples, distance\) or None"),
     (16, TypeError, r"ambient_occlusion must be \(samples, distance\) or None, got int")],
)
def test_bad_values_name_ambient_occlusion(value, error, message):
    with pytest.raises(error, match=message):
        durer.render(sphere_over_plane(), TOP_CAMERA, 8, 8, ambient_occlusion=value)


def test_secondary_hits_are_occluded_too():
    # A half-mirror floor under a ceiling 20 above: the camera's hits on the floor and the mirrored
    # rays' hits on the ceiling each see the other plane within a distance L only along directions
    # within acos(20 / L) of the normal, a cosine-weighted fraction 1 − (20 / L)²: (20 / L)² is open.
    scene = durer.Scene()
    scene.add_plane((0, 1, 0), 0.0, material=scene.add_material((0.5, 0.5, 0.5), reflective=(0.5, 0.5, 0.5)))
    scene.add_plane((0, -1, 0), -20.0, material=scene.add_material((1, 1, 1)))
    scene.shading = "lit"
    scene.ambient = (1, 1, 1)
    camera = durer.OrthographicCamera((0, 10, 0), (0, -1, 0), (0, 0, -1), size=4.0, t_min=0.0)
    samples = 64
    result = durer.render(scene, camera, 32, 32, ambient_occlusion=(samples, 21.0))
    assert result.stats["reflection_rays"] == 32 * 32
    assert result.stats["ao_rays"] == 2 * samples * 32 * 32  # at the floor and at the mirrored ceiling
    value = result.color[..., 0]  # 0.5·open(floor) + 0.5·1·open(ceiling)
    open_fraction = (20 / 21) ** 2
    sigma = np.sqrt(0.5 * open_fraction * (1 - open_fraction) / samples)
    assert np.all(np.abs(value - open_fraction) <= 4 * sigma)
    assert abs(value.mean() - open_fraction) < 4 * sigma / 32
    unoccluded = durer.render(scene, camera, 32, 32, ambient_occlusion=(samples, 19.0))
    assert np.all(unoccluded.color[..., :3] == 1.0)
    assert unoccluded.stats["ambient_occlusion"] == (samples, 19.0)
