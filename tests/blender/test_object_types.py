"""Object kinds reaching the render in ways beside a plain object: hair strands, metaballs whose balls
are instanced, curves whose geometry nodes make only instances, and the Visibility settings of
collections and of objects met only as instances (what Dürer renders, warns, and how it compares
with Cycles)."""

from __future__ import annotations

import numpy as np
import pytest
from helpers.blender import (
    DEG,
    MISS,
    aim_camera,
    both,
    export,
    light,
    link,
    material,
    uv_sphere,
    vertex_object,
    world,
)

from helpers.blender_import import blender_module

bpy = blender_module("bpy")

from durer.blender import engine

pytestmark = pytest.mark.blender

VISIBILITY = ("Dürer renders every object as seen by every ray and lit by every light; it does not follow "
              "Object › Visibility or light linking for ")


def _particles(emitter, name: str, kind: str = "HAIR", count: int = 50):
    """A particle system on `emitter` as the Particles tab's + adds one (Hair: rendered as Path)."""
    modifier = emitter.modifiers.new(name, "PARTICLE_SYSTEM")
    settings = modifier.particle_system.settings
    settings.type, settings.count = kind, count
    return modifier, settings


def test_hair_particle_systems_drawn_as_strands_are_counted_as_skipped(scene):
    """Hair rendered as Path (the default for hair) is strands in Cycles; Dürer has no curve
    primitive: each such system is counted in the skipped-geometry warning, its emitter rendered.
    Hair rendered as objects, emitted particles and a system whose modifier is off for renders
    are not strands in Cycles' render: not counted (in the viewport, the modifier's viewport
    toggle decides)."""
    _, beads = _particles(uv_sphere(scene, "Beaded", location=(-3, 0, 0)), "Beads")
    beads.render_type, beads.instance_object = "OBJECT", uv_sphere(scene, "Bead", radius=0.05)
    _, emitted = _particles(uv_sphere(scene, "Emitter", location=(0, 3, 0)), "Sparks", kind="EMITTER")
    emitted.render_type = "PATH"
    assert not export(scene).skipped
    hairy = uv_sphere(scene, "Hairy")
    _particles(hairy, "Hair")
    _particles(hairy, "Fuzz")  # a second system on the same object: counted too
    assert hairy.particle_systems[0].settings.render_type == "PATH"
    shaved = uv_sphere(scene, "Shaved", location=(3, 0, 0))
    modifier, _ = _particles(shaved, "Hair")
    modifier.show_render = False
    d = export(scene)
    assert d.skipped == {"hair particle system": 3}  # the viewport shows Shaved's hair
    assert bpy.ops.render.render() == {"FINISHED"}
    assert engine.last_render.warnings == ["Dürer skipped geometry it cannot render: 2 hair particle system"]


def test_holdout_and_indirect_only_set_on_a_collection_are_reported(scene):
    """Holdout and Indirect Only on a view layer's collection (Cycles' holdout hole and
    indirect-only objects) are said like an object's own holdout, naming the objects."""
    world(scene, (0.2, 0.2, 0.2))
    aim_camera(scene, (0, -10, 0))
    held, indirect = bpy.data.collections.new("Held"), bpy.data.collections.new("Indirect")
    for i, collection in enumerate((held, indirect)):
        scene.collection.children.link(collection)
        ball = uv_sphere(scene, f"In {collection.name}", location=(3 * i, 0, 0))
        scene.collection.objects.unlink(ball)
        collection.objects.link(ball)
    uv_sphere(scene, "Own", location=(-3, 0, 0)).is_holdout = True
    layer = bpy.context.view_layer.layer_collection
    layer.children["Held"].holdout = True
    layer.children["Indirect"].indirect_only = True
    assert bpy.ops.render.render() == {"FINISHED"}
    assert engine.last_render.warnings == [f"{VISIBILITY}'In Held', 'Own' a holdout; 'In Indirect' indirect only"]


