"""Blender scene -> plain numpy data (durer.blender.export), for every object kind."""

from __future__ import annotations

import math

import numpy as np
import pytest
from helpers.blender import (
    DEG,
    cube,
    export,
    grid,
    ico_sphere,
    light,
    link,
    material,
    mesh_object,
    pointcloud_object,
    points_object,
    quad,
    uv_sphere,
    world,
)

from helpers.blender_import import blender_module

bpy = blender_module("bpy")
bmesh = blender_module("bmesh")

from durer.blender.export.depsgraph import export_depsgraph
from durer.blender.export.shapes import metaball_iso_radius

pytestmark = pytest.mark.blender


# --- spheres ---------------------------------------------------------------------------------------


def test_uv_and_ico_sphere_meshes_become_spheres(scene):
    uv_sphere(scene, "UV", radius=1.5, location=(1, 2, 3))
    ico_sphere(scene, "Ico", radius=0.5, location=(-1, 0, 0), scale=(2, 2, 2))
    d = export(scene)
    assert d.sphere_count == 2 and not d.planes and not d.skipped
    order = np.argsort(d.sphere_radii)
    np.testing.assert_allclose(d.sphere_radii[order], [1.0, 1.5], rtol=1e-5)
    np.testing.assert_allclose(d.sphere_centers[order], [[-1, 0, 0], [1, 2, 3]], atol=1e-5)
    assert d.sources == {"UV": 1, "Ico": 1}
    assert not d.warnings


def test_rotated_scaled_parented_sphere(scene):
    parent = link(scene, bpy.data.objects.new("Parent", None))
    parent.location = (0, 0, 5)
    parent.scale = (3, 3, 3)
    s = uv_sphere(scene, "Child", radius=0.25, location=(1, 0, 0), rotation=(30 * DEG, 10 * DEG, 0))
    s.parent = parent
    d = export(scene)
    assert d.sphere_count == 1
    np.testing.assert_allclose(d.sphere_centers[0], [3, 0, 5], atol=1e-5)
    np.testing.assert_allclose(d.sphere_radii[0], 0.75, rtol=1e-5)


def test_nonuniform_scale_keeps_the_sphere_and_its_matrix(scene):
    uv_sphere(scene, "Squashed", radius=1.0, scale=(1, 1, 8), location=(0, 2, 0))
    d = export(scene)
    assert d.sphere_count == 0 and d.ellipsoid_count == 1 and not d.warnings
    (g,) = d.transformed_spheres
    np.testing.assert_allclose(g.centers, [[0, 0, 0]], atol=1e-6)
    np.testing.assert_allclose(g.radii, [1.0], rtol=1e-6)
    np.testing.assert_allclose(g.matrix, [[1, 0, 0, 0], [0, 1, 0, 2], [0, 0, 8, 0], [0, 0, 0, 1]], atol=1e-6)


def test_shapes_with_equidistant_corners_are_not_spheres(scene):
    cube(scene, "Cube")
    mesh_object(
        scene,
        "Cylinder",
        lambda bm: bmesh.ops.create_cone(bm, cap_ends=True, segments=32, radius1=1, radius2=1, depth=2),
    )
    mesh_object(scene, "Circle", lambda bm: bmesh.ops.create_circle(bm, cap_ends=True, segments=32, radius=1))
    ico_sphere(scene, "Icosahedron", subdivisions=1)
    d = export(scene)
    assert d.sphere_count == 0 and not d.planes and not d.skipped and not d.warnings
    # They render as their triangles: 6 quads, 32 side quads + two 32-gons, one 32-gon, 20 faces.
    counts = {m.name: len(m.faces) for m in d.meshes}
    assert counts == {"Cube": 12, "Cylinder": 64 + 2 * 30, "Circle": 30, "Icosahedron": 20}


def test_skipped_geometry_is_counted_by_kind(scene):
    cube(scene, "A")
    curve = bpy.data.curves.new("Curve", "CURVE")
    spline = curve.splines.new("POLY")
    spline.points.add(2)
    spline.points.foreach_set("co", [0, 0, 0, 1, 1, 0, 0, 1, 1, 1, 0, 1])
    curve.bevel_depth = 0.1
    link(scene, bpy.data.objects.new("Curve", curve))  # beveled: triangles
    link(scene, bpy.data.objects.new("Fog", bpy.data.volumes.new("Fog")))
    link(scene, bpy.data.objects.new("Fog 2", bpy.data.volumes.new("Fog 2")))
    link(scene, bpy.data.objects.new("Pen", bpy.data.grease_pencils.new("Pen")))
    d = export(scene)
    assert d.skipped == {"volume": 2, "greasepencil": 1}
    assert d.warnings[0] == "Dürer skipped geometry it cannot render: 1 greasepencil, 2 volume"
    assert sorted(m.name for m in d.meshes) == ["A", "Curve"]


