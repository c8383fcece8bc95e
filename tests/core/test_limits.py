"""Numbers at the extremes (issue 18, item 3): every accepted input renders finite colour, depth and
normal, or is refused with a ValueError naming it. The limits are durer._core.LIMITS (Limits.h), derived
in docs/numerics.md ("Accepted ranges"); each case of the issue is here, in both precisions."""

from __future__ import annotations

import math

import numpy as np
import pytest

import durer
from durer import _core
from durer.render import PRECISIONS

LIMITS = _core.LIMITS
FLOAT_MAX = float(np.finfo(np.float32).max)
ORTHO = dict(center=(0, 0, 5), direction=(0, 0, -1), up=(0, 1, 0), size=4.0)


def unit_sphere() -> durer.Scene:
    scene = durer.Scene()
    scene.add_spheres([[0, 0, 0]], 1.0)
    return scene


def assert_finite_passes(result: durer.RenderResult) -> np.ndarray:
    """Colour and normal finite everywhere, depth finite on hits and +inf on misses, unit normals on
    hits and 0 on misses; returns the hit mask."""
    hit = np.isfinite(result.depth)
    assert np.isfinite(result.color).all()
    assert not np.isnan(result.depth).any() and (result.depth[~hit] == math.inf).all()
    assert np.isfinite(result.normal).all()
    np.testing.assert_allclose(np.linalg.norm(result.normal[hit], axis=-1), 1.0, atol=1e-6)
    assert not result.normal[~hit].any()
    return hit


def test_the_limits_table():
    assert LIMITS == {"float": {"coordinate": 1e18, "color": 1e18}, "double": {"coordinate": 1e36, "color": 1e18}}


# --- coordinates --------------------------------------------------------------------------------
@pytest.mark.parametrize(("add", "field"), [
    (lambda s: s.add_spheres([[1e39, 0, 0]], 1.0), r"centers\[0\] ± radii\[0\]"),
    (lambda s: s.add_spheres([[1e36, 0, 0]], 1e35), r"centers\[0\] ± radii\[0\]"),  # the radius takes it past
    (lambda s: s.add_triangles([[[-1e154, -1e154, 0], [1e154, -1e154, 0], [0, 1e154, 0]]]), r"vertices\[0\]\[0\]"),
    (lambda s: s.add_mesh([[0, 0, 0], [2e36, 0, 0], [0, 1, 0]], [[0, 1, 2]]), r"vertices\[1\]"),
    (lambda s: s.add_boxes([[0, 0, 0]], [[1, 1, 1e37]]), r"hi\[0\]"),
    (lambda s: s.add_plane((0, 0, 1), -1e308), r"offset / \|normal\|"),
    (lambda s: s.add_plane((0, 0, 1), 0.0, bounds=((0, 0, 0), (1e37, 0, 0), (0, 1, 0))), r"bounds \(corner \+ edges\)"),
    (lambda s: s.add_point_light((0, 1e37, 0), (1, 1, 1)), "position"),
    (lambda s: s.add_spheres([[1e30, 0, 0]], 1.0, transform=np.diag([1e7, 1, 1, 1])),
     r"transform applied to centers\[0\] ± radii\[0\]"),
], ids=["sphere-1e39", "sphere-radius-past", "triangle-1e154", "mesh", "box", "plane-offset", "plane-bounds",
        "light", "transformed"])
def test_coordinates_beyond_every_precision_are_refused_by_the_add(add, field):
    scene = durer.Scene()
    with pytest.raises(ValueError, match="^" + field + r" must lie within ±1e\+36 \(precision='double'; 'float': "
                                         r"±1e\+18\), got "):
        add(scene)
    assert scene.object_count == 0 and scene.light_count == 0


