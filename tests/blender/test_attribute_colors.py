"""Attribute colours in Blender (issue 14 item 1): point clouds made by geometry nodes and meshes
whose material's Base Color reads an attribute, directly or through common nodes, render with
each point's / vertex's / corner's / face's colour as Cycles does; graphs that cannot be mapped
fall back to the material's colour with one message."""

from __future__ import annotations

import numpy as np
import pytest
from helpers.blender import (
    DEG,
    aim_camera,
    both,
    compare_shading,
    cube,
    grid,
    light,
    material,
    pointcloud_object,
    points_object,
    render_passes,
    uv_sphere,
    world,
)

from helpers.blender_import import blender_module

bpy = blender_module("bpy")

from durer.blender import engine  # noqa: E402
from durer.blender.export.depsgraph import export_depsgraph  # noqa: E402

pytestmark = pytest.mark.blender

#: The foreach_set field that writes each attribute type (byte colours: their sRGB bytes).
WRITE_FIELD = {"FLOAT_COLOR": "color", "BYTE_COLOR": "color_srgb", "FLOAT_VECTOR": "vector", "FLOAT": "value",
               "INT": "value", "INT8": "value", "BOOLEAN": "value", "FLOAT2": "vector"}
#: The numpy type each attribute type is written from (float32 otherwise).
WRITE_DTYPE = {"INT": np.int32, "INT8": np.int32, "BOOLEAN": bool}


def srgb_to_linear(c):
    c = np.asarray(c, np.float64)
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def set_attribute(geometry, name, kind, domain, values):
    attribute = geometry.attributes.new(name, kind, domain)
    dtype = WRITE_DTYPE.get(kind, np.float32)
    attribute.data.foreach_set(WRITE_FIELD[kind], np.ascontiguousarray(values, dtype).ravel())
    return attribute


def colored_cloud(s, positions, mat, attributes, radius=0.4):
    """A point cloud as molecular add-ons make one: a vertex mesh with per-vertex attributes
    {name: (type, values)} through geometry nodes (Mesh to Points, then Set Material `mat`)."""
    obj = points_object(s, "Cloud", positions, radius)
    for name, (kind, values) in attributes.items():
        set_attribute(obj.data, name, kind, "POINT", values)
    group = obj.modifiers[0].node_group
    to_points, output = group.nodes["Mesh to Points"], group.nodes["Group Output"]
    set_material = group.nodes.new("GeometryNodeSetMaterial")
    set_material.inputs["Material"].default_value = mat
    group.links.new(to_points.outputs[0], set_material.inputs["Geometry"])
    group.links.new(set_material.outputs[0], output.inputs[0])
    return obj


def attribute_material(name, build, color=(0.3, 0.6, 0.9)):
    """The tests' diffuse Principled material (helpers.material) whose Base Color is the socket
    build(node_tree) returns."""
    mat = material(name, color)
    tree = mat.node_tree
    tree.links.new(build(tree), tree.nodes["Principled BSDF"].inputs["Base Color"])
    return mat


def attribute_node(tree, name, output="Color"):
    node = tree.nodes.new("ShaderNodeAttribute")
    node.attribute_name = name
    return node.outputs[output]


def grid_positions(n=5, spacing=1.0):
    """n x n points in the plane y = 0, facing a camera on -y."""
    x, z = np.meshgrid((np.arange(n) - (n - 1) / 2) * spacing, (np.arange(n) - (n - 1) / 2) * spacing)
    return np.column_stack([x.ravel(), np.zeros(n * n), z.ravel()])


def front_view(s, scale=6.0):
    world(s, (0, 0, 0))
    cam = aim_camera(s, (0, -10, 0)).data
    cam.type = "ORTHO"
    cam.ortho_scale = scale
    s.render.resolution_x, s.render.resolution_y = 160, 120
    light(s, "SUN", energy=2.0, rotation=(80 * DEG, 0, 15 * DEG), angle=0.0)  # from about the camera


