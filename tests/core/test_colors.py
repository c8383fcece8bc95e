"""Per-primitive colours (`colors=` of add_spheres, add_triangles, add_mesh, add_boxes): the kd of each
primitive in place of its material's, flat and lit, interpolated across triangles, kept through the
hierarchy's reorder, move_spheres and pickling; bad colours named."""

from __future__ import annotations

import pickle

import numpy as np
import pytest

import durer

SIZE = 8.0  # the orthographic window's side, world units
PIXELS = 64


def camera() -> durer.OrthographicCamera:
    return durer.OrthographicCamera(center=(0, 0, 10), direction=(0, 0, -1), up=(0, 1, 0), size=SIZE)


def flat(scene: durer.Scene, precision: str = "double", **kwargs) -> np.ndarray:
    """The (H, W, 3) flat colour image of `scene`, one sample per pixel centre."""
    return durer.render(scene, camera(), PIXELS, PIXELS, precision=precision, passes=("color",), **kwargs).color[..., :3]


def pixel_of(x: float, y: float) -> tuple[int, int]:
    """(row, col) of the pixel whose centre ray passes through world (x, y)."""
    col = int((x + SIZE / 2) / SIZE * PIXELS)
    row = int((SIZE / 2 - y) / SIZE * PIXELS)
    return row, col


def pixel_xy() -> np.ndarray:
    """(H, W, 2) world x, y of every pixel centre ray."""
    origins, _ = camera().rays(PIXELS, PIXELS)
    return origins[..., :2]


def close(precision: str) -> float:
    return 1e-6 if precision == "float" else 1e-7  # colours come back as float32


def test_each_sphere_takes_its_own_colour_flat_beside_uncoloured_spheres_of_the_same_set(rng, precision):
    scene = durer.Scene()
    red = scene.add_material((0.9, 0.1, 0.1), emission=(0.05, 0.0, 0.0))
    scene.add_spheres([[-3, 3, 0]], 0.4, material=red)  # before the coloured ones: keeps its kd
    grid = np.array([(x, y, 0.0) for x in np.arange(-3, 3.5, 1.0) for y in np.arange(-2, 2.5, 1.0)])
    colors = rng.uniform(0, 1, (len(grid), 3))  # 35 spheres: past the hierarchy's threshold
    scene.add_spheres(grid, 0.3, material=red, colors=colors)
    scene.add_spheres([[3, 3, 0]], 0.4)  # after them: the default material's kd
    image = flat(scene, precision)
    for (x, y, _), color in zip(grid, colors):
        np.testing.assert_allclose(image[pixel_of(x, y)], color + (0.05, 0, 0), atol=close(precision))
    np.testing.assert_allclose(image[pixel_of(-3, 3)], (0.95, 0.1, 0.1), atol=close(precision))
    np.testing.assert_allclose(image[pixel_of(3, 3)], (0.8, 0.8, 0.8), atol=close(precision))
    np.testing.assert_array_equal(image[pixel_of(0, 3.6)], (0, 0, 0))  # background between them


def test_lit_spheres_use_the_colour_as_kd_with_ambient_and_shadowed_lights(precision):
    scene = durer.Scene()
    material = scene.add_material((0.5, 0.5, 0.5), specular=(0.2, 0.2, 0.2), exponent=10)
    scene.add_spheres([[-2, 0, 0], [2, 0, 0]], 1.0, material=material, colors=[[0.2, 0.4, 0.6], [1.0, 0.0, 0.5]])
    scene.add_directional_light((0, 0, -1), (2.0, 2.0, 2.0), shadows=True)
    scene.ambient = (0.1, 0.1, 0.1)
    result = durer.render(scene, camera(), PIXELS, PIXELS, precision=precision, passes=("color",))
    assert "colors" in result.stats["effects"]
    # Light and viewer both along +z: cos = N·L = N·H = n_z, sqrt(1 - dx² - dy²) on a unit sphere at
    # the pixel centre's offset (dx, dy) from the sphere's centre.
    for x, kd in ((-2, (0.2, 0.4, 0.6)), (2, (1.0, 0.0, 0.5))):
        offset = pixel_xy()[pixel_of(x, 0)] - (x, 0)
        cosine = np.sqrt(1 - offset @ offset)
        assert cosine > 0.99
        expected = 0.1 * np.array(kd) + 2.0 * np.array(kd) * cosine + 2.0 * 0.2 * cosine**10
        np.testing.assert_allclose(result.color[pixel_of(x, 0)][:3], expected, rtol=1e-5)


