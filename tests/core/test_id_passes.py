"""The id passes (issue 14 item 3): `object_id` and `material_id`, int32, the object and material
ids of each pixel's nearest hit sample (object ids as the adds return them and `cast` reports
them), -1 where every sample missed. Asked for by name: not among the default passes."""

from __future__ import annotations

import numpy as np
import pytest

import durer
from durer.render import DEFAULT_PASSES, PASSES, PRECISIONS

IDS = ("object_id", "material_id")
W, H = 48, 32
# Looking straight down from z = 5 over x in [-3, 3]: the plane z = 0 is at depth 5 exactly.
DOWN = durer.OrthographicCamera((0, 0, 5), (0, 0, -1), (0, 1, 0), 6.0)
LOOKING = durer.PerspectiveCamera((1.0, -7.0, 4.0), (-0.1, 1.0, -0.55), (0, 0, 1), fov_degrees=45)


def two_spheres_and_a_plane() -> tuple[durer.Scene, dict[str, int]]:
    """Spheres of radius 1 at x = -1.2 (material red) and x = +1.4 (material blue), resting on a
    floor plane z = 0 (material grey, the scene's default material 0), bounded to 8 x 8."""
    scene = durer.Scene()
    red, blue = scene.add_material((1, 0, 0)), scene.add_material((0, 0, 1))
    floor = scene.add_plane((0, 0, 1), 0.0, bounds=((-4, -4, 0), (8, 0, 0), (0, 8, 0)))
    left, right = scene.add_spheres([(-1.2, 0, 1), (1.4, 0, 1)], 1.0, [red, blue])
    return scene, {"floor": floor, "left": int(left), "right": int(right), "red": red, "blue": blue}


def cast_centres(scene: durer.Scene, camera, precision: str) -> durer.CastResult:
    """The pixel-centre rays, exactly as render makes them with spp=1, cast."""
    origins, directions = camera.rays(W, H, precision)
    return durer.cast(scene, origins.reshape(-1, 3), directions.reshape(-1, 3), t_min=max(camera.t_min, -1e30),
                      precision=precision)


def test_id_passes_are_asked_for_by_name():
    assert PASSES[-2:] == IDS and set(DEFAULT_PASSES) == {"color", "depth", "normal"}
    scene, _ = two_spheres_and_a_plane()
    default = durer.render(scene, DOWN, 8, 8)
    assert default.object_id is None and default.material_id is None
    assert default.stats["passes"] == DEFAULT_PASSES
    only = durer.render(scene, DOWN, 8, 8, passes=("object_id",))
    assert only.color is None and only.depth is None and only.material_id is None
    assert only.object_id.dtype == np.int32 and only.object_id.shape == (8, 8)
    assert durer.render(scene, DOWN, 8, 8, passes="material_id").stats["passes"] == ("material_id",)


@pytest.mark.parametrize("precision", PRECISIONS)
def test_top_view_ids_are_the_analytic_ones(precision):
    scene, ids = two_spheres_and_a_plane()
    result = durer.render(scene, DOWN, W, H, passes=IDS, sampler="center", precision=precision)
    # Pixel centres: x = -3 + (col + 0.5)/8, y = 2 - (row + 0.5)/8 (6 units over 48 pixels).
    x = -3 + (np.arange(W) + 0.5) / 8
    y = 2 - (np.arange(H) + 0.5) / 8
    xx, yy = np.meshgrid(x, y)
    expected_object = np.full((H, W), ids["floor"])
    expected_material = np.zeros((H, W), np.int32)
    for name, material, cx in (("left", "red", -1.2), ("right", "blue", 1.4)):
        inside = (xx - cx) ** 2 + yy**2 < 1
        expected_object[inside], expected_material[inside] = ids[name], ids[material]
    np.testing.assert_array_equal(result.object_id, expected_object)
    np.testing.assert_array_equal(result.material_id, expected_material)
    assert {ids["floor"], ids["left"], ids["right"]} == set(np.unique(result.object_id))


