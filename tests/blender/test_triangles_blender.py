"""Meshes that are neither spheres nor flat quads render as triangles, split by material slot;
spheres under a non-uniform scale render as exact ellipsoids."""

from __future__ import annotations


import numpy as np
import pytest
from helpers.blender import (
    DEG,
    MISS,
    aim_camera,
    both,
    cube,
    export,
    link,
    material,
    mesh_object,
    points_object,
    render_passes,
    use_cycles,
    uv_sphere,
    vertex_object,
    world,
)

from helpers.blender_import import blender_module

bpy = blender_module("bpy")
bmesh = blender_module("bmesh")

from durer.blender import build, engine

pytestmark = pytest.mark.blender


def suzanne(s, name="Suzanne", **kw):
    return mesh_object(s, name, lambda bm: bmesh.ops.create_monkey(bm), **kw)


def loop_triangles(me):
    tris = me.loop_triangles
    faces = np.empty(len(tris) * 3, np.int32)
    tris.foreach_get("vertices", faces)
    return faces.reshape(-1, 3)


def vertex_array(me):
    co = np.empty(len(me.vertices) * 3, np.float32)
    me.vertices.foreach_get("co", co)
    return co.reshape(-1, 3)


# --- export ----------------------------------------------------------------------------------------


def test_mesh_exports_its_loop_triangles_in_object_space(scene):
    obj = suzanne(scene, location=(1, 2, 3), rotation=(10 * DEG, 20 * DEG, 30 * DEG), scale=(2, 1, 1))
    obj.data.materials.append(material("Skin", (0.6, 0.4, 0.3)))
    d = export(scene)
    assert d.sphere_count == 0 and not d.planes and not d.skipped and not d.warnings
    (m,) = d.meshes
    assert m.name == "Suzanne" and d.sources == {"Suzanne": 1}
    assert m.vertices.dtype == np.float32 and m.faces.dtype == np.int32
    np.testing.assert_array_equal(m.vertices, vertex_array(obj.data))  # bit for bit, no transform applied
    np.testing.assert_array_equal(m.faces, loop_triangles(obj.data))
    assert d.triangle_count == 968  # 500 polygons, quads and triangles
    np.testing.assert_allclose(m.matrix, np.array(obj.matrix_world), atol=1e-7)
    assert d.materials[m.material].diffuse == pytest.approx((0.6, 0.4, 0.3))


def test_mesh_with_several_material_slots_splits_per_slot(scene):
    obj = cube(scene, "Dice", size=2.0)
    me = obj.data
    for name, color in (("Red", (1, 0, 0)), ("Green", (0, 1, 0)), ("Blue", (0, 0, 1))):
        me.materials.append(material(name, color))
    # Faces 0-1 green, face 5 past the last slot (Blender clamps it: blue), the rest red.
    me.polygons.foreach_set("material_index", np.array([1, 1, 0, 0, 0, 7], np.int32))
    me.update()
    d = export(scene)
    parts = {d.materials[m.material].diffuse: m for m in d.meshes}
    assert {c: len(m.faces) for c, m in parts.items()} == {(1, 0, 0): 6, (0, 1, 0): 4, (0, 0, 1): 2}
    assert d.sources == {"Dice": 3}
    # Each part keeps only the vertices its faces use (a quad: 4), and together they are the cube.
    assert len(parts[(0, 0, 1)].vertices) == 4
    full = vertex_array(me)[loop_triangles(me)]
    split = np.concatenate([m.vertices[m.faces] for m in d.meshes])
    assert sorted(map(tuple, np.round(full.reshape(-1, 9), 6))) == sorted(map(tuple, np.round(split.reshape(-1, 9), 6)))


def test_instances_of_one_mesh_share_its_arrays(scene):
    a = suzanne(scene, "A")
    b = link(scene, bpy.data.objects.new("B", a.data))
    b.location = (3, 0, 0)
    d = export(scene)
    ma, mb = sorted(d.meshes, key=lambda m: m.name)
    assert ma.vertices is mb.vertices and ma.faces is mb.faces
    assert mb.matrix[0, 3] == 3 and ma.transform is None  # identity: nothing for the core to apply