def test_a_mirror_shows_the_colour_of_the_sphere_it_reflects(precision):
    scene = durer.Scene()
    mirror = scene.add_material((0, 0, 0), reflective=(1, 1, 1))
    scene.add_plane((0, 0, 1), 0.0, mirror, bounds=((-4, -4, 0), (8, 0, 0), (0, 8, 0)))
    scene.add_spheres([[0, 0, 15]], 3.0, colors=[[0.25, 0.5, 0.75]])  # behind the camera: seen only in the mirror
    eye = durer.PerspectiveCamera(center=(0, 0, 10), direction=(0, 0, -1), up=(0, 1, 0), fov_degrees=20)
    result = durer.render(scene, eye, 16, 16, precision=precision, passes=("color",))
    assert "reflection" in result.stats["effects"] and "colors" in result.stats["effects"]
    np.testing.assert_allclose(result.color[8, 8, :3], (0.25, 0.5, 0.75), atol=close(precision))


def test_a_scene_without_colours_asks_for_no_colour_effect():
    scene = durer.Scene()
    scene.add_spheres([[0, 0, 0]], 1.0)
    assert durer.render(scene, camera(), 8, 8).stats["effects"] == ("flat",)
    scene.add_boxes([[2, 2, -1]], [[3, 3, 1]], colors=[[0.1, 0.2, 0.3]])
    assert durer.render(scene, camera(), 8, 8).stats["effects"] == ("colors", "flat")


def barycentric(xy: np.ndarray, a, b, c) -> np.ndarray:
    """(..., 3) barycentric coordinates of 2D points xy (..., 2) in triangle a, b, c (x, y used)."""
    e1, e2, p = np.subtract(b, a)[:2], np.subtract(c, a)[:2], xy - np.asarray(a)[:2]
    det = e1[0] * e2[1] - e2[0] * e1[1]
    wb = (p[..., 0] * e2[1] - e2[0] * p[..., 1]) / det
    wc = (e1[0] * p[..., 1] - p[..., 0] * e1[1]) / det
    return np.stack([1 - wb - wc, wb, wc], axis=-1)


def inside(weights: np.ndarray, margin: float = 0.02) -> np.ndarray:
    return (weights > margin).all(axis=-1)


CORNERS = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.2, 1.0]])


def test_triangle_corner_colours_interpolate_barycentrically(precision):
    a, b, c = np.array([-3.0, -3, 0]), np.array([3.0, -3, 0]), np.array([0.0, 3, 0])
    scene = durer.Scene()
    scene.add_triangles([[a, b, c]], colors=[CORNERS])
    image = flat(scene, precision)
    weights = barycentric(pixel_xy(), a, b, c)
    mask = inside(weights)
    assert mask.sum() > 1000
    np.testing.assert_allclose(image[mask], (weights @ CORNERS)[mask], atol=10 * close(precision))
    np.testing.assert_array_equal(image[(weights < -0.02).any(axis=-1)], 0)


def test_one_colour_per_triangle_is_uniform_over_it(precision):
    a, b, c = np.array([-3.0, -3, 0]), np.array([3.0, -3, 0]), np.array([0.0, 3, 0])
    scene = durer.Scene()
    scene.add_triangles([[a, b, c], [a + (0, 0, -1), b + (0, 0, -1), c + (0, 0, -1)]], colors=[[0.3, 0.6, 0.9], [1, 1, 1]])
    image = flat(scene, precision)
    mask = inside(barycentric(pixel_xy(), a, b, c))
    np.testing.assert_allclose(image[mask], np.broadcast_to((0.3, 0.6, 0.9), image[mask].shape), atol=close(precision))


