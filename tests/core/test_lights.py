"""Light kinds, falloff, spot cones, emission and the shading mode, against hand-computed pixels."""

from __future__ import annotations

import math

import numpy as np
import pytest

import durer


def floor_scene() -> durer.Scene:
    """A white infinite floor y = 0 seen from above by an orthographic camera (see `floor_points`)."""
    scene = durer.Scene()
    scene.add_plane((0, 1, 0), 0.0, material=scene.add_material((1, 1, 1)))
    return scene


CAMERA = durer.OrthographicCamera((0, 10, 0), (0, -1, 0), (0, 0, -1), 8.0)


def floor_points(n: int = 33) -> np.ndarray:
    origins, _ = CAMERA.rays(n, n)
    points = origins.copy()
    points[..., 1] = 0
    return points


def lambert_to(points: np.ndarray, position) -> tuple[np.ndarray, np.ndarray]:
    to_light = np.asarray(position, float) - points
    d = np.linalg.norm(to_light, axis=-1)
    return to_light[..., 1] / d, d


def test_point_light_attenuation(precision):
    scene = floor_scene()
    scene.add_point_light((1, 3, -2), (2, 1, 0.5), attenuation=(0.5, 0.25, 0.125))
    image = durer.render(scene, CAMERA, 33, 33, precision=precision).color
    cosine, d = lambert_to(floor_points(), (1, 3, -2))
    falloff = 1 / (0.5 + 0.25 * d + 0.125 * d * d)
    expected = (cosine * falloff)[..., None] * np.array([2, 1, 0.5])
    np.testing.assert_allclose(image[..., :3], expected, rtol=2e-5)


def test_inverse_square_point_light():
    scene = floor_scene()
    scene.add_point_light((0, 2, 0), (4, 4, 4), attenuation=(0, 0, 1))
    image = durer.render(scene, CAMERA, 33, 33).color
    cosine, d = lambert_to(floor_points(), (0, 2, 0))
    np.testing.assert_allclose(image[..., 0], 4 * cosine / d**2, rtol=1e-6)
    assert image[16, 16, 0] == pytest.approx(1.0, rel=1e-6)  # the centre pixel is right under the light: 4 / 2²


@pytest.mark.parametrize("blend", [0.0, 0.3, 1.0])
def test_spot_light_cone(blend):
    scene = floor_scene()
    half = 30.0
    scene.add_spot_light((0, 2, 0), (0, -1, 0), (1, 1, 1), half_angle_degrees=half, blend=blend)
    image = durer.render(scene, CAMERA, 33, 33).color[..., 0]
    points = floor_points()
    cosine, _ = lambert_to(points, (0, 2, 0))
    # The angle to the spot's axis (straight down) equals the angle of incidence here.
    cos_half = math.cos(math.radians(half))
    if blend == 0:
        factor = (cosine > cos_half).astype(float)
    else:
        x = np.clip((cosine - cos_half) / ((1 - cos_half) * blend), 0, 1)
        factor = x * x * (3 - 2 * x)
    expected = cosine * factor
    edge = np.abs(cosine - cos_half) < 1e-9
    np.testing.assert_allclose(image[~edge], expected[~edge], rtol=1e-5, atol=1e-7)
    radius = 2 * math.tan(math.radians(half))
    inside = np.hypot(points[..., 0], points[..., 2]) < radius
    assert (image[~inside] == 0).all() and (image[inside] > 0).sum() > 50


@pytest.mark.parametrize("exponent, highlight", [(2.0, 0.0), (0.0, 1.0)])
def test_no_highlight_where_the_half_vector_is_undefined(precision, exponent, highlight):
    """The floor's underside seen from below, lit by a light above it on the camera ray: the light
    and the viewer are exactly opposite, so L + V = 0 and H is undefined (found by the hardening
    fuzz: normalising it gave a NaN colour). No highlight then: max(N·H, 0) is 0, and 0^0 = 1."""
    scene = durer.Scene()
    scene.add_plane((0, 1, 0), 0.0, material=scene.add_material((0.5, 0.5, 0.5), specular=(0.25, 0.25, 0.25),
                                                                  exponent=exponent))
    scene.add_point_light((0, 3, 0), (1, 1, 1))
    below = durer.OrthographicCamera((0, -10, 0), (0, 1, 0), (0, 0, -1), 8.0)
    image = durer.render(scene, below, 1, 1, precision=precision).color
    np.testing.assert_array_equal(image[0, 0], [0.5 + 0.25 * highlight] * 3 + [1.0])