def nested_scene() -> durer.Scene:
    """Every kind of primitive, world-space and under transforms (ellipsoids, a rotated mesh, boxes
    sharing one transformed group with a sphere), with misses around them."""
    scene, _ = two_spheres_and_a_plane()
    gold = scene.add_material((1, 0.8, 0.2))
    turn = np.array([[0, -1, 0, 0.5], [1, 0, 0, 0.5], [0, 0, 1, 2.6], [0, 0, 0, 1]], float)
    squash = np.diag([1.6, 0.5, 0.4, 1.0])
    squash[:3, 3] = (0.2, 1.6, 0.5)
    scene.add_spheres([(0, 0, 0), (0, 0, 1.5)], [0.6, 0.3], [gold, 2], transform=squash)
    scene.add_mesh([(-1, -0.5, 0), (1, -0.5, 0), (0, 0.8, 0.3)], [(0, 1, 2)], gold, transform=turn)
    scene.add_boxes([(-0.4, -0.4, -0.4), (0.6, 0.6, 0.6)], [(0.0, 0.0, 0.0), (1.0, 1.0, 1.0)], [1, gold],
                    transform=turn)
    scene.add_spheres([(-1.0, 1.0, 0.0)], 0.3, gold, transform=turn)
    scene.add_triangles([[(2.5, -2, 0.5), (3.5, -2, 0.5), (3, -1, 1.5)]], 2)
    return scene


@pytest.mark.parametrize("precision", PRECISIONS)
@pytest.mark.parametrize("passes", [IDS, ("color", "object_id", "material_id"), ("normal", "object_id", "material_id")],
                         ids=["ids", "with-color", "with-normal"])
def test_one_sample_per_pixel_gives_what_cast_gives(precision, passes):
    """Nested groups and every primitive kind: each pixel's ids are its centre ray's hit record."""
    scene = nested_scene()
    hits = cast_centres(scene, LOOKING, precision)
    result = durer.render(scene, LOOKING, W, H, passes=passes, sampler="center", precision=precision)
    np.testing.assert_array_equal(result.object_id, hits.object_id.reshape(H, W))
    np.testing.assert_array_equal(result.material_id, hits.material_id.reshape(H, W))
    assert len(np.unique(result.object_id)) >= 8 and (result.object_id == -1).any()


def test_lit_scenes_with_shadows_and_mirrors_give_the_same_ids():
    """A lit render (hit records and shading) finds the same nearest primitives as the flat one."""
    scene = nested_scene()
    mirror = scene.add_material((0.2, 0.2, 0.2), reflective=(0.5, 0.5, 0.5))
    ball = int(scene.add_spheres([(-2.5, -1.5, 0.6)], 0.6, mirror)[0])  # on the floor nearest the camera: a mirror
    flat = durer.render(scene, LOOKING, W, H, passes=IDS, spp=4, seed=3)
    scene.add_point_light((0, -3, 6), (30, 30, 30), shadows=True)
    lit = durer.render(scene, LOOKING, W, H, passes=("color",) + IDS, spp=4, seed=3)
    assert "shadows" in lit.stats["effects"] and "reflection" in lit.stats["effects"]
    assert lit.stats["reflection_rays"] > 0 and (lit.object_id == ball).sum() > 20
    np.testing.assert_array_equal(lit.material_id[lit.object_id == ball], mirror)
    np.testing.assert_array_equal(lit.object_id, flat.object_id)
    np.testing.assert_array_equal(lit.material_id, flat.material_id)