def test_empty_displayed_as_sphere(scene):
    e = link(scene, bpy.data.objects.new("Ball", None))
    e.empty_display_type = "SPHERE"
    e.empty_display_size = 0.5
    e.location = (0, 1, 0)
    e.scale = (2, 2, 2)
    axes = link(scene, bpy.data.objects.new("Axes", None))  # plain axes: not geometry, not skipped
    axes.empty_display_type = "PLAIN_AXES"
    e.color = (0.1, 0.2, 0.3, 1.0)
    d = export(scene)
    np.testing.assert_allclose(d.sphere_radii, [1.0])
    np.testing.assert_allclose(d.sphere_centers, [[0, 1, 0]])
    assert d.materials[d.sphere_materials[0]].diffuse == pytest.approx((0.1, 0.2, 0.3))  # Cycles draws no empty
    assert not d.skipped


def test_a_metaball_family_takes_its_basis_material_and_threshold(scene):
    """Metaballs named Meta, Meta.001 are one family: Blender draws both on Meta (its material, its
    threshold); Solo.002, whose family has no lower number, draws itself with its own."""
    red, blue, green = material("Red", (0.9, 0.1, 0.1)), material("Blue", (0.1, 0.1, 0.9)), material("Green", (0.1, 0.9, 0.1))
    for i, (name, mat, threshold) in enumerate([("Meta.001", blue, 0.2), ("Meta", red, 0.6), ("Solo.002", green, 0.2)]):
        mb = bpy.data.metaballs.new(name)
        mb.threshold = threshold
        mb.elements.new(type="BALL").radius = 1.0
        mb.materials.append(mat)
        link(scene, bpy.data.objects.new(name, mb)).location = (5 * i, 0, 0)
    d = export(scene)
    assert d.sphere_count == 3
    order = np.argsort(d.sphere_centers[:, 0])
    colours = [tuple(np.round(d.materials[d.sphere_materials[i]].diffuse, 3)) for i in order]
    assert colours == [(0.9, 0.1, 0.1), (0.9, 0.1, 0.1), (0.1, 0.9, 0.1)]
    radius = [metaball_iso_radius(1.0, 2.0, t) for t in (0.6, 0.6, 0.2)]
    np.testing.assert_allclose(d.sphere_radii[order], radius, rtol=1e-6)
    dg = bpy.context.evaluated_depsgraph_get()
    assert len(bpy.data.objects["Meta.001"].evaluated_get(dg).to_mesh().vertices) == 0  # drawn on Meta


def test_metaball_balls_match_blender_surface(scene):
    mb = bpy.data.metaballs.new("Meta")
    mb.resolution = 0.02
    mb.render_resolution = 0.02
    el = mb.elements.new(type="BALL")
    el.radius = 2.0
    el.co = (0, 0, 0)
    obj = link(scene, bpy.data.objects.new("Meta", mb))
    obj.location = (10, 0, 0)
    caps = mb.elements.new(type="CAPSULE")
    caps.co = (100, 0, 0)
    d = export(scene)
    assert d.sphere_count == 1
    assert d.skipped == {"metaball capsule": 1}
    np.testing.assert_allclose(d.sphere_centers[0], [10, 0, 0], atol=1e-6)
    # Blender's own tessellation of the ball: its vertices lie on the exported sphere.
    dg = bpy.context.evaluated_depsgraph_get()
    me = obj.evaluated_get(dg).to_mesh()
    co = np.array([v.co[:] for v in me.vertices])
    obj.evaluated_get(dg).to_mesh_clear()
    near = co[np.linalg.norm(co, axis=1) < 20]
    r = np.linalg.norm(near, axis=1)
    assert len(r) > 100
    np.testing.assert_allclose(np.median(r), d.sphere_radii[0], rtol=0.01)


def test_collection_instances_count(scene):
    coll = bpy.data.collections.new("Proto")
    s = uv_sphere(scene, "Proto Sphere", radius=0.5)
    scene.collection.objects.unlink(s)
    coll.objects.link(s)
    for i in range(3):
        inst = link(scene, bpy.data.objects.new(f"Inst{i}", None))
        inst.instance_type = "COLLECTION"
        inst.instance_collection = coll
        inst.location = (i * 2, 0, 0)
        inst.empty_display_type = "SPHERE"  # an instancer's own display is not geometry
    d = export(scene)
    assert d.sphere_count == 3
    np.testing.assert_allclose(np.sort(d.sphere_centers[:, 0]), [0, 2, 4], atol=1e-6)
    np.testing.assert_allclose(d.sphere_radii, 0.5, rtol=1e-5)


