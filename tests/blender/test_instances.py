"""Instances as scatter setups make them: geometry-nodes Instance on Points of a sphere object,
collection instances, vertex instancing. Sphere-shaped instances are exported in bulk
(export/instances.py) and must give exactly the spheres, one per instance, that their matrices say."""

from __future__ import annotations

import numpy as np
import pytest
from helpers.blender import cube, export, grid, link, uv_sphere

from helpers.blender_import import blender_module

bpy = blender_module("bpy")

from durer.blender import build, point_cloud

pytestmark = pytest.mark.blender


def instance_transforms(obj) -> tuple[np.ndarray, np.ndarray]:
    """The instance transforms (N, 4, 4) and reference indices of obj's evaluated geometry, read
    from Blender's own geometry set (what the export must agree with)."""
    evaluated = obj.evaluated_get(bpy.context.evaluated_depsgraph_get())
    geometry = bpy.types.GeometrySet.from_evaluated_object(evaluated)
    cloud = geometry.instances_pointcloud()
    values = np.empty(len(cloud.points) * 16, np.float32)
    cloud.attributes["instance_transform"].data.foreach_get("value", values)
    world = np.array(evaluated.matrix_world)
    return world @ values.reshape(-1, 4, 4).transpose(0, 2, 1), cloud


def test_instance_on_points_of_a_uv_sphere_gives_one_sphere_per_instance(scene):
    positions = np.random.default_rng(3).uniform(-4, 4, (500, 3))
    points = point_cloud.vertex_object(scene.collection, "Points", positions)
    points.location, points.rotation_euler, points.scale = (1, -2, 0.5), (0.3, 0.1, -0.4), (1.5, 1.5, 1.5)
    ball = uv_sphere(scene, "Ball", radius=0.2)
    ball.hide_render = ball.hide_viewport = True  # only its instances are seen
    point_cloud.instance_on_points(points, ball, scale=(0.5, 2.0), seed=4)
    data = export(scene)
    transforms, _ = instance_transforms(points)
    assert data.sphere_count == 500 and data.ellipsoid_count == 0 and data.sources["Points"] == 500
    order = np.lexsort(data.sphere_centers.T)
    expected_centers = transforms[:, :3, 3]
    expected_radii = 0.2 * np.abs(np.linalg.det(transforms[:, :3, :3])) ** (1 / 3)
    expected = np.lexsort(expected_centers.T)
    np.testing.assert_allclose(data.sphere_centers[order], expected_centers[expected], rtol=0, atol=1e-5)
    np.testing.assert_allclose(data.sphere_radii[order], expected_radii[expected], rtol=1e-5)
    assert expected_radii.min() < 0.2 * 1.5 * 0.7 and expected_radii.max() > 0.2 * 1.5 * 1.5  # scales varied


def test_collection_instances_with_a_squashed_one_and_instanced_cubes(scene):
    """Empties instancing a collection of one sphere: uniform ones give spheres, a squashed one an
    exact ellipsoid; a cube instanced on points is one mesh with a matrix per instance, stored once
    in the core scene."""
    collection = bpy.data.collections.new("Ball collection")
    ball = uv_sphere(scene, "Ball", radius=0.5)
    scene.collection.objects.unlink(ball)
    collection.objects.link(ball)
    for i, scale in enumerate([(1, 1, 1), (2, 2, 2), (1, 3, 1)]):
        empty = link(scene, bpy.data.objects.new(f"Empty {i}", None))
        empty.instance_type, empty.instance_collection = "COLLECTION", collection
        empty.location, empty.scale = (3 * i, 0, 0), scale
    data = export(scene)
    assert data.sphere_count == 2 and data.ellipsoid_count == 1
    np.testing.assert_allclose(sorted(data.sphere_radii), [0.5, 1.0], rtol=1e-6)
    np.testing.assert_allclose(data.transformed_spheres[0].matrix[:3, :3], np.diag([1.0, 3.0, 1.0]), atol=1e-6)
    box = cube(scene, "Box", size=0.2)
    box.hide_render = box.hide_viewport = True
    points = point_cloud.vertex_object(scene.collection, "Points", np.random.default_rng(1).uniform(-3, 3, (20, 3)))
    point_cloud.instance_on_points(points, box)
    data = export(scene)
    assert data.sphere_count == 2 and len(data.meshes) == 1 and data.triangle_count == 20 * 12
    (mesh,) = data.meshes
    assert mesh.instances.shape == (20, 4, 4) and np.array_equal(mesh.instances[0], mesh.matrix)
    centres = np.sort(mesh.instances[:, :3, 3], axis=0)
    expected = np.array([np.array(points.matrix_world) @ (*v.co, 1) for v in points.data.vertices])[:, :3]
    np.testing.assert_allclose(centres, np.sort(expected, axis=0), atol=1e-5)
    core = build.make_scene(data)
    assert core.triangle_count == 20 * 12 and core.stored_triangle_count == 12


