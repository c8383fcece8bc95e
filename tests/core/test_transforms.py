"""Transformed objects: rays go into object space, t stays in world units, normals come back by the
inverse transpose. Checked against closed-form ellipsoids, boxes and pre-transformed meshes."""

from __future__ import annotations

import math

import numpy as np
import pytest

import durer
from durer.render import PRECISIONS


def rotation(axis, degrees: float) -> np.ndarray:
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    a = math.radians(degrees)
    return np.eye(3) + math.sin(a) * k + (1 - math.cos(a)) * k @ k


def affine(linear: np.ndarray, offset=(0, 0, 0)) -> np.ndarray:
    m = np.eye(4)
    m[:3, :3], m[:3, 3] = linear, offset
    return m


def ellipsoid_hits(m: np.ndarray, origins: np.ndarray, directions: np.ndarray):
    """Closest t >= 0 and world normal of rays against the unit sphere seen through m, in double."""
    inv = np.linalg.inv(m)
    o = origins @ inv[:3, :3].T + inv[:3, 3]
    d = directions @ inv[:3, :3].T
    a, b, c = (d * d).sum(1), (o * d).sum(1), (o * o).sum(1) - 1
    disc = b * b - a * c
    with np.errstate(invalid="ignore"):
        roots = np.stack([(-b - np.sqrt(disc)) / a, (-b + np.sqrt(disc)) / a])
    t = np.where(roots[0] >= 0, roots[0], np.where(roots[1] >= 0, roots[1], np.inf))
    t[~(disc > 0)] = np.inf
    with np.errstate(invalid="ignore"):  # misses: inf·0
        p = o + t[:, None] * d
        n = p @ inv[:3, :3]  # the inverse transpose applied to the object normal p
    return t, n / np.linalg.norm(n, axis=1, keepdims=True)


def test_ellipsoid_t_and_normals_match_the_closed_form(rng, precision):
    m = affine(rotation((1, 2, 3), 37) @ np.diag([3.0, 0.5, 1.5]), (1, -2, 0.5))
    scene = durer.Scene()
    scene.add_spheres([[0, 0, 0]], 1.0, transform=m)
    origins = rng.uniform(-6, 6, (4000, 3))
    aims = rng.uniform(-1.2, 1.2, (4000, 3)) @ m[:3, :3].T + m[:3, 3]  # around the ellipsoid: hits and misses
    directions = aims - origins
    hit = durer.cast(scene, origins, directions, precision=precision)
    t, normal = ellipsoid_hits(m, origins, directions)
    # Rays that graze the ellipsoid are left out: there any answer within rounding is right.
    inv = np.linalg.inv(m)
    o, d = origins @ inv[:3, :3].T + inv[:3, 3], directions @ inv[:3, :3].T
    miss_distance = np.linalg.norm(np.cross(o, d), axis=1) / np.linalg.norm(d, axis=1) - 1
    clear = np.abs(miss_distance) > (1e-3 if precision == "float" else 1e-9)
    hits = clear & np.isfinite(t)
    assert clear.sum() > 3900 and hits.sum() > 1000
    np.testing.assert_array_equal(np.isfinite(hit.t[clear]), np.isfinite(t[clear]))
    np.testing.assert_allclose(hit.t[hits], t[hits], rtol=2e-4 if precision == "float" else 1e-11)
    np.testing.assert_allclose(hit.normal[hits], normal[hits], atol=2e-3 if precision == "float" else 1e-9)