def test_point_cloud_spheres_follow_object_transform(scene):
    rng = np.random.default_rng(1)
    pts = rng.uniform(-1, 1, (1000, 3)).astype(np.float32)
    points_object(scene, "Points", pts, radius=0.02, location=(5, 0, 0), scale=(2, 2, 2))
    d = export(scene)
    assert d.sphere_count == 1000
    assert d.sources == {"Points": 1000}
    np.testing.assert_allclose(np.sort(d.sphere_centers, axis=0), np.sort(pts * 2 + [5, 0, 0], axis=0), atol=1e-5)
    np.testing.assert_allclose(d.sphere_radii, 0.04, rtol=1e-6)
    assert not d.skipped and not d.warnings


@pytest.mark.parametrize("positions", [np.zeros((4, 2)), np.zeros(3), np.zeros((2, 3, 1))])
def test_point_cloud_refuses_positions_not_n_by_3(scene, positions):
    from durer.blender.point_cloud import point_cloud_object

    with pytest.raises(ValueError, match=r"positions must have shape \(N, 3\)"):
        point_cloud_object(scene.collection, "Bad", positions)
    assert "Bad" not in bpy.data.objects and "Bad" not in bpy.data.meshes


def test_point_cloud_object_with_material_index(scene):
    obj = pointcloud_object(scene, "Cloud", [(0, 0, 0), (1, 0, 0), (2, 0, 0)], radius=0.1)
    pc = obj.data
    pc.materials.append(material("Red", (1, 0, 0)))
    pc.materials.append(material("Blue", (0, 0, 1)))
    d = export(scene)
    assert d.sphere_count == 3 and {d.materials[m].diffuse for m in d.sphere_materials} == {(1, 0, 0)}
    index = pc.attributes.new("material_index", "INT", "POINT")
    index.data.foreach_set("value", np.array([0, 1, 5], np.int32))
    pc.update_tag()
    d = export(scene)
    colors = [d.materials[m].diffuse for m in d.sphere_materials[np.argsort(d.sphere_centers[:, 0])]]
    assert colors == [(1, 0, 0), (0, 0, 1), (0, 0, 1)]  # an index past the last slot clamps
    np.testing.assert_allclose(d.sphere_radii, 0.1, rtol=1e-6)


def test_spheres_of_single_objects_keep_the_walks_order_among_the_others(scene):
    """Sphere objects are made into arrays at the end of the export (one scale test for all):
    still in the walk's order among a point cloud's spheres, squashed ones exact ellipsoids, ones
    scaled to nothing left out."""
    for name, location, scale in [("A", (0, 0, 0), (2, 2, 2)), ("B squashed", (3, 0, 0), (1, 2, 1)),
                                  ("C flat", (6, 0, 0), (0, 0, 0))]:
        uv_sphere(scene, name, radius=0.5, location=location, scale=scale)
    points_object(scene, "Points", [(0, 5, 0), (1, 5, 0)], radius=0.1)
    uv_sphere(scene, "D", radius=0.25, location=(9, 0, 0))
    d = export(scene)
    walk = [o.name for o in bpy.context.evaluated_depsgraph_get().objects if o.name in ("A", "Points", "D")]
    owners = [d.objects[i].name for i in d.sphere_owners]
    assert owners == [name for name in walk for _ in range(2 if name == "Points" else 1)]
    radius = {"A": 1.0, "Points": 0.1, "D": 0.25}
    np.testing.assert_allclose(d.sphere_radii, [radius[name] for name in owners], rtol=1e-6)
    (squashed,) = d.transformed_spheres
    assert squashed.name == "B squashed" and d.sources["B squashed"] == 1 and "C flat" not in d.sources
    np.testing.assert_allclose(squashed.matrix[:3, :3], np.diag([1.0, 2.0, 1.0]), atol=1e-6)


def test_million_point_cloud_exports_every_point(scene):
    # Its speed is measured by bench/blender_export.py.
    n = 1_000_000
    pts = np.random.default_rng(0).uniform(-10, 10, (n, 3)).astype(np.float32)
    points_object(scene, "Million", pts, radius=0.01, location=(1, 2, 3), scale=(2, 2, 2))
    d = export_depsgraph(bpy.context.evaluated_depsgraph_get())
    assert d.sphere_count == n and d.sphere_centers.dtype == np.float64
    # Under the uniform scale 2 and the offset (1, 2, 3), in double precision.
    order = np.lexsort(d.sphere_centers.T)
    expected = pts.astype(np.float64) * 2 + (1, 2, 3)
    np.testing.assert_allclose(d.sphere_centers[order], expected[np.lexsort(expected.T)], rtol=0, atol=1e-12)
    np.testing.assert_allclose(d.sphere_radii, 0.02, rtol=1e-6)


# --- planes ----------------------------------------------------------------------------------------