def test_a_geometry_nodes_point_cloud_takes_each_points_colour_as_cycles_does(scene, tmp_path):
    rng = np.random.default_rng(1)
    colors = rng.uniform(0.05, 1.0, (25, 4))
    mat = attribute_material("Atoms", lambda tree: attribute_node(tree, "Color"))
    colored_cloud(scene, grid_positions(), mat, {"Color": ("FLOAT_COLOR", colors)})
    front_view(scene)
    data = export_depsgraph(bpy.context.evaluated_depsgraph_get())
    np.testing.assert_allclose(data.sphere_colors, colors[:, :3], rtol=1e-7)
    c, d = both(scene, tmp_path, normal=False)
    compare_shading(c, d, min_fraction=0.15)
    assert "colors" in engine.last_render.stats["effects"] and engine.last_render.warnings == []
    # The spheres differ as their colours do: not one colour for all.
    assert len(np.unique(np.round(d["color"][..., :3].reshape(-1, 3), 2), axis=0)) > 25


def test_mesh_vertex_corner_and_face_colours_interpolate_as_in_cycles(scene, tmp_path):
    rng = np.random.default_rng(2)
    for i, (domain, kind) in enumerate((("POINT", "BYTE_COLOR"), ("CORNER", "FLOAT_COLOR"), ("FACE", "FLOAT_COLOR"))):
        obj = grid(scene, f"Grid {domain}", size=0.9, n=4, location=(2 * i - 2, 0, 0), rotation=(90 * DEG, 0, 0))
        count = {"POINT": len(obj.data.vertices), "CORNER": len(obj.data.loops), "FACE": len(obj.data.polygons)}[domain]
        set_attribute(obj.data, "Col", kind, domain, rng.uniform(0.05, 1.0, (count, 4)))
        obj.data.materials.append(attribute_material(f"M {domain}", lambda tree: attribute_node(tree, "Col")))
    front_view(scene)
    data = export_depsgraph(bpy.context.evaluated_depsgraph_get())
    shapes = sorted(m.colors.shape for m in data.meshes)
    assert shapes == [(25, 3), (32, 3, 3), (32, 3, 3)]  # vertices per vertex, corners and faces per corner
    c, d = both(scene, tmp_path, normal=False)
    compare_shading(c, d, min_fraction=0.2)


def chain(tree):
    """Attribute Factor -> Math (× 0.8) -> Color Ramp -> Hue/Saturation/Value -> Gamma -> Mix
    (multiply with a constant colour)."""
    math = tree.nodes.new("ShaderNodeMath")
    math.operation = "MULTIPLY"
    math.inputs[1].default_value = 0.8
    tree.links.new(attribute_node(tree, "Heat", "Factor"), math.inputs[0])
    ramp = tree.nodes.new("ShaderNodeValToRGB")
    ramp.color_ramp.elements[0].color = (0.1, 0.2, 0.9, 1)
    ramp.color_ramp.elements[1].color = (1.0, 0.3, 0.05, 1)
    ramp.color_ramp.elements.new(0.45).color = (0.2, 0.9, 0.3, 1)
    tree.links.new(math.outputs[0], ramp.inputs["Fac"])
    hsv = tree.nodes.new("ShaderNodeHueSaturation")
    hsv.inputs["Hue"].default_value, hsv.inputs["Saturation"].default_value = 0.6, 0.8
    hsv.inputs["Value"].default_value = 1.1
    tree.links.new(ramp.outputs["Color"], hsv.inputs["Color"])
    gamma = tree.nodes.new("ShaderNodeGamma")
    gamma.inputs["Gamma"].default_value = 1.3
    tree.links.new(hsv.outputs[0], gamma.inputs["Color"])
    mix = tree.nodes.new("ShaderNodeMix")
    mix.data_type, mix.blend_type = "RGBA", "MULTIPLY"
    mix.inputs["Factor"].default_value = 0.7
    next(s for s in mix.inputs if s.identifier == "B_Color").default_value = (0.9, 0.8, 1.0, 1)
    tree.links.new(gamma.outputs[0], next(s for s in mix.inputs if s.identifier == "A_Color"))
    return next(s for s in mix.outputs if s.identifier == "Result_Color")


def swizzle(tree):
    """Attribute Color -> Separate Color -> Combine Color as (blue, red, the colour itself: a colour
    into a factor is its luminance, through a muted Invert: Cycles passes its colour through)."""
    separate, combine = tree.nodes.new("ShaderNodeSeparateColor"), tree.nodes.new("ShaderNodeCombineColor")
    color = attribute_node(tree, "Color")
    tree.links.new(color, separate.inputs["Color"])
    tree.links.new(separate.outputs["Blue"], combine.inputs["Red"])
    tree.links.new(separate.outputs["Red"], combine.inputs["Green"])
    muted = tree.nodes.new("ShaderNodeInvert")
    muted.mute = True
    tree.links.new(color, muted.inputs["Color"])
    tree.links.new(muted.outputs["Color"], combine.inputs["Blue"])
    return combine.outputs["Color"]


