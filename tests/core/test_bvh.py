"""The sphere hierarchy (used from 16 spheres on) finds exactly what testing every sphere finds."""

from __future__ import annotations

import math

import numpy as np

import durer


def brute_force(centers, radii, origins, directions, **kwargs):
    """Closest hit by casting against one sphere at a time (below the hierarchy's threshold)."""
    best_t = np.full(len(origins), np.inf)
    best_id = np.full(len(origins), -1)
    for i, (c, r) in enumerate(zip(centers, radii)):
        scene = durer.Scene()
        scene.add_spheres([c], [r])
        hit = durer.cast(scene, origins, directions, **kwargs)
        closer = hit.t < best_t
        best_t[closer] = hit.t[closer]
        best_id[closer] = i
    return best_t, best_id


def assert_same_as_brute_force(centers, radii, origins, directions, **kwargs):
    scene = durer.Scene()
    scene.add_spheres(centers, radii)
    hit = durer.cast(scene, origins, directions, **kwargs)
    t, ids = brute_force(centers, radii, origins, directions, **kwargs)
    np.testing.assert_array_equal(hit.object_id, ids)
    np.testing.assert_array_equal(hit.t, t.astype(hit.t.dtype))
    return hit


def test_random_spheres_and_rays(rng, precision, method):
    centers = rng.uniform(-10, 10, (120, 3))
    radii = rng.uniform(0.1, 2.0, 120)
    origins = rng.uniform(-15, 15, (1500, 3))
    directions = rng.normal(size=(1500, 3))
    hit = assert_same_as_brute_force(centers, radii, origins, directions, precision=precision, sphere_method=method)
    assert 300 < (hit.object_id >= 0).sum() < 1500


def test_axis_parallel_rays_and_origins_on_box_planes(rng):
    # Zero direction components give infinite slab distances; origins on a box face give 0·inf.
    centers = np.array([[x, y, 0.0] for x in range(5) for y in range(5)], float)
    radii = np.full(len(centers), 0.5)
    xs = np.linspace(-1, 5, 61)
    origins = np.array([[x, y, 10.0] for x in xs for y in (-0.5, 0.0, 0.5, 1.5, 2.25)])  # x = -0.5 ... on faces
    directions = np.tile([0.0, 0.0, -1.0], (len(origins), 1))
    hit = assert_same_as_brute_force(centers, radii, origins, directions)
    assert (hit.object_id >= 0).sum() > 50
    sideways = np.array([[-5, y, 0.0] for y in np.linspace(-1, 5, 25)])
    assert_same_as_brute_force(centers, radii, sideways, np.tile([1.0, 0, 0], (25, 1)))


def test_orthographic_t_min_minus_infinity_sees_spheres_behind(rng):
    centers = rng.uniform(-5, 5, (64, 3))
    radii = rng.uniform(0.2, 0.6, 64)
    origins = np.column_stack([rng.uniform(-5, 5, (400, 2)), np.zeros(400)])  # inside the cloud
    directions = np.tile([0.0, 0, -1], (400, 1))
    hit = assert_same_as_brute_force(centers, radii, origins, directions, t_min=-math.inf)
    assert (hit.t[hit.object_id >= 0] < 0).any()


def test_degenerate_sets(rng):
    # All at one centre; all on a line; sizes over twelve orders of magnitude.
    same = np.zeros((40, 3))
    assert_same_as_brute_force(same, np.linspace(0.5, 2, 40), rng.uniform(-5, 5, (200, 3)), rng.normal(size=(200, 3)))
    line = np.column_stack([np.linspace(-20, 20, 50), np.zeros(50), np.zeros(50)])
    assert_same_as_brute_force(line, np.full(50, 0.3), rng.uniform(-25, 25, (300, 3)), rng.normal(size=(300, 3)))
    scales = np.column_stack([10.0 ** rng.uniform(-6, 6, 30), rng.uniform(-1, 1, (30, 2))])
    radii = 10.0 ** rng.uniform(-7, 2, 30)
    assert_same_as_brute_force(scales, radii, rng.uniform(-1e6, 1e6, (300, 3)), rng.normal(size=(300, 3)),
                               t_min=-math.inf)


def test_render_uses_the_hierarchy_consistently():
    # A render over many spheres equals the per-pixel brute-force answer.
    rng = np.random.default_rng(3)
    centers = rng.uniform(-4, 4, (300, 3))
    radii = rng.uniform(0.05, 0.4, 300)
    scene = durer.Scene()
    scene.add_spheres(centers, radii)
    camera = durer.PerspectiveCamera((0, 0, 12), (0, 0, -1), (0, 1, 0), 45.0)
    result = durer.render(scene, camera, 48, 36, passes="depth")
    origins, directions = camera.rays(48, 36)
    t, _ = brute_force(centers, radii, origins.reshape(-1, 3), directions.reshape(-1, 3))
    np.testing.assert_array_equal(result.depth.ravel(), t.astype(np.float32))


def test_adding_spheres_after_a_render_rebuilds():
    scene = durer.Scene()
    scene.add_spheres(np.column_stack([np.arange(20.0), np.zeros(20), np.zeros(20)]), 0.4)
    probe = dict(origins=[[100.0, 0, 10]], directions=[[0.0, 0, -1]])
    assert durer.cast(scene, **probe).object_id[0] == -1
    scene.add_spheres([[100.0, 0, 0]], 0.5)
    assert durer.cast(scene, **probe).object_id[0] == 20


def test_ray_lying_in_a_box_face():
    # Spheres of radius 0.5 at integer x: a box face of the leaf holding x = 0..3 lies at exactly
    # x = -0.5 after outward rounding only if the rounding is exact; aim rays along that plane and
    # along sphere extremes, where 0·inf arises.
    centers = np.array([[float(i), 0.0, 0.0] for i in range(32)])
    radii = np.full(32, 0.5)
    lo = np.nextafter(-0.5, -np.inf)
    origins = np.array([[lo, 0.0, 10.0], [-0.5, 0.0, 10.0], [lo, 0.0, -10.0]])
    directions = np.array([[0.0, 0.0, -1.0], [0.0, 0.0, -1.0], [0.0, 0.0, 1.0]])
    assert_same_as_brute_force(centers, radii, origins, directions)


def test_rays_parallel_to_box_faces_are_culled():
    # Orthographic rays with a zero direction component (here x): slab distances are infinite. The
    # hierarchy must still skip the boxes these rays miss, not visit every node (slack on an
    # infinite end used to give NaN, which counted as "entering").
    rng = np.random.default_rng(5)
    scene = durer.Scene()
    scene.add_spheres(rng.uniform(-10, 10, (2000, 3)) * [1, 1, 0.1], rng.uniform(0.02, 0.08, 2000))
    camera = durer.OrthographicCamera((0, 0, 5), (0, -0.4, -1), (0, 1, 0), 20.0)
    stats = durer.render(scene, camera, 64, 64, passes="depth").stats
    assert stats["intersection_tests"] < 100 * stats["rays"]  # every node visited: 2000 tests per ray
    origins, directions = camera.rays(16, 16)  # and the hierarchy still finds what brute force finds
    centers = rng.uniform(-10, 10, (40, 3)) * [1, 1, 0.1]
    assert_same_as_brute_force(centers, np.full(40, 0.5), origins.reshape(-1, 3), directions.reshape(-1, 3),
                               t_min=-math.inf)