def test_t_stays_in_world_units_under_scale():
    # scene2_16: a sphere of radius 0.25 scaled by 5 is a sphere of radius 1.25, and t (the depth)
    # is the world distance, not the object-space one.
    scene = durer.Scene()
    scene.add_spheres([[0, 0, 0]], 0.25, transform=affine(5 * np.eye(3), (-1.25, -1.25, -2)))
    plain = durer.Scene()
    plain.add_spheres([[-1.25, -1.25, -2]], 1.25)
    origins = np.column_stack([np.linspace(-2.4, -0.1, 50), np.full(50, -1.25), np.full(50, 5.0)])
    directions = np.tile([0.0, 0.0, -1.0], (50, 1))
    scaled, reference = durer.cast(scene, origins, directions), durer.cast(plain, origins, directions)
    assert np.isfinite(reference.t).sum() == 50
    np.testing.assert_allclose(scaled.t, reference.t, rtol=1e-14)
    np.testing.assert_allclose(scaled.normal, reference.normal, atol=1e-14)
    np.testing.assert_allclose(reference.t, 7 - np.sqrt(1.25**2 - (origins[:, 0] + 1.25) ** 2), rtol=1e-14)


def test_a_transformed_mesh_equals_the_mesh_transformed(rng, precision):
    vertices = rng.uniform(-1, 1, (60, 3))
    faces = rng.integers(0, 60, (100, 3))
    faces = faces[(faces[:, 0] != faces[:, 1]) & (faces[:, 1] != faces[:, 2]) & (faces[:, 0] != faces[:, 2])]
    m = affine(rotation((0, 1, 1), 70) @ np.diag([2, 1, 0.5]), (3, 0, -1))
    moved = durer.Scene()
    moved.add_mesh(vertices @ m[:3, :3].T + m[:3, 3], faces)
    instanced = durer.Scene()
    instanced.add_mesh(vertices, faces, transform=m)
    origins = rng.uniform(-5, 8, (3000, 3))
    aims = rng.uniform(-1, 1, (3000, 3)) @ m[:3, :3].T + m[:3, 3]  # points of the mesh's box
    directions = aims - origins
    a = durer.cast(moved, origins, directions, precision=precision)
    b = durer.cast(instanced, origins, directions, precision=precision)
    same = a.object_id == b.object_id
    assert same.mean() > 0.995 and (a.object_id >= 0).sum() > 300  # rays through edges may differ
    both = same & (a.object_id >= 0)
    np.testing.assert_allclose(b.t[both], a.t[both], rtol=1e-4 if precision == "float" else 1e-11)
    assert np.abs(np.abs((a.normal[both] * b.normal[both]).sum(1)) - 1).max() < (1e-4 if precision == "float" else 1e-11)


def test_rotated_box(precision):
    # A unit cube turned 45° about z: a ray along -y through x = 0 meets the edge at y = √2/2... and
    # a ray at x = 0.5 meets the face at y = √2/2 - 0.5, with normal (±1, 1, 0)/√2.
    scene = durer.Scene()
    scene.add_boxes([[-0.5, -0.5, -0.5]], [[0.5, 0.5, 0.5]], transform=affine(rotation((0, 0, 1), 45)))
    hit = durer.cast(scene, [[0.5, 5, 0], [-0.3, 5, 0.2]], [[0, -1, 0], [0, -1, 0]], precision=precision)
    r = math.sqrt(0.5)
    tol = 1e-6 if precision == "float" else 1e-14
    np.testing.assert_allclose(hit.t, [5 - (r - 0.5), 5 - (r - 0.3)], rtol=tol)
    np.testing.assert_allclose(hit.normal, [[r, r, 0], [-r, r, 0]], atol=tol)


def test_mirroring_transform_keeps_outward_normals():
    # A reflection (negative determinant) maps a sphere to a sphere: its normals still point out.
    scene = durer.Scene()
    scene.add_spheres([[1, 0, 0]], 1.0, transform=np.diag([-1.0, 1, 1, 1]))
    hit = durer.cast(scene, [[-1, 0, 5], [-5, 0, 0]], [[0, 0, -1], [1, 0, 0]])
    np.testing.assert_allclose(hit.t, [4, 3])
    np.testing.assert_allclose(hit.normal, [[0, 0, 1], [-1, 0, 0]], atol=1e-15)