def ranges(tree):
    """Attribute Factor -> Map Range (clamped) -> Clamp -> Combine Color (with a constant and the
    factor) -> Invert -> Brightness/Contrast."""
    factor = attribute_node(tree, "Heat", "Factor")
    map_range = tree.nodes.new("ShaderNodeMapRange")
    for name, value in (("From Min", 0.2), ("From Max", 0.9), ("To Min", 0.1), ("To Max", 1.2)):
        map_range.inputs[name].default_value = value
    tree.links.new(factor, map_range.inputs["Value"])
    clamp = tree.nodes.new("ShaderNodeClamp")
    clamp.inputs["Min"].default_value, clamp.inputs["Max"].default_value = 0.25, 0.95
    tree.links.new(map_range.outputs["Result"], clamp.inputs["Value"])
    combine = tree.nodes.new("ShaderNodeCombineColor")
    combine.inputs["Green"].default_value = 0.5
    tree.links.new(clamp.outputs["Result"], combine.inputs["Red"])
    tree.links.new(factor, combine.inputs["Blue"])
    invert = tree.nodes.new("ShaderNodeInvert")
    invert.inputs["Fac"].default_value = 0.6
    tree.links.new(combine.outputs["Color"], invert.inputs["Color"])
    adjust = tree.nodes.new("ShaderNodeBrightContrast")
    adjust.inputs["Bright"].default_value, adjust.inputs["Contrast"].default_value = 0.1, 0.3
    tree.links.new(invert.outputs["Color"], adjust.inputs["Color"])
    return adjust.outputs["Color"]


def test_colours_through_every_mapped_node_match_cycles(scene, tmp_path):
    rng = np.random.default_rng(3)
    heat = rng.uniform(0, 1, 25)
    colored_cloud(scene, grid_positions() + (-5.2, 0, 0), attribute_material("Heat", chain),
                  {"Heat": ("FLOAT", heat)}, radius=0.45)
    colored_cloud(scene, grid_positions(), attribute_material("Ranges", ranges), {"Heat": ("FLOAT", heat)}, radius=0.45)
    colors = rng.uniform(0.05, 1, (25, 4))
    colored_cloud(scene, grid_positions() + (5.2, 0, 0), attribute_material("Swizzle", swizzle),
                  {"Color": ("FLOAT_COLOR", colors)}, radius=0.45)
    front_view(scene, scale=16.0)
    scene.render.resolution_x, scene.render.resolution_y = 240, 180
    data = export_depsgraph(bpy.context.evaluated_depsgraph_get())
    swizzled = data.sphere_colors[data.sphere_centers[:, 0] > 2.6]
    luminance = colors[:, :3].astype(np.float32) @ (0.2126729, 0.7151522, 0.0721750)
    np.testing.assert_allclose(swizzled, np.column_stack([colors[:, 2], colors[:, 0], luminance]), rtol=1e-6)
    c, d = both(scene, tmp_path, normal=False)
    compare_shading(c, d, min_fraction=0.04)  # about 1,000 pixels: the spheres are small here
    assert engine.last_render.warnings == []


@pytest.mark.parametrize("kind", ["FLOAT_COLOR", "BYTE_COLOR", "FLOAT_VECTOR", "FLOAT", "INT", "INT8", "BOOLEAN",
                                  "FLOAT2"])
def test_each_attribute_type_gives_the_colour_blender_renders(scene, kind):
    rng = np.random.default_rng(4)
    width = {"FLOAT_VECTOR": 3, "FLOAT": 1, "FLOAT2": 2}.get(kind, 4)
    values = rng.uniform(0, 1, (9, width)).squeeze()
    if kind in WRITE_DTYPE:  # integers, booleans: read as floats, as Cycles reads them
        values = rng.integers(0, 2 if kind == "BOOLEAN" else 5, 9)
    mat = attribute_material("M", lambda tree: attribute_node(tree, "A"))
    colored_cloud(scene, grid_positions(3), mat, {"A": (kind, values)})
    data = export_depsgraph(bpy.context.evaluated_depsgraph_get())
    if kind == "BYTE_COLOR":  # stored as sRGB bytes, decoded to linear as Blender renders them
        expected = srgb_to_linear(np.round(values[:, :3] * 255) / 255)
    elif kind in ("FLOAT", "INT", "INT8", "BOOLEAN"):
        expected = np.repeat(values[:, None], 3, axis=1)
    elif kind == "FLOAT2":
        expected = np.column_stack([values, np.zeros(9)])
    else:
        expected = values[:, :3]
    np.testing.assert_allclose(data.sphere_colors, expected, rtol=1e-6, atol=1e-7)