def test_flat_quad_is_bounded_plane(scene):
    quad(scene, "Floor", location=(0, 0, -1), scale=(3, 2, 1), rotation=(0, 0, 90 * DEG))
    d = export(scene)
    assert d.sphere_count == 0 and len(d.planes) == 1
    p = d.planes[0]
    np.testing.assert_allclose(p.normal, [0, 0, 1], atol=1e-6)
    assert p.offset == pytest.approx(-1)
    corner, e1, e2 = p.bounds
    np.testing.assert_allclose(corner, [2, -3, -1], atol=1e-5)  # (-1,-1) scaled (3,2), rotated 90°
    np.testing.assert_allclose(e1, [0, 6, 0], atol=1e-5)
    np.testing.assert_allclose(e2, [-4, 0, 0], atol=1e-5)


def test_plane_normal_follows_face_winding_and_mirroring(scene):
    quad(scene, "Down", corners=((-1, -1, 0), (-1, 1, 0), (1, 1, 0), (1, -1, 0)))
    quad(scene, "Mirrored", location=(0, 0, 3), scale=(-1, 1, 1))
    d = export(scene)
    normals = {p.name: p.normal for p in d.planes}
    np.testing.assert_allclose(normals["Down"], [0, 0, -1], atol=1e-6)
    np.testing.assert_allclose(normals["Mirrored"], [0, 0, 1], atol=1e-6)


def test_grid_is_a_plane_and_trapezoid_is_not(scene):
    grid(scene, "Grid", size=2.0, location=(0, 0, 1))
    quad(scene, "Trapezoid", corners=((-2, -1, 0), (2, -1, 0), (1, 1, 0), (-1, 1, 0)))
    d = export(scene)
    assert [p.name for p in d.planes] == ["Grid"]
    corner, e1, e2 = d.planes[0].bounds
    np.testing.assert_allclose(corner, [-2, -2, 1], atol=1e-5)
    np.testing.assert_allclose(np.cross(e1, e2), [0, 0, 16], atol=1e-4)
    assert [(m.name, len(m.faces)) for m in d.meshes] == [("Trapezoid", 2)]


def test_infinite_plane_setting(scene):
    obj = quad(scene, "Ground", location=(0, 0, 2))
    obj.durer.infinite_plane = True
    d = export(scene)
    assert d.planes[0].bounds is None
    assert d.planes[0].offset == pytest.approx(2)


# --- the per-object override -----------------------------------------------------------------------


def test_override_ignore_sphere_plane(scene):
    uv_sphere(scene, "Hidden").durer.primitive = "IGNORE"
    c = cube(scene, "CubeBall", size=2.0, location=(5, 0, 0))
    c.durer.primitive = "SPHERE"
    flat = cube(scene, "Slab", location=(0, 0, -3), scale=(4, 4, 0.01))
    flat.durer.primitive = "PLANE"
    pc = points_object(scene, "Ignored Points", [(0, 0, 0)])
    pc.durer.primitive = "IGNORE"
    ico_sphere(scene, "Icosahedron", subdivisions=1, location=(0, 5, 0)).durer.primitive = "SPHERE"
    d = export(scene)
    assert d.sources == {"CubeBall": 1, "Slab": 1, "Icosahedron": 1}
    assert not d.skipped
    centers = {tuple(np.round(c, 6)) for c in d.sphere_centers}
    assert centers == {(5.0, 0.0, 0.0), (0.0, 5.0, 0.0)}
    np.testing.assert_allclose(sorted(d.sphere_radii), [1.0, 1.0], rtol=1e-5)
    p = d.planes[0]
    assert p.offset == pytest.approx(-3) and p.normal[2] == pytest.approx(1)
    np.testing.assert_allclose(np.cross(p.bounds[1], p.bounds[2]), [0, 0, 64], atol=1e-4)


def test_override_sphere_on_text(scene):
    curve = bpy.data.curves.new("Text", "FONT")
    curve.body = "O"
    obj = link(scene, bpy.data.objects.new("Text", curve))
    d = export(scene)
    assert not d.skipped and [m.name for m in d.meshes] == ["Text"] and d.triangle_count > 10
    obj.durer.primitive = "SPHERE"
    d = export(scene)
    assert d.sphere_count == 1 and not d.skipped and not d.meshes


