"""Analytic ray/sphere and ray/plane answers through the public `cast` API."""

from __future__ import annotations

import math

import numpy as np
import pytest

import durer
from durer.render import SPHERE_METHODS
from helpers.core import cast_one, tolerance, unit_sphere_scene


@pytest.mark.parametrize(
    ("origin", "direction", "t", "normal"),
    [
        ((0, 0, 5), (0, 0, -1), 4.0, (0, 0, 1)),          # two roots, the near one
        ((0, 0, 5), (0, 0, -2), 2.0, (0, 0, 1)),          # t is in units of the direction
        ((0, 0, 5), (0, 0, -0.25), 16.0, (0, 0, 1)),
        ((0, 0, 0.5), (0, 0, -1), 1.5, (0, 0, -1)),       # origin inside: the far root, outward normal
        ((0, 0, 0), (1, 0, 0), 1.0, (1, 0, 0)),           # from the centre
        ((3, 4, 12), (-3, -4, -12), 1 - 1 / 13, (3 / 13, 4 / 13, 12 / 13)),  # oblique, off-axis
        ((0.6, 0, 5), (0, 0, -1), 5 - 0.8, (0.6, 0, 0.8)),
    ],
)
def test_sphere_hits(origin, direction, t, normal, method, precision):
    hit = cast_one(unit_sphere_scene(), origin, direction, sphere_method=method, precision=precision)
    assert hit.t[0] == pytest.approx(t, rel=tolerance(precision) * 10, abs=1e-6 if precision == "float" else 1e-13)
    np.testing.assert_allclose(hit.normal[0], normal, atol=1e-5 if precision == "float" else 1e-12)
    assert hit.object_id[0] == 0 and hit.material_id[0] == 0
    assert hit.t.dtype == (np.float32 if precision == "float" else np.float64)


@pytest.mark.parametrize(
    ("origin", "direction"),
    [
        ((0, 0, 5), (0, 0, 1)),        # sphere behind the origin
        ((2, 0, 5), (0, 0, -1)),       # passes beside it
        ((1.001, 0, 5), (0, 0, -1)),   # just outside the tangent
        ((0, 5, 0), (1, 0, 0)),        # parallel, far
    ],
)
def test_sphere_misses(origin, direction, method, precision):
    hit = cast_one(unit_sphere_scene(), origin, direction, sphere_method=method, precision=precision)
    assert math.isinf(hit.t[0]) and hit.t[0] > 0
    assert hit.object_id[0] == -1 and hit.material_id[0] == -1
    np.testing.assert_array_equal(hit.normal[0], 0)


def test_exact_tangent(method, precision):
    # The double root t = 5. The lecture's formulas see it; the robust method reports a hit only
    # where the discriminant exceeds its rounding-error bound, so an exact graze is a miss.
    hit = cast_one(unit_sphere_scene(), (1, 0, 5), (0, 0, -1), sphere_method=method, precision=precision)
    if method == "robust":
        assert hit.object_id[0] == -1 and math.isinf(hit.t[0])
    else:
        assert hit.object_id[0] == 0 and hit.t[0] == pytest.approx(5.0)
    inside = cast_one(unit_sphere_scene(), (1 - 1e-3, 0, 5), (0, 0, -1), sphere_method=method, precision=precision)
    assert inside.object_id[0] == 0 and inside.t[0] == pytest.approx(5 - math.sqrt(1 - (1 - 1e-3) ** 2), rel=1e-4)


def test_sphere_behind_is_hit_with_negative_t_min(method):
    # The orthographic camera's t_min = -inf: objects behind the ray origin are visible.
    hit = cast_one(unit_sphere_scene(), (0, 0, 5), (0, 0, 1), t_min=-math.inf, sphere_method=method)
    assert hit.t[0] == pytest.approx(-6.0)
    np.testing.assert_allclose(hit.normal[0], (0, 0, -1), atol=1e-12)  # at (0, 0, -1)


