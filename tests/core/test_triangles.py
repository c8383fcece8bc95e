"""Triangles and meshes: the watertight test (Woop, Benthin & Wald 2013) against analytic answers."""

from __future__ import annotations

import math

import numpy as np
import pytest

import durer
from helpers.meshes import icosphere


def edge_and_vertex_targets(vertices: np.ndarray, faces: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Points exactly at every vertex and on every edge (its midpoint and a random point)."""
    edges = {tuple(sorted((f[i], f[(i + 1) % 3]))) for f in faces for i in range(3)}
    a = vertices[[e[0] for e in edges]]
    b = vertices[[e[1] for e in edges]]
    s = rng.uniform(0, 1, (len(edges), 1))
    return np.concatenate([vertices, (a + b) / 2, a + s * (b - a)])


@pytest.mark.parametrize("subdivisions", [1, 3])
def test_rays_at_shared_edges_and_vertices_all_hit(rng, precision, subdivisions):
    # A closed mesh seen from outside, rays aimed at its vertices and edges from within 20° of the
    # outward normal there (so every face at the point faces the ray: a tangent ray may rightly pass
    # a silhouette vertex by a rounding). Each must meet the mesh; a crack would let one through.
    vertices, faces = icosphere(subdivisions)
    scene = durer.Scene()
    scene.add_mesh(vertices, faces)
    targets = np.repeat(edge_and_vertex_targets(vertices, faces, rng), 4, axis=0)
    origins = outside_origins(targets, rng)
    hit = durer.cast(scene, origins, targets - origins, precision=precision)
    assert len(targets) > 1000
    assert (hit.object_id == 0).all(), f"{(hit.object_id < 0).sum()} of {len(targets)} rays slipped through"
    np.testing.assert_allclose(hit.t, 1.0, rtol=1e-5 if precision == "float" else 1e-12)


def outside_origins(targets: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Origins 2 to 50 units out from points of a unit icosphere, within 20° of its outward normal."""
    normal = targets / np.linalg.norm(targets, axis=1, keepdims=True)
    tilt = rng.normal(size=targets.shape)
    tilt -= np.einsum("ij,ij->i", tilt, normal)[:, None] * normal
    tilt *= np.tan(np.radians(rng.uniform(0, 20, (len(targets), 1)))) / np.linalg.norm(tilt, axis=1, keepdims=True)
    away = normal + tilt
    return targets + away / np.linalg.norm(away, axis=1, keepdims=True) * rng.uniform(2, 50, (len(targets), 1))


def grid_mesh(n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A flat n x n grid of right triangles (spacing 0.1) in z = 0 wound toward +z, and the points
    exactly at its inner vertices and at the midpoints of its edges."""
    xs, ys = np.meshgrid(np.arange(n + 1) * 0.1, np.arange(n + 1) * 0.1, indexing="ij")
    vertices = np.column_stack([xs.ravel(), ys.ravel(), np.zeros(xs.size)])
    index = np.arange((n + 1) ** 2).reshape(n + 1, n + 1)
    a, b, c, d = index[:-1, :-1].ravel(), index[1:, :-1].ravel(), index[:-1, 1:].ravel(), index[1:, 1:].ravel()
    faces = np.concatenate([np.column_stack([a, b, d]), np.column_stack([a, d, c])])
    edges = np.concatenate([(vertices[a] + vertices[b]) / 2, (vertices[a] + vertices[d]) / 2,
                            (vertices[a] + vertices[c]) / 2])
    inner = index[1:-1, 1:-1].ravel()
    return vertices, faces, np.concatenate([vertices[inner], edges])


def test_rays_through_a_grid_of_shared_vertices_hit(precision):
    # Straight down through every inner vertex and edge midpoint: each ray hits at exactly t = 1.
    vertices, faces, targets = grid_mesh(40)
    scene = durer.Scene()
    scene.add_mesh(vertices, faces)
    hit = durer.cast(scene, targets + [0.0, 0.0, 1.0], np.tile([0.0, 0.0, -1.0], (len(targets), 1)), precision=precision)
    assert (hit.object_id == 0).all()
    np.testing.assert_array_equal(hit.t, 1.0)
    np.testing.assert_array_equal(hit.normal, np.tile([0.0, 0.0, 1.0], (len(targets), 1)))


def test_textbook_float_test_leaks_where_the_watertight_one_does_not(rng):
    # The control for the tests above: strict-inequality Möller–Trumbore in float32 lets rays through
    # the grid's shared vertices and edges slip between its triangles, so those tests can fail.
    vertices, faces, targets = grid_mesh(10)
    origins = targets + rng.normal(scale=0.2, size=targets.shape) * [1, 1, 0] + [0, 0, 1]
    directions = targets - origins
    f32 = np.float32
    v0, v1, v2 = (vertices[faces[:, i]].astype(f32) for i in range(3))
    e1, e2 = v1 - v0, v2 - v0
    leaks = 0
    for o, d in zip(origins.astype(f32), directions.astype(f32)):
        p = np.cross(d, e2)
        inv = f32(1) / np.einsum("ij,ij->i", e1, p)
        s = o - v0
        u = np.einsum("ij,ij->i", s, p) * inv
        q = np.cross(s, e1)
        v = (q @ d) * inv
        leaks += not ((u > 0) & (v > 0) & (u + v < 1) & (np.einsum("ij,ij->i", e2, q) * inv > 0)).any()
    assert leaks > 10
    scene = durer.Scene()
    scene.add_mesh(vertices, faces)
    assert (durer.cast(scene, origins, directions, precision="float").object_id == 0).all()


def reference_hits(v0, v1, v2, origins, directions):
    """Closest hit per ray by solving o + t·d = v0 + β·e1 + γ·e2 in double (numpy), with each
    ray's smallest barycentric margin (how far from an edge it passes, relative)."""
    best_t = np.full(len(origins), np.inf)
    best = np.full(len(origins), -1)
    margin = np.full(len(origins), np.inf)
    for i, (a, b, c) in enumerate(zip(v0, v1, v2)):
        m = np.stack([np.broadcast_to(b - a, directions.shape), np.broadcast_to(c - a, directions.shape), -directions], -1)
        with np.errstate(all="ignore"):
            beta, gamma, t = np.linalg.solve(m, (origins - a)[..., None])[..., 0].T
        bary = np.minimum(np.minimum(beta, gamma), 1 - beta - gamma)
        inside = bary >= 0
        closer = inside & (t >= 0) & (t < best_t)
        best_t[closer], best[closer] = t[closer], i
        margin = np.minimum(margin, np.abs(bary))
    return best_t, best, margin


def test_random_triangles_match_the_analytic_solution(rng, precision):
    # 200 random triangles (a hierarchy: more than 16), 3000 random rays: the closest triangle and t
    # agree with the exact linear solve wherever a ray passes clear of every edge.
    v0 = rng.uniform(-5, 5, (200, 3))
    v1 = v0 + rng.normal(size=(200, 3))
    v2 = v0 + rng.normal(size=(200, 3))
    origins = rng.uniform(-8, 8, (3000, 3))
    directions = rng.normal(size=(3000, 3))
    scene = durer.Scene()
    ids = scene.add_triangles(np.stack([v0, v1, v2], 1))
    hit = durer.cast(scene, origins, directions, precision=precision)
    t, best, margin = reference_hits(v0, v1, v2, origins, directions)
    clear = margin > (1e-4 if precision == "float" else 1e-10)
    assert clear.sum() > 2500 and 300 < (best[clear] >= 0).sum()
    np.testing.assert_array_equal(hit.object_id[clear], np.where(best[clear] >= 0, ids[best[clear]], -1))
    hits = clear & (best >= 0)
    np.testing.assert_allclose(hit.t[hits], t[hits], rtol=1e-4 if precision == "float" else 1e-12)
    normals = np.cross(v1 - v0, v2 - v0)
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    np.testing.assert_allclose(hit.normal[hits], normals[best[hits]], atol=1e-6 if precision == "float" else 1e-14)


def test_winding_gives_the_normal_and_back_faces_still_hit():
    scene = durer.Scene()
    scene.add_triangles([[[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 0, -1], [0, 1, -1], [1, 0, -1]]])
    hit = durer.cast(scene, [[0.2, 0.2, 5], [0.2, 0.2, -5]], [[0, 0, -1], [0, 0, 1]])
    np.testing.assert_array_equal(hit.object_id, [0, 1])
    np.testing.assert_array_equal(hit.t, [5.0, 4.0])
    np.testing.assert_array_equal(hit.normal, [[0, 0, 1], [0, 0, -1]])  # as wound, not toward the ray


def test_degenerate_triangles_miss_without_nan(precision):
    # Collinear, repeated and zero-size triangles beside a real one: rays at them miss, nothing is NaN.
    scene = durer.Scene()
    ids = scene.add_triangles([
        [[0, 0, 0], [1, 0, 0], [2, 0, 0]],      # collinear
        [[0, 1, 0], [0, 1, 0], [1, 1, 0]],      # a repeated vertex
        [[3, 3, 0], [3, 3, 0], [3, 3, 0]],      # a point
        [[10, 0, 0], [11, 0, 0], [10, 1, 0]],   # a real one
    ])
    origins = np.array([[1, 0, 1], [0.5, 1, 1], [3, 3, 1], [1, 0, 0], [10.2, 0.2, 1], [0.5, 1, 0]])
    directions = np.array([[0, 0, -1], [0, 0, -1], [0, 0, -1], [1, 0, 0], [0, 0, -1], [1, 0, 0]], float)
    hit = durer.cast(scene, origins, directions, precision=precision, t_min=-math.inf)
    np.testing.assert_array_equal(hit.object_id, [-1, -1, -1, -1, ids[3], -1])
    assert not np.isnan(hit.t).any() and not np.isnan(hit.normal).any()


def test_ray_in_the_plane_of_a_triangle_misses():
    scene = durer.Scene()
    scene.add_triangles([[[0, 0, 0], [1, 0, 0], [0, 1, 0]]])
    hit = durer.cast(scene, [[-1, 0.2, 0], [0.2, -1, 0]], [[1, 0, 0], [0, 1, 0]], t_min=-math.inf)
    np.testing.assert_array_equal(hit.object_id, [-1, -1])


def test_mesh_is_one_object_with_one_material():
    vertices, faces = icosphere(1)
    scene = durer.Scene()
    red = scene.add_material((1, 0, 0))
    first = scene.add_spheres([[5, 0, 0]], 0.5)[0]
    mesh = scene.add_mesh(vertices, faces, red)
    assert (first, mesh) == (0, 1) and scene.triangle_count == len(faces) and scene.object_count == 2
    hit = durer.cast(scene, [[0, 0, 5], [0, 5, 0], [0.3, 0.1, -5]], [[0, 0, -1], [0, -1, 0], [0, 0, 1]])
    np.testing.assert_array_equal(hit.object_id, [mesh] * 3)
    np.testing.assert_array_equal(hit.material_id, [red] * 3)


def test_orthographic_render_of_a_cube_mesh_is_an_exact_square():
    # The unit cube seen along -z through a 2x2 window: pixel centres inside |x|, |y| < 1 see its
    # front face at depth 5 - 1 = 4, the rest see nothing.
    corners = np.array([[x, y, z] for z in (-1, 1) for y in (-1, 1) for x in (-1, 1)], float)
    faces = np.array([[0, 2, 1], [1, 2, 3], [4, 5, 6], [5, 7, 6], [0, 1, 4], [1, 5, 4],
                      [2, 6, 3], [3, 6, 7], [0, 4, 2], [2, 4, 6], [1, 3, 5], [3, 7, 5]])
    scene = durer.Scene()
    scene.add_mesh(corners, faces)
    camera = durer.OrthographicCamera((0, 0, 5), (0, 0, -1), (0, 1, 0), size=4.0)
    result = durer.render(scene, camera, 40, 40, passes=("depth", "normal"))
    centres = (np.arange(40) + 0.5) / 40 * 4 - 2
    inside = (np.abs(centres)[:, None] < 1) & (np.abs(centres)[None, :] < 1)
    np.testing.assert_array_equal(result.depth, np.where(inside, 4.0, np.inf).astype(np.float32))
    np.testing.assert_array_equal(result.normal[inside], np.tile([0, 0, 1], (inside.sum(), 1)))


def test_bad_meshes_and_triangles_name_the_argument():
    scene = durer.Scene()
    with pytest.raises(ValueError, match=r"faces\[1\]\[2\] = 3 is not a vertex index"):
        scene.add_mesh([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2], [0, 1, 3]])
    with pytest.raises(ValueError, match=r"faces\[0\]\[0\] = -1"):
        scene.add_mesh([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[-1, 1, 2]])
    with pytest.raises(TypeError, match="faces must hold integer"):
        scene.add_mesh([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0.0, 1.0, 2.0]])
    with pytest.raises(ValueError, match=r"faces must have shape \(F, 3\)"):
        scene.add_mesh([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [0, 1, 2])
    with pytest.raises(ValueError, match=r"vertices must have shape \(N, 3\)"):
        scene.add_mesh([[0, 0], [1, 0], [0, 1]], [[0, 1, 2]])
    with pytest.raises(ValueError, match="vertices must be finite"):
        scene.add_triangles([[[0, 0, 0], [1, np.nan, 0], [0, 1, 0]]])
    with pytest.raises(ValueError, match=r"vertices must have shape \(N, 3, 3\)"):
        scene.add_triangles([[0, 0, 0], [1, 0, 0], [0, 1, 0]])
    with pytest.raises(ValueError, match="material 7 is not a material id"):
        scene.add_mesh([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]], 7)
    assert scene.triangle_count == 0 and scene.object_count == 0  # a failed add changes nothing