@pytest.mark.parametrize("primitive", ["PLANE", "MESH", "SPHERE", "IGNORE"])
def test_a_hosts_primitive_is_for_its_own_geometry_not_what_its_nodes_instance(scene, primitive):
    """A ground that scatters spheres with geometry nodes (Instance on Points joined with the
    ground), set to Primitive = Plane / Mesh / Sphere: the ground follows it, the scattered UV
    spheres stay spheres, directly and in a collection instance's copy of the ground; Ignore
    leaves out the ground with all it makes."""
    from durer.blender.point_cloud import instance_on_points

    collection = bpy.data.collections.new("Scatter")
    scene.collection.children.link(collection)
    ground = grid(scene, "Ground", size=3.0, n=4)
    scene.collection.objects.unlink(ground)
    collection.objects.link(ground)
    ball = uv_sphere(scene, "Ball", radius=0.2)
    ball.hide_render = ball.hide_viewport = True
    group = instance_on_points(ground, ball, rotate=False).node_group
    join = group.nodes.new("GeometryNodeJoinGeometry")  # the ground and its spheres, as scatter set-ups do
    group.links.new(group.nodes["Instance on Points"].outputs[0], join.inputs[0])
    group.links.new(group.nodes["Group Input"].outputs[0], join.inputs[0])
    group.links.new(join.outputs[0], group.nodes["Group Output"].inputs[0])
    ground.durer.primitive = primitive
    copy = link(scene, bpy.data.objects.new("Copy", None))
    copy.instance_type, copy.instance_collection, copy.location = "COLLECTION", collection, (10, 0, 0)
    d = export(scene)
    if primitive == "IGNORE":
        assert d.sphere_count == 0 and not d.planes and not d.meshes
        return
    triangles = 2 * 2 * len(ground.data.polygons)  # its quads in both copies
    own = {"PLANE": (0, 2, 0), "MESH": (0, 0, triangles), "SPHERE": (2, 0, 0)}[primitive]  # spheres, planes, triangles
    assert (d.sphere_count - 2 * 25, len(d.planes), d.triangle_count) == own
    np.testing.assert_allclose(np.sort(d.sphere_radii)[: 2 * 25], 0.2, rtol=1e-5)
    assert (np.abs(d.sphere_centers[:, 0] - 10) < 4).sum() == 25 + own[0] // 2  # the copy's
    box = cube(scene, "Box", size=0.2)
    box.hide_render = box.hide_viewport = True
    group.nodes["Object Info"].inputs["Object"].default_value = box  # scattering cubes: cubes they stay
    d = export(scene)
    assert (d.sphere_count, len(d.planes), d.triangle_count - 2 * 25 * 12) == own