@pytest.mark.parametrize(("add", "field"), [
    (lambda s: s.add_spheres([[0, 0, 0], [1e20, 0, 0]], 1.0), r"centers\[1\] ± radii\[1\]"),
    (lambda s: s.add_triangles([[[0, 0, -1e19], [1, 0, -1e19], [0, 1, -1e19]]]), r"vertices\[0\]\[0\]"),
    (lambda s: s.add_point_light((0, 0, 3e18), (1, 1, 1)), "position"),
    # a radius of 1e30 under a scale of 1e-30: a unit sphere in world space, 1e30 in object space
    (lambda s: s.add_spheres([[0, 0, 0]], 1e30, transform=np.diag([1e-30, 1e-30, 1e-30, 1])), r"centers\[0\]"),
    # a unit sphere under that scale: the camera, 5 away, is 5e30 away in object space
    (lambda s: s.add_spheres([[0, 0, 0]], 1.0, transform=np.diag([1e-30, 1e-30, 1e-30, 1])), "^transform"),
], ids=["sphere", "triangle", "light", "scaled-radius", "scaled-space"])
def test_coordinates_beyond_float_render_in_double_and_are_refused_in_float(add, field):
    scene = unit_sphere()
    add(scene)
    camera = durer.OrthographicCamera(**ORTHO)
    assert assert_finite_passes(durer.render(scene, camera, 4, 4, precision="double")).any()
    with pytest.raises(ValueError, match=field + r".* must lie within ±1e\+18 with precision='float', got "):
        durer.render(scene, camera, 4, 4, precision="float")
    with pytest.raises(ValueError, match=field + r".* must lie within ±1e\+18 with precision='float'"):
        durer.cast(scene, [[0, 0, 5]], [[0, 0, -1]], precision="float")


def test_a_scaled_down_sphere_is_hit_in_double():
    """The issue's radius 1e30 under a scale of 1e-30 (it vanished in float): a unit sphere."""
    scene = durer.Scene()
    scene.add_spheres([[0, 0, 0]], 1e30, transform=np.diag([1e-30, 1e-30, 1e-30, 1]))
    result = durer.cast(scene, [[0, 0, 5]], [[0, 0, -1]])
    assert result.t[0] == pytest.approx(4.0, rel=1e-15) and result.object_id[0] == 0


@pytest.mark.parametrize("precision", PRECISIONS)
def test_geometry_at_the_limit_is_hit(precision):
    """Spheres and triangles spanning the whole range, seen from the far side of it: the sphere
    test's squares and the triangle test's products of three coordinates (scaled by a power of two)
    stay finite; t to a few roundings."""
    s = LIMITS[precision]["coordinate"] / 2
    scene = durer.Scene()
    scene.add_spheres([[0, 0, -s / 2]], s / 2)
    scene.add_triangles([[[-s, -s, -s], [s, -s, -s], [0, s, -s]]])
    result = durer.cast(scene, [[0, 0, s], [s / 4, 0, s]], [[0, 0, -1], [0, 0, -1]], precision=precision)
    np.testing.assert_array_equal(result.object_id, [0, 0])
    np.testing.assert_allclose(result.t, [s, s + s * (1 - math.sqrt(0.75)) / 2], rtol=1e-6)
    # a perspective camera (t counted from 0, with the triangle's error bound on t) inside it
    result = durer.cast(scene, [[0, s / 2, s]], [[0, 0, -1]], precision=precision)
    assert result.object_id[0] == 1 and result.t[0] == pytest.approx(2 * s, rel=1e-6)
    camera = durer.PerspectiveCamera((0, s / 2, s), (0, 0, -1), (0, 1, 0), fov_degrees=1.0)
    hit = assert_finite_passes(durer.render(scene, camera, 3, 3, precision=precision))
    assert hit.all()