def test_mesh_mode_ignore_and_empty_meshes(scene):
    uv_sphere(scene, "Faceted").durer.primitive = "MESH"  # would be a sphere in Auto
    suzanne(scene, "Hidden").durer.primitive = "IGNORE"
    vertex_object(scene, "Loose", [(0, 0, 0), (1, 0, 0)])  # no faces: nothing to render, nothing to warn
    link(scene, bpy.data.objects.new("Void", bpy.data.meshes.new("Void")))
    d = export(scene)
    assert d.sphere_count == 0 and [m.name for m in d.meshes] == ["Faceted"]
    assert d.triangle_count == 32 * 14 * 2 + 2 * 32  # UV sphere: quads between the poles, fans at them
    assert not d.skipped and not d.warnings


def test_flattened_mesh_goes_to_world_space(scene):
    """A scale of 0 leaves no inverse for the core: the triangles are moved into world space."""
    obj = suzanne(scene, "Flat", location=(0, 0, 1), scale=(1, 0, 1))
    d = export(scene)
    (m,) = d.meshes
    assert m.transform is None
    np.testing.assert_allclose(m.vertices[:, 1], 0.0)
    np.testing.assert_allclose(m.vertices[:, 2], vertex_array(obj.data)[:, 2] + 1.0, atol=1e-6)


def test_nonuniform_sphere_empty_and_point_cloud_become_ellipsoids(scene):
    e = link(scene, bpy.data.objects.new("Egg", None))
    e.empty_display_type = "SPHERE"
    e.empty_display_size = 0.5
    e.scale = (1, 2, 3)
    pts = np.array([(0, 0, 0), (1, 0, 0), (0, 1, 0)], np.float32)
    points_object(scene, "Grains", pts, radius=0.1, scale=(1, 1, 4))
    d = export(scene)
    assert d.sphere_count == 0 and not d.warnings
    groups = {g.name: g for g in d.transformed_spheres}
    assert set(groups) == {"Egg", "Grains"} and d.ellipsoid_count == 4
    np.testing.assert_allclose(groups["Egg"].radii, [0.5])
    np.testing.assert_allclose(np.diag(groups["Egg"].matrix), [1, 2, 3, 1], atol=1e-7)
    np.testing.assert_allclose(np.sort(groups["Grains"].centers, axis=0), np.sort(pts, axis=0))
    np.testing.assert_allclose(groups["Grains"].radii, 0.1, rtol=1e-6)


# --- renders ---------------------------------------------------------------------------------------

N = 40  # pixels; an orthographic scale of 2 makes them 0.05 wide, so a unit cube's edges fall between centres


def ortho_front(s, size=N, scale=2.0, distance=5.0):
    """An orthographic camera on -Y looking along +Y (up +Z), pixel centres at ±0.025 + k·0.05."""
    cam = aim_camera(s, (0, -distance, 0)).data
    cam.type = "ORTHO"
    cam.ortho_scale = scale
    cam.clip_start, cam.clip_end = 0.1, 100.0
    s.render.resolution_x = s.render.resolution_y = size


def pixel_centres(size=N, scale=2.0):
    """x (left to right) and z (top row first) of the pixel centres of `ortho_front`."""
    c = (np.arange(size) + 0.5) * scale / size - scale / 2
    return np.meshgrid(c, c[::-1])


def test_cube_silhouette_and_depth_are_exact(scene, tmp_path):
    world(scene, (0, 0, 0))
    cube(scene, "Box", size=1.0)
    ortho_front(scene)
    out = render_passes(scene, tmp_path / "cube.exr")
    assert engine.last_render.error is None and not engine.last_render.warnings
    expected = np.zeros((N, N), bool)
    expected[10:30, 10:30] = True  # x, z in (-0.5, 0.5): a 20-pixel square
    hit = out["depth"] < 1e9
    np.testing.assert_array_equal(hit, expected)
    np.testing.assert_allclose(out["depth"][hit], 4.5, rtol=1e-6)  # the front face, y = -0.5
    np.testing.assert_allclose(out["normal"][hit], np.broadcast_to([0, -1, 0], (400, 3)), atol=1e-6)
    assert engine.last_render.triangles == 12


