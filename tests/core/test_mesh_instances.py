"""Scene.add_mesh_instances: one mesh stored once and seen through many transforms renders what
adding a copy per transform renders, counts what it stores, and refuses bad transforms by index."""

from __future__ import annotations

import pickle

import numpy as np
import pytest

import durer
from durer.render import PRECISIONS
from helpers.meshes import icosphere


def transforms(n: int, seed: int = 3) -> np.ndarray:
    """n (4, 4) matrices: random rotations, non-uniform scales (ellipsoids), shears, translations
    across a 12 x 8 field."""
    rng = np.random.default_rng(seed)
    out = np.zeros((n, 4, 4))
    for i in range(n):
        q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
        shear = np.eye(3)
        shear[0, 1] = rng.uniform(-0.3, 0.3)
        out[i, :3, :3] = q @ np.diag(rng.uniform(0.2, 0.7, 3)) @ shear
        out[i, :3, 3] = (rng.uniform(-6, 6), rng.uniform(-4, 4), rng.uniform(-1, 1))
        out[i, 3, 3] = 1
    return out


def scenes(n: int, **colors) -> tuple[durer.Scene, durer.Scene, int]:
    vertices, faces = icosphere(2)
    matrices = transforms(n)
    shared, copies = durer.Scene(), durer.Scene()
    for scene in (shared, copies):
        scene.add_directional_light((-0.3, -0.5, -1), (0.9, 0.9, 0.9), shadows=True)
        scene.add_plane((0, 0, 1), -1.5, scene.add_material((0.6, 0.6, 0.6)))
        scene.ambient = (0.1, 0.1, 0.1)
    red = shared.add_material((0.9, 0.2, 0.1), specular=(0.3, 0.3, 0.3), exponent=20)
    copies.add_material((0.9, 0.2, 0.1), specular=(0.3, 0.3, 0.3), exponent=20)
    shared_id = shared.add_mesh_instances(vertices, faces, matrices, red, **colors)
    for m in matrices:
        copies.add_mesh(vertices, faces, red, transform=m, **colors)
    return shared, copies, shared_id


CAMERA = durer.PerspectiveCamera((0, -9, 9), (0, 1, -1), (0, 0, 1), 60.0)