def test_t_range_selects_the_root(method):
    scene = unit_sphere_scene()
    assert cast_one(scene, (0, 0, 5), (0, 0, -1), t_min=4.5, sphere_method=method).t[0] == pytest.approx(6.0)
    assert math.isinf(cast_one(scene, (0, 0, 5), (0, 0, -1), t_min=6.5, sphere_method=method).t[0])
    assert math.isinf(cast_one(scene, (0, 0, 5), (0, 0, -1), t_max=4.0, sphere_method=method).t[0])  # [t_min, t_max)
    assert cast_one(scene, (0, 0, 5), (0, 0, -1), t_max=4.0001, sphere_method=method).t[0] == pytest.approx(4.0)


def test_methods_agree_on_random_ordinary_rays(rng, precision):
    scene = durer.Scene()
    centers = rng.uniform(-5, 5, (50, 3))
    scene.add_spheres(centers, rng.uniform(0.2, 1.5, 50))
    origins = rng.uniform(-10, 10, (2000, 3))
    directions = rng.normal(size=(2000, 3)) * rng.uniform(0.1, 10, (2000, 1))
    results = {m: durer.cast(scene, origins, directions, sphere_method=m, precision=precision) for m in SPHERE_METHODS}
    base = results["robust"]
    assert 100 < np.isfinite(base.t).sum() < 2000  # a real mix of hits and misses
    for name, r in results.items():
        # Rays grazing a sphere within rounding may legitimately flip; ordinary ones must not.
        same = r.object_id == base.object_id
        assert same.mean() > 0.998, name
        both = same & np.isfinite(base.t)
        np.testing.assert_allclose(r.t[both], base.t[both], rtol=1e-3 if precision == "float" else 1e-9)


def plane_scene(normal=(0, 1, 0), offset=-1.0, **kwargs) -> durer.Scene:
    scene = durer.Scene()
    scene.add_plane(normal, offset, **kwargs)
    return scene


@pytest.mark.parametrize(
    ("origin", "direction", "t"),
    [
        ((0, 0, 0), (0, -1, 0), 1.0),
        ((0, 0, 0), (0, -4, 0), 0.25),
        ((3, 2, -7), (1, -1, 0), 3.0),
        ((0, 0, 0), (0, 1, 0), math.inf),    # plane behind
        ((0, 0, 0), (1, 0, 0), math.inf),    # parallel
        ((0, -1, 0), (1, 0, 0), math.inf),   # lying in the plane (0/0)
        ((0, -1, 0), (0, -1, 0), 0.0),       # origin on the plane: t = 0 is in [0, inf)
    ],
)
def test_plane(origin, direction, t, precision):
    hit = cast_one(plane_scene(), origin, direction, precision=precision)
    assert hit.t[0] == pytest.approx(t)
    expected_normal = (0, 0, 0) if math.isinf(t) else (0, 1, 0)
    np.testing.assert_allclose(hit.normal[0], expected_normal)


def test_plane_normal_need_not_be_unit():
    # 2y = -2 is the plane y = -1; its unit normal is reported.
    hit = cast_one(plane_scene(normal=(0, 2, 0), offset=-2), (0, 5, 0), (0, -1, 0))
    assert hit.t[0] == pytest.approx(6.0)
    np.testing.assert_allclose(hit.normal[0], (0, 1, 0))


def test_plane_normal_is_not_flipped():
    hit = cast_one(plane_scene(), (0, -3, 0), (0, 1, 0))  # from below
    assert hit.t[0] == pytest.approx(2.0)
    np.testing.assert_allclose(hit.normal[0], (0, 1, 0))


@pytest.mark.parametrize(
    ("x", "y", "hits"),
    [
        (0.0, 0.0, True), (0.999, 0.5, True), (-0.999, -0.999, True),
        (1.0, 0.0, True), (-1.0, 1.0, True),             # the edges belong to the rectangle
        (1.001, 0.0, False), (0.0, -1.001, False), (5.0, 5.0, False),
    ],
)
def test_bounded_plane_edges(x, y, hits, precision):
    scene = durer.Scene()
    scene.add_plane((0, 0, 1), 0.0, bounds=((-1, -1, 0), (2, 0, 0), (0, 2, 0)))
    hit = cast_one(scene, (x, y, 3), (0, 0, -1), precision=precision)
    assert bool(hit.object_id[0] == 0) is hits
    assert hit.t[0] == (pytest.approx(3.0) if hits else math.inf)