@pytest.mark.parametrize("as_mesh", [False, True])
def test_secondary_rays_never_meet_the_triangle_they_leave(precision, as_mesh):
    # A floor of two triangles in y = 0 (no transform): its hit points have no rounding error across
    # the plane, so their shadow and mirror rays start one ulp above it, while the sheared test's t
    # carries ~1e-15 of cancellation. Without a conservative t > 0 these rays met their own triangle:
    # speckled shadows and a mirror that saw itself.
    floor = np.array([[-4, 0, -4], [4, 0, -4], [4, 0, 4], [-4, 0, 4]], float)
    faces = np.array([[0, 2, 1], [0, 3, 2]])  # wound so that the normal is +y
    scene = durer.Scene()
    grey = scene.add_material((0.5, 0.5, 0.5))
    mirror = scene.add_material((0, 0, 0), reflective=(1, 1, 1))
    for material, shift in ((grey, -4.0), (mirror, 4.0)):
        moved = floor * [0.5, 1, 1] + [shift, 0, 0]
        if as_mesh:
            scene.add_mesh(moved, faces, material)
        else:
            scene.add_triangles(moved[faces], material)
    scene.add_directional_light((0.3, -1, 0.2), (1, 1, 1), shadows=True)
    scene.background = (0, 0, 1)
    camera = durer.PerspectiveCamera((0, 6, 9), (0, -0.6, -1), (0, 1, 0), fov_degrees=50)
    result = durer.render(scene, camera, 96, 96, precision=precision, max_bounces=1)
    grey_pixels = (result.depth < np.inf) & (result.color[..., 2] < 0.9)
    mirror_pixels = (result.depth < np.inf) & ~grey_pixels
    assert grey_pixels.sum() > 1000 and mirror_pixels.sum() > 1000
    cosine = 1 / np.linalg.norm([0.3, -1, 0.2])
    np.testing.assert_allclose(result.color[grey_pixels][:, :3], 0.5 * cosine, rtol=1e-5)  # never shadowed
    np.testing.assert_array_equal(result.color[mirror_pixels][:, :3], [[0, 0, 1]] * mirror_pixels.sum())
    assert result.stats["shadow_rays"] > 1000 and result.stats["reflection_rays"] > 1000