def test_rotated_cube_depth_is_exact(scene, tmp_path):
    """Turned 45° about Z, the unit cube shows an edge: depth 5 − √½ + |x| over |x| < √½."""
    world(scene, (0, 0, 0))
    cube(scene, "Box", size=1.0, rotation=(0, 0, 45 * DEG))
    ortho_front(scene)
    out = render_passes(scene, tmp_path / "cube45.exr", normal=False)
    x, z = pixel_centres()
    half = np.sqrt(0.5)
    expected = (np.abs(x) < half) & (np.abs(z) < 0.5)
    hit = out["depth"] < 1e9
    np.testing.assert_array_equal(hit, expected)
    np.testing.assert_allclose(out["depth"][hit], (5 - half + np.abs(x))[hit], rtol=1e-6)


def test_multi_material_cube_renders_each_slot_colour(scene, tmp_path):
    """No lights: a white world lights the faces with kd (ambient 1), so each pixel is its face's colour."""
    world(scene, (1, 1, 1))
    obj = cube(scene, "Dice", size=1.0)
    obj.data.materials.append(material("Red", (0.9, 0.1, 0.1)))
    obj.data.materials.append(material("Blue", (0.1, 0.2, 0.9)))
    y = np.empty(6 * 3, np.float32)
    obj.data.polygons.foreach_get("normal", y)
    front = y.reshape(6, 3)[:, 1] < -0.5  # the face the camera sees
    obj.data.polygons.foreach_set("material_index", front.astype(np.int32))
    obj.data.update()
    ortho_front(scene)
    color = render_passes(scene, tmp_path / "dice.exr", depth=False, normal=False)["color"][..., :3]
    np.testing.assert_allclose(color[10:30, 10:30], np.broadcast_to(np.float32([0.1, 0.2, 0.9]), (20, 20, 3)), rtol=1e-6)
    np.testing.assert_allclose(color[0, 0], [1, 1, 1])  # the world


