"""Point clouds as most Blender users make them: a mesh of loose vertices whose geometry-nodes
modifier "Mesh to Points" turns every vertex into a point of one radius. Dürer renders each point
as a sphere (Cycles too). For scripts, the tests and bench/::

    import durer.blender.point_cloud as point_cloud
    obj = point_cloud.point_cloud_object(bpy.context.scene.collection, "Cloud", positions, radius=0.02)
"""

from __future__ import annotations

import bpy
import numpy as np
from numpy.typing import ArrayLike


def vertex_object(collection: bpy.types.Collection, name: str, positions: ArrayLike) -> bpy.types.Object:
    """A mesh object of loose vertices at `positions` ((N, 3), object space), linked into `collection`."""
    co = np.ascontiguousarray(positions, dtype=np.float32)
    if co.ndim != 2 or co.shape[1] != 3:
        raise ValueError(f"positions must have shape (N, 3), got {co.shape}")
    mesh = bpy.data.meshes.new(name)
    mesh.vertices.add(len(co))
    mesh.vertices.foreach_set("co", co.ravel())
    obj = bpy.data.objects.new(name, mesh)
    collection.objects.link(obj)
    return obj


def mesh_to_points(obj: bpy.types.Object, radius: float) -> bpy.types.NodesModifier:
    """Give `obj` a geometry-nodes modifier that turns its mesh's vertices into points of `radius`."""
    group = bpy.data.node_groups.new(f"{obj.name} points", "GeometryNodeTree")
    group.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
    group.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    group_in, group_out = group.nodes.new("NodeGroupInput"), group.nodes.new("NodeGroupOutput")
    to_points = group.nodes.new("GeometryNodeMeshToPoints")
    to_points.inputs["Radius"].default_value = radius
    group.links.new(group_in.outputs[0], to_points.inputs["Mesh"])
    group.links.new(to_points.outputs[0], group_out.inputs[0])
    modifier = obj.modifiers.new("Points", "NODES")
    modifier.node_group = group
    return modifier


def point_cloud_object(
    collection: bpy.types.Collection, name: str, positions: ArrayLike, radius: float = 0.05
) -> bpy.types.Object:
    """A point cloud of spheres of `radius` at `positions` ((N, 3), object space): a vertex mesh
    object through `mesh_to_points`, linked into `collection`."""
    obj = vertex_object(collection, name, positions)
    mesh_to_points(obj, radius)
    return obj


def instance_on_points(obj: bpy.types.Object, instance: bpy.types.Object, rotate: bool = True,
                       scale: tuple[float, float] = (1.0, 1.0), seed: int = 0) -> bpy.types.NodesModifier:
    """Give `obj` a geometry-nodes modifier that puts an instance of `instance` (its geometry, as
    an Object Info node gives it) on each of its mesh's vertices, as scatter setups do: a random
    rotation if `rotate`, a uniform random scale in `scale` (seeded)."""
    group = bpy.data.node_groups.new(f"{obj.name} instances", "GeometryNodeTree")
    group.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
    group.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    nodes, links = group.nodes, group.links
    group_in, group_out = nodes.new("NodeGroupInput"), nodes.new("NodeGroupOutput")
    on_points = nodes.new("GeometryNodeInstanceOnPoints")
    info = nodes.new("GeometryNodeObjectInfo")
    info.inputs["Object"].default_value = instance
    links.new(group_in.outputs[0], on_points.inputs["Points"])
    links.new(info.outputs["Geometry"], on_points.inputs["Instance"])
    if rotate:
        angles = nodes.new("FunctionNodeRandomValue")
        angles.data_type = "FLOAT_VECTOR"
        angles.inputs["Max"].default_value = (6.2832, 6.2832, 6.2832)
        angles.inputs["Seed"].default_value = seed
        links.new(angles.outputs["Value"], on_points.inputs["Rotation"])
    if scale != (1.0, 1.0):
        size = nodes.new("FunctionNodeRandomValue")
        size.data_type = "FLOAT"
        size.inputs[2].default_value, size.inputs[3].default_value = scale  # Min, Max of the FLOAT variant
        size.inputs["Seed"].default_value = seed + 1
        links.new(size.outputs[1], on_points.inputs["Scale"])
    links.new(on_points.outputs[0], group_out.inputs[0])
    modifier = obj.modifiers.new("Instances", "NODES")
    modifier.node_group = group
    return modifier