@pytest.mark.parametrize("on_stop", [False, True])
def test_an_integer_attribute_through_a_color_ramp_colours_atoms_as_cycles_does(scene, tmp_path, on_stop):
    """Atoms coloured by an integer element number through a constant Color Ramp, as molecular
    add-ons colour them: each atom its element's colour, as Cycles renders it (integers fell back to
    the material's colour, with a warning)."""
    elements = np.arange(25) % 3

    def ramp(tree):
        node = tree.nodes.new("ShaderNodeValToRGB")
        node.color_ramp.interpolation = "CONSTANT"
        node.color_ramp.elements[0].color = (0.9, 0.1, 0.1, 1)  # 0: red
        node.color_ramp.elements.new(0.3).color = (0.1, 0.8, 0.1, 1)  # 1 / 2.5: green
        node.color_ramp.elements[-1].position, node.color_ramp.elements[-1].color = 0.6, (0.1, 0.2, 0.9, 1)  # 2: blue
        if on_stop:  # 1 / 2.5 exactly on a stop: Cycles' table of 257 entries puts it below (red)
            node.color_ramp.elements[1].position = 0.4
        scale = tree.nodes.new("ShaderNodeMath")
        scale.operation, scale.inputs[1].default_value = "DIVIDE", 2.5
        tree.links.new(attribute_node(tree, "element", "Fac"), scale.inputs[0])
        tree.links.new(scale.outputs[0], node.inputs["Fac"])
        return node.outputs["Color"]

    colored_cloud(scene, grid_positions(), attribute_material("Elements", ramp), {"element": ("INT", elements)})
    front_view(scene)
    data = export_depsgraph(bpy.context.evaluated_depsgraph_get())
    assert data.warnings == [] and len(np.unique(data.sphere_colors, axis=0)) == (2 if on_stop else 3)
    c, d = both(scene, tmp_path, normal=False)
    compare_shading(c, d, min_fraction=0.15)


def test_each_material_slot_of_a_mesh_reads_its_own_attribute_and_domain(scene):
    obj = grid(scene, "Slots", n=4)
    me = obj.data
    rng = np.random.default_rng(8)
    vertex_colors = rng.uniform(0, 1, (len(me.vertices), 4))
    face_colors = rng.uniform(0, 1, (len(me.polygons), 4))
    set_attribute(me, "V", "FLOAT_COLOR", "POINT", vertex_colors)
    set_attribute(me, "F", "FLOAT_COLOR", "FACE", face_colors)
    slots = np.arange(len(me.polygons)) % 2
    me.attributes.new("material_index", "INT", "FACE").data.foreach_set("value", slots.astype(np.int32))
    me.materials.append(attribute_material("By vertex", lambda tree: attribute_node(tree, "V")))
    me.materials.append(attribute_material("By face", lambda tree: attribute_node(tree, "F")))
    by_vertex, by_face = export_depsgraph(bpy.context.evaluated_depsgraph_get()).meshes
    co = np.array([v.co for v in me.vertices])
    index_of = {tuple(np.round(p, 5)): i for i, p in enumerate(co)}
    vertex_ids = [index_of[tuple(np.round(p, 5))] for p in by_vertex.vertices]
    np.testing.assert_allclose(by_vertex.colors, vertex_colors[vertex_ids, :3], rtol=1e-7)
    assert by_face.colors.shape == (2 * (slots == 1).sum(), 3, 3)
    np.testing.assert_array_equal(by_face.colors[:, 0], by_face.colors[:, 2])  # one colour per face
    expected = {tuple(np.float64(c[:3])) for c in face_colors[slots == 1].astype(np.float32)}
    assert {tuple(c) for c in by_face.colors[:, 0]} == expected