@pytest.mark.parametrize("precision", PRECISIONS)
@pytest.mark.parametrize("sampler", ["stratified", "random", "sobol", "adaptive"])
def test_several_samples_give_the_nearest_hit_samples_ids(precision, sampler):
    """Seen from above, the floor is at depth 5 and the spheres nearer: a pixel's ids are a
    sphere's exactly where its nearest sample (the depth pass) is nearer than the floor, so every
    edge pixel that any sample of which meets a sphere takes the sphere's ids, never the floor's."""
    scene, ids = two_spheres_and_a_plane()
    result = durer.render(scene, DOWN, W, H, spp=16, sampler=sampler, precision=precision,
                          passes=("color", "depth") + IDS)
    on_sphere = result.depth < 5 - 1e-4
    floor = result.depth == 5
    assert (on_sphere | floor).all()  # the floor covers the whole view
    np.testing.assert_array_equal(result.object_id[floor], ids["floor"])
    np.testing.assert_array_equal(result.material_id[floor], 0)
    left = result.object_id == ids["left"]
    assert (on_sphere == (left | (result.object_id == ids["right"]))).all()
    np.testing.assert_array_equal(result.material_id[left], ids["red"])
    np.testing.assert_array_equal(result.material_id[on_sphere & ~left], ids["blue"])
    # The edge pixels, partly floor in colour, still carry the sphere's id.
    red = result.color[..., 0]
    edges = left & (red < 0.9) & (red > 0.1)
    assert edges.sum() >= 20


@pytest.mark.parametrize("precision", PRECISIONS)
def test_misses_are_minus_one(precision):
    scene, ids = two_spheres_and_a_plane()
    up = durer.OrthographicCamera((0, 0, 5), (0, 0, 1), (0, 1, 0), 6.0, t_min=0.0)  # looking away
    result = durer.render(scene, up, 8, 8, spp=4, passes=IDS, precision=precision)
    np.testing.assert_array_equal(result.object_id, -1)
    np.testing.assert_array_equal(result.material_id, -1)
    side = durer.OrthographicCamera((0, -6, 1), (0, 1, 0), (0, 0, 1), 6.0, t_min=0.0)
    result = durer.render(scene, side, W, H, sampler="center", passes=IDS, precision=precision)
    # Rows above z = 2 see nothing (the floor is edge-on): all -1; the spheres' rows both.
    assert (result.object_id[:4] == -1).all() and (result.material_id[:4] == -1).all()
    assert ((result.object_id == -1) == (result.material_id == -1)).all()
    assert {-1, ids["left"], ids["right"]} <= set(np.unique(result.object_id))


@pytest.mark.parametrize("sampler", ["stratified", "adaptive"])
def test_a_region_is_that_part_of_the_whole_render(sampler):
    scene = nested_scene()
    whole = durer.render(scene, LOOKING, W, H, spp=4, sampler=sampler, passes=IDS)
    part = durer.render(scene, LOOKING, W, H, spp=4, sampler=sampler, passes=IDS, region=(8, 16, 24, 16))
    np.testing.assert_array_equal(part.object_id, whole.object_id[16:32, 8:32])
    np.testing.assert_array_equal(part.material_id, whole.material_id[16:32, 8:32])


def test_out_reuses_the_id_arrays_and_checks_their_type():
    scene = nested_scene()
    first = durer.render(scene, LOOKING, W, H, passes=IDS)
    arrays = first.object_id, first.material_id
    arrays[0][:] = 1234
    again = durer.render(scene, LOOKING, W, H, passes=IDS, out=first)
    assert again.object_id is arrays[0] and again.material_id is arrays[1]
    assert (again.object_id != 1234).all()
    first.object_id = first.object_id.astype(np.float32)
    with pytest.raises(TypeError, match="out.object_id must be a int32 array"):
        durer.render(scene, LOOKING, W, H, passes=IDS, out=first)


def test_a_mesh_is_one_object_and_moved_spheres_keep_their_ids():
    scene = durer.Scene()
    mesh = scene.add_mesh([(-2, -2, 0), (2, -2, 0), (2, 2, 0), (-2, 2, 0)], [(0, 1, 2), (0, 2, 3)], 0)
    balls = scene.add_spheres([(-1, 0, 1), (1, 0, 1)], 0.5)
    before = durer.render(scene, DOWN, W, H, sampler="center", passes=("object_id",)).object_id
    assert set(np.unique(before)) == {-1, mesh, *balls}
    scene.move_spheres(balls[::-1], [(-1, 0, 1), (1, 0, 1)])  # swapped places
    after = durer.render(scene, DOWN, W, H, sampler="center", passes=("object_id",)).object_id
    swapped = np.where(before == balls[0], balls[1], np.where(before == balls[1], balls[0], before))
    np.testing.assert_array_equal(after, swapped)