def test_an_instancer_inside_instanced_collections_gives_each_copy_its_spheres(scene):
    """The bulk path reads an instancer's own instance transforms; a collection instance of that
    instancer must still give its copy of the spheres, where the copy is."""
    from helpers.blender import material

    collection = bpy.data.collections.new("Cloud")
    points = point_cloud.vertex_object(collection, "Points", np.random.default_rng(2).uniform(-1, 1, (50, 3)))
    ball = uv_sphere(scene, "Ball", radius=0.1)
    ball.data.materials.append(material("Red", (0.9, 0.1, 0.1)))
    ball.hide_render = ball.hide_viewport = True
    point_cloud.instance_on_points(points, ball, rotate=False)
    for i, x in enumerate((-5.0, 5.0)):
        empty = link(scene, bpy.data.objects.new(f"Copy {i}", None))
        empty.instance_type, empty.instance_collection = "COLLECTION", collection
        empty.location = (x, 0, 0)
    data = export(scene)
    assert data.sphere_count == 100
    left = data.sphere_centers[:, 0] < 0
    assert left.sum() == 50
    np.testing.assert_allclose(np.sort(data.sphere_centers[left][:, 1]), np.sort(data.sphere_centers[~left][:, 1]))
    scene.collection.children.link(collection)  # the instancer itself in the scene too: its 50 more
    data = export(scene)
    assert data.sphere_count == 150
    red = [i for i, m in enumerate(data.materials) if np.allclose(m.diffuse, (0.9, 0.1, 0.1), atol=1e-6)]
    assert len(red) == 1 and (data.sphere_materials == red[0]).all()


def test_point_cloud_instances_are_read_in_bulk(scene):
    """Instance on Points of a point cloud (Mesh to Points): every instance's points become spheres
    at once from the instancer's transform arrays, where the instance puts them, scaled with it."""
    cloud = point_cloud.vertex_object(scene.collection, "Cloud", np.array([[0, 0, 0], [0.3, 0, 0], [0, 0.3, 0]], float))
    point_cloud.mesh_to_points(cloud, 0.05)
    cloud.hide_render = cloud.hide_viewport = True
    where = np.random.default_rng(4).uniform(-5, 5, (40, 3))
    points = point_cloud.vertex_object(scene.collection, "Points", where)
    point_cloud.instance_on_points(points, cloud, rotate=False, scale=(0.5, 2.0))
    data = export(scene)
    assert data.sphere_count == 120 and data.ellipsoid_count == 0 and not data.meshes
    # Each instance: a uniform scale s about its point; its three spheres at p, p + 0.3 s x, p + 0.3 s y.
    radii = data.sphere_radii.reshape(40, 3)
    scales = radii[:, 0] / 0.05
    assert np.all((scales >= 0.5 - 1e-6) & (scales <= 2.0 + 1e-6)) and np.ptp(scales) > 0.5
    np.testing.assert_allclose(radii, 0.05 * scales[:, None] * np.ones(3), rtol=1e-6)
    centres = data.sphere_centers.reshape(40, 3, 3)
    np.testing.assert_allclose(centres[:, 0], where, atol=1e-5)
    np.testing.assert_allclose(centres[:, 1] - centres[:, 0], 0.3 * scales[:, None] * [1, 0, 0], atol=1e-5)
    np.testing.assert_allclose(centres[:, 2] - centres[:, 0], 0.3 * scales[:, None] * [0, 1, 0], atol=1e-5)