def test_visibility_of_objects_rendered_only_as_instances_is_reported(scene):
    """A ball instanced on its parent's vertices (a molecule importer's atoms) hidden from the
    camera, an object of an excluded collection instanced by empties hidden from the camera and a
    shadow catcher: Cycles follows each in every copy (an instance's ray visibility is its own
    object's and its instancer's); Dürer does not, and says so. An instanced object's own holdout
    Cycles does not follow (it takes its instancer's): not said."""
    carbon = vertex_object(scene, "Carbon", [(-2, 0, 0), (2, 0, 0)])
    carbon.instance_type = "VERTS"
    ball = uv_sphere(scene, "Ball", radius=0.5)
    ball.parent = carbon
    ball.visible_camera = False
    proto = bpy.data.collections.new("Proto")
    scene.collection.children.link(proto)
    for name in ("Atom", "Held"):
        atom = uv_sphere(scene, name, location=(0, 0, 3))
        scene.collection.objects.unlink(atom)
        proto.objects.link(atom)
    bpy.data.objects["Atom"].visible_camera = False
    bpy.data.objects["Atom"].is_shadow_catcher = True
    bpy.data.objects["Held"].is_holdout = True
    bpy.context.view_layer.layer_collection.children["Proto"].exclude = True
    for i in range(2):
        empty = link(scene, bpy.data.objects.new(f"Copy {i}", None))
        empty.instance_type, empty.instance_collection = "COLLECTION", proto
        empty.location = (4 * i, 3, 0)
    assert bpy.ops.render.render() == {"FINISHED"}
    assert engine.last_render.spheres == 6
    assert engine.last_render.warnings == [
        f"{VISIBILITY}'Ball', 'Atom' hidden from the camera; 'Atom' a shadow catcher"]


def _metaball_scene(scene, how: str):
    """A metaball (made as Add › Metaball › Ball makes it) instanced as Atomic Blender instances its
    atoms (on a parent's vertices) or by a particle system, lit and seen from the front; and a
    family of its own, not instanced, beside them."""
    world(scene, (0.05, 0.05, 0.05))
    scene.render.resolution_x, scene.render.resolution_y = 96, 72
    cam = aim_camera(scene, (0, -10, 0)).data
    cam.type, cam.ortho_scale = "ORTHO", 9.0
    light(scene, "SUN", energy=2.0, rotation=(60 * DEG, 0, 25 * DEG))
    bpy.ops.object.metaball_add(type="BALL", location=(0, 0, 0))
    ball = bpy.context.view_layer.objects.active
    ball.name = "Ball_Carbon"
    ball.data.render_resolution = 0.05
    ball.data.materials.append(material("Carbon", (0.5, 0.5, 0.5)))
    if how == "verts":
        carbon = vertex_object(scene, "Carbon", [(-2.5, 0, 1.5), (2.5, 0, 1.5), (0, 0, -2)])
        carbon.instance_type = "VERTS"
        ball.parent = carbon
        ball.scale = (0.8,) * 3
    else:
        bpy.ops.mesh.primitive_plane_add(size=6, location=(0, 0, 0), rotation=(90 * DEG, 0, 0))
        emitter = bpy.context.view_layer.objects.active
        emitter.show_instancer_for_render = emitter.show_instancer_for_viewport = False
        _, settings = _particles(emitter, "Atoms", kind="EMITTER", count=6)
        settings.frame_start = settings.frame_end = 1
        settings.physics_type, settings.emit_from, settings.use_emit_random = "NO", "FACE", False
        settings.render_type, settings.instance_object, settings.particle_size = "OBJECT", ball, 0.6
        ball.location = (0, 0, -3.8)
    bpy.ops.object.metaball_add(type="BALL", location=(3.5, 0, -3))
    solo = bpy.context.view_layer.objects.active
    solo.name, solo.pass_index = "Solo", 1
    scene.frame_set(1)


