"""The normal pass of supersampled pixels (issue 18, item 4): a unit normal on every hit pixel. It is
the normalised mean of the pixel's hit samples' normals; where those (nearly) cancel -- the mean
shorter than 1/1024 of the hit samples' count -- the nearest hit sample's normal."""

from __future__ import annotations

import numpy as np
import pytest

import durer
from durer.render import PRECISIONS

DOWN = durer.OrthographicCamera((0, 0, 5), (0, 0, -1), (0, 1, 0), 3.0)  # pixels x in [-1.5, -.5], [-.5, .5], [.5, 1.5]


def facing_halves(far_normal_z: float = 1.0, near_z: float = 1.0) -> durer.Scene:
    """Left half (x < 0): a plane at z = 0 facing +z; right half: a plane at z = near_z facing -z
    (away from the camera). The middle pixel's four stratified samples see two of each."""
    scene = durer.Scene()
    scene.add_plane((0, 0, far_normal_z), 0.0, bounds=((-2, -1, 0), (2, 0, 0), (0, 2, 0)))
    scene.add_plane((0, 0, -1), -near_z, bounds=((0, -1, near_z), (2, 0, 0), (0, 2, 0)))
    return scene


@pytest.mark.parametrize("passes", [("normal",), ("color", "depth", "normal")], ids=["normal-only", "all"])
@pytest.mark.parametrize("sampler", ["stratified", "adaptive"])
@pytest.mark.parametrize("precision", PRECISIONS)
def test_samples_on_opposite_faces_give_the_nearest_samples_normal(precision, sampler, passes):
    result = durer.render(facing_halves(), DOWN, 3, 1, spp=4, sampler=sampler, precision=precision, passes=passes)
    np.testing.assert_array_equal(result.normal[0], [[0, 0, 1], [0, 0, -1], [0, 0, -1]])


@pytest.mark.parametrize("precision", PRECISIONS)
def test_a_tie_takes_the_first_nearest_sample(precision):
    """Both halves at z = 0: every sample of the middle pixel is equally near; the first one taken
    (the stratified grid's first stratum, at x < 0) gives the normal."""
    result = durer.render(facing_halves(near_z=0.0), DOWN, 3, 1, spp=4, precision=precision, passes=("normal",))
    np.testing.assert_array_equal(result.normal[0], [[0, 0, 1], [0, 0, 1], [0, 0, -1]])


@pytest.mark.parametrize("precision", PRECISIONS)
def test_samples_that_agree_give_their_normalised_mean(precision):
    """shade_back flips the far face toward the camera: the samples agree and the mean is +z. With a
    tilted left plane the middle pixel's mean of two tilted and two flat normals is their bisector."""
    result = durer.render(facing_halves(), DOWN, 3, 1, spp=4, precision=precision, shade_back=True)
    np.testing.assert_array_equal(result.normal[0], [[0, 0, 1]] * 3)
    scene = durer.Scene()
    tilt = np.array([0.0, 0.6, 0.8])
    scene.add_plane(tilt, 0.0, bounds=((-2, -1, 0.75), (2, 0, 0), (0, 2, -1.5)))
    scene.add_plane((0, 0, 1), -1.0, bounds=((0, -1, -1), (2, 0, 0), (0, 2, 0)))
    result = durer.render(scene, DOWN, 3, 1, spp=4, precision=precision, passes=("normal",))
    bisector = (tilt + (0, 0, 1)) / np.linalg.norm(tilt + (0, 0, 1))
    np.testing.assert_allclose(result.normal[0, 1], bisector, atol=1e-6)
    np.testing.assert_allclose(np.linalg.norm(result.normal[0], axis=-1), 1.0, atol=1e-6)


@pytest.mark.parametrize("precision", PRECISIONS)
def test_a_pixel_half_missed_keeps_its_hit_normal(precision):
    """Two of four samples miss: the normal is the hits' (unit), the depth the nearest hit's."""
    scene = durer.Scene()
    scene.add_plane((0, 0, 1), 0.0, bounds=((-2, -1, 0), (2, 0, 0), (0, 2, 0)))
    result = durer.render(scene, DOWN, 3, 1, spp=4, precision=precision)
    np.testing.assert_array_equal(result.normal[0], [[0, 0, 1], [0, 0, 1], [0, 0, 0]])
    np.testing.assert_array_equal(result.depth[0], [5, 5, np.inf])


def mixed_scene() -> durer.Scene:
    """Spheres and planes (the normal pass's own branch-free loop: unbounded planes, and a bounded one
    seen from behind) beside a triangle, a box and an ellipsoid (their hit records)."""
    rng = np.random.default_rng(18)
    scene = durer.Scene()
    scene.add_spheres(rng.uniform((-3, -1, -6), (3, 2, -1), (30, 3)), rng.uniform(0.1, 0.6, 30))
    scene.add_plane((0, 1, 0), -1.0)
    scene.add_plane((0.2, 0.1, 1.0), -8.0)
    scene.add_plane((0, 0, -1), 2.0, bounds=((-3, 1.2, -2), (1.5, 0, 0), (0, 1, 0)))  # faces away from the camera
    scene.add_triangles([[[-3, -1, -3], [-1, -1, -3], [-2, 1, -4]]])
    scene.add_boxes([[1.0, -1.0, -2.5]], [[1.8, -0.2, -1.7]])
    scene.add_spheres([[0.0, 0.0, 0.0]], 0.5, transform=np.diag([1.0, 2.0, 1.0, 1.0]))
    return scene


@pytest.mark.parametrize("shade_back", [False, True])
@pytest.mark.parametrize("precision", PRECISIONS)
def test_one_sample_normals_are_the_hit_records_bit_for_bit(precision, shade_back):
    # The pass computes its spheres' and planes' normals itself, over a packet at a time; durer.cast
    # takes every normal from a hit record. At one sample per pixel (its centre) they are the same
    # bits, turned towards the ray where shade_back asks for it.
    scene = mixed_scene()
    camera = durer.PerspectiveCamera((0.3, 0.8, 4.0), (0, -0.1, -1), (0, 1, 0), fov_degrees=75)
    width, height = 64, 40
    result = durer.render(scene, camera, width, height, passes=("normal",), precision=precision, shade_back=shade_back)
    origins, directions = camera.rays(width, height, precision)
    hits = durer.cast(scene, origins.reshape(-1, 3), directions.reshape(-1, 3), precision=precision)
    normals = hits.normal
    if shade_back:
        facing_away = np.einsum("ij,ij->i", directions.reshape(-1, 3).astype(normals.dtype), normals) > 0
        normals = np.where(facing_away[:, None], -normals, normals)
    seen = set(np.unique(hits.object_id).tolist())
    assert set(range(30, 36)) <= seen and len(seen & set(range(30))) > 15  # every plane and the rest, most spheres
    np.testing.assert_array_equal(result.normal.reshape(-1, 3), normals.astype(np.float32))
