"""Scenes and cameras pickle (for Dask workers): an unpickled scene renders the same image."""

from __future__ import annotations

import pickle
import tracemalloc

import numpy as np
import pytest

import durer

from helpers.distributed import assert_same_image, every_kind_scene, orbit_cameras


def test_unpickled_scene_renders_bit_identical_with_same_ids():
    scene = every_kind_scene()
    scene.shading = "lit"
    copy = pickle.loads(pickle.dumps(scene))
    assert repr(copy) == repr(scene) and copy.object_count == scene.object_count
    assert (copy.background, copy.ambient, copy.shading) == (scene.background, scene.ambient, "lit")
    camera = orbit_cameras(3)[1]
    for options in ({"spp": 4}, {"spp": 9, "sampler": "sobol", "precision": "float"}):
        assert_same_image(durer.render(scene, camera, 48, 32, **options), durer.render(copy, camera, 48, 32, **options))
    origins, directions = camera.rays(48, 32)
    hits, hits_copy = (durer.cast(s, origins.reshape(-1, 3), directions.reshape(-1, 3)) for s in (scene, copy))
    assert (hits.object_id >= 0).sum() > 500  # the view sees many objects
    assert np.array_equal(hits.object_id, hits_copy.object_id)
    assert np.array_equal(hits.material_id, hits_copy.material_id)
    assert np.array_equal(hits.t, hits_copy.t)


def test_pickled_scene_keeps_what_was_added_not_later_changes_to_the_callers_arrays():
    centers = np.array([[0.0, 0.0, 0.0], [2.0, 0.0, 0.0]])
    radii = np.array([0.5, 0.7])
    scene = durer.Scene()
    scene.add_spheres(centers, radii)
    before = durer.render(scene, durer.OrthographicCamera((1, 0, 5), (0, 0, -1), (0, 1, 0), size=4), 32, 32)
    centers += 10.0  # the caller reuses its arrays: the scene must not see it
    radii[:] = 0.01
    copy = pickle.loads(pickle.dumps(scene))
    after = durer.render(copy, durer.OrthographicCamera((1, 0, 5), (0, 0, -1), (0, 1, 0), size=4), 32, 32)
    assert_same_image(before, after)
    assert np.isfinite(after.depth).sum() > 100  # both spheres are in view


def test_failed_add_is_not_recorded():
    scene = durer.Scene()
    scene.add_spheres([[0, 0, 0]], 1.0)
    with pytest.raises(ValueError, match="radii"):
        scene.add_spheres([[1, 0, 0], [2, 0, 0]], [1.0, -1.0])
    with pytest.raises(ValueError):
        scene.add_mesh([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 5]])  # the core rejects the index
    copy = pickle.loads(pickle.dumps(scene))
    assert copy.object_count == scene.object_count == 1 and copy.sphere_count == 1


def test_record_of_a_large_sphere_array_costs_one_copy_at_most():
    n = 400_000
    rng = np.random.default_rng(1)
    centers32 = rng.uniform(-100, 100, (n, 3)).astype(np.float32)  # converted: the conversion is the record
    centers64 = centers32.astype(np.float64)                        # the caller's array: copied once
    for centers in (centers32, centers64):
        scene = durer.Scene()
        tracemalloc.start()
        scene.add_spheres(centers, 0.1)
        kept, _ = tracemalloc.get_traced_memory()
        tracemalloc.stop()
        record = 24 * n + 8 * n  # float64 centres and radii
        assert record <= kept < 1.1 * record + 100_000, kept
        recorded_centers = scene._adds[0][1][0]
        assert not np.shares_memory(recorded_centers, centers) and not recorded_centers.flags.writeable
        del scene


@pytest.mark.parametrize("camera", [
    durer.PerspectiveCamera((1, 2, 3), (0, -0.2, -1), (0, 1, 0.1), fov_degrees=35, fit="vertical", shift=(0.1, -0.2),
                            pixel_aspect=1.25, t_min=0.5, t_max=40.0),
    durer.OrthographicCamera((0, 0, 5), (0, 0, -1), (1, 1, 0), size=3.5, fit="horizontal", t_min=-2.0),
])
def test_cameras_pickle_to_equal_cameras_with_the_same_rays(camera):
    copy = pickle.loads(pickle.dumps(camera))
    assert copy == camera and type(copy) is type(camera)
    for a, b in zip(camera.rays(7, 5), copy.rays(7, 5)):
        assert np.array_equal(a, b)


def test_empty_scene_and_settings_alone_pickle():
    scene = durer.Scene()
    scene.background = (0.2, 0.3, 0.4, 0.5)
    scene.shading = "flat"
    copy = pickle.loads(pickle.dumps(scene))
    assert (copy.object_count, copy.material_count, copy.background, copy.shading) == (0, 1, scene.background, "flat")
    camera = durer.OrthographicCamera((0, 0, 1), (0, 0, -1), (0, 1, 0))
    assert_same_image(durer.render(copy, camera, 4, 3), durer.render(scene, camera, 4, 3))