def test_emission_is_added_unlit():
    scene = durer.Scene()
    glow = scene.add_material(diffuse=(0.5, 0.5, 0.5), emission=(0.25, 0.5, 1.0))
    scene.add_spheres([[0, 0, 0]], [1.0], material=glow)
    camera = durer.OrthographicCamera((0, 0, 5), (0, 0, -1), (0, 1, 0), 0.5)  # sees only the sphere's front cap
    flat = durer.render(scene, camera, 4, 4).color
    np.testing.assert_allclose(flat[..., :3], np.broadcast_to([0.75, 1.0, 1.5], (4, 4, 3)), rtol=1e-6)
    scene.add_directional_light((0, 0, -1), (1, 1, 1))
    lit = durer.render(scene, camera, 4, 4, passes=("color",))
    # The light along the view: cos = n_z = sqrt(1 - x² - y²) on the unit sphere at each pixel centre.
    origins, _ = camera.rays(4, 4)
    cosine = np.sqrt(1 - origins[..., 0] ** 2 - origins[..., 1] ** 2)
    expected = np.array([0.25, 0.5, 1.0]) + 0.5 * cosine[..., None]
    np.testing.assert_allclose(lit.color[..., :3], expected, rtol=1e-6)


def test_shading_mode():
    scene = durer.Scene()
    scene.add_spheres([[0, 0, 0]], [1.0], material=scene.add_material((0.5, 0.25, 1.0)))
    scene.ambient = (0.2, 0.2, 0.2)
    camera = durer.OrthographicCamera((0, 0, 5), (0, 0, -1), (0, 1, 0), 0.5)
    assert scene.shading == "auto"
    np.testing.assert_allclose(durer.render(scene, camera, 2, 2).color[0, 0, :3], [0.5, 0.25, 1.0])
    scene.shading = "lit"  # no lights: ambient only (a Blender scene without lights is dark)
    np.testing.assert_allclose(durer.render(scene, camera, 2, 2).color[0, 0, :3], [0.1, 0.05, 0.2], rtol=1e-6)
    scene.add_directional_light((0, 0, -1), (1, 1, 1))
    scene.shading = "flat"
    np.testing.assert_allclose(durer.render(scene, camera, 2, 2).color[0, 0, :3], [0.5, 0.25, 1.0])
    with pytest.raises(ValueError, match="shading"):
        scene.shading = "phong"


@pytest.mark.parametrize(
    ("call", "error", "field"),
    [
        (lambda s: s.add_point_light((0, 0, 0), (1, 1, 1), attenuation=(0, 0, 0)), ValueError, "attenuation"),
        (lambda s: s.add_point_light((0, 0, 0), (1, 1, 1), attenuation=(1, -1, 0)), ValueError, "attenuation"),
        (lambda s: s.add_spot_light((0, 0, 0), (0, -1, 0), (1, 1, 1), half_angle_degrees=0.0), ValueError,
         "half_angle_degrees"),
        (lambda s: s.add_spot_light((0, 0, 0), (0, -1, 0), (1, 1, 1), half_angle_degrees=180.0), ValueError,
         "half_angle_degrees"),
        (lambda s: s.add_spot_light((0, 0, 0), (0, 0, 0), (1, 1, 1), half_angle_degrees=30.0), ValueError, "direction"),
        (lambda s: s.add_spot_light((0, 0, 0), (0, -1, 0), (1, 1, 1), half_angle_degrees=30.0, blend=1.5), ValueError,
         "blend"),
        (lambda s: s.add_material((1, 1, 1), emission=(0, math.nan, 0)), ValueError, "emission"),
        (lambda s: s.add_point_light((0, 0, 0), (1, 1, 1), shadows="yes"), TypeError, "shadows"),  # not a bool
    ],
)
def test_bad_light_and_material_input(call, error, field):
    with pytest.raises(error, match=f"^{field} must "):
        call(durer.Scene())