# Two slivers about 1e-9 across, 1e6 from the origin, under a transform: the traversal fuzz's case
# (bench/fuzz_sanitized.sh, 2026-11-26). The ray's line passes ~2e6 from them, where their edge
# functions are rounding noise; all three once shared a sign and the ray hit at t = 10642.
SLIVERS = np.array([
    [[-288644.5614894652, -956041.8290800145, -51655.95969921923], [-288644.56148946466, -956041.8290800136, -51655.95969921969],
     [-288644.56148946437, -956041.8290800129, -51655.959699219886]],
    [[-288644.5614886783, -956041.8290803473, -51655.95969927017], [-288644.5614886864, -956041.8290803558, -51655.959699261424],
     [-288644.56148867216, -956041.8290803569, -51655.95969926647]]])
SLIVER_TRANSFORM = np.array([
    [0.4159374897992043, 0.6631454252694189, -1.363329222165041, 394984.2188243123],
    [0.14028285737057308, 0.21223348864794273, 0.6040985095047653, -681440.5642888768],
    [0.8985080547816388, -0.852940964842535, -0.5539660805938679, -636369.3858920503],
    [0, 0, 0, 1]])


def test_slivers_far_from_a_ray_are_never_hit():
    scene = durer.Scene()
    scene.add_triangles(SLIVERS, transform=SLIVER_TRANSFORM)
    origin = [0.01273474385517384, -0.0024086237677881876, -51655.95969974432]
    # The second ray, aimed at the slivers, enters their group's box, so the packet searches the group.
    aimed = [-288644.5614895, -956041.8290794, -51655.9597] - np.array(origin)
    hit = durer.cast(scene, [origin, origin], [[149.37088159014405, -32.2156084412135, 0.0], aimed], t_min=-math.inf)
    assert hit.t[0] == math.inf and hit.object_id[0] == -1