@pytest.mark.parametrize("how", ["verts", "particles"])
def test_metaballs_instanced_on_vertices_or_by_particles_render_as_in_cycles(scene, tmp_path, how):
    """Blender polygonizes a metaball family whole, balls instanced on vertices or by particles
    included, into its basis's mesh (the walk never meets those instances): Dürer renders that
    family as that mesh, no sphere for its balls (they would be doubles), and matches Cycles pixel
    for pixel (it drew the original ball alone); a family not instanced stays one sphere per ball."""
    _metaball_scene(scene, how)
    d = export(scene)
    assert [m.name for m in d.meshes] == ["Ball_Carbon"] and d.sphere_count == 1 and not d.warnings
    assert d.objects[d.sphere_owners[0]].name == "Solo"
    c, du = both(scene, tmp_path, normal=False, indexes=True)
    hit_c, hit_d = c["depth"] < MISS, du["depth"] < MISS
    assert (hit_c != hit_d).sum() <= 3, "hit masks agree but for silhouette pixels"
    error = np.abs(du["depth"] - c["depth"]) / c["depth"]
    family, solo = hit_c & hit_d & (c["IndexOB"] == 0), hit_c & hit_d & (c["IndexOB"] == 1)
    assert family.sum() > 500 and solo.sum() > 50
    assert error[family].max() <= 1e-5  # the same triangles
    assert np.median(error[solo]) <= 2e-3  # Dürer's sphere, Cycles' its tessellation


def _curve(scene, name: str, bevel: float = 0.0):
    """A poly curve of 4 points, as drawn with the Draw tool and set to 3D."""
    data = bpy.data.curves.new(name, "CURVE")
    data.dimensions, data.bevel_depth = "3D", bevel
    spline = data.splines.new("POLY")
    spline.points.add(3)
    for point, co in zip(spline.points, [(-4, 0, -1), (-1.5, 0, 2), (1.5, 0, -1), (4, 0, 2)]):
        point.co = (*co, 1)
    return link(scene, bpy.data.objects.new(name, data))


def _nodes(obj, make):
    """A geometry-nodes modifier on `obj` whose output is `make(group)`'s socket."""
    group = bpy.data.node_groups.new(obj.name, "GeometryNodeTree")
    group.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
    group.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    group.nodes.new("NodeGroupInput")
    group.links.new(make(group), group.nodes.new("NodeGroupOutput").inputs[0])
    obj.modifiers.new("Nodes", "NODES").node_group = group


def test_a_curve_whose_geometry_nodes_output_only_instances_is_not_skipped(scene):
    """Beads along a curve (Curve to Points, Instance on Points of a sphere object), the curve not
    in the output: the beads render, as in Cycles, and nothing is said to be skipped; a curve
    without bevel renders as nothing, in Cycles too: not skipped either; a volume its nodes output
    is counted once, as a volume."""
    bead = uv_sphere(scene, "Bead", radius=0.5)
    bead.hide_render = bead.hide_viewport = True

    def beads(group):
        points = group.nodes.new("GeometryNodeCurveToPoints")
        points.mode = "EVALUATED"
        group.links.new(group.nodes["Group Input"].outputs[0], points.inputs["Curve"])
        on_points = group.nodes.new("GeometryNodeInstanceOnPoints")
        info = group.nodes.new("GeometryNodeObjectInfo")
        info.inputs["Object"].default_value = bead
        info.inputs["As Instance"].default_value = True
        group.links.new(points.outputs["Points"], on_points.inputs["Points"])
        group.links.new(info.outputs["Geometry"], on_points.inputs["Instance"])
        return on_points.outputs[0]

    _nodes(_curve(scene, "Backbone"), beads)
    _curve(scene, "Wire")
    d = export(scene)
    assert d.sphere_count == 4 and not d.meshes and not d.skipped and not d.warnings
    _nodes(_curve(scene, "Cloud"), lambda group: group.nodes.new("GeometryNodeVolumeCube").outputs[0])
    assert export(scene).skipped == {"volume": 1}