def test_bounded_parallelogram():
    # Skewed edges: the region is corner + a*e1 + b*e2, not its bounding box.
    scene = durer.Scene()
    scene.add_plane((0, 0, 1), 2.0, bounds=((0, 0, 2), (2, 0, 0), (1, 1, 0)))
    origins = np.array([[1.5, 0.5, 5], [0.2, 0.8, 5], [2.9, 0.95, 5], [2.5, 0.2, 5]], float)
    hit = durer.cast(scene, origins, np.tile([0.0, 0, -1], (4, 1)))
    np.testing.assert_array_equal(hit.object_id, [0, -1, 0, -1])


def test_closest_of_several_objects(precision):
    scene = durer.Scene()
    red, green = scene.add_material((1, 0, 0)), scene.add_material((0, 1, 0))
    far_ids = scene.add_spheres([[0, 0, -6], [0, 0, -3]], [1.0, 1.0], material=np.array([red, green]))
    near_id = scene.add_spheres([[0, 0, 0]], 1.0)[0]
    wall = scene.add_plane((0, 0, 1), -10.0, material=red)
    origins = np.array([[0, 0, 5], [0, 0, 5], [0, 0, 5], [0, 3, 5]], float)
    directions = np.tile([0.0, 0, -1], (4, 1))
    hit = durer.cast(scene, origins, directions, precision=precision)
    assert list(far_ids) == [0, 1] and near_id == 2 and wall == 3
    np.testing.assert_array_equal(hit.object_id[:1], [near_id])
    np.testing.assert_array_equal(hit.object_id[3:], [wall])
    np.testing.assert_allclose(hit.t[[0, 3]], [4.0, 15.0])
    # Past the near sphere's entry point the exit is the closest hit; beyond it, the next sphere.
    hit = durer.cast(scene, origins[:2], directions[:2], t_min=4.5, precision=precision)
    np.testing.assert_allclose(hit.t, [6.0, 6.0])
    hit = durer.cast(scene, origins[:1], directions[:1], t_min=6.5, precision=precision)
    assert hit.object_id[0] == far_ids[1] and hit.material_id[0] == green and hit.t[0] == pytest.approx(7.0)


def test_cast_many_rays_matches_one_by_one(rng):
    scene = durer.Scene()
    scene.add_spheres(rng.uniform(-3, 3, (20, 3)), rng.uniform(0.3, 1.0, 20))
    scene.add_plane((0.1, 1, 0.2), -2.5)
    origins = rng.uniform(-8, 8, (3000, 3))  # several work items and a partial packet
    directions = rng.normal(size=(3000, 3))
    bulk = durer.cast(scene, origins, directions, threads=2)
    for i in rng.choice(3000, 40, replace=False):
        one = durer.cast(scene, origins[i : i + 1], directions[i : i + 1], threads=1)
        assert one.object_id[0] == bulk.object_id[i]
        assert one.t[0] == bulk.t[i]


def test_cast_empty_scene_and_no_rays():
    scene = durer.Scene()
    hit = cast_one(scene, (0, 0, 0), (1, 0, 0))
    assert math.isinf(hit.t[0]) and hit.object_id[0] == -1
    none = durer.cast(unit_sphere_scene(), np.empty((0, 3)), np.empty((0, 3)))
    assert none.t.shape == (0,) and none.normal.shape == (0, 3)


def test_unchecked_cast_misses_for_nan_and_zero_directions(method, precision):
    scene = unit_sphere_scene()
    scene.add_plane((0, 1, 0), -1.0)
    nan = math.nan
    origins = np.array([[0, 0, 5], [nan, 0, 5], [0, 0, 5], [0, 0, 5], [0, math.inf, 5]], float)
    directions = np.array([[0, 0, -1], [0, 0, -1], [nan, 0, -1], [0, 0, 0], [0, -1, 0]], float)
    hit = durer.cast(scene, origins, directions, check=False, sphere_method=method, precision=precision)
    np.testing.assert_array_equal(hit.object_id, [0, -1, -1, -1, -1])
    assert np.isinf(hit.t[1:]).all()