def test_mesh_vertex_colours_are_shared_across_faces_and_face_colours_given_per_corner(precision):
    # A quad of two faces sharing the edge v0-v2; a vertex's colour is the same on both faces.
    vertices = np.array([[-3.0, -3, 0], [3, -3, 0], [3, 3, 0], [-3, 3, 0]])
    faces = np.array([[0, 1, 2], [0, 2, 3]])
    vertex_colors = np.array([[1.0, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 0]])
    scene = durer.Scene()
    scene.add_mesh(vertices, faces, colors=vertex_colors)
    image = flat(scene, precision)
    xy = pixel_xy()
    for face in faces:
        weights = barycentric(xy, *vertices[face])
        mask = inside(weights)
        np.testing.assert_allclose(image[mask], (weights @ vertex_colors[face])[mask], atol=10 * close(precision))
    face_scene = durer.Scene()
    face_colors = np.array([[0.2, 0.3, 0.4], [0.9, 0.8, 0.7]])
    face_scene.add_mesh(vertices, faces, colors=np.repeat(face_colors[:, None, :], 3, axis=1))
    image = flat(face_scene, precision)
    for face, color in zip(faces, face_colors):
        mask = inside(barycentric(xy, *vertices[face]))
        np.testing.assert_allclose(image[mask], np.broadcast_to(color, image[mask].shape), atol=close(precision))


def test_mesh_colours_follow_their_faces_through_the_hierarchy_and_a_transform(rng, precision):
    # 200 separate small triangles (a hierarchy), each with its own corner colours, under a translation.
    centers = np.column_stack([rng.uniform(-3, 3, (200, 2)), rng.uniform(-1, 1, 200)])
    offsets = np.array([[-0.08, -0.08, 0], [0.08, -0.08, 0], [0, 0.08, 0]])
    vertices = (centers[:, None, :] + offsets).reshape(-1, 3)
    faces = np.arange(600).reshape(200, 3)
    colors = rng.uniform(0, 1, (200, 3, 3))
    matrix = np.eye(4)
    matrix[:3, 3] = (0.25, -0.25, 0)
    scene = durer.Scene()
    scene.add_mesh(vertices, faces, colors=colors, transform=matrix)
    ids = durer.cast(scene, np.column_stack([centers[:, :2] + (0.25, -0.25), np.full(200, 10.0)]),
                     np.tile([0.0, 0, -1], (200, 1)))
    assert (ids.object_id == 0).all()
    result = durer.render(scene, camera(), 256, 256, precision=precision, passes=("color", "depth"))
    origins, _ = camera().rays(256, 256)
    checked = 0
    for corners, triangle_colors in zip(centers[:, None, :] + offsets + (0.25, -0.25, 0), colors):
        weights = barycentric(origins[..., :2], *corners)
        # Its pixels away from its edges where no other triangle lies in front.
        seen = inside(weights, 0.1) & np.isclose(result.depth, 10 - corners[0, 2], atol=1e-4)
        checked += seen.sum()
        np.testing.assert_allclose(result.color[..., :3][seen], (weights @ triangle_colors)[seen], atol=10 * close(precision))
    assert checked > 1000


def test_each_box_takes_its_own_colour_lit_and_flat(rng, precision):
    lo = np.array([[x, y, -0.5] for x in range(-3, 3) for y in range(-3, 3)], float) + 0.1
    colors = rng.uniform(0, 1, (len(lo), 3))
    scene = durer.Scene()
    scene.add_boxes(lo, lo + (0.8, 0.8, 1.0), colors=colors)
    image = flat(scene, precision)
    for corner, color in zip(lo, colors):
        np.testing.assert_allclose(image[pixel_of(*(corner[:2] + 0.4))], color, atol=close(precision))
    scene.add_directional_light((0, 0, -1), (0.5, 0.5, 0.5))
    image = flat(scene, precision)
    for corner, color in zip(lo, colors):
        np.testing.assert_allclose(image[pixel_of(*(corner[:2] + 0.4))], 0.5 * color, rtol=1e-5, atol=1e-7)


