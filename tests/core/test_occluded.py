"""`durer.occluded`: whether anything lies along each ray in [t_min, t_max) -- the any-hit search
(each ray's search stops at the first hit it finds), exactly where `cast` reports a hit."""

from __future__ import annotations

import numpy as np
import pytest

import durer
from durer.render import SPHERE_METHODS
from helpers.traversal_fuzz import Shape, make_case

# The cast cases of tests/core/test_bad_input.py, each asked of occluded: the same checks, the same errors.
BAD = [
    (([[0, np.nan, 0]], [[0, 0, 1]]), {}, ValueError, "origins"),
    (([[0, 0, 0]], [[0, -np.inf, 1]]), {}, ValueError, "directions"),
    (([[0, 0, 0], [1, 1, 1]], [[0, 0, 1], [0, 0, 0]]), {}, ValueError, "directions\\[1\\]"),
    (([0, 0, 0], [[0, 0, 1]]), {}, ValueError, "origins"),
    (([[0, 0, 0]], [[0, 0, 1], [0, 1, 0]]), {}, ValueError, "directions"),
    (([[0, 0, 0]], [[0, 0, 1]]), {"precision": "quad"}, ValueError, "precision"),
    (([[0, 0, 0]], [[0, 0, 1]]), {"sphere_method": "exact"}, ValueError, "sphere_method"),
    (([[0, 0, 0]], [[0, 0, 1]]), {"t_min": 2.0, "t_max": 1.0}, ValueError, "t_min"),
    (([[0, 0, 0]], [[0, 0, 1]]), {"threads": 0}, ValueError, "threads"),
    ((np.zeros((1, 3), complex), [[0, 0, 1]]), {}, TypeError, "origins"),
]


def two_spheres() -> durer.Scene:
    scene = durer.Scene()
    scene.add_spheres([[0, 0, 0], [0, 0, -10]], [1.0, 2.0])
    return scene


@pytest.mark.parametrize("precision", ["double", "float"])
def test_shadow_rays_by_hand(precision):
    # From z = 5 down -z: the unit sphere's surface at t = 4, the far sphere's at t = 13.
    origins, down = np.array([[0.0, 0, 5]] * 5), np.array([[0.0, 0, -1]] * 5)
    windows = [(0.0, np.inf), (0.0, 4.0), (0.0, 4.0001), (4.5, 12.9), (6.5, 14.0)]
    expected = [True, False, True, True, True]  # [t_min, t_max): t = 4 is outside [0, 4)
    # The far root of the unit sphere, t = 6, lies in [4.5, 12.9); from 6.5 on only the far sphere.
    for (t_min, t_max), want, o, d in zip(windows, expected, origins, down):
        got = durer.occluded(two_spheres(), [o], [d], t_min=t_min, t_max=t_max, precision=precision)
        assert got.dtype == bool and got.shape == (1,) and got[0] == want, (t_min, t_max)
    # Away from both, and beside them: nothing.
    assert not durer.occluded(two_spheres(), [[0, 0, 5], [3, 0, 5]], [[0, 0, 1], [0, 0, -1]]).any()
    # Behind the origin only with a negative t_min.
    assert durer.occluded(two_spheres(), [[0, 0, 5]], [[0, 0, 1]], t_min=-np.inf).all()


@pytest.mark.parametrize("seed", range(6))
def test_occluded_is_where_cast_hits_in_every_kind_of_scene(seed):
    # Spheres, triangles, boxes, a mesh and planes, some under transforms (their own hierarchies),
    # rays of every kind the traversal fuzz makes (fans, random, aimed, grazing, axis-parallel, leaving
    # surfaces), each ray range and both precisions: the any-hit search agrees with cast ray by ray.
    ranges = ["forward", "line", "window", "surface"]
    shape = Shape(seed, (120, 60, 60, 60, 2), seed % 4, 0.0, 0.0, 400, ["double", "float"][seed % 2], "robust",
                  ranges[seed % 4])
    case = make_case(shape)
    scene = case.scene()
    hits = np.isfinite(case.cast(scene).t)
    assert 0.05 * len(hits) < hits.sum() < len(hits)  # both answers, in earnest
    np.testing.assert_array_equal(case.occluded(scene), hits)


@pytest.mark.parametrize("method", SPHERE_METHODS)
def test_every_sphere_method_and_many_threads(method):
    rng = np.random.default_rng(5)
    scene = durer.Scene()
    scene.add_spheres(rng.uniform(-5, 5, (500, 3)), rng.uniform(0.05, 0.5, 500))
    origins, directions = rng.uniform(-6, 6, (5000, 3)), rng.normal(size=(5000, 3))
    hits = np.isfinite(durer.cast(scene, origins, directions, sphere_method=method, threads=2).t)
    np.testing.assert_array_equal(durer.occluded(scene, origins, directions, sphere_method=method, threads=2), hits)
    assert 0.2 * len(hits) < hits.sum() < 0.95 * len(hits)


def test_unchecked_bad_rays_are_not_occluded():
    got = durer.occluded(two_spheres(), [[0, 0, 5], [np.nan, 0, 5], [0, 0, 5]], [[0, 0, -1], [0, 0, -1], [0, 0, 0]],
                         check=False)
    np.testing.assert_array_equal(got, [True, False, False])


@pytest.mark.parametrize(("arguments", "options", "error", "field"), BAD)
def test_bad_input_is_rejected_as_cast_rejects_it(arguments, options, error, field):
    for call in (durer.cast, durer.occluded):
        with pytest.raises(error, match=field):
            call(two_spheres(), *arguments, **options)
    with pytest.raises(TypeError, match="scene"):
        durer.occluded("scene", [[0, 0, 0]], [[0, 0, 1]])


def test_cancel_stops_it():
    with pytest.raises(RuntimeError, match="cancelled"):
        durer.occluded(two_spheres(), np.zeros((200_000, 3)), np.tile([0.0, 0, 1], (200_000, 1)), cancel=lambda: True)