@pytest.mark.parametrize("precision", ["float", "double"])
def test_rays_passing_far_from_tiny_far_triangles_all_miss(rng, precision):
    """Triangles 1e-9 (double) or 1e-3 (float) across, 1e6 from the rays' origins: a ray whose line
    passes a unit or more from every triangle must miss them all, however noisy their edge functions."""
    size = 1e-9 if precision == "double" else 1e-3
    centres = rng.normal(size=(200, 3)) * 1e6
    triangles = centres[:, None, :] + rng.normal(size=(200, 3, 3)) * size
    scene = durer.Scene()
    scene.add_triangles(triangles)
    origins = rng.normal(size=(40000, 3))
    directions = rng.normal(size=(40000, 3))
    unit = directions / np.linalg.norm(directions, axis=1, keepdims=True)
    offsets = centres[None, :, :] - origins[:, None, :]
    along = np.einsum("rcj,rj->rc", offsets, unit)
    distance = np.linalg.norm(offsets - along[:, :, None] * unit[:, None, :], axis=2)
    far = distance.min(axis=1) > 1.0
    hit = durer.cast(scene, origins[far], directions[far], t_min=-math.inf, precision=precision)
    assert far.sum() > 39000
    assert (hit.object_id == -1).all(), f"{(hit.object_id != -1).sum()} rays hit a triangle more than a unit away"