@pytest.mark.parametrize("hierarchy", [True, False])
def test_moved_spheres_keep_their_colours_through_refits_and_rebuilds(rng, hierarchy):
    # A flat render of camera rays alone goes through the camera's view and prepares the spheres
    # without a hierarchy (in an order of their own); a cast first makes the hierarchy, which the
    # renders then use and the moves refit or rebuild.
    grid = np.array([(x, y, 0.0) for x in np.arange(-3, 3.5, 1.0) for y in np.arange(-3, 3.5, 1.0)])
    colors = rng.uniform(0, 1, (len(grid), 3))
    scene = durer.Scene()
    ids = scene.add_spheres(grid, 0.3, colors=colors)
    if hierarchy:
        durer.cast(scene, [[0.0, 0.0, 5.0]], [[0.0, 0.0, -1.0]])
    flat(scene)
    order = rng.permutation(len(grid))  # every sphere to another's place: the refit degrades, a rebuild follows
    scene.move_spheres(ids, grid[order])
    image = flat(scene)
    assert scene.hierarchy_counts["rebuilt"] == (1 if hierarchy else 0)
    for (x, y, _), color in zip(grid[order], colors):
        np.testing.assert_allclose(image[pixel_of(x, y)], color, atol=1e-7)
    before = scene.hierarchy_counts
    scene.move_spheres(ids, grid[order] + (0.05, 0, 0))  # a small move: refitted, not rebuilt
    image = flat(scene)
    after = scene.hierarchy_counts
    assert after["refitted"] == before["refitted"] + 1 and after["rebuilt"] == before["rebuilt"]
    for (x, y, _), color in zip(grid[order], colors):
        np.testing.assert_allclose(image[pixel_of(x + 0.05, y)], color, atol=1e-7)


def test_a_pickled_scene_keeps_its_colours(rng):
    scene = durer.Scene()
    scene.add_spheres(rng.uniform(-3, 3, (50, 3)), 0.3, colors=rng.uniform(0, 1, (50, 3)))
    scene.add_triangles([[[-3, -3, -2], [3, -3, -2], [0, 3, -2]]], colors=[CORNERS])
    scene.add_mesh([[-4, -4, -3], [4, -4, -3], [0, 4, -3]], [[0, 1, 2]], colors=[[0, 0, 1], [0, 1, 0], [1, 0, 0]])
    scene.add_boxes([[3, 3, -1]], [[4, 4, 0]], colors=[[0.5, 0.25, 0.125]])
    copy = pickle.loads(pickle.dumps(scene))
    np.testing.assert_array_equal(flat(copy), flat(scene))
    assert len(np.unique(flat(scene).reshape(-1, 3), axis=0)) > 100


@pytest.mark.parametrize(
    ("add", "error", "message"),
    [
        (lambda s: s.add_spheres([[0, 0, 0]], 1, colors=[0.1, 0.2, 0.3]), ValueError,
         r"colors must have shape \(1, 3\), got \(3,\)"),
        (lambda s: s.add_spheres([[0, 0, 0], [1, 1, 1]], 1, colors=[[0, 0, 0], [0, -0.5, 0]]),
         ValueError, r"colors\[1\] must be >= 0 in each channel, got \(0, -0.5, 0\)"),
        (lambda s: s.add_boxes([[0, 0, 0]], [[1, 1, 1]], colors=[[np.nan, 0, 0]]), ValueError,
         r"colors\[0\] must be finite"),
        (lambda s: s.add_boxes([[0, 0, 0]], [[1, 1, 1]], colors=[[1e19, 0, 0]]), ValueError,
         r"colors\[0\] must be <= 1e\+18"),
        (lambda s: s.add_triangles(np.zeros((2, 3, 3)), colors=np.zeros((2, 3, 2))),
         ValueError, r"colors must have shape \(2, 3\) or \(2, 3, 3\), got \(2, 3, 2\)"),
        (lambda s: s.add_triangles(np.zeros((1, 3, 3)), colors=[[[0, 0, 0], [0, 0, 0], [0, np.inf, 0]]]),
         ValueError, r"colors\[0\]\[2\] must be finite"),
        (lambda s: s.add_mesh(np.zeros((4, 3)), [[0, 1, 2]], colors=np.zeros((3, 3))),
         ValueError, r"colors must have shape \(4, 3\) or \(1, 3, 3\), got \(3, 3\)"),
        (lambda s: s.add_mesh(np.zeros((3, 3)), [[0, 1, 2]], colors=[[0, 0, 0], [0, 0, 0], [-1, 0, 0]]),
         ValueError, r"colors\[2\] must be >= 0"),
        (lambda s: s.add_spheres([[0, 0, 0]], 1, colors=[["red", "green", "blue"]]), TypeError,
         r"colors must contain real numbers"),
    ],
)
def test_bad_colours_are_named_and_change_nothing(add, error, message):
    scene = durer.Scene()
    with pytest.raises(error, match="^" + message):
        add(scene)
    assert scene.object_count == 0
    assert (scene.sphere_count, scene.triangle_count, scene.box_count) == (0, 0, 0)