@pytest.mark.parametrize("scale", [(1.7, 1.7, 1.7), (1.0, 1.0, 2.0)])
def test_a_sphere_placed_any_way_is_the_same_sphere_bit_for_bit(scene, scale):
    """A sphere object and an instance of its sphere under the same matrix, a point cloud and an
    instance of it under the same matrix: the same world-space sphere, or the same ellipsoid, to
    the bit (one rule places them all)."""
    from helpers.blender import pointcloud_object

    def placed(name):
        obj = scene.objects[name]
        obj.location, obj.rotation_euler, obj.scale = (0.3, -1.1, 2.9), (0.4, -0.7, 1.3), scale

    uv_sphere(scene, "Ball", radius=0.5)
    pointcloud_object(scene, "Cloud", np.zeros((1, 3)), radius=0.5)
    for name, reference in (("Ball instancer", "Ball"), ("Cloud instancer", "Cloud")):
        copy = scene.objects[reference].copy()
        copy.name = f"{reference} reference"
        link(scene, copy).hide_render = copy.hide_viewport = True
        point_cloud.instance_on_points(point_cloud.vertex_object(scene.collection, name, np.zeros((1, 3))), copy,
                                       rotate=False)
        placed(name)
        placed(reference)
    data = export(scene)
    owners = {obj.name: i for i, obj in enumerate(data.objects)}
    if scale[0] == scale[2]:
        assert data.sphere_count == 4 and data.ellipsoid_count == 0
        sphere = {name: (data.sphere_centers[data.sphere_owners == owners[name]],
                         data.sphere_radii[data.sphere_owners == owners[name]]) for name in owners}
        for name, reference in (("Ball instancer", "Ball"), ("Cloud instancer", "Cloud")):
            assert np.array_equal(sphere[name][0], sphere[reference][0])
            assert np.array_equal(sphere[name][1], sphere[reference][1])
        np.testing.assert_allclose(sphere["Cloud"][1], [0.85], rtol=1e-6)
        return
    assert data.sphere_count == 0 and data.ellipsoid_count == 4
    groups = {g.name: g for g in data.transformed_spheres}
    for name, reference in (("Ball instancer", "Ball"), ("Cloud instancer", "Cloud")):
        for field in ("centers", "radii", "matrix"):
            assert np.array_equal(getattr(groups[name], field), getattr(groups[reference], field)), (name, field)


def test_instances_render_as_the_equivalent_point_cloud(scene):
    """Instance on Points of a UV sphere renders, pixel for pixel, as a point cloud of the same
    centres and radius (Mesh to Points) does: the instances are spheres, not meshes."""
    import durer

    positions = np.random.default_rng(9).uniform(-3, 3, (300, 3))
    points = point_cloud.vertex_object(scene.collection, "Points", positions)
    ball = uv_sphere(scene, "Ball", radius=0.25)
    ball.hide_render = ball.hide_viewport = True
    point_cloud.instance_on_points(points, ball)  # random rotations: still the same spheres
    instanced = build.make_scene(export(scene))
    points.modifiers.clear()
    point_cloud.mesh_to_points(points, 0.25)
    cloud = build.make_scene(export(scene))
    assert instanced.sphere_count == cloud.sphere_count == 300
    camera = durer.PerspectiveCamera((0, -12, 4), (0, 3, -1), (0, 0, 1), 50.0)
    a = durer.render(instanced, camera, 160, 120)
    b = durer.render(cloud, camera, 160, 120)
    assert np.isfinite(a.depth).mean() > 0.05
    np.testing.assert_allclose(a.depth, b.depth, rtol=1e-6)
    np.testing.assert_allclose(a.color, b.color, atol=1e-5)
    np.testing.assert_allclose(a.normal, b.normal, atol=1e-4)


def particle_system(scene, emitter, instanced, count, seed, **settings):
    """A particle system on `emitter` as users set one up to scatter objects: every particle born
    on frame 1 and left where it is born (no physics), rendered as `instanced` (an object, or a
    collection with render_type="COLLECTION"), at random sizes and rotations."""
    emitter.modifiers.new(f"Particles {len(emitter.particle_systems)}", "PARTICLE_SYSTEM")
    system = emitter.particle_systems[-1]
    system.seed = seed
    part = system.settings
    part.count, part.frame_start, part.frame_end, part.physics_type = count, 1, 1, "NO"
    part.particle_size, part.size_random = 1.0, 0.6
    part.use_rotations, part.rotation_mode, part.rotation_factor_random = True, "NOR", 0.8
    part.render_type = settings.pop("render_type", "OBJECT")
    if part.render_type == "OBJECT":
        part.instance_object = instanced
    else:
        part.instance_collection = instanced
    for name, value in settings.items():
        setattr(part, name, value)
    scene.frame_set(1)
    return system


