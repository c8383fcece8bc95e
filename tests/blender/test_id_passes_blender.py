"""Blender's index passes from Dürer (issue 14 item 3): IndexOB (the object's Pass Index) and IndexMA
(the material's), equal to Cycles' on the same scene at every pixel away from silhouette edges, and
Dürer's Object ID pass (the file's objects numbered from 1 in the order of their unique names, the
same on every frame, the table saved with the image)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from helpers.blender import (aim_camera, cube, export, light, link, material, pointcloud_object, quad,
                             render_passes, use_cycles, uv_sphere, world)
from helpers.exr import read_exr, read_exr_headers
from PIL import Image

from helpers.blender_import import blender_module

bpy = blender_module("bpy")

from durer.blender import batch, engine, point_cloud  # noqa: E402
from durer.blender.build import IdTables, object_numbers  # noqa: E402
from durer.blender.export.depsgraph import export_depsgraph  # noqa: E402

pytestmark = pytest.mark.blender

#: Object name -> its Pass Index (all different, so IndexOB tells the objects apart).
OBJECT_INDEX = {"Floor": 0, "Ball": 3, "Twin": 4, "Egg": 11, "Box": 7, "Cloud": 5, "Bare": 9}
#: Material name -> its Pass Index; "Red" and "Red 6" differ only in it.
MATERIAL_INDEX = {"Grey": 2, "Red": 1, "Red 6": 6, "Blue": 8}


def index_scene(s):
    """A mesh sphere, its twin with a material alike but for its pass index, an ellipsoid (a
    sphere scaled unevenly), a cube (triangles), a point cloud (spheres), an object without a
    material, on a bounded floor; a sun, a black world."""
    world(s, (0, 0, 0))
    light(s, "SUN", energy=2.0, rotation=(0.5, 0.2, 0.3))
    mats = {name: material(name, color) for name, color in
            (("Grey", (0.6, 0.6, 0.6)), ("Red", (0.8, 0.1, 0.1)), ("Red 6", (0.8, 0.1, 0.1)), ("Blue", (0.1, 0.2, 0.8)))}
    for name, index in MATERIAL_INDEX.items():
        mats[name].pass_index = index
    floor = quad(s, "Floor", location=(0, 0, -1.0), scale=(5, 4, 1))
    ball = uv_sphere(s, "Ball", radius=0.9, location=(-2.2, 0.5, 0))
    twin = uv_sphere(s, "Twin", radius=0.6, location=(-0.6, -1.6, -0.4))
    egg = uv_sphere(s, "Egg", radius=0.5, location=(2.4, 1.5, 0), scale=(1.6, 0.8, 1.0))
    box = cube(s, "Box", size=1.2, location=(0.4, 1.2, -0.4), rotation=(0, 0, 0.5))
    rng = np.random.default_rng(7)
    cloud = pointcloud_object(s, "Cloud", np.column_stack([rng.uniform(1.2, 3.2, 12), rng.uniform(-2.5, -0.8, 12),
                                                           rng.uniform(-0.6, 0.4, 12)]), radius=0.3)
    bare = uv_sphere(s, "Bare", radius=0.5, location=(-2.6, -2.2, -0.5))
    for obj, mat in ((floor, "Grey"), (ball, "Red"), (twin, "Red 6"), (egg, "Blue"), (box, "Grey"), (cloud, "Blue")):
        obj.data.materials.append(mats[mat])
    for obj in (floor, ball, twin, egg, box, cloud, bare):
        obj.pass_index = OBJECT_INDEX[obj.name]
    aim_camera(s, (1, -9, 7))
    s.render.resolution_x, s.render.resolution_y = 96, 72


def away_from_edges(ids: np.ndarray) -> np.ndarray:
    """Pixels whose 3x3 neighbourhood holds one id (the mask of each id eroded by a pixel)."""
    h, w = ids.shape
    pad = np.pad(ids, 1, mode="edge")
    same = np.ones((h, w), bool)
    for dy in range(3):
        for dx in range(3):
            same &= pad[dy : dy + h, dx : dx + w] == ids
    return same


@pytest.mark.parametrize("samples", [1, 4])
def test_index_passes_equal_cycles_away_from_edges(scene, tmp_path, samples):
    index_scene(scene)
    use_cycles(scene, samples=samples)
    cycles = render_passes(scene, tmp_path / "cycles.exr", normal=False, indexes=True)
    scene.render.engine = "DURER"
    scene.durer.samples = samples
    durer_ = render_passes(scene, tmp_path / "durer.exr", normal=False, indexes=True)
    assert engine.last_render.error is None
    for name, table in (("IndexOB", OBJECT_INDEX), ("IndexMA", MATERIAL_INDEX)):
        c, d = cycles[name], durer_[name]
        assert set(np.unique(c)) == {0, *table.values()}, name  # every index is seen
        compared = away_from_edges(cycles["IndexOB"] * 100 + cycles["IndexMA"])
        assert compared.mean() > 0.75, name  # measured: 82.9 %
        np.testing.assert_array_equal(d[compared], c[compared], err_msg=name)
        # On edges the two may differ (Cycles' first sample against Dürer's nearest), but only there.
        assert (d != c).mean() < 0.05, name  # measured: 0.1 % at 1 sample, 2.1-2.4 % at 4
    # The compared pixels include the world seen past the floor: 0 in both, as nothing is hit.
    assert (compared & (cycles["depth"] > 1e9)).sum() > 100


@pytest.mark.parametrize("crop", [False, True])
def test_index_passes_of_a_render_region_equal_cycles(scene, tmp_path, crop):
    index_scene(scene)
    r = scene.render
    r.use_border, r.use_crop_to_border = True, crop
    r.border_min_x, r.border_max_x, r.border_min_y, r.border_max_y = 0.13, 0.71, 0.27, 0.88
    use_cycles(scene)
    cycles = render_passes(scene, tmp_path / "cycles.exr", depth=False, normal=False, indexes=True)
    scene.render.engine = "DURER"
    durer_ = render_passes(scene, tmp_path / "durer.exr", depth=False, normal=False, indexes=True)
    for name in ("IndexOB", "IndexMA"):
        assert durer_[name].shape == cycles[name].shape == ((44, 56) if crop else (72, 96))
        compared = away_from_edges(cycles["IndexOB"] * 100 + cycles["IndexMA"])
        np.testing.assert_array_equal(durer_[name][compared], cycles[name][compared], err_msg=name)
        assert len(np.unique(cycles[name][compared])) >= 4


def test_instances_take_the_pass_index_cycles_gives_them(scene, tmp_path):
    """Geometry-nodes instances (of a sphere: exported in bulk; of a cube: a mesh each) show their
    instancer's Pass Index, collection instances the instanced object's, in Cycles and Dürer alike."""
    world(scene, (0, 0, 0))
    light(scene, "SUN", energy=2.0, rotation=(0.5, 0.2, 0.3))
    rng = np.random.default_rng(3)
    for instanced, instancer, make, x0 in (("Ball", "Points", uv_sphere, -3.0), ("Box", "Points 2", cube, 0.0)):
        shape = make(scene, instanced, 0.3)
        shape.hide_render = shape.hide_viewport = True
        points = point_cloud.vertex_object(scene.collection, instancer, rng.uniform(0, 3, (10, 3)) * (1, 1, 0.2) + (x0, 0, 0))
        point_cloud.instance_on_points(points, shape)
        shape.pass_index, points.pass_index = (3, 5) if instanced == "Ball" else (7, 9)
    collection = bpy.data.collections.new("Balls")
    ball = uv_sphere(scene, "Ball 2", radius=0.5)
    scene.collection.objects.unlink(ball)
    collection.objects.link(ball)
    ball.pass_index = 4
    for i in range(3):
        empty = link(scene, bpy.data.objects.new(f"Empty {i}", None))
        empty.instance_type, empty.instance_collection = "COLLECTION", collection
        empty.location, empty.pass_index = (-3 + 2.5 * i, 3, 0), 8
    aim_camera(scene, (0, -2, 12))
    scene.render.resolution_x, scene.render.resolution_y = 96, 72
    use_cycles(scene)
    cycles = render_passes(scene, tmp_path / "cycles.exr", normal=False, indexes=True)["IndexOB"]
    scene.render.engine = "DURER"
    durer_ = render_passes(scene, tmp_path / "durer.exr", normal=False, indexes=True)["IndexOB"]
    assert set(np.unique(cycles)) == {0, 4, 5, 9}
    compared = away_from_edges(cycles)
    np.testing.assert_array_equal(durer_[compared], cycles[compared])
    assert set(np.unique(cycles[compared])) == {0, 4, 5, 9}
    assert (compared & (cycles > 0)).sum() > 200  # measured: 304 of the objects' 916 pixels are inside ones


def saved_object_ids(metadata: dict) -> dict[int, str]:
    """The Object ID table an image's metadata (an EXR header, a PNG's text) holds."""
    return {int(number): name for number, name in json.loads(metadata[engine.OBJECT_IDS_FIELD]).items()}


def test_object_id_numbers_objects_by_name_and_saves_its_table_with_the_image(scene, tmp_path):
    """The objects that can be rendered are numbered in the order of their names (not the camera
    nor the light); the table is last_render.object_ids, and the EXR's header and a PNG's text
    carry it too."""
    index_scene(scene)
    scene.view_layers[0].durer.use_pass_object_id = True
    out = render_passes(scene, tmp_path / "durer.exr", normal=False, indexes=True)
    names = engine.last_render.object_ids
    assert names == dict(enumerate(sorted(OBJECT_INDEX), 1))
    object_id = read_exr(tmp_path / "durer.exr")[f"{scene.view_layers[0].name}.Object ID.X"]
    # Object ID n is names[n]: the same pixels as that object's Pass Index in IndexOB.
    expected = np.array([0] + [OBJECT_INDEX[names[n]] for n in sorted(names)], np.float32)[object_id.astype(int)]
    np.testing.assert_array_equal(out["IndexOB"], expected)
    assert set(np.unique(object_id)) == {0, *names}
    assert saved_object_ids(read_exr_headers(tmp_path / "durer.exr")[0]) == names  # the first part's (Combined)
    settings = scene.render.image_settings
    settings.media_type, settings.file_format = "IMAGE", "PNG"
    scene.render.filepath = str(tmp_path / "durer.png")
    assert bpy.ops.render.render(write_still=True) == {"FINISHED"}
    with Image.open(tmp_path / "durer.png") as png:
        assert saved_object_ids(png.text) == names


def rock_library(s, path) -> bpy.types.Collection:
    """Collection "Rocks" of a library file `path`, linked: it holds object "Rock" (a sphere at
    x = -1, Pass Index 5, a material of Pass Index 2), which this file never had."""
    rock = uv_sphere(s, "Rock", radius=0.6, location=(-1, 0, 0))
    rock.pass_index = 5
    rock.data.materials.append(material("Moss", (0.2, 0.8, 0.2)))
    rock.data.materials[0].pass_index = 2
    rocks = bpy.data.collections.new("Rocks")
    rocks.objects.link(rock)
    bpy.data.libraries.write(str(path), {rocks})
    bpy.data.objects.remove(rock)
    bpy.data.collections.remove(rocks)
    with bpy.data.libraries.load(str(path), link=True) as (_, linked):
        linked.collections = ["Rocks"]
    return linked.collections[0]


def local_rock(s) -> bpy.types.Object:
    """A local object "Rock" at x = -3, Pass Index 9, a material of Pass Index 4."""
    rock = uv_sphere(s, "Rock", radius=0.6, location=(-3, 0, 0))
    rock.pass_index = 9
    rock.data.materials.append(material("Rust", (0.8, 0.2, 0.1)))
    rock.data.materials[0].pass_index = 4
    return rock


def test_objects_of_one_name_in_a_file_and_its_library_are_told_apart(scene, tmp_path):
    """A local "Rock", the library's "Rock" (linked into the scene, and instanced by an empty) and a
    library override of it (a local copy Blender names "Rock.001"): three objects, by `name_full`."""
    rocks = rock_library(scene, tmp_path / "rocks.blend")
    local_rock(scene)
    link(scene, rocks.objects[0])
    empty = link(scene, bpy.data.objects.new("Rocks", None))
    empty.instance_type, empty.instance_collection, empty.location = "COLLECTION", rocks, (2, 0, 0)
    override = rocks.override_hierarchy_create(scene, bpy.context.view_layer).objects[0]
    override.location = (3, 0, 0)
    data = export(scene)
    assert {o.name: o.pass_index for o in data.objects} == {"Rock": 9, "Rock [rocks.blend]": 5, "Rock.001": 5}
    assert data.sources == {"Rock": 1, "Rock [rocks.blend]": 2, "Rock.001": 1}
    assert list(object_numbers(bpy.data.objects, data)) == ["Rock", "Rock [rocks.blend]", "Rock.001", "Rocks"]


def test_objects_of_one_name_keep_their_own_indices_and_ids(scene, tmp_path):
    """A local "Rock" and one linked from a library: each its own Object and Material Index, as in
    Cycles, and its own Object ID, which names it with its library."""
    world(scene, (0, 0, 0))
    light(scene, "SUN", energy=2.0, rotation=(0.3, 0.2, 0.1))
    link(scene, rock_library(scene, tmp_path / "rocks.blend").objects[0])
    local_rock(scene)
    aim_camera(scene, (-2, -6, 0), (-2, 0, 0))
    use_cycles(scene)
    cycles = render_passes(scene, tmp_path / "cycles.exr", depth=False, normal=False, indexes=True)
    scene.render.engine = "DURER"
    scene.view_layers[0].durer.use_pass_object_id = True
    durer_ = render_passes(scene, tmp_path / "durer.exr", depth=False, normal=False, indexes=True)
    compared = away_from_edges(cycles["IndexOB"])
    for name in ("IndexOB", "IndexMA"):
        np.testing.assert_array_equal(durer_[name][compared], cycles[name][compared], err_msg=name)
    counts = dict(zip(*np.unique(durer_["IndexOB"], return_counts=True)))
    assert counts.keys() == {0, 5, 9} and abs(counts[5] - counts[9]) <= 4  # two spheres alike
    object_id = read_exr(tmp_path / "durer.exr")[f"{scene.view_layers[0].name}.Object ID.X"]
    named = {name: number for number, name in engine.last_render.object_ids.items()}
    for index, name in ((9, "Rock"), (5, "Rock [rocks.blend]")):
        assert set(np.unique(object_id[durer_["IndexOB"] == index])) == {named[name]}


def test_object_ids_stay_the_same_over_an_animation_rendered_from_the_command_line(scene, tmp_path):
    """Three balls, the first hidden on frame 2 (hide_render keyframed): each keeps its Object ID
    on every frame `python -m durer render` writes, and each frame's own header decodes the ids."""
    world(scene, (0, 0, 0))
    for i in range(3):
        ball = uv_sphere(scene, f"Ball {i + 1}", radius=0.4, location=(1.0 * i - 1, 0, 0))
        ball.pass_index = 10 + i
    first = bpy.data.objects["Ball 1"]
    for frame, hidden in ((1, False), (2, True), (3, False)):
        first.hide_render = hidden
        first.keyframe_insert("hide_render", frame=frame)
    aim_camera(scene, (0, -6, 0))
    scene.render.resolution_x, scene.render.resolution_y = 48, 24
    layer = scene.view_layers[0]
    layer.use_pass_object_index = layer.durer.use_pass_object_id = True
    settings = scene.render.image_settings
    settings.media_type, settings.file_format, settings.exr_codec = "MULTI_LAYER_IMAGE", "OPEN_EXR_MULTILAYER", "NONE"
    blend = tmp_path / "balls.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend))
    assert batch.main([str(blend), "-q", "--frames", "1-3", "-o", str(tmp_path / "f_####.exr")]) == 0
    pass_index = {f"Ball {i + 1}": 10 + i for i in range(3)}
    seen = {}
    for frame in (1, 2, 3):
        path = tmp_path / f"f_{frame:04d}.exr"
        names = saved_object_ids(read_exr_headers(path)[0])
        assert names == {1: "Ball 1", 2: "Ball 2", 3: "Ball 3"}
        passes = read_exr(path)
        object_id, object_index = passes["ViewLayer.Object ID.X"], passes["ViewLayer.Object Index.X"]
        hit = object_id > 0
        decoded = np.array([pass_index[names[n]] for n in object_id[hit].astype(int)], np.float32)
        np.testing.assert_array_equal(decoded, object_index[hit])
        seen[frame] = set(np.unique(object_id[hit]))
    assert seen == {1: {1, 2, 3}, 2: {2, 3}, 3: {1, 2, 3}}