def test_objects_sharing_a_matrix_share_a_transform():
    scene = durer.Scene()
    m = affine(rotation((1, 0, 0), 30), (0, 1, 0))
    scene.add_spheres([[0, 0, 0], [2, 0, 0]], 0.5, transform=m)
    scene.add_boxes([[4, 0, 0]], [[5, 1, 1]], transform=m)
    scene.add_plane((0, 1, 0), -3.0, transform=m)
    scene.add_spheres([[0, 0, 0]], 0.5, transform=np.eye(4))  # the identity: world space
    scene.add_triangles([[[0, 0, 0], [1, 0, 0], [0, 1, 0]]], transform=2 * m - np.diag([0, 0, 0, 1.0]))
    assert (scene.transform_count, scene.sphere_count, scene.box_count, scene.plane_count) == (2, 3, 1, 1)


def test_many_transformed_objects_are_all_found(rng):
    # 40 transforms, each holding an ellipsoid: whatever the culling by world bounds does, every
    # ray's closest hit is the closest of the closed-form answers.
    scene = durer.Scene()
    matrices = []
    for i in range(40):
        m = affine(rotation(rng.normal(size=3), rng.uniform(0, 180)) @ np.diag(rng.uniform(0.2, 1, 3)),
                   rng.uniform(-5, 5, 3))
        matrices.append(m)
        scene.add_spheres([[0, 0, 0]], 1.0, transform=m)
    assert scene.transform_count == 40
    origins = rng.uniform(-8, 8, (2000, 3))
    directions = np.array([matrices[i][:3, 3] for i in rng.integers(0, 40, 2000)]) + rng.normal(size=(2000, 3)) - origins
    hit = durer.cast(scene, origins, directions)
    ts = np.stack([ellipsoid_hits(m, origins, directions)[0] for m in matrices])
    best = np.argmin(ts, axis=0)
    t = ts.min(axis=0)
    second = np.sort(ts, axis=0)[1]
    with np.errstate(invalid="ignore"):  # inf − inf where a ray misses them all
        clear = np.isinf(t) | (second - t > 1e-6)  # no near tie between two ellipsoids
    assert np.isfinite(t).sum() > 500
    np.testing.assert_array_equal(hit.object_id[clear], np.where(np.isfinite(t), best, -1)[clear])
    np.testing.assert_allclose(hit.t[clear & np.isfinite(t)], t[clear & np.isfinite(t)], rtol=1e-9)


def test_render_of_a_lit_shadowed_ellipsoid_has_no_acne():
    # An ellipsoid lit head-on with shadows on: every pixel equals ambient·kd + max(N·L, 0)·kd with
    # the normal pass's own normal, so no hit point is shadowed by its own surface.
    scene = durer.Scene()
    kd = 0.8
    material = scene.add_material((kd, kd, kd))
    scene.add_spheres([[0, 0, 0]], 1.0, material, transform=affine(rotation((1, 1, 0), 30) @ np.diag([2, 1, 0.3])))
    light = np.array([-0.3, -0.2, -1.0])
    scene.add_directional_light(light, (1, 1, 1), shadows=True)
    scene.ambient = (0.1, 0.1, 0.1)
    camera = durer.PerspectiveCamera((0, 0, 8), (0, 0, -1), (0, 1, 0), fov_degrees=40)
    for precision in PRECISIONS:
        result = durer.render(scene, camera, 64, 64, precision=precision)
        hits = np.isfinite(result.depth)
        assert hits.sum() > 500
        cosine = np.maximum(result.normal[hits] @ (-light / np.linalg.norm(light)), 0)
        expected = kd * 0.1 + kd * cosine
        np.testing.assert_allclose(result.color[hits][:, 0], expected, atol=2e-6 if precision == "float" else 1e-6)