def test_a_sphere_mesh_takes_the_material_its_faces_use(scene):
    """A UV sphere with two material slots: all faces on the second gives a sphere of the second's
    colour; faces split between the two, triangles of each (as Cycles draws it), unless forced to
    a sphere, which takes the slot most faces use; instances of such a sphere too."""
    red, blue = material("Red", (0.9, 0.1, 0.1)), material("Blue", (0.1, 0.1, 0.9))

    def two_slot_sphere(name, blue_faces, location=(0, 0, 0)):
        obj = uv_sphere(scene, name, radius=1.0, location=location)
        obj.data.materials.append(red)
        obj.data.materials.append(blue)
        slots = np.zeros(len(obj.data.polygons), np.int32)
        slots[:blue_faces] = 1
        obj.data.polygons.foreach_set("material_index", slots)
        obj.data.update()
        return obj

    def colour(d, index):
        return tuple(np.round(d.materials[index].diffuse, 3))

    faces = len(uv_sphere(scene, "Probe").data.polygons)
    bpy.data.objects.remove(bpy.data.objects["Probe"])
    two_slot_sphere("All blue", faces)
    split = two_slot_sphere("Split", faces // 3, location=(4, 0, 0))
    d = export(scene)
    assert d.sphere_count == 1 and colour(d, d.sphere_materials[0]) == (0.1, 0.1, 0.9)
    assert sorted(colour(d, m.material) for m in d.meshes) == [(0.1, 0.1, 0.9), (0.9, 0.1, 0.1)]
    split.durer.primitive = "SPHERE"
    d = export(scene)
    assert d.sphere_count == 2 and not d.meshes
    assert sorted(colour(d, m) for m in d.sphere_materials) == [(0.1, 0.1, 0.9), (0.9, 0.1, 0.1)]
    for obj in list(scene.objects):
        if obj.type == "MESH":
            bpy.data.objects.remove(obj)
    ball = two_slot_sphere("Ball", faces)
    ball.hide_render = ball.hide_viewport = True
    from durer.blender.point_cloud import instance_on_points, vertex_object

    instance_on_points(vertex_object(scene.collection, "Points", np.arange(12.0).reshape(4, 3)), ball)
    d = export(scene)
    assert d.sphere_count == 4 and {colour(d, m) for m in d.sphere_materials} == {(0.1, 0.1, 0.9)}


# --- materials, world, lights ----------------------------------------------------------------------


def test_material_colours(scene):
    s1 = uv_sphere(scene, "Principled")
    s1.data.materials.append(material("Red", (0.9, 0.1, 0.1)))
    s2 = uv_sphere(scene, "Glow", location=(3, 0, 0))
    s2.data.materials.append(material("Glow", emission=((1.0, 0.5, 0.0), 4.0)))
    s3 = uv_sphere(scene, "ObjectColour", location=(6, 0, 0))
    s3.color = (0.1, 0.2, 0.3, 1)
    s4 = uv_sphere(scene, "Textured", location=(9, 0, 0))
    tex = material("Textured", (0.5, 0.5, 0.5))
    tex.diffuse_color = (0.25, 0.5, 0.75, 1)
    noise = tex.node_tree.nodes.new("ShaderNodeTexNoise")
    tex.node_tree.links.new(noise.outputs["Color"], tex.node_tree.nodes["Principled BSDF"].inputs["Base Color"])
    s4.data.materials.append(tex)
    s5 = uv_sphere(scene, "SameRed", location=(12, 0, 0))
    s5.data.materials.append(material("Red2", (0.9, 0.1, 0.1)))
    d = export(scene)
    by_x = {round(c[0]): d.materials[m] for c, m in zip(d.sphere_centers, d.sphere_materials)}
    assert by_x[0].diffuse == pytest.approx((0.9, 0.1, 0.1))
    assert by_x[3].diffuse == (0, 0, 0) and by_x[3].emission == pytest.approx((4, 2, 0))
    # No material: Cycles' default surface (a default Principled BSDF), whatever the object colour.
    assert by_x[6].diffuse == pytest.approx((0.768, 0.768, 0.768)) and by_x[6].exponent == 30
    assert by_x[9].diffuse == pytest.approx((0.25, 0.5, 0.75))
    assert len(d.materials) == 4  # identical colours share a material


def test_shaders_are_read_as_cycles_reads_them(scene):
    """Constants linked into inputs (RGB and Value nodes, maths on them) are their values; the
    surface is the one the Cycles output takes, through reroutes and through muted nodes as Cycles
    passes them (a muted Mix Shader: the shader its internal link takes); a muted BSDF or a missing surface is black;
    a shader Dürer does not convert is its viewport colour, said once; an input linked to what
    varies is named, and so is emission (it lights nothing in Dürer)."""

    def principled(name, x):
        mat = material(name, (0.2, 0.2, 0.2))
        mat.diffuse_color = (0.0, 1.0, 0.0, 1.0)  # the viewport colour: what a fallback shows
        uv_sphere(scene, name, radius=0.5, location=(x, 0, 0)).data.materials.append(mat)
        return mat, mat.node_tree, mat.node_tree.nodes["Principled BSDF"]

    _, tree, bsdf = principled("RGB node", 0)
    colour = tree.nodes.new("ShaderNodeRGB")
    colour.outputs[0].default_value = (0.9, 0.5, 0.1, 1.0)
    tree.links.new(colour.outputs[0], bsdf.inputs["Base Color"])
    tree.links.new(colour.outputs[0], bsdf.inputs["Emission Color"])
    strength, double = tree.nodes.new("ShaderNodeValue"), tree.nodes.new("ShaderNodeMath")
    strength.outputs[0].default_value = 1.5
    double.operation, double.inputs[1].default_value = "MULTIPLY", 2.0
    tree.links.new(strength.outputs[0], double.inputs[0])
    tree.links.new(double.outputs[0], bsdf.inputs["Emission Strength"])
    _, tree, bsdf = principled("Textured glow", 10)
    bsdf.inputs["Emission Color"].default_value, bsdf.inputs["Emission Strength"].default_value = (1, 1, 1, 1), 3.0
    noise = tree.nodes.new("ShaderNodeTexNoise")  # varies: the socket's own strength stands in
    tree.links.new(noise.outputs["Fac"], bsdf.inputs["Emission Strength"])
    _, tree, bsdf = principled("Rerouted", 2)
    reroute, output = tree.nodes.new("NodeReroute"), tree.nodes["Material Output"]
    tree.links.new(bsdf.outputs[0], reroute.inputs[0])
    tree.links.new(reroute.outputs[0], output.inputs["Surface"])
    eevee = tree.nodes.new("ShaderNodeOutputMaterial")  # another output, for EEVEE only, active
    eevee.target, eevee.is_active_output = "EEVEE", True
    tree.links.new(tree.nodes.new("ShaderNodeEmission").outputs[0], eevee.inputs["Surface"])
    _, tree, bsdf = principled("Muted", 4)
    bsdf.mute = True
    _, tree, bsdf = principled("Unlinked", 6)
    tree.links.remove(tree.nodes["Material Output"].inputs["Surface"].links[0])
    _, tree, bsdf = principled("Mixed", 8)
    mix = tree.nodes.new("ShaderNodeMixShader")
    tree.links.new(bsdf.outputs[0], mix.inputs[1])
    tree.links.new(mix.outputs[0], tree.nodes["Material Output"].inputs["Surface"])
    for name, x, into in (("Muted mix", 12, 1), ("Muted mix, second", 14, 2), ("Muted mix of nothing", 16, None)):
        _, tree, bsdf = principled(name, x)
        mix = tree.nodes.new("ShaderNodeMixShader")
        if into is not None:
            tree.links.new(bsdf.outputs[0], mix.inputs[into])
        mix.mute = True
        tree.links.new(mix.outputs[0], tree.nodes["Material Output"].inputs["Surface"])
    d = export(scene)
    by_x = {round(float(c[0])): d.materials[m] for c, m in zip(d.sphere_centers, d.sphere_materials)}
    # The Principled BSDF passed through (Blender's internal link takes the linked shader), or nothing.
    assert by_x[12].diffuse == by_x[14].diffuse == by_x[2].diffuse and by_x[16].diffuse == (0.0, 0.0, 0.0)
    assert by_x[0].diffuse == pytest.approx((0.9, 0.5, 0.1)) and by_x[0].emission == pytest.approx((2.7, 1.5, 0.3))
    assert by_x[2].diffuse == pytest.approx((0.2, 0.2, 0.2)) and by_x[2].emission == (0.0, 0.0, 0.0)
    assert by_x[4].diffuse == by_x[6].diffuse == (0.0, 0.0, 0.0) and by_x[4].emission == (0.0, 0.0, 0.0)
    assert by_x[8].diffuse == (0.0, 1.0, 0.0)
    assert by_x[10].emission == pytest.approx((3.0, 3.0, 3.0))
    assert sorted(d.warnings) == [
        "Material 'Mixed': Dürer draws its Mix Shader surface in the material's viewport colour",
        "Material 'RGB node' glows but lights nothing: Dürer draws its emission on its own surface (Cycles "
        "lights the scene with it)",
        "Material 'Textured glow' glows but lights nothing: Dürer draws its emission on its own surface "
        "(Cycles lights the scene with it)",
        "Material 'Textured glow': Dürer takes one value for its Emission Strength, linked to what it cannot "
        "evaluate (a texture, attributes, a node group): the material's Viewport Display setting or the socket's "
        "own value"]


def test_world_background_and_transparent_film(scene):
    world(scene, (0.2, 0.4, 0.6), strength=0.5)
    d = export(scene)
    assert d.background == pytest.approx((0.1, 0.2, 0.3, 1.0))
    assert d.ambient == pytest.approx((0.1, 0.2, 0.3))
    scene.render.film_transparent = True
    scene.durer.use_world_lighting = False
    d = export(scene)
    assert d.background == pytest.approx((0.1, 0.2, 0.3, 0.0))  # no world behind: mirrors still show it
    assert d.ambient == (0, 0, 0)


def test_lights_are_radiometric_like_cycles(scene):
    light(scene, "SUN", energy=3.0, color=(1, 0.5, 0.25), rotation=(0, 90 * DEG, 0))
    light(scene, "POINT", energy=100.0, location=(1, 2, 3))
    light(scene, "SPOT", energy=50.0, location=(0, 0, 4), spot_size=60 * DEG, spot_blend=0.25)
    d = export(scene)
    sun, point, spot = sorted(d.lights, key=lambda l: ["sun", "point", "spot"].index(l.kind))
    np.testing.assert_allclose(sun.color, np.array([1, 0.5, 0.25]) * 3 / math.pi)
    np.testing.assert_allclose(sun.direction, [-1, 0, 0], atol=1e-6)  # -Z rotated 90° about Y
    np.testing.assert_allclose(point.color, [100 / (4 * math.pi**2)] * 3)
    np.testing.assert_allclose(point.position, [1, 2, 3])
    assert point.falloff == "inverse_square"
    assert spot.spot_half_angle == pytest.approx(30 * DEG)
    assert spot.spot_blend == pytest.approx(0.25)
    np.testing.assert_allclose(spot.direction, [0, 0, -1], atol=1e-6)
    assert d.warnings == []
    spot_obj = next(obj for obj in scene.objects if obj.type == "LIGHT" and obj.data.type == "SPOT")
    spot_obj.scale = (2, 2, 2)  # the same cone, as in Cycles
    assert export(scene).warnings == []
    spot_obj.scale = (1, 2, 1)  # Cycles' cone an ellipse: said, not silently round
    said = [f"Spot light '{spot_obj.name}' is scaled unevenly: Cycles stretches its cone, Dürer keeps it round"]
    assert export(scene).warnings == said
    lamps = bpy.data.collections.new("Lamps")  # the spot twice more, by collection instances: said once
    lamps.objects.link(spot_obj)
    for x in (5, 10):
        copy = link(scene, bpy.data.objects.new(f"Lamps {x}", None))
        copy.instance_type, copy.instance_collection, copy.location = "COLLECTION", lamps, (x, 0, 0)
    d = export(scene)
    assert sum(light.kind == "spot" for light in d.lights) == 3 and d.warnings == said


# --- camera ----------------------------------------------------------------------------------------


@pytest.mark.parametrize("projection", ["ORTHO", "PERSP"])
@pytest.mark.parametrize("fit", ["AUTO", "HORIZONTAL", "VERTICAL"])
@pytest.mark.parametrize(
    "res, pct, aspect",
    [((64, 48), 100, (1, 1)), ((30, 80), 50, (1, 1)), ((64, 48), 100, (2, 1)), ((40, 40), 25, (1, 3))],
)
def test_camera_view_plane_matches_blender_view_frame(scene, projection, fit, res, pct, aspect):
    cam_obj = scene.camera
    cam = cam_obj.data
    cam.type = projection
    cam.sensor_fit = fit
    cam.lens, cam.sensor_width, cam.sensor_height = 35.0, 36.0, 20.0
    cam.ortho_scale = 7.0
    cam.shift_x, cam.shift_y = 0.1, -0.2
    scene.render.resolution_x, scene.render.resolution_y = res
    scene.render.resolution_percentage = pct
    scene.render.pixel_aspect_x, scene.render.pixel_aspect_y = aspect
    cam_obj.location = (1, 2, 3)
    cam_obj.rotation_euler = (60 * DEG, 0, 30 * DEG)
    c = export(scene).camera
    assert (c.width, c.height) == (res[0] * pct // 100, res[1] * pct // 100)
    assert c.pixel_aspect == aspect[1] / aspect[0]
    frame = np.array([v[:] for v in cam.view_frame(scene=scene)])  # camera space
    if projection == "PERSP":
        frame = frame[:, :2] / -frame[:, 2:3]
    else:
        frame = frame[:, :2]
    left, right, bottom, top = c.view_plane()
    np.testing.assert_allclose([frame[:, 0].min(), frame[:, 0].max()], [left, right], rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose([frame[:, 1].min(), frame[:, 1].max()], [bottom, top], rtol=1e-5, atol=1e-6)
    m = np.array(cam_obj.matrix_world)
    np.testing.assert_allclose(c.center, [1, 2, 3], atol=1e-6)
    np.testing.assert_allclose(c.direction, -m[:3, 2], atol=1e-6)
    np.testing.assert_allclose(c.up, m[:3, 1], atol=1e-6)


def test_material_inputs_dürer_leaves_out_are_said_once_per_material(scene):
    """A bump map, a Principled BSDF's alpha and coat, sheen and subsurface layers, the output's
    displacement: Cycles draws them, Dürer does not (docs/blender.md); said, naming the material
    (they went unsaid: an Alpha of 0.3 rendered opaque without a word)."""
    mat = material("Frosted", (0.5, 0.5, 0.5))
    tree, bsdf = mat.node_tree, mat.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Alpha"].default_value = 0.3
    bsdf.inputs["Coat Weight"].default_value = 0.5
    bsdf.inputs["Subsurface Weight"].default_value = 0.1
    tree.links.new(tree.nodes.new("ShaderNodeBump").outputs["Normal"], bsdf.inputs["Normal"])
    tree.links.new(tree.nodes.new("ShaderNodeDisplacement").outputs[0],
                   tree.nodes["Material Output"].inputs["Displacement"])
    for x in (0, 3):  # two objects, one message
        uv_sphere(scene, f"Ball {x}", location=(x, 0, 0)).data.materials.append(mat)
    uv_sphere(scene, "Plain", location=(6, 0, 0)).data.materials.append(material("Plain", (0.5, 0.5, 0.5)))
    # What changes nothing in Cycles either: a muted bump and displacement, constants of no effect.
    quiet = material("Quiet", (0.5, 0.5, 0.5))
    tree, bsdf = quiet.node_tree, quiet.node_tree.nodes["Principled BSDF"]
    bump, displacement = tree.nodes.new("ShaderNodeBump"), tree.nodes.new("ShaderNodeDisplacement")
    bump.mute = displacement.mute = True
    tree.links.new(bump.outputs["Normal"], bsdf.inputs["Normal"])
    tree.links.new(displacement.outputs[0], tree.nodes["Material Output"].inputs["Displacement"])
    for name, value in (("Alpha", 1.0), ("Coat Weight", 0.0)):
        constant = tree.nodes.new("ShaderNodeValue")
        constant.outputs[0].default_value = value
        tree.links.new(constant.outputs[0], bsdf.inputs[name])
    uv_sphere(scene, "Quiet", location=(9, 0, 0)).data.materials.append(quiet)
    assert export(scene).warnings == ["Material 'Frosted': Dürer ignores its Normal input (bump or normal map), "
                                      "Alpha (drawn opaque), Coat, Subsurface, Displacement"]