@pytest.mark.parametrize("precision", PRECISIONS)
def test_a_sphere_finer_than_its_hit_points_spacing_has_a_normal(precision):
    """A radius of 1e-20 met dead centre from 5 away: the hit point rounds to the centre, p - c = 0
    (its normal was NaN); the normal faces the ray, in cast and in both of render's normal paths."""
    scene = durer.Scene()
    scene.add_spheres([[0, 0, 0]], 1e-20)
    result = durer.cast(scene, [[0, 0, 5]], [[0, 0, -1]], precision=precision)
    assert result.object_id[0] == 0 and result.t[0] == 5
    np.testing.assert_array_equal(result.normal[0], [0, 0, 1])
    camera = durer.OrthographicCamera(**ORTHO)
    np.testing.assert_array_equal(durer.render(scene, camera, 1, 1, precision=precision).normal[0, 0], [0, 0, 1])
    scene.add_directional_light((0, 0, -1), (1, 1, 1))  # hit records instead of the flat path
    lit = durer.render(scene, camera, 1, 1, precision=precision)
    np.testing.assert_array_equal(lit.normal[0, 0], [0, 0, 1])
    np.testing.assert_allclose(lit.color[0, 0], [0.8, 0.8, 0.8, 1], rtol=1e-6)


@pytest.mark.parametrize("precision", PRECISIONS)
def test_a_normal_through_a_huge_scale_stays_unit(precision):
    """A sphere of radius 1e-13 scaled by 1e30: the inverse transpose shrinks its normal to ~1e-30,
    whose square underflows float (the normal was NaN); it is scaled by a power of two first."""
    scene = durer.Scene()
    scene.add_spheres([[0, 0, 0]], 1e-13, transform=np.diag([1e30, 1e30, 1e30, 1.0]))
    result = durer.cast(scene, [[0, 0, 5e17]], [[0, 0, -1]], precision=precision)
    assert result.object_id[0] == 0 and result.t[0] == pytest.approx(4e17, rel=1e-6)
    np.testing.assert_allclose(result.normal[0], [0, 0, 1], atol=1e-7)


# --- the camera -------------------------------------------------------------------------------------
@pytest.mark.parametrize("precision", PRECISIONS)
@pytest.mark.parametrize(("camera", "field"), [
    (dict(ORTHO, center=(1e308, 0, 5)), "center"),
    (dict(ORTHO, size=1e308), r"the image window \(center, size, shift, pixel_aspect at 4x4\)"),
    (dict(ORTHO, shift=(1e308, 0)), r"the image window \(center, size, shift, pixel_aspect at 4x4\)"),
    (dict(ORTHO, pixel_aspect=1e308), r"the image window \(center, size, shift, pixel_aspect at 4x4\)"),
    (dict(ORTHO, size=1e20), r"the image window \(center, size, shift, pixel_aspect at 4x4\)"),  # float only
])
def test_camera_values_beyond_the_limits_are_refused(camera, field, precision):
    scene = unit_sphere()
    cam = durer.OrthographicCamera(**camera)
    if camera.get("size") == 1e20 and precision == "double":
        assert_finite_passes(durer.render(scene, cam, 4, 4, precision=precision))
        return
    limit = LIMITS[precision]["coordinate"]
    with pytest.raises(ValueError, match=f"^{field} must lie within ±{limit:g} with precision='{precision}', got "
                                         .replace("+", r"\+")):
        durer.render(scene, cam, 4, 4, precision=precision)
    with pytest.raises(ValueError, match=f"^{field}"):
        cam.rays(4, 4, precision)


@pytest.mark.parametrize("precision", PRECISIONS)
def test_extreme_but_finite_pixel_aspects_render(precision):
    """pixel_aspect 1e300 with a vertical fit, 1e-300 with a horizontal one: the window stays finite."""
    for aspect, fit in ((1e300, "vertical"), (1e-300, "horizontal"), (1e-300, "auto")):
        cam = durer.OrthographicCamera((0, 0, 5), (0, 0, -1), (0, 1, 0), 1.0, fit=fit, pixel_aspect=aspect)
        assert assert_finite_passes(durer.render(unit_sphere(), cam, 4, 4, precision=precision)).any()