def test_principled_kd_scales_the_colour_and_color_attribute_nodes_read_the_default(scene):
    obj = grid(scene, "Painted", n=3)
    colors = np.random.default_rng(5).uniform(0, 1, (len(obj.data.vertices), 4))
    obj.data.color_attributes.new("Paint", "FLOAT_COLOR", "POINT").data.foreach_set("color", colors.ravel())
    obj.data.color_attributes.default_color_name = "Paint"

    def color_attribute(tree):
        return tree.nodes.new("ShaderNodeVertexColor").outputs["Color"]  # no name: the default attribute

    mat = attribute_material("Half metal", color_attribute)
    mat.node_tree.nodes["Principled BSDF"].inputs["Metallic"].default_value = 0.5
    obj.data.materials.append(mat)
    data = export_depsgraph(bpy.context.evaluated_depsgraph_get())
    np.testing.assert_allclose(data.meshes[0].colors, 0.5 * colors[:, :3], rtol=1e-6)
    # Cycles tints the metal by the attribute too; Dürer's per-point colour is kd alone: said.
    assert data.notes == ["Material 'Half metal': attribute colours tint its diffuse layer alone; the Viewport "
                          "Display colour tints its metallic layer"]


def test_points_of_a_plain_material_keep_its_kd_beside_coloured_ones(scene):
    cloud = pointcloud_object(scene, "Mixed", grid_positions(2), radius=0.3)
    colors = np.random.default_rng(6).uniform(0, 1, (4, 4))
    set_attribute(cloud.data, "Color", "FLOAT_COLOR", "POINT", colors)
    set_attribute(cloud.data, "material_index", "INT", "POINT", [0, 1, 1, 0])
    cloud.data.materials.append(attribute_material("Coloured", lambda tree: attribute_node(tree, "Color")))
    cloud.data.materials.append(material("Red", (0.9, 0.1, 0.1)))
    data = export_depsgraph(bpy.context.evaluated_depsgraph_get())
    np.testing.assert_allclose(data.sphere_colors[[0, 3]], colors[[0, 3], :3], rtol=1e-7)
    np.testing.assert_allclose(data.sphere_colors[[1, 2]], [(0.9, 0.1, 0.1)] * 2, rtol=1e-7)


def test_geometry_nodes_instances_take_their_instance_colour_read_by_an_instancer_attribute(scene, tmp_path):
    from durer.blender import point_cloud

    positions = grid_positions(3, spacing=1.5)
    points = point_cloud.vertex_object(scene.collection, "Points", positions)
    colors = np.random.default_rng(7).uniform(0.1, 1, (9, 4))
    set_attribute(points.data, "Color", "FLOAT_COLOR", "POINT", colors)  # carried to the instances
    ball = uv_sphere(scene, "Ball", radius=0.5)
    ball.data.shade_smooth()
    ball.hide_render = ball.hide_viewport = True

    def instancer_color(tree):
        node = tree.nodes.new("ShaderNodeAttribute")
        node.attribute_type, node.attribute_name = "INSTANCER", "Color"
        return node.outputs["Color"]

    ball.data.materials.append(attribute_material("Per instance", instancer_color))
    point_cloud.instance_on_points(points, ball, rotate=False)
    front_view(scene)
    data = export_depsgraph(bpy.context.evaluated_depsgraph_get())
    assert data.warnings == [] and data.sphere_count == 9
    order = np.lexsort((data.sphere_centers[:, 2], data.sphere_centers[:, 0]))
    np.testing.assert_allclose(data.sphere_colors[order], colors[np.lexsort((positions[:, 2], positions[:, 0])), :3],
                               rtol=1e-7)
    c, d = both(scene, tmp_path, normal=False)
    # Each instance's centre pixel (the UV sphere's smooth normals there face the camera, as the sphere's do).
    for x, z in positions[:, [0, 2]]:
        row, col = int(60 - z * 160 / 6), int(80 + x * 160 / 6)
        np.testing.assert_allclose(d["color"][row, col, :3], c["color"][row, col, :3], rtol=0.02, atol=1e-3)