@pytest.mark.parametrize("precision", ["float", "double"])
def test_instances_render_as_copies_do(precision):
    shared, copies, _ = scenes(60)
    a = durer.render(shared, CAMERA, 96, 64, spp=2, precision=precision)
    b = durer.render(copies, CAMERA, 96, 64, spp=2, precision=precision)
    assert np.isfinite(a.depth).sum() > 0.5 * a.depth.size  # the instances and the floor fill the view
    for name in ("color", "depth", "normal"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
    assert a.stats["shadow_rays"] == b.stats["shadow_rays"] > 0


def test_a_shared_mesh_is_stored_once_and_is_one_object():
    vertices, faces = icosphere(2)
    shared, copies, shared_id = scenes(500)
    assert shared.triangle_count == copies.triangle_count == 500 * len(faces)
    assert shared.stored_triangle_count == len(faces)
    assert copies.stored_triangle_count == 500 * len(faces)
    assert shared.transform_count == copies.transform_count == 500
    assert shared.object_count == 2  # the plane and the instanced mesh
    # Every instance's hits report the mesh's object id, in every precision.
    origins = np.array([[m[0, 3], m[1, 3], 20.0] for m in transforms(500)[:50]])
    directions = np.tile([0.0, 0.0, -1.0], (50, 1))
    for precision in PRECISIONS:
        # Each ray passes through an instance's centre, so it hits the mesh (that instance or one above it),
        # never misses and never reaches the floor.
        hits = durer.cast(shared, origins, directions, precision=precision)
        np.testing.assert_array_equal(hits.object_id, shared_id)


def test_colours_and_pickling_keep_what_copies_render():
    vertices, _ = icosphere(2)
    colours = np.abs(vertices)  # per vertex, interpolated
    shared, copies, _ = scenes(20, colors=colours)
    a = durer.render(shared, CAMERA, 64, 48)
    np.testing.assert_array_equal(a.color, durer.render(copies, CAMERA, 64, 48).color)
    again = pickle.loads(pickle.dumps(shared))
    assert again.stored_triangle_count == shared.stored_triangle_count
    np.testing.assert_array_equal(durer.render(again, CAMERA, 64, 48).color, a.color)


@pytest.mark.parametrize(("matrices", "error", "message"), [
    (np.zeros((0, 4, 4)), ValueError, r"transforms must have shape \(N, 4, 4\) or \(N, 3, 4\) with N >= 1"),
    (np.eye(4), ValueError, "transforms must have shape"),
    (np.stack([np.eye(4), np.diag([1.0, 1.0, 0.0, 1.0])]), ValueError, r"transforms\[1\] must be invertible"),
    (np.stack([np.eye(4), np.eye(4) * np.nan]), ValueError, r"transforms\[1\] must be"),
    (np.stack([np.eye(4), np.eye(4) + np.eye(4, k=-3)]), ValueError, r"transforms\[1\] must be affine"),
    (np.stack([np.eye(4)[:3]] * 2), None, None),  # (N, 3, 4) is fine
    ("eye", TypeError, "transforms must contain real numbers"),
])
def test_bad_transforms_are_refused_by_index(matrices, error, message):
    vertices, faces = icosphere(0)
    scene = durer.Scene()
    if error is None:
        assert scene.add_mesh_instances(vertices, faces, matrices) == 0
        return
    with pytest.raises(error, match=message):
        scene.add_mesh_instances(vertices, faces, matrices)
    assert scene.object_count == 0 and scene.triangle_count == 0  # a refused add changes nothing


def test_far_instances_are_checked_against_the_precision():
    vertices, faces = icosphere(0)
    far = np.stack([np.eye(4), np.eye(4)])
    far[1, :3, 3] = (1e30, 0, 0)
    scene = durer.Scene()
    scene.add_mesh_instances(vertices, faces, far)
    durer.render(scene, CAMERA, 8, 8, precision="double")
    with pytest.raises(ValueError, match="precision='float'"):
        durer.render(scene, CAMERA, 8, 8, precision="float")


def test_are_invertible_is_is_invertible_for_each_matrix():
    rng = np.random.default_rng(8)
    matrices = rng.normal(size=(200, 3, 4))
    matrices[::7, 2] = matrices[::7, 0]            # singular: two equal rows
    matrices[::11, :, :3] *= 1e-200                 # an inverse that overflows
    matrices[5, 1, 1] = np.nan
    expected = [durer._core.is_invertible(np.ascontiguousarray(m)) for m in matrices]
    assert sum(expected) < 170 and any(expected)
    np.testing.assert_array_equal(durer._core.are_invertible(matrices), expected)


@pytest.mark.parametrize("lit", [False, True])
def test_instance_colours_replace_the_mesh_colours(lit):
    vertices, faces = icosphere(2)
    n = 12
    matrices = np.tile(np.eye(4), (n, 1, 1))
    matrices[:, 0, 3] = np.arange(n) * 2.5 - 14  # a row of unit balls along x
    colours = np.random.default_rng(2).uniform(0.05, 1.0, (n, 3))
    shared, copies = durer.Scene(), durer.Scene()
    for scene in (shared, copies):
        if lit:
            scene.add_directional_light((0, 0, -1), (0.8, 0.8, 0.8))
            scene.ambient = (0.2, 0.2, 0.2)
    shared.add_mesh_instances(vertices, faces, matrices, colors=np.zeros_like(vertices), instance_colors=colours)
    for m, c in zip(matrices, colours):
        copies.add_mesh(vertices, faces, transform=m, colors=np.tile(c, (len(vertices), 1)))
    camera = durer.OrthographicCamera((0, 0, 10), (0, 0, -1), (0, 1, 0), 32.0)
    a = durer.render(shared, camera, 256, 24, passes="color")
    b = durer.render(copies, camera, 256, 24, passes="color")
    np.testing.assert_allclose(a.color, b.color, atol=1e-6)
    if not lit:  # flat: the centre pixel of ball i is its colour
        centres = ((np.arange(n) * 2.5 - 14 + 16) / 32 * 256).astype(int)
        np.testing.assert_allclose(a.color[12, centres, :3], colours, rtol=1e-6)
    assert "colors" in a.stats["effects"]


def test_bad_instance_colours_name_the_field():
    vertices, faces = icosphere(0)
    scene = durer.Scene()
    with pytest.raises(ValueError, match=r"instance_colors must have shape \(2, 3\)"):
        scene.add_mesh_instances(vertices, faces, np.stack([np.eye(4)] * 2), instance_colors=np.ones((3, 3)))
    with pytest.raises(ValueError, match=r"instance_colors\[1\]"):
        scene.add_mesh_instances(vertices, faces, np.stack([np.eye(4)] * 2), instance_colors=[[1, 1, 1], [1, -1, 1]])
    assert scene.object_count == 0