# --- planes end at the limit --------------------------------------------------------------------
@pytest.mark.parametrize("precision", PRECISIONS)
def test_a_plane_met_beyond_the_limit_is_not_hit(precision):
    """The issue's orthographic camera along (0, 1, 1e-296) over the plane z = 0 met it at
    t ~ -1e296: depth -inf in the float32 pass. Planes end at the coordinate limit: a miss, and a
    ray meeting the plane inside the limit still hits it."""
    scene = durer.Scene()
    scene.add_plane((0, 0, 1), 0.0)
    camera = durer.OrthographicCamera((0, 0, 1), (0, 1, 1e-296), (0, 0, 1), 1.0)
    result = durer.render(scene, camera, 3, 3, precision=precision)
    assert not assert_finite_passes(result).any()
    # 1e-30: the plane is met 1e30 away, inside double's limit and beyond float's
    camera = durer.OrthographicCamera((0, 0, 1), (0, 1, 1e-30), (0, 0, 1), 1.0)
    hit = assert_finite_passes(durer.render(scene, camera, 3, 3, precision=precision))
    if precision == "double":
        assert hit.all()
    else:
        assert not hit.any()


# --- cast directions ----------------------------------------------------------------------------
@pytest.mark.parametrize("precision", PRECISIONS)
def test_a_direction_of_any_normal_length_meets_the_same_sphere(precision):
    """A unit sphere in front of a box: directions from the smallest normal number to the largest
    finite one meet the sphere first, at t = 4/|d| (the 1e308 direction used to pass through it)."""
    scene = unit_sphere()
    scene.add_boxes([[-1, -1, -10]], [[1, 1, -5]])
    info = np.finfo(np.float32 if precision == "float" else np.float64)
    lengths = [float(info.tiny) * 2**60, 1e-10, 1.0, 3e38, float(info.max)]
    directions = [[0, 0, -length] for length in lengths]
    result = durer.cast(scene, [[0, 0, 5]] * len(lengths), directions, precision=precision)
    np.testing.assert_array_equal(result.object_id, 0)
    np.testing.assert_allclose(result.t.astype(float) * np.array(lengths), 4.0, rtol=1e-6)


@pytest.mark.parametrize(("direction", "precision"), [
    ((0, 0, -1e307), "float"), ((0, 1e-39, 0), "float"), ((0, 0, -1e-320), "double")])
def test_a_direction_the_precision_cannot_scale_is_refused(direction, precision):
    with pytest.raises(ValueError, match=r"^directions\[1\] must have its largest \|component\| in \["):
        durer.cast(unit_sphere(), [[0, 0, 5], [0, 0, 5]], [[0, 0, -1], direction], precision=precision)


@pytest.mark.parametrize("precision", PRECISIONS)
def test_cast_origins_beyond_the_limit_are_refused(precision):
    limit = LIMITS[precision]["coordinate"]
    with pytest.raises(ValueError, match=r"^origins\[1\] must lie within "):
        durer.cast(unit_sphere(), [[0, 0, 5], [0, 0, 2 * limit]], [[0, 0, -1]] * 2, precision=precision)


# --- colours ------------------------------------------------------------------------------------
@pytest.mark.parametrize(("add", "field"), [
    (lambda s: s.add_directional_light((0, 0, -1), (1e39, 1e39, 1e39)), "color"),
    (lambda s: s.add_point_light((0, 0, 3), (1, 1, 1), attenuation=(1e19, 0, 0)), "attenuation"),
    (lambda s: s.add_material(diffuse=(2e18, 0, 0)), "diffuse"),
    (lambda s: s.add_material(exponent=1e300), "exponent"),
    (lambda s: setattr(s, "background", (0, 0, 1e19)), "background"),
    (lambda s: setattr(s, "ambient", (1e19, 0, 0)), "ambient"),
], ids=["light", "attenuation", "diffuse", "exponent", "background", "ambient"])
def test_colours_beyond_the_limit_are_refused(add, field):
    # a scalar (exponent) has no channels
    channels = "" if field == "exponent" else " in each channel"
    with pytest.raises(ValueError, match=f"^{field} must be <= 1e\\+18{channels}, got "):
        add(durer.Scene())