def test_instanced_meshes_take_their_instance_colour_read_by_an_instancer_attribute(scene, tmp_path):
    """Geometry-nodes instances of a cube (a mesh shared by the instances in the core) with an
    Instancer attribute colour: each instance's kd, as Cycles renders it."""
    from durer.blender import point_cloud

    positions = grid_positions(3, spacing=1.5)
    points = point_cloud.vertex_object(scene.collection, "Points", positions)
    colors = np.random.default_rng(8).uniform(0.1, 1, (9, 4))
    set_attribute(points.data, "Color", "FLOAT_COLOR", "POINT", colors)  # carried to the instances
    box = cube(scene, "Box", size=0.8)
    box.hide_render = box.hide_viewport = True
    box.data.materials.append(attribute_material("Per instance", instancer_attribute))
    point_cloud.instance_on_points(points, box, rotate=False)
    front_view(scene)
    data = export_depsgraph(bpy.context.evaluated_depsgraph_get())
    assert data.warnings == [] and len(data.meshes) == 1
    (mesh,) = data.meshes
    assert mesh.instances.shape == (9, 4, 4) and mesh.colors is None
    order = np.lexsort((mesh.instances[:, 2, 3], mesh.instances[:, 0, 3]))
    np.testing.assert_allclose(mesh.instance_colors[order], colors[np.lexsort((positions[:, 2], positions[:, 0])), :3],
                               rtol=1e-7)
    c, d = both(scene, tmp_path, normal=False)
    for x, z in positions[:, [0, 2]]:  # each cube's front face, flat and facing the camera
        row, col = int(60 - z * 160 / 6), int(80 + x * 160 / 6)
        np.testing.assert_allclose(d["color"][row, col, :3], c["color"][row, col, :3], rtol=0.02, atol=1e-3)


def test_geometry_nodes_instances_of_a_mesh_coloured_by_its_own_attribute_stay_triangles(scene, tmp_path):
    """A UV sphere painted in two colours (its default colour attribute, read by a Color Attribute
    node) instanced on points: its triangles in each instance, with the mesh's colours, as Cycles
    renders them (not a sphere of one colour: that is for Instancer attributes)."""
    from durer.blender import point_cloud

    points = point_cloud.vertex_object(scene.collection, "Points", grid_positions(3, spacing=1.5))
    ball = uv_sphere(scene, "Ball", radius=0.5, location=(0, 0, 30))  # out of sight
    z = np.array([v.co.z for v in ball.data.vertices])
    set_attribute(ball.data, "Paint", "FLOAT_COLOR", "POINT", np.where((z > 0)[:, None], (0.9, 0.1, 0.1, 1), (0.1, 0.1, 0.9, 1)))
    ball.data.color_attributes.default_color_name = "Paint"
    ball.data.materials.append(attribute_material("Painted", lambda tree: tree.nodes.new("ShaderNodeVertexColor").outputs[0]))
    point_cloud.instance_on_points(points, ball, rotate=False)
    front_view(scene)
    data = export_depsgraph(bpy.context.evaluated_depsgraph_get())
    assert data.warnings == [] and data.sphere_count == 0
    instanced = [m for m in data.meshes if m.instances is not None]
    assert len(instanced) == 1 and instanced[0].instances.shape == (9, 4, 4) and instanced[0].colors.shape == (len(z), 3)
    c, d = both(scene, tmp_path, normal=False)
    compare_shading(c, d, min_fraction=0.1)
    hit = d["depth"] < 1e9
    red, blue = d["color"][hit][:, 0] > d["color"][hit][:, 2], d["color"][hit][:, 2] > d["color"][hit][:, 0]
    assert red.mean() > 0.3 and blue.mean() > 0.3  # both halves painted, in every instance