def particle_instances() -> list[tuple[str, np.ndarray]]:
    """Blender's own particle instances: each one's object name and world matrix."""
    depsgraph = bpy.context.evaluated_depsgraph_get()
    return [(inst.object.name, np.array(inst.matrix_world, np.float64))
            for inst in depsgraph.object_instances if inst.particle_system is not None]


def offset_sphere(scene, name, radius, offset):
    """A UV sphere whose mesh sits `offset` from its object's origin (so an instance's rotation
    moves its centre)."""
    from helpers.blender import bmesh, mesh_object

    def build_mesh(bm):
        bmesh.ops.create_uvsphere(bm, u_segments=32, v_segments=16, radius=radius)
        bmesh.ops.translate(bm, verts=bm.verts, vec=offset)

    return mesh_object(scene, name, build_mesh)


def assert_same_rows(rows, expected, atol):
    """The same rows in any order: each expected one matched to the nearest exported one not
    matched yet (particles may be born on the same spot: Blender's own matrices repeat)."""
    assert rows.shape == expected.shape
    distance = np.abs(expected[:, None, :] - rows[None, :, :]).max(axis=2)
    for i in range(len(expected)):
        j = int(distance[i].argmin())
        np.testing.assert_allclose(rows[j], expected[i], rtol=0, atol=atol)
        distance[:, j] = np.inf


def expected_spheres(instances, own) -> tuple[np.ndarray, np.ndarray]:
    """The spheres Blender's instances make of objects whose meshes are spheres (`own`: name ->
    its mesh's centre and radius in object space)."""
    centres = np.array([m[:3, :3] @ own[name][0] + m[:3, 3] for name, m in instances])
    radii = np.array([own[name][1] * abs(np.linalg.det(m[:3, :3])) ** (1 / 3) for name, m in instances])
    return centres, radii


def test_particles_rendered_as_a_sphere_object_give_one_sphere_each_where_blender_puts_it(scene):
    """A particle system instancing a sphere (legacy particles, as emitters scatter objects): one
    sphere per particle, centred and sized by Blender's own instance matrix, the object's offset
    from its origin rotated with each particle; a second system on the same emitter with another
    sphere keeps its own radius; an instanced object squashed on one axis gives exact ellipsoids."""
    emitter = grid(scene, "Emitter", size=3.0, n=8)
    emitter.location, emitter.rotation_euler = (0.5, -1.0, 0.2), (0.3, 0.0, 0.7)
    emitter.show_instancer_for_render = emitter.show_instancer_for_viewport = False
    ball = offset_sphere(scene, "Ball", 0.1, (0.3, 0.0, 0.0))
    ball.location, ball.scale = (4, 4, 4), (1.5, 1.5, 1.5)
    small = uv_sphere(scene, "Small", radius=0.04)
    for obj in (ball, small):
        obj.hide_render = obj.hide_viewport = True  # only its instances are seen
    particle_system(scene, emitter, ball, 300, seed=1)
    particle_system(scene, emitter, small, 200, seed=2, use_scale_instance=False)
    instances = particle_instances()
    assert len(instances) == 500
    data = export(scene)
    assert data.sphere_count == 500 and data.ellipsoid_count == 0
    assert data.sources == {"Ball": 300, "Small": 200}
    centres, radii = expected_spheres(instances, {"Ball": (np.array([0.3, 0.0, 0.0]), 0.1), "Small": (np.zeros(3), 0.04)})
    assert_same_rows(np.column_stack([data.sphere_centers, data.sphere_radii]), np.column_stack([centres, radii]), 2e-5)
    scales = radii[[name == "Ball" for name, _ in instances]] / (0.1 * 1.5)
    assert scales.min() < 0.7 and scales.max() > 0.95  # sizes varied
    ball.scale = (1.5, 3.0, 1.5)
    data = export(scene)
    assert data.ellipsoid_count == 300 and data.sphere_count == 200
    exported = np.array([t.matrix[:3, :].ravel() for t in data.transformed_spheres])
    assert_same_rows(exported, np.array([m[:3, :].ravel() for name, m in particle_instances() if name == "Ball"]), 1e-5)