def test_export_keeps_pass_indices_and_tables_map_core_ids(scene):
    """The export carries each object's and material's pass index (two materials alike but for it
    stay two); IdTables maps the core's ids to them in make_scene's order."""
    index_scene(scene)
    data = export_depsgraph(bpy.context.evaluated_depsgraph_get())
    by_name = {o.name: o.pass_index for o in data.objects}
    assert by_name == OBJECT_INDEX
    assert sorted(data.material_pass_indices) == sorted([0, *MATERIAL_INDEX.values()])  # 0: "Bare"'s
    tables = IdTables.of(data, object_numbers(bpy.data.objects, data))
    owners = np.array([[o.name for o in data.objects].index("Cloud")] * 12)
    np.testing.assert_array_equal(data.sphere_owners[data.sphere_owners == owners[0]], owners)
    objects = data.sphere_count + data.ellipsoid_count + len(data.planes) + len(data.meshes)
    assert len(tables.object_pass_index) == len(tables.object_number) == objects + 1
    assert sorted(set(tables.object_pass_index[1:])) == sorted(OBJECT_INDEX.values())
    np.testing.assert_array_equal(IdTables.lookup(tables.material_pass_index, np.array([-1, 0])), [0, 0])


def test_the_index_panel_and_the_passes_the_compositor_offers(scene):
    assert bpy.types.DURER_PT_index_passes.bl_parent_id == "VIEWLAYER_PT_layer_passes"
    tree = bpy.data.node_groups.new("Compositing", "CompositorNodeTree")
    scene.compositing_node_group = tree
    node = tree.nodes.new("CompositorNodeRLayers")
    node.scene = scene

    def offered():
        return {name for name, _, _, _ in engine.INDEX_PASSES if name in node.outputs and node.outputs[name].enabled}

    layer = scene.view_layers[0]
    assert offered() == set()
    layer.use_pass_object_index = True
    assert offered() == {"Object Index"}
    layer.durer.use_pass_object_id = True
    assert offered() == {"Object Index", "Object ID"}
    layer.use_pass_object_index = False
    layer.use_pass_material_index = True
    assert offered() == {"Material Index", "Object ID"}