def nested_assembly(scene, atom, lone=None):
    """Copies of a molecule as biological assemblies are built: an outer Instance on Points of a
    geometry-nodes molecule, itself an Instance on Points of `atom`'s mesh on the molecule's three
    points. The molecule's points carry "Col" (to its atoms' instances), the copies' points "Col"
    too and "Tint" (to the copies' instances). With `lone`, the copies' points also place one
    `lone` each, 1.5 below, joined so that it is the first of the instancer's references."""
    from durer.blender import point_cloud

    molecule = point_cloud.vertex_object(scene.collection, "Molecule", [(0, 0, 0), (0.45, 0, 0), (-0.25, 0, 0.4)])
    set_attribute(molecule.data, "Col", "FLOAT_COLOR", "POINT", [(0.9, 0.1, 0.1, 1), (0.1, 0.9, 0.1, 1), (0.1, 0.1, 0.9, 1)])
    molecule.location = (0, 0, 40)  # out of sight
    copies = point_cloud.vertex_object(scene.collection, "Assembly", grid_positions(2, spacing=2.0))
    set_attribute(copies.data, "Col", "FLOAT_COLOR", "POINT", np.full((4, 4), 0.5))  # hidden by the atoms'
    set_attribute(copies.data, "Tint", "FLOAT", "POINT", [0.25, 0.5, 0.75, 1.0])
    group = bpy.data.node_groups.new("Assembly", "GeometryNodeTree")
    group.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
    group.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    nodes, links = group.nodes, group.links
    given, out = nodes.new("NodeGroupInput"), nodes.new("NodeGroupOutput")
    info, atom_info = nodes.new("GeometryNodeObjectInfo"), nodes.new("GeometryNodeObjectInfo")
    info.inputs["Object"].default_value, atom_info.inputs["Object"].default_value = molecule, atom
    inner, outer = nodes.new("GeometryNodeInstanceOnPoints"), nodes.new("GeometryNodeInstanceOnPoints")
    links.new(info.outputs["Geometry"], inner.inputs["Points"])
    links.new(atom_info.outputs["Geometry"], inner.inputs["Instance"])
    links.new(given.outputs[0], outer.inputs["Points"])
    links.new(inner.outputs[0], outer.inputs["Instance"])
    outer.inputs["Rotation"].default_value = (0, 0.5, 0)
    if lone is None:
        links.new(outer.outputs[0], out.inputs[0])
    else:
        lone_info, below, beside = (nodes.new(kind) for kind in ("GeometryNodeObjectInfo", "GeometryNodeTransform",
                                                                 "GeometryNodeInstanceOnPoints"))
        lone_info.inputs["Object"].default_value = lone
        below.inputs["Translation"].default_value = (0, 0, -1.5)
        links.new(given.outputs[0], below.inputs[0])
        links.new(below.outputs[0], beside.inputs["Points"])
        links.new(lone_info.outputs["Geometry"], beside.inputs["Instance"])
        join = nodes.new("GeometryNodeJoinGeometry")
        links.new(outer.outputs[0], join.inputs[0])  # Join lists its inputs last first: the lone ones lead
        links.new(beside.outputs[0], join.inputs[0])
        links.new(join.outputs[0], out.inputs[0])
    copies.modifiers.new("Assembly", "NODES").node_group = group
    return copies


def instancer_tinted(tree):
    """Base Color = the instancer attribute "Col" × "Tint": each read where Cycles finds it."""
    col, tint = (tree.nodes.new("ShaderNodeAttribute") for _ in range(2))
    col.attribute_type = tint.attribute_type = "INSTANCER"
    col.attribute_name, tint.attribute_name = "Col", "Tint"
    mix = tree.nodes.new("ShaderNodeMix")
    mix.data_type, mix.blend_type = "RGBA", "MULTIPLY"
    mix.inputs["Factor"].default_value = 1.0
    tree.links.new(col.outputs["Color"], mix.inputs[6])
    tree.links.new(tint.outputs["Color"], mix.inputs[7])
    return mix.outputs[2]


@pytest.mark.parametrize("atom", ["uv sphere", "cube"])
def test_nested_instances_take_each_level_s_instancer_attribute_as_cycles_does(scene, tmp_path, atom):
    """Copies of a molecule of instanced atoms: each atom's "Col" from the innermost level that has it
    (the molecule's points, not the copies'), "Tint" from the copies' (Blender's
    find_geonode_attribute_rgba); Dürer took the copies one at a time, grey with a warning."""
    shape = uv_sphere(scene, "Atom", radius=0.3, location=(0, 0, 50)) if atom == "uv sphere" else \
        cube(scene, "Atom", size=0.4, location=(0, 0, 50))
    shape.data.materials.append(attribute_material("Atoms", instancer_tinted))
    shape.hide_render = shape.hide_viewport = True  # itself no instance: nothing to read there
    nested_assembly(scene, shape)
    front_view(scene)
    data = export_depsgraph(bpy.context.evaluated_depsgraph_get())
    assert data.warnings == []
    if atom == "uv sphere":
        assert data.sphere_count == 12 and sorted({tuple(np.round(c, 4)) for c in data.sphere_colors}) == sorted(
            {tuple(np.round(np.multiply(rgb, t), 4)) for rgb in ((0.9, 0.1, 0.1), (0.1, 0.9, 0.1), (0.1, 0.1, 0.9))
             for t in (0.25, 0.5, 0.75, 1.0)})
    else:
        (mesh,) = data.meshes
        assert mesh.instances.shape == (12, 4, 4) and mesh.instance_colors.shape == (12, 3)
    c, d = both(scene, tmp_path, normal=False)
    if atom == "uv sphere":  # each atom's centre pixel: its colour (a UV sphere's facets shade it within 6 %)
        lit = 0
        for x, _, z in data.sphere_centers:
            ours, cycles = (image["color"][int(60 - z * 160 / 6), int(80 + x * 160 / 6), :3] for image in (d, c))
            if cycles.sum() < 0.05:  # another atom's shadow
                continue
            lit += 1
            np.testing.assert_allclose(ours / ours.sum(), cycles / cycles.sum(), atol=2e-3)
            assert abs(ours.sum() / cycles.sum() - 1) < 0.06
        assert lit >= 8
    else:
        compare_shading(c, d, min_fraction=0.02)
    lit = d["color"][..., :3][d["color"][..., :3].sum(axis=-1) > 0.05]
    assert len(np.unique(np.round(lit / lit.sum(axis=1, keepdims=True), 1), axis=0)) >= 3  # red, green, blue atoms