def test_particles_rendered_as_a_collection_give_each_particle_its_own_objects_sphere(scene):
    """A collection-rendered system picks an object per particle: each particle's sphere has the
    radius of the object Blender instanced there, so the walk may not reuse one particle's object
    for the next."""
    collection = bpy.data.collections.new("Balls")
    radii = {"Small": 0.05, "Large": 0.2}
    for name, radius in radii.items():
        obj = uv_sphere(scene, name, radius=radius)
        scene.collection.objects.unlink(obj)
        collection.objects.link(obj)
    emitter = grid(scene, "Emitter", size=3.0, n=6)
    emitter.show_instancer_for_render = emitter.show_instancer_for_viewport = False
    particle_system(scene, emitter, collection, 120, seed=3, render_type="COLLECTION", use_collection_pick_random=True)
    instances = particle_instances()
    names = [name for name, _ in instances]
    assert len(instances) == 120 and 20 < names.count("Small") < 100
    data = export(scene)
    assert data.sphere_count == 120 and data.ellipsoid_count == 0
    centres, expected_radii = expected_spheres(instances, {name: (np.zeros(3), r) for name, r in radii.items()})
    assert_same_rows(np.column_stack([data.sphere_centers, data.sphere_radii]),
                     np.column_stack([centres, expected_radii]), 2e-5)


def node_group(obj, name):
    """A geometry-nodes modifier on `obj` with an empty group: (group, nodes, links, input, output)."""
    group = bpy.data.node_groups.new(name, "GeometryNodeTree")
    group.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
    group.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    obj.modifiers.new(name, "NODES").node_group = group
    return group, group.nodes, group.links, group.nodes.new("NodeGroupInput"), group.nodes.new("NodeGroupOutput")


def test_atoms_and_bonds_made_by_one_modifier_are_all_there(scene):
    """Ball and stick as geometry nodes make it: an ico sphere and a cylinder instanced on points,
    or the atoms as a point cloud, joined with the bonds' instances. Every atom a sphere, every
    bond a cylinder (each reference's mesh read while it lives; the point cloud beside the
    instances not taken for one of them)."""
    atoms = np.random.default_rng(5).uniform(-2, 2, (30, 3))
    for variant in ("ico atoms", "points atoms"):
        for obj in list(scene.objects):
            if obj.type != "CAMERA":
                bpy.data.objects.remove(obj)
        host = point_cloud.vertex_object(scene.collection, "Atoms", atoms)
        bonds = point_cloud.vertex_object(scene.collection, "Bond points", (atoms[:-1] + atoms[1:]) / 2)
        bonds.hide_render = True
        group, nodes, links, given, output = node_group(host, variant)
        join = nodes.new("GeometryNodeJoinGeometry")
        if variant == "ico atoms":
            ico, on_atoms = nodes.new("GeometryNodeMeshIcoSphere"), nodes.new("GeometryNodeInstanceOnPoints")
            ico.inputs["Radius"].default_value, ico.inputs["Subdivisions"].default_value = 0.1, 3
            links.new(given.outputs[0], on_atoms.inputs["Points"])
            links.new(ico.outputs[0], on_atoms.inputs["Instance"])
            links.new(on_atoms.outputs[0], join.inputs[0])
        else:
            to_points = nodes.new("GeometryNodeMeshToPoints")
            to_points.inputs["Radius"].default_value = 0.1
            links.new(given.outputs[0], to_points.inputs["Mesh"])
            links.new(to_points.outputs[0], join.inputs[0])
        info, cylinder = nodes.new("GeometryNodeObjectInfo"), nodes.new("GeometryNodeMeshCylinder")
        info.inputs["Object"].default_value = bonds
        cylinder.inputs["Radius"].default_value, cylinder.inputs["Vertices"].default_value = 0.02, 8
        on_bonds = nodes.new("GeometryNodeInstanceOnPoints")
        links.new(info.outputs["Geometry"], on_bonds.inputs["Points"])
        links.new(cylinder.outputs["Mesh"], on_bonds.inputs["Instance"])
        links.new(on_bonds.outputs[0], join.inputs[0])
        links.new(join.outputs[0], output.inputs[0])
        d = export(scene)
        assert d.sphere_count == 30, variant
        np.testing.assert_allclose(np.sort(d.sphere_centers, axis=0), np.sort(atoms, axis=0), atol=1e-5)
        (mesh,) = d.meshes
        assert len(mesh.instances) == 29 and d.triangle_count == 29 * len(mesh.faces), variant