def test_reflection_in_a_rotated_mirror():
    # The mirror plane y = 0 turned 90° about x is the plane z = 0 facing +z. A camera looking at it
    # along -z (t_min = 0) sees, reflected, a red sphere behind the camera and the background.
    scene = durer.Scene()
    mirror = scene.add_material((0, 0, 0), reflective=(1, 1, 1))
    red = scene.add_material((1, 0, 0))
    scene.add_plane((0, 1, 0), 0.0, mirror, transform=affine(rotation((1, 0, 0), 90)))
    scene.add_spheres([[0, 0, 20]], 1.0, red)
    scene.background = (0, 0, 1)
    camera = durer.OrthographicCamera((0, 0, 10), (0, 0, -1), (0, 1, 0), size=4.0, t_min=0.0)
    color = durer.render(scene, camera, 20, 20, passes="color", max_bounces=1).color
    np.testing.assert_allclose(color[10, 10, :3], [1, 0, 0])  # the sphere, seen in the mirror
    np.testing.assert_allclose(color[0, 0, :3], [0, 0, 1])    # the background, seen in the mirror


@pytest.mark.parametrize(
    ("matrix", "error", "message"),
    [
        (np.zeros((4, 4)), ValueError, "bottom row must be"),
        (np.diag([1.0, 1, 0, 1]), ValueError, "transform must be invertible"),
        (np.eye(4) * np.array([1, 1, 1, 1]) + np.array([[0, 0, 0, 0], [0, 0, 0, 0], [0, 0, 0, 0], [1, 0, 0, 0]]),
         ValueError, "bottom row must be"),
        (np.full((4, 4), np.nan), ValueError, "transform must be finite"),
        (np.eye(3), ValueError, r"transform must have shape \(4, 4\) or \(3, 4\)"),
        ([["a"] * 4] * 4, TypeError, "transform must contain real numbers"),
        (np.array([[1, 0, 0, 0], [0, 1, 0, 0], [1, 1, 0, 0]], float), ValueError, "transform must be invertible"),
    ],
)
def test_bad_transforms_name_the_argument(matrix, error, message):
    scene = durer.Scene()
    for add in (lambda: scene.add_spheres([[0, 0, 0]], 1.0, transform=matrix),
                lambda: scene.add_plane((0, 0, 1), 0.0, transform=matrix),
                lambda: scene.add_boxes([[0, 0, 0]], [[1, 1, 1]], transform=matrix),
                lambda: scene.add_mesh([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]], transform=matrix),
                lambda: scene.add_triangles([[[0, 0, 0], [1, 0, 0], [0, 1, 0]]], transform=matrix)):
        with pytest.raises(error, match=message):
            add()
    assert scene.object_count == 0 and scene.transform_count == 0


def test_a_spheres_verdict_does_not_depend_on_the_other_spheres_of_its_group():
    """A map whose rotation and offset cancel puts a sphere 0.8 from the origin from terms of ~250:
    in float the group's world box, made from the corners' mapped positions, was off by more than its
    slack and culled the ray alone; beside any other sphere it did not (the traversal fuzz's case).
    The box now carries each corner's own rounding."""
    transform = [[-2.676875592679573, -1.6914481592251143, -1.9665689137607794, 38.81770854240598],
                 [1.22679362372765, -3.31549094684753, 1.1817572901205808, 27.000530930031907],
                 [2.285468786200647, -0.2014348843322086, -2.9377048049925816, -454.56787247926235], [0, 0, 0, 1]]
    centre, radius = [55.429426222324125, -0.7773917093174076, -83.22844721966948], 1.3630745522475062e-07
    origin = [[55.42942568732757, -0.7773916334122676, -83.22844683703717]]
    direction = [[-0.4659956274188303, -0.5734954655311147, 0.5194099980806174]]
    verdicts = []
    for others in ([], [[55.0, 10.0, -80.0]], [[centre[0] + 1e-6, centre[1], centre[2]]]):
        scene = durer.Scene()
        scene.add_spheres([centre, *others], [radius] * (1 + len(others)), transform=transform)
        hit = durer.cast(scene, origin, direction, precision="float")
        verdicts.append((float(hit.t[0]), int(hit.object_id[0])))
    # Which verdict is rounding's (the sphere is 400 times below float's spacing there); it must be one.
    assert verdicts[1] == verdicts[0] and verdicts[2] == verdicts[0]