def test_a_nested_instance_takes_its_innermost_attribute_whatever_the_order_of_the_references(scene):
    """The instancer's first reference a plain sphere, its second the molecule's copies: each atom's
    "Col" is still its molecule point's (the innermost level), the lone spheres' the copies' (the
    outer level: theirs). The copies' level came first for the atoms when it was met first."""
    mat = attribute_material("Atoms", instancer_tinted)
    atom, lone = uv_sphere(scene, "Atom", radius=0.2, location=(0, 0, 50)), uv_sphere(scene, "Lone", radius=0.3)
    for shape in (atom, lone):
        shape.data.materials.append(mat)
        shape.hide_render = shape.hide_viewport = True
    copies = nested_assembly(scene, atom, lone)
    depsgraph = bpy.context.evaluated_depsgraph_get()
    geometry = bpy.types.GeometrySet.from_evaluated_object(copies.evaluated_get(depsgraph))
    assert [r.instances_pointcloud() is not None for r in geometry.instance_references()] == [False, True]
    data = export_depsgraph(depsgraph)
    assert data.warnings == [] and data.sphere_count == 4 + 12
    tints = (0.25, 0.5, 0.75, 1.0)
    lone_rows = np.isclose(data.sphere_radii, 0.3)
    atoms = {tuple(np.round(c, 4)) for c in data.sphere_colors[~lone_rows]}
    assert atoms == {tuple(np.round(np.multiply(rgb, t), 4)) for t in tints
                     for rgb in ((0.9, 0.1, 0.1), (0.1, 0.9, 0.1), (0.1, 0.1, 0.9))}
    np.testing.assert_allclose(sorted(data.sphere_colors[lone_rows][:, 0]), np.multiply(0.5, tints))


def noise_into_base_color(tree):
    return tree.nodes.new("ShaderNodeTexNoise").outputs["Color"]


def instancer_attribute(tree):
    node = tree.nodes.new("ShaderNodeAttribute")
    node.attribute_type, node.attribute_name = "INSTANCER", "Color"
    return node.outputs["Color"]


@pytest.mark.parametrize(
    ("build", "reason"),
    [
        (noise_into_base_color, "node 'Noise Texture' (Noise Texture) is not mapped"),
        (instancer_attribute, "it reads the instancer attribute 'Color' where there is none"),
        (lambda tree: attribute_node(tree, "Missing"), "no attribute 'Missing'"),
    ],
)
def test_an_unmapped_graph_falls_back_to_the_material_colour_with_one_message(scene, tmp_path, build, reason):
    # The Base Color socket's own value (blue / red 1/4) differs from the viewport colour (4): the hue
    # below tells which one the fallback took.
    mat = attribute_material("Fallback", build, color=(0.8, 0.4, 0.2))
    mat.diffuse_color = (0.2, 0.4, 0.8, 1)  # the viewport colour: what a linked Base Color falls back to
    colored_cloud(scene, grid_positions(), mat, {"Color": ("FLOAT_COLOR", np.ones((25, 4)))})
    front_view(scene)
    d = render_passes(scene, tmp_path / "durer.exr", normal=False)
    assert engine.last_render.warnings == [
        f"Material 'Fallback' is drawn in its Viewport Display colour where Cycles varies its colour: {reason}"]
    assert "colors" not in engine.last_render.stats["effects"]
    lit = d["color"][..., :3].max(axis=-1) > 0.05
    assert lit.mean() > 0.1  # never silently black
    np.testing.assert_allclose(d["color"][lit][:, 2] / d["color"][lit][:, 0], 4.0, rtol=1e-4)  # the material's hue