def test_instances_of_a_point_cloud_take_its_own_attribute_colours(scene):
    """A point cloud whose material reads its own colour attribute, instanced twice by geometry
    nodes (as molecular add-ons build assemblies): each copy of each point has that point's
    colour, as Cycles draws it."""
    from helpers.blender import material

    positions = np.random.default_rng(6).uniform(-1, 1, (20, 3))
    colours = np.random.default_rng(7).uniform(0, 1, (20, 3))
    molecule = point_cloud.vertex_object(scene.collection, "Molecule", positions)
    molecule.data.attributes.new("Color", "FLOAT_COLOR", "POINT").data.foreach_set(
        "color", np.c_[colours, np.ones(20)].astype(np.float32).ravel())
    mat = material("Atoms", (0.5, 0.5, 0.5))
    tree, bsdf = mat.node_tree, mat.node_tree.nodes["Principled BSDF"]
    attribute = tree.nodes.new("ShaderNodeAttribute")
    attribute.attribute_name = "Color"
    tree.links.new(attribute.outputs["Color"], bsdf.inputs["Base Color"])
    group, nodes, links, given, output = node_group(molecule, "Assembly")
    to_points, set_material = nodes.new("GeometryNodeMeshToPoints"), nodes.new("GeometryNodeSetMaterial")
    to_points.inputs["Radius"].default_value = 0.05
    set_material.inputs["Material"].default_value = mat
    copies, on_copies = nodes.new("GeometryNodePoints"), nodes.new("GeometryNodeInstanceOnPoints")
    copies.inputs["Count"].default_value = 2
    links.new(given.outputs[0], to_points.inputs["Mesh"])
    links.new(to_points.outputs[0], set_material.inputs["Geometry"])
    links.new(copies.outputs[0], on_copies.inputs["Points"])
    links.new(set_material.outputs[0], on_copies.inputs["Instance"])
    links.new(on_copies.outputs[0], output.inputs[0])
    d = export(scene)
    assert d.sphere_count == 40 and d.warnings == []
    np.testing.assert_allclose(d.sphere_colors, np.tile(colours, (2, 1)), atol=1e-6)


def test_instancers_of_spheres_alike_but_for_their_radius_keep_their_own(scene):
    """Instancers of UV spheres of one topology, radius 0.2 and 0.5 (small balls, big balls), and
    of an egg (the 0.2 sphere bulged but at its first and last vertices): the meshes geometry nodes
    instance are temporary, and one freed leaves its address to the next; every export gives each
    instancer its own shape (spheres of its radius; the egg's triangles)."""
    rng = np.random.default_rng(0)
    for name, radius, x in (("Small", 0.2, -2.0), ("Big", 0.5, 1.0), ("Egg", 0.2, 4.0)):
        ball = uv_sphere(scene, name, radius=radius)
        if name == "Egg":
            co = np.empty(len(ball.data.vertices) * 3)
            ball.data.vertices.foreach_get("co", co)
            co = co.reshape(-1, 3)
            co[1:-1, 2] *= 1.5
            ball.data.vertices.foreach_set("co", co.ravel())
            ball.data.update()
        ball.hide_render = ball.hide_viewport = True
        points = point_cloud.vertex_object(scene.collection, f"{name} points", rng.uniform(0, 1.5, (6, 3)) * (1, 1, 0) + (x, 0, 0))
        point_cloud.instance_on_points(points, ball, rotate=False)
    depsgraph = bpy.context.evaluated_depsgraph_get()
    from durer.blender.export.depsgraph import export_depsgraph

    for _ in range(10):
        d = export_depsgraph(depsgraph)
        names = [o.name for o in d.objects]
        for name, radius in (("Small points", 0.2), ("Big points", 0.5)):
            np.testing.assert_allclose(d.sphere_radii[d.sphere_owners == names.index(name)], radius, rtol=1e-5)
        assert d.sphere_count == 12 and [m.name for m in d.meshes] == ["Egg points"]