def _barycentric_rays(triangle: np.ndarray, weights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rays straight down onto points of `triangle` (in a z = const plane) at barycentric `weights`."""
    targets = weights @ triangle
    return targets + [0, 0, 5], np.broadcast_to([0.0, 0.0, -1.0], targets.shape)


@pytest.mark.parametrize("per_corner", [False, True])
def test_a_smooth_triangle_interpolates_its_corners_normals(rng, precision, per_corner):
    """The normal at a hit is the corners' normals (made unit) weighted by its barycentrics, made
    unit; the hit's t and ids are the flat triangle's."""
    triangle = np.array([[0, 0, 0], [2, 0, 0], [0, 2, 0]], float)
    normals = np.array([[0.3, 0.1, 1], [-0.2, 0.4, 2], [0.1, -0.5, 0.5]])
    scene = durer.Scene()
    given = normals[None] if per_corner else normals
    scene.add_mesh(triangle, [[0, 1, 2]], normals=given)
    weights = rng.dirichlet((1, 1, 1), 200)
    origins, directions = _barycentric_rays(triangle, weights)
    hit = durer.cast(scene, origins, directions, precision=precision)
    unit = normals / np.linalg.norm(normals, axis=1, keepdims=True)
    expected = weights @ unit
    expected /= np.linalg.norm(expected, axis=1, keepdims=True)
    tolerance = 1e-13 if precision == "double" else 2e-6
    np.testing.assert_allclose(hit.normal, expected, atol=tolerance)
    flat = durer.Scene()
    flat.add_mesh(triangle, [[0, 1, 2]])
    flat_hit = durer.cast(flat, origins, directions, precision=precision)
    np.testing.assert_array_equal(flat_hit.normal, [[0, 0, 1]] * 200)
    np.testing.assert_array_equal(hit.t, flat_hit.t)
    np.testing.assert_allclose(hit.t, 5.0, rtol=1e-6)
    assert (hit.object_id == 0).all()


def test_a_smooth_icosphere_shades_as_the_sphere_it_approximates():
    """An icosphere whose vertex normals are the sphere's: its normal pass within a few degrees of
    the exact sphere's where the faceted mesh is off by up to its facets' angle, and so is its
    Lambert shading; flat triangles added before and after keep their own normals."""
    vertices, faces = icosphere(2)
    camera = durer.OrthographicCamera((0, 0, 5), (0, 0, -1), (0, 1, 0), 2.2)
    error = {}
    for smooth in (False, True):
        scene = durer.Scene()
        scene.add_triangles([[[-9, -9, -3], [9, -9, -3], [0, 9, -3]]])
        scene.add_mesh(vertices, faces, normals=vertices if smooth else None)
        scene.add_triangles([[[-9, -9, -4], [9, -9, -4], [0, 9, -4]]])
        result = durer.render(scene, camera, 64, 64, passes=("depth", "normal"))
        on_ball = result.depth < 4.5
        exact = np.zeros(on_ball.shape + (3,))
        ys, xs = np.nonzero(on_ball)
        px = (xs + 0.5) / 64 * 2.2 - 1.1
        py = 1.1 - (ys + 0.5) / 64 * 2.2
        hit = np.stack([px, py, 5 - result.depth[on_ball]], axis=1)
        exact[on_ball] = hit / np.linalg.norm(hit, axis=1, keepdims=True)
        cosine = np.clip(np.sum(result.normal[on_ball] * exact[on_ball], axis=1), -1, 1)
        error[smooth] = np.degrees(np.arccos(cosine))
        floor = (result.depth > 7.5) & (result.depth < 8.5)
        assert floor.sum() > 100
        np.testing.assert_array_equal(result.normal[floor], [[0, 0, 1]] * floor.sum())
    assert error[False].max() > 10 and np.median(error[False]) > 3
    assert error[True].max() < 2.5 and np.median(error[True]) < 0.5


def test_a_smooth_mesh_s_instances_turn_its_normals():
    """add_mesh_instances with normals: each instance's normals turned by its matrix (its inverse
    transpose), made unit."""
    triangle = np.array([[0, 0, 0], [2, 0, 0], [0, 2, 0]], float)
    normals = np.array([[0.3, 0.1, 1], [0.3, 0.1, 1], [0.3, 0.1, 1]])
    turn = np.array([[0, -1, 0, 10], [1, 0, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]], float)  # 90° about z, moved
    squash = np.diag([1.0, 1.0, 4.0, 1.0])
    scene = durer.Scene()
    scene.add_mesh_instances(triangle, [[0, 1, 2]], [turn, squash], normals=normals)
    hit = durer.cast(scene, [[9.5, 0.5, 5], [0.5, 0.5, 50]], [[0, 0, -1], [0, 0, -1]])
    assert (hit.object_id == 0).all()
    n = normals[0] / np.linalg.norm(normals[0])
    turned = turn[:3, :3] @ n
    squashed = np.linalg.inv(squash[:3, :3]).T @ n
    np.testing.assert_allclose(hit.normal, [turned, squashed / np.linalg.norm(squashed)], atol=1e-14)


def test_light_on_a_smooth_mesh_leaves_by_its_own_faces():
    """A flat floor whose corner normals lean, lit from just below its plane but above its leaning
    normals' horizon: shaded by the leaning normals and lit, as Cycles lights it, because its shadow
    rays leave by the faces' own side (offset along the leaning normal, every ray started above the
    floor and met it: all black)."""
    floor = np.array([[-4, -4, 0], [4, -4, 0], [4, 4, 0], [-4, 4, 0]], float)
    faces = np.array([[0, 1, 2], [0, 2, 3]])
    lean = np.array([[0.9, 0, 1], [0.9, 0, 1], [0.9, 0, 1], [0.9, 0, 1]])
    scene = durer.Scene()
    scene.add_mesh(floor, faces, scene.add_material((1, 1, 1)), normals=lean)
    light = np.array([-1.0, 0.0, 0.2])  # the direction light travels: toward the light is (1, 0, -0.2)
    scene.add_directional_light(light, (1, 1, 1), shadows=True)
    camera = durer.OrthographicCamera((0, 0, 5), (0, 0, -1), (0, 1, 0), 6)
    result = durer.render(scene, camera, 48, 48, passes=("color", "normal"))
    n = lean[0] / np.linalg.norm(lean[0])
    np.testing.assert_allclose(result.normal.reshape(-1, 3), [n] * 48 * 48, atol=1e-6)
    expected = float(n @ -light / np.linalg.norm(light))
    assert expected > 0.4
    np.testing.assert_allclose(result.color[..., :3], expected, rtol=1e-5)
    assert result.stats["shadow_rays"] == 48 * 48


def test_bad_normals_name_the_argument():
    scene = durer.Scene()
    triangle, face = [[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]]
    with pytest.raises(ValueError, match=r"normals\[1\] = \(0, 0, 0\) has no direction"):
        scene.add_mesh(triangle, face, normals=[[0, 0, 1], [0, 0, 0], [0, 0, 1]])
    with pytest.raises(ValueError, match=r"normals\[0\]\[2\] must be finite"):
        scene.add_mesh(triangle, face, normals=[[[0, 0, 1], [0, 0, 1], [0, np.nan, 1]]])
    with pytest.raises(ValueError, match=r"normals must have shape \(3, 3\) or \(1, 3, 3\)"):
        scene.add_mesh(triangle, face, normals=[[0, 0, 1]])
    assert scene.triangle_count == 0
    scene.add_mesh(triangle, face, normals=[[0, 0, 1e-300], [0, 0, 1e300], [5e-324, 0, 0]])  # any length
    hit = durer.cast(scene, [[0.0, 0.0, 1.0]], [[0.0, 0.0, -1.0]])
    np.testing.assert_array_equal(hit.normal, [[0, 0, 1]])


def test_glass_with_smooth_normals_is_entered_from_the_front_of_its_faces():
    """A glass quad facing the camera whose corner normals lean past the oblique rays: the rays
    enter it (the face decides the side), bent about its own normal where the smooth one leans
    past the ray. Deciding by the smooth normal, all 64 were taken as leaving: total internal
    reflection."""
    quad = np.array([[-4, -4, 0], [4, -4, 0], [4, 4, 0], [-4, 4, 0]], float)
    scene = durer.Scene()
    glass = scene.add_material((0, 0, 0), transparent=(1, 1, 1), ior=1.5)
    scene.add_mesh(quad, [[0, 1, 2], [0, 2, 3]], glass, normals=[[1, 0, 1.8]] * 4)
    camera = durer.OrthographicCamera((-6, 0, 4), (0.9, 0, -0.436), (0, 1, 0), 1.0)
    result = durer.render(scene, camera, 8, 8, max_bounces=1)
    assert result.stats["refraction_rays"] == 64 and result.stats["total_internal_reflections"] == 0


def test_total_internal_reflection_at_a_smooth_face_turns_back_into_the_glass():
    """Leaving glass at a grazing angle where the smooth normal leans past the ray: the ray is
    bent about the face's own normal, totally reflected, and the reflection turns back below the
    face (about the smooth normal it passed through the glass to the red light above)."""
    quad = np.array([[-4, -4, 0], [4, -4, 0], [4, 4, 0], [-4, 4, 0]], float)
    scene = durer.Scene()
    glass = scene.add_material((0, 0, 0), transparent=(1, 1, 1), ior=1.5)
    scene.add_mesh(quad, [[0, 1, 2], [0, 2, 3]], glass, normals=[[-1, 0, 1.8]] * 4)
    scene.add_plane((0, 0, 1), 5.0, scene.add_material((0, 0, 0), emission=(1, 0, 0)))
    camera = durer.OrthographicCamera((-6, 0, -4), (0.9, 0, 0.436), (0, 0, 1), 1.0)
    result = durer.render(scene, camera, 8, 8, max_bounces=1)
    assert result.stats["total_internal_reflections"] == 64
    np.testing.assert_array_equal(result.color[..., :3], 0.0)  # the black background below, not the red above


def _low_poly_sphere(around: int = 8, rings: int = 6) -> tuple[np.ndarray, np.ndarray]:
    """A UV sphere of radius 1 wound outward: (V, 3) vertices, which are also its smooth normals."""
    vertices = [(0.0, 0.0, 1.0)]
    for j in range(1, rings):
        theta = math.pi * j / rings
        vertices += [(math.sin(theta) * math.cos(phi), math.sin(theta) * math.sin(phi), math.cos(theta))
                     for phi in 2 * math.pi * np.arange(around) / around]
    vertices.append((0.0, 0.0, -1.0))
    faces = [(0, 1 + i, 1 + (i + 1) % around) for i in range(around)]
    for j in range(rings - 2):
        for i in range(around):
            a, b = 1 + j * around + i, 1 + j * around + (i + 1) % around
            faces += [(a, a + around, b + around), (a, b + around, b)]
    last, base = len(vertices) - 1, 1 + (rings - 2) * around
    faces += [(base + i, last, base + (i + 1) % around) for i in range(around)]
    v, f = np.array(vertices), np.array(faces)
    inward = (np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]) * v[f].mean(axis=1)).sum(axis=1) < 0
    f[inward] = f[inward][:, ::-1]
    return v, f


@pytest.mark.parametrize("elevation", [60, 30, 5])
def test_a_smooth_low_poly_sphere_is_not_shadowed_along_its_terminator(precision, elevation):
    """A smooth 8 x 6 sphere under a sun: every pixel its smooth normals light is lit, as Cycles
    lights it (its shadow terminator offset): the shadow rays start on the smooth surface the
    corners' normals describe, not on the flat faces, whose neighbours shadowed 196 of 2,398."""
    vertices, faces = _low_poly_sphere()
    sun = (-math.cos(math.radians(elevation)), 0.0, -math.sin(math.radians(elevation)))
    camera = durer.OrthographicCamera((0, -5, 0), (0, 1, 0), (0, 0, 1), 2.4)
    lit = {}
    for shadows in (False, True):
        scene = durer.Scene()
        scene.add_mesh(vertices, faces, scene.add_material((0.8, 0.8, 0.8)), normals=vertices)
        scene.add_directional_light(sun, (1, 1, 1), shadows=shadows)
        result = durer.render(scene, camera, 96, 96, precision=precision)
        lit[shadows] = result.color[..., 0]
        assert (result.stats["shadow_rays"] > 1000) == shadows
    assert (lit[False] > 1e-4).sum() > 1500
    np.testing.assert_array_equal(lit[True], lit[False])