@pytest.mark.parametrize("precision", PRECISIONS)
def test_a_pixel_brighter_than_float32_saturates(precision):
    """kd·light = 1e18·1e18 = 1e36 fits every precision; a constant attenuation c0 = 1e-18 (a falloff of
    1e18) makes ~1e54: the colour pass saturates at float32's largest number, and a zero channel stays 0
    (no 0·inf)."""
    scene = durer.Scene()
    scene.add_spheres([[0, 0, 0]], 1.0, material=scene.add_material(diffuse=(1e18, 0, 1)))
    scene.add_point_light((0, 0, 3), (1e18, 1e18, 0), attenuation=(1e-18, 0, 0))
    result = durer.render(scene, durer.OrthographicCamera(**ORTHO), 4, 4, precision=precision)
    hit = assert_finite_passes(result)
    centre = result.color[1, 1]
    assert hit[1, 1] and centre[0] == FLOAT_MAX and centre[1] == 0 and centre[2] == 0 and centre[3] == 1


@pytest.mark.parametrize("precision", PRECISIONS)
def test_adaptive_sampling_of_a_pixel_brighter_than_float32_saturates(precision):
    """The same overflow under adaptive sampling, on a sphere whose silhouette crosses pixels (their
    samples inside and outside it are weighed apart): colours saturate, never NaN; where a float
    render's sums overflowed, the estimated error is infinite (unknown), never NaN."""
    scene = durer.Scene()
    scene.add_spheres([[0.3, -0.2, 0]], 1.3, material=scene.add_material(diffuse=(1e18, 1e18, 1e18)))
    scene.add_point_light((0, 0, 30), (1e18, 1e18, 1e18), attenuation=(1e-3, 0, 0))
    result = durer.render(scene, durer.OrthographicCamera(**ORTHO), 16, 16, spp=16, sampler="adaptive",
                          precision=precision)
    assert not np.isnan(result.color).any() and not np.isnan(result.error).any()
    assert result.color[..., 0].max() == FLOAT_MAX
    assert not math.isnan(result.stats["estimated_rmse"])


@pytest.mark.parametrize("precision", PRECISIONS)
def test_a_back_face_lit_from_straight_behind_has_no_highlight(precision):
    """The plane z = 0 (normal +z) seen from below, the sun straight above: toLight + toViewer = 0,
    the half vector has no direction (the colour was NaN with a specular material); the highlight is
    0 and the diffuse term stays (no shade_back: the normal is as given, facing the light)."""
    scene = durer.Scene()
    scene.add_plane((0, 0, 1), 0.0, material=scene.add_material((0.5, 0.25, 0.125), specular=(1, 1, 1), exponent=8))
    scene.add_directional_light((0, 0, -1), (1, 1, 1))
    camera = durer.OrthographicCamera((0, 0, -5), (0, 0, 1), (0, 1, 0), 2.0, t_min=0.0)
    result = durer.render(scene, camera, 2, 2, precision=precision)
    assert_finite_passes(result)
    np.testing.assert_array_equal(result.color, np.broadcast_to([0.5, 0.25, 0.125, 1], (2, 2, 4)))


# --- integers -----------------------------------------------------------------------------------
@pytest.mark.parametrize(("kwargs", "field"), [
    (dict(width=2**31), "width"), (dict(height=-(2**31) - 1), "height"), (dict(spp=2**40), "spp"),
    (dict(seed=2**64), "seed"), (dict(seed=-1), "seed"), (dict(max_bounces=2**31), "max_bounces"),
    (dict(threads=2**63), "threads"), (dict(region=(0, 0, 2**31, 1)), "region width"),
])
def test_integers_are_range_checked_before_conversion(kwargs, field):
    args = dict(width=4, height=4) | kwargs
    with pytest.raises(ValueError, match=f"^{field} must be "):
        durer.render(unit_sphere(), durer.OrthographicCamera(**ORTHO), **args)