def test_nonuniformly_scaled_sphere_is_an_exact_ellipsoid(scene, tmp_path):
    """A UV sphere scaled (1, 3, 0.5), seen along +Y from 5 away: the centre pixel's depth is
    5 − 3 = 2, and every pixel's depth is the distance along its camera ray to the ellipsoid (the
    quadratic solved in object space, in double), not to a faceted or mean-scale sphere. The
    exported centre and radius are the UV sphere's fit (2e-7 off), and the camera ray's direction
    is Blender's float32 rotation: both matter at the rim, so the expectation uses them."""
    world(scene, (0, 0, 0))
    uv_sphere(scene, "Egg", radius=1.0, scale=(1, 3, 0.5))
    size = 41  # odd: the centre pixel's ray is the axis
    ortho_front(scene, size=size, scale=2.5, distance=5.0)
    out = render_passes(scene, tmp_path / "egg.exr")
    assert not engine.last_render.warnings  # no "non-uniform scale" warning any more
    assert out["depth"][size // 2, size // 2] == pytest.approx(2.0, rel=1e-6)
    d = export(scene)
    (g,) = d.transformed_spheres
    np.testing.assert_allclose(g.matrix, np.diag([1, 3, 0.5, 1]), atol=1e-7)
    origins, directions = build.make_camera(d.camera).rays(size, size)
    inverse = np.linalg.inv(g.matrix)
    o = origins @ inverse[:3, :3].T + inverse[:3, 3] - g.centers[0]
    v = directions @ inverse[:3, :3].T
    a, b, c = (v * v).sum(-1), (o * v).sum(-1), (o * o).sum(-1) - g.radii[0] ** 2
    disc = b * b - a * c
    hit = out["depth"] < 1e9
    np.testing.assert_array_equal(hit, disc > 0)
    t = (-b[hit] - np.sqrt(disc[hit])) / a[hit]
    np.testing.assert_allclose(out["depth"][hit], t, rtol=1e-6)
    # The normal is the gradient of |M⁻¹p − c|², M⁻ᵀ(M⁻¹p − c), normalised.
    grad = (o[hit] + t[:, None] * v[hit]) @ inverse[:3, :3]
    np.testing.assert_allclose(out["normal"][hit], grad / np.linalg.norm(grad, axis=-1, keepdims=True), atol=1e-5)


def test_suzanne_silhouette_matches_cycles(scene, tmp_path):
    world(scene, (0, 0, 0))
    suzanne(scene, rotation=(0, 0, 20 * DEG))
    aim_camera(scene, (0.5, -4, 1.0))
    scene.render.resolution_x, scene.render.resolution_y = 96, 72
    durer_hit = render_passes(scene, tmp_path / "durer.exr", normal=False)["depth"] < 1e9
    use_cycles(scene)
    cycles_hit = render_passes(scene, tmp_path / "cycles.exr", normal=False)["depth"] < 1e9
    assert durer_hit.sum() > 1500  # the head fills a good part of the frame
    assert (durer_hit != cycles_hit).sum() <= 2  # only where a pixel centre grazes an edge


def test_million_triangle_mesh_exports_every_triangle(scene):
    """A 1M-triangle mesh (a grid of 708 × 708 quads, rendered as a mesh) exports whole, its
    vertices as stored. Its speed is measured by bench/blender_export.py."""
    bpy.ops.mesh.primitive_grid_add(x_subdivisions=708, y_subdivisions=708, size=2)
    obj = bpy.context.active_object
    obj.durer.primitive = "MESH"  # not the plane Auto would see
    co = np.empty(len(obj.data.vertices) * 3, np.float32)
    obj.data.vertices.foreach_get("co", co)
    from durer.blender.export.depsgraph import export_depsgraph

    d = export_depsgraph(bpy.context.evaluated_depsgraph_get())
    assert d.triangle_count == 2 * 708**2 > 1_000_000
    (mesh,) = d.meshes
    np.testing.assert_array_equal(mesh.vertices, co.reshape(-1, 3))
    assert mesh.faces.min() == 0 and mesh.faces.max() == 709**2 - 1


def _normal_angles(c, d):
    """Degrees between Cycles' and Dürer's Normal pass where both hit, away from silhouettes."""
    hit = (c["depth"] < MISS) & (d["depth"] < MISS)
    inner = hit.copy()
    inner[1:-1, 1:-1] &= hit[:-2, 1:-1] & hit[2:, 1:-1] & hit[1:-1, :-2] & hit[1:-1, 2:]
    cosine = np.clip(np.sum(c["normal"][inner] * d["normal"][inner], axis=-1), -1, 1)
    return np.degrees(np.arccos(cosine))


@pytest.mark.parametrize("shading", ["flat", "smooth", "by angle", "mixed", "squashed", "squashed, two users",
                                     "squashed, mirrored"])
def test_normals_are_shaded_as_cycles_shades_them(scene, tmp_path, shading):
    """Shade Flat, Shade Smooth and Smooth by Angle (sharp edges: normals per corner) as Blender
    shades them: the Normal pass as Cycles' (the faces' own normals were up to 78° off on a
    smooth head); flat faces export no normals."""
    scene.render.resolution_x, scene.render.resolution_y = 96, 72
    head = suzanne(scene, rotation=(0, 0, 30 * DEG))
    head.data.materials.append(material("Skin", (0.6, 0.4, 0.3)))
    if shading == "smooth":
        head.data.shade_smooth()
    elif shading == "by angle":
        head.data.shade_smooth()
        head.data.set_sharp_from_angle(angle=30 * DEG)
    elif shading == "mixed":  # every other face flat, no sharp edge: Cycles shades the smooth ones
        head.data.shade_smooth()  # by their vertices' normals (Blender's corner normals split there)
        head.data.polygons.foreach_set("use_smooth", np.arange(len(head.data.polygons)) % 2 == 0)
    elif shading.startswith("squashed"):  # Cycles turns a mesh of one user into world space before
        # interpolating its normals, and keeps one of several users in its own space
        head.data.shade_smooth()
        head.scale = (-1.6, 1.0, 0.5) if shading.endswith("mirrored") else (1.6, 1.0, 0.5)
        if shading == "squashed, two users":
            twin = link(scene, bpy.data.objects.new("Twin", head.data))
            twin.location = (0, 30, 0)  # out of view
    aim_camera(scene, (0, -5, 1))
    mesh = export(scene).meshes[0]
    assert (mesh.normals is None) == (shading == "flat")
    assert head.data.normals_domain == {"flat": "FACE", "by angle": "CORNER", "mixed": "CORNER"}.get(shading, "POINT")
    c, d = both(scene, tmp_path)
    angles = _normal_angles(c, d)
    assert len(angles) > 1000
    assert np.median(angles) < 0.05 and np.percentile(angles, 95) < 1.0, (np.median(angles), np.percentile(angles, 95))


def test_a_smooth_mesh_with_a_zero_area_face_renders(scene, tmp_path):
    """Blender gives a zero-area face's corners no normal (zeros): the export gives them the
    face's own, so the mesh renders (the core rejected the zero normals and the render failed)."""
    def build(bm):
        a, b, c, d = (bm.verts.new(p) for p in ((-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)))
        bm.faces.new((a, b, c, d))
        e, f, g = (bm.verts.new(p) for p in ((0, 0, 1), (1, 0, 1), (2, 0, 1)))  # collinear
        bm.faces.new((e, f, g))

    obj = mesh_object(scene, "Sliver", build)
    obj.data.shade_smooth()
    corner = np.empty(len(obj.data.loops) * 3, np.float32)
    obj.data.corner_normals.foreach_get("vector", corner)
    assert (~corner.reshape(-1, 3).any(axis=1)).any()  # Blender's zeros
    (mesh,) = export(scene).meshes
    assert (np.linalg.norm(mesh.normals, axis=2) > 0).all() and np.isfinite(mesh.normals).all()
    aim_camera(scene, (0, -0.5, 6))
    out = render_passes(scene, tmp_path / "sliver.exr")
    assert engine.last_render.error is None and (out["depth"] < MISS).sum() > 100


@pytest.mark.parametrize("elevation", [60, 20])
def test_a_smooth_low_poly_sphere_is_lit_along_its_terminator_as_in_cycles(scene, tmp_path, elevation):
    """A smooth 8 x 6 UV sphere read as a mesh under a sun from the side: the pixels Cycles lights
    are the pixels Dürer lights (Cycles' shadow terminator offset; the faces' neighbours shadowed
    207 of Cycles' 1,836 lit pixels)."""
    from helpers.blender import light

    scene.render.resolution_x, scene.render.resolution_y = 128, 96
    ball = mesh_object(scene, "Ball", lambda bm: bmesh.ops.create_uvsphere(bm, u_segments=8, v_segments=6, radius=1.0))
    ball.data.shade_smooth()
    ball.data.materials.append(material("White", (0.8, 0.8, 0.8)))
    ball.durer.primitive = "MESH"
    light(scene, "SUN", energy=3.0, rotation=(0, (90 - elevation) * DEG, 0))
    aim_camera(scene, (0, -5, 0))
    c, d = both(scene, tmp_path, normal=False)
    hit = (c["depth"] < MISS) & (d["depth"] < MISS)
    cycles, durer_ = c["color"][..., :3].mean(-1), d["color"][..., :3].mean(-1)  # black: in shadow (black world)
    assert (hit & (cycles > 0.02)).sum() > 1500
    assert not (hit & (cycles > 0.02) & (durer_ < 1e-4)).any() and not (hit & (durer_ > 0.02) & (cycles < 1e-4)).any()
