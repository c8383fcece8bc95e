"""Closed meshes at scale (issue 17): more than a million rays from inside meshes of several sizes
and offsets, in both precisions, all meet the mesh; shadow and mirror rays leaving a convex mesh
never meet it again (no acne at grazing light, no mirror that sees itself)."""

from __future__ import annotations

import numpy as np
import pytest

import durer
from helpers.meshes import icosphere

# (radius, offset of the centre): tiny, unit, large, and far from the origin for its size.
MESHES = [(1e-4, 0.0), (1.0, 0.0), (1e4, 0.0), (1.0, 1e3), (50.0, 1e5)]
RAYS_PER_MESH = 120_000  # x 5 meshes x 2 precisions: 1.2 million rays


def inside_rays(vertices: np.ndarray, faces: np.ndarray, radius: float, center: np.ndarray,
                rng: np.random.Generator, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Origins anywhere within half the radius of the centre; a third of the rays aimed exactly at
    vertices, a third at points of edges, a third in random directions; lengths from 1e-6 to 1e6 of
    the radius, so no length is special."""
    origins = center + radius * 0.5 * rng.uniform(-1, 1, (n, 3)) / np.sqrt(3)
    third = n // 3
    edges = vertices[faces[:, [0, 1]]]
    along = rng.uniform(0, 1, (third, 1))
    picked = edges[rng.integers(0, len(edges), third)]
    targets = np.concatenate([
        vertices[rng.integers(0, len(vertices), third)],
        picked[:, 0] + along * (picked[:, 1] - picked[:, 0]),
        center + radius * rng.normal(size=(n - 2 * third, 3)),
    ])
    lengths = 10.0 ** rng.uniform(-6, 6, (n, 1))
    directions = (targets - origins) / np.linalg.norm(targets - origins, axis=1, keepdims=True) * radius * lengths
    return origins, directions


@pytest.mark.parametrize("radius, offset", MESHES)
def test_a_million_rays_from_inside_closed_meshes_all_hit(precision, radius, offset):
    rng = np.random.default_rng(int(radius * 7 + offset) % 1000)
    unit_vertices, faces = icosphere(4)
    center = np.array([offset, -0.5 * offset, 0.25 * offset])
    vertices = center + radius * unit_vertices
    scene = durer.Scene()
    scene.add_mesh(vertices, faces)
    origins, directions = inside_rays(vertices, faces, radius, center, rng, RAYS_PER_MESH)
    hit = durer.cast(scene, origins, directions, precision=precision)
    escaped = hit.object_id != 0
    assert not escaped.any(), (f"{escaped.sum()} of {RAYS_PER_MESH} rays left the mesh, e.g. from "
                               f"{origins[escaped][0]!r} along {directions[escaped][0]!r}")
    assert np.isfinite(hit.t).all() and (hit.t > 0).all()
    # Each hit lies on the mesh: between the inscribed and the circumscribed sphere (radius).
    distance = np.linalg.norm(origins + hit.t[:, None] * directions - center, axis=1) / radius
    inscribed = np.cos(np.radians(7.0))  # icosphere(4): an edge spans under 4.3°, so faces dip less than this
    slack = 1e-3 if precision == "float" else 1e-9
    assert distance.min() > inscribed - slack and distance.max() < 1 + slack + 1e-6 * abs(offset) / radius


def lit_tessellated_sphere(material_kind: str) -> durer.Scene:
    vertices, faces = icosphere(4)
    scene = durer.Scene()
    if material_kind == "mirror":
        material = scene.add_material((0.2, 0.2, 0.2), reflective=(0.5, 0.5, 0.5))
    else:
        material = scene.add_material((0.8, 0.8, 0.8))
    scene.add_mesh(vertices, faces, material)
    scene.background = (0.0, 0.25, 1.0)
    return scene


@pytest.mark.parametrize("elevation_degrees", [0.5, 2.0, 10.0])
def test_no_acne_on_a_tessellated_sphere_lit_at_grazing_angles(precision, elevation_degrees):
    """A convex mesh cannot shadow itself: where a face turns toward the light, its shadow ray leaves
    the half-space the whole mesh lies in. So shadows on or off give the same image, bit for bit,
    with the light a fraction of a degree above the faces along the terminator; and the lit region
    is the analytic sphere's but for the faceting."""
    camera = durer.OrthographicCamera((0, 0, 5), (0, 0, -1), (0, 1, 0), size=2.2)
    light = (-np.cos(np.radians(elevation_degrees)), 0.0, -np.sin(np.radians(elevation_degrees)))
    images = []
    for shadows in (False, True):
        scene = lit_tessellated_sphere("diffuse")
        scene.add_directional_light(light, (1, 1, 1), shadows=shadows)
        images.append(durer.render(scene, camera, 160, 160, precision=precision))
    without, with_shadows = images
    assert with_shadows.stats["shadow_rays"] > 5000
    np.testing.assert_array_equal(with_shadows.color, without.color)
    analytic = durer.Scene()
    analytic.add_spheres([[0, 0, 0]], 1.0, analytic.add_material((0.8, 0.8, 0.8)))
    analytic.background = (0.0, 0.25, 1.0)
    analytic.add_directional_light(light, (1, 1, 1), shadows=True)
    sphere = durer.render(analytic, camera, 160, 160, precision=precision)
    on_both = np.isfinite(sphere.depth) & np.isfinite(with_shadows.depth)
    lit_mesh, lit_sphere = with_shadows.color[..., 0] > 0, sphere.color[..., 0] > 0
    assert lit_sphere[on_both].sum() > 1000
    assert (lit_mesh != lit_sphere)[on_both].mean() < 0.02  # only along the faceted terminator


def test_mirror_rays_leaving_a_convex_mesh_never_see_it(precision):
    """Every mirror ray off a convex mesh leaves it for the background: each hit pixel is exactly
    its flat diffuse colour plus half the background, none the mesh seen in itself."""
    scene = lit_tessellated_sphere("mirror")
    scene.shading = "flat"
    camera = durer.PerspectiveCamera((0.3, 0.2, 4), (-0.075, -0.05, -1), (0, 1, 0), fov_degrees=35)
    result = durer.render(scene, camera, 160, 160, precision=precision, max_bounces=2)
    hit = np.isfinite(result.depth)
    assert hit.sum() > 5000 and result.stats["reflection_rays"] == hit.sum()
    expected = np.array([0.2, 0.2 + 0.5 * 0.25, 0.2 + 0.5 * 1.0], np.float32)
    np.testing.assert_allclose(result.color[hit][:, :3], np.broadcast_to(expected, (hit.sum(), 3)), rtol=1e-6)


def test_rays_through_shared_edges_and_vertices_cross_the_surface_once(precision):
    """No double hit: a pane of glass (ior 1, a flat grid of triangles) seen straight down with pixel
    centres on its vertices and edges (spacing 1/8, pixels 1/16 apart: all binary fractions). Each
    camera ray that meets the pane spawns one refracted ray, which must reach the floor below, not
    meet a neighbouring triangle of the edge it crossed."""
    n = 8
    xs = np.arange(n + 1) / n
    vertices = np.array([[x, y, 0.0] for y in xs for x in xs])
    index = np.arange((n + 1) ** 2).reshape(n + 1, n + 1)
    a, b, c, d = index[:-1, :-1].ravel(), index[:-1, 1:].ravel(), index[1:, :-1].ravel(), index[1:, 1:].ravel()
    faces = np.concatenate([np.column_stack([a, b, d]), np.column_stack([a, d, c])])
    scene = durer.Scene()
    glass = scene.add_material((0, 0, 0), transparent=(1, 1, 1), ior=1.0)
    floor = scene.add_material((0.25, 0.5, 0.75))
    scene.add_mesh(vertices, faces, glass)
    scene.add_plane((0, 0, 1), -1.0, floor)
    scene.shading = "flat"
    camera = durer.OrthographicCamera((0.5, 0.5, 1), (0, 0, -1), (0, 1, 0), size=17 / 16)
    result = durer.render(scene, camera, 17, 17, precision=precision, max_bounces=3)
    assert result.stats["refraction_rays"] == 17 * 17  # one per pixel: every centre is on the pane
    np.testing.assert_array_equal(result.color[..., :3], np.broadcast_to(np.float32([0.25, 0.5, 0.75]), (17, 17, 3)))
