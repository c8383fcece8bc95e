"""Axis-aligned boxes: the slab test against the analytic answer, faces, inside origins, bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest

import durer


def reference(lo, hi, origins, directions, t_min=0.0):
    """Closest box hit per ray by the slab method in double (numpy), entry or, from inside, exit."""
    best_t = np.full(len(origins), np.inf)
    best = np.full(len(origins), -1)
    with np.errstate(divide="ignore", invalid="ignore"):
        for i, (a, b) in enumerate(zip(lo, hi)):
            t0, t1 = (a - origins) / directions, (b - origins) / directions
            near = np.minimum(t0, t1).max(axis=1)
            far = np.maximum(t0, t1).min(axis=1)
            t = np.where(near >= t_min, near, far)
            closer = (near <= far) & (t >= t_min) & (t < best_t)
            best_t[closer], best[closer] = t[closer], i
    return best_t, best


@pytest.mark.parametrize("count", [5, 300])  # below and above the hierarchy's threshold
def test_random_boxes_match_the_slab_method(rng, precision, count):
    lo = rng.uniform(-10, 10, (count, 3))
    hi = lo + rng.uniform(0.1, 2, (count, 3))
    origins = rng.uniform(-12, 12, (2000, 3))
    directions = rng.normal(size=(2000, 3))
    scene = durer.Scene()
    ids = scene.add_boxes(lo, hi)
    hit = durer.cast(scene, origins, directions, precision=precision)
    t, best = reference(lo, hi, origins, directions)
    assert (best >= 0).sum() > (200 if count > 100 else 5)
    np.testing.assert_array_equal(hit.object_id, np.where(best >= 0, ids[np.maximum(best, 0)], -1))
    hits = best >= 0
    # t = (lo − o)/d: its error is a rounding of the coordinates (~1e-6 in float), whatever t's size.
    tolerance = dict(rtol=1e-5, atol=1e-4) if precision == "float" else dict(rtol=1e-13, atol=1e-12)
    np.testing.assert_allclose(hit.t[hits], t[hits], **tolerance)


def test_faces_give_axis_normals_and_the_point_on_the_face():
    scene = durer.Scene()
    scene.add_boxes([[-1, -2, -3]], [[1, 2, 3]])
    origins = np.array([[5, 0.5, 0.5], [-5, 0.5, 0.5], [0.2, 5, 0.1], [0.2, -5, 0.1], [0.3, 0.3, 9], [0.3, 0.3, -9]])
    directions = -np.sign(origins) * (np.abs(origins) == np.abs(origins).max(axis=1, keepdims=True))
    hit = durer.cast(scene, origins, directions)
    np.testing.assert_array_equal(hit.t, [4, 4, 3, 3, 6, 6])
    np.testing.assert_array_equal(hit.normal, -directions)


def test_origin_inside_meets_the_exit_and_t_min_minus_infinity_the_entry():
    scene = durer.Scene()
    scene.add_boxes([[-1, -1, -1]], [[1, 1, 1]])
    inside = durer.cast(scene, [[0, 0, 0.5]], [[0, 0, 1]])
    assert inside.t[0] == 0.5 and inside.normal[0].tolist() == [0, 0, 1]
    behind = durer.cast(scene, [[0, 0, 0.5]], [[0, 0, 1]], t_min=-math.inf)
    assert behind.t[0] == -1.5 and behind.normal[0].tolist() == [0, 0, -1]


def test_grazing_and_parallel_rays_never_give_nan():
    scene = durer.Scene()
    scene.add_boxes([[0, 0, 0]], [[1, 1, 1]])
    origins = [[0, 0.5, 5], [1, 0.5, 5], [2, 0.5, 5], [-1, 0, 0], [0.5, 0.5, 5]]
    directions = [[0, 0, -1], [0, 0, -1], [0, 0, -1], [1, 0, 0], [0, 0, -1]]
    hit = durer.cast(scene, origins, directions)
    # Rays in a face plane count as inside that slab (as the BVH does); a ray beside the box misses.
    np.testing.assert_array_equal(hit.object_id, [0, 0, -1, 0, 0])
    assert not np.isnan(hit.t).any() and not np.isnan(hit.normal).any()
    np.testing.assert_array_equal(hit.t[[0, 1, 3, 4]], [4, 4, 1, 4])


def test_render_of_a_box_under_lights_and_shadows():
    # A box [-1, 1] x [1, 2] x [-1, 1] over the floor y = 0, lit along (1, -1, 0): its shadow covers
    # the floor for x in [0, 3], |z| < 1, of which the part x > 1 shows beside it from above. Lit
    # surfaces (the box top, the floor) get ambient + kd·cos 45°; the shadow gets ambient only, and no
    # lit pixel is darkened by acne.
    scene = durer.Scene()
    grey = scene.add_material((0.5, 0.5, 0.5))
    scene.add_boxes([[-1, 1, -1]], [[1, 2, 1]], grey)
    scene.add_plane((0, 1, 0), 0.0, grey)
    scene.add_directional_light((1, -1, 0), (1, 1, 1), shadows=True)
    scene.ambient = (0.2, 0.2, 0.2)
    camera = durer.OrthographicCamera((0, 10, 0), (0, -1, 0), (0, 0, -1), size=8.0)  # image x = world x
    color = durer.render(scene, camera, 80, 80, passes="color").color[..., :3]
    lit, shadowed = 0.5 * 0.2 + 0.5 * math.sqrt(0.5), 0.5 * 0.2
    np.testing.assert_allclose(color[32:48, 32:48], lit, rtol=1e-6)  # box top: x, z in (-0.8, 0.8)
    np.testing.assert_allclose(color[32:48, 52:68], shadowed, rtol=1e-6)  # floor, x in (1.2, 2.8)
    np.testing.assert_allclose(color[32:48, 72:80], lit, rtol=1e-6)  # floor beyond the shadow
    np.testing.assert_allclose(color[:25], lit, rtol=1e-6)  # floor behind the box (z < -1.5)


def test_bad_boxes_name_the_argument():
    scene = durer.Scene()
    with pytest.raises(ValueError, match=r"lo\[1\] must be < hi\[1\] in every axis"):
        scene.add_boxes([[0, 0, 0], [0, 0, 0]], [[1, 1, 1], [1, 0, 1]])
    with pytest.raises(ValueError, match="lo must be finite"):
        scene.add_boxes([[0, np.inf, 0]], [[1, 1, 1]])
    with pytest.raises(ValueError, match=r"hi must have shape \(1, 3\)"):
        scene.add_boxes([[0, 0, 0]], [[1, 1, 1], [2, 2, 2]])
    with pytest.raises(ValueError, match="material 3 is not a material id"):
        scene.add_boxes([[0, 0, 0]], [[1, 1, 1]], 3)
    assert scene.box_count == 0 and scene.object_count == 0
