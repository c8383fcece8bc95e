"""Instances of sphere-shaped meshes exported in bulk, not one Python step per instance (100,000
instanced UV spheres: ~6 s one at a time, 0.3 s so). Geometry-nodes instancers are read whole from
Blender's instance arrays when the walk meets them (`take_instancer`); other instances (collection
instances, vertex instancing, particles) leave only their matrices, and each instanced mesh's
spheres are computed at once at the end (`take`, `finish`). The walk still steps through every
instance, so `skips` lets it pass those it has nothing more to do for with the fewest reads of
Blender's data: an instancer's, and a particle system's once one of its particles was taken."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import bpy
import numpy as np

from .builder import Builder
from .materials import object_materials
from .matrices import are_invertible
from .attribute_colors import read_values
from .shapes import MeshShape, cloud_points, mesh_key, mesh_shape


@dataclass
class _Cloud:
    """A point cloud that geometry-nodes instances reference: its points (object space)."""

    positions: np.ndarray  # (N, 3)
    radii: np.ndarray  # (N,), > 0
    colors: np.ndarray | None = None  # (N, 3) kd from the cloud's own attributes, if its material reads some
    kind: str = "points"


class _Matrices:
    """4x4 matrices copied as the walk meets them (an instance's own is valid only until the next
    step), in a float32 array that doubles as it fills: Blender's matrices are float32."""

    def __init__(self) -> None:
        self.array = np.empty((64, 4, 4), np.float32)
        self.count = 0

    def add(self, matrix) -> None:
        if self.count == len(self.array):
            self.array = np.concatenate([self.array, np.empty_like(self.array)])
        self.array[self.count] = matrix  # mathutils' buffer: one copy, no Python row objects
        self.count += 1

    def rows(self) -> np.ndarray:
        """The matrices' top three rows, (N, 3, 4) float64."""
        return self.array[: self.count, :3, :].astype(np.float64)


@dataclass
class _Batch:
    owner: int  # the instanced object's index in SceneData.objects
    shape: MeshShape | None  # None: not a sphere, exported one instance at a time
    material: int = 0
    matrices: _Matrices = field(default_factory=_Matrices)


#: Object type -> the component of its evaluated geometry that is the object itself; Blender's walk
#: gives the other components as instances of it.
_OWN_COMPONENT = {"MESH": "mesh", "POINTCLOUD": "pointcloud", "CURVES": "curves", "VOLUME": "volume",
                  "GREASEPENCIL": "grease_pencil"}


def _instances_alone(obj) -> tuple[Any, Any, list] | None:
    """(the evaluated geometry, its instances' point cloud, their references) of an object whose
    geometry nodes make instances and nothing beside them that the walk would meet as instances of
    it too; else None. The cloud and the references' data live as long as the geometry set and
    the references do."""
    original = obj.original or obj
    if not any(modifier.type == "NODES" for modifier in getattr(original, "modifiers", ())):
        return None
    try:
        geometry = bpy.types.GeometrySet.from_evaluated_object(obj)
    except TypeError:  # an object type without geometry
        return None
    cloud = geometry.instances_pointcloud()
    if cloud is None or len(cloud.points) == 0:
        return None
    own = _OWN_COMPONENT.get(obj.type)
    if any(getattr(geometry, part) is not None for part in _OWN_COMPONENT.values() if part != own):
        return None
    return geometry, cloud, list(geometry.instance_references())


def _instance_matrices(cloud) -> tuple[np.ndarray, np.ndarray]:
    """Each instance's matrix in its instancer's space ((N, 4, 4), float64) and reference index, from
    Blender's arrays."""
    n = len(cloud.points)
    values = np.empty(n * 16, np.float32)
    cloud.attributes["instance_transform"].data.foreach_get("value", values)
    index = np.zeros(n, np.int32)
    if ".reference_index" in cloud.attributes:
        cloud.attributes[".reference_index"].data.foreach_get("value", index)
    return values.reshape(n, 4, 4).transpose(0, 2, 1).astype(np.float64), index  # stored by column


#: Instances nested deeper than this are left to the walk (Blender records four levels of instance
#: attributes: DupliObject.instance_data).
_MOST_NESTED = 4


@dataclass
class _Leaves:
    """Instances flattened through nested instances to what they finally place (meshes, point
    clouds): each one's matrix in the instancer's space, its reference among `references`, and for
    each instance level met on the way, innermost first for any one instance, the level's instances
    (a point cloud), which of them each instance comes from (-1: not under it) and its depth."""

    matrices: np.ndarray  # (L, 4, 4)
    index: np.ndarray  # (L,)
    references: list
    levels: list[tuple[Any, np.ndarray, int]]  # and each level's depth (the instancer's own: 1)
    held: list = field(default_factory=list)  # the nested geometry sets read: their data lives as long


def _leaves(cloud, references: list, depth: int = 1) -> _Leaves | None:
    """The instances of `cloud` (whose references are `references`) flattened (`_Leaves`); None where
    a reference holds instances beside other geometry or nesting is deeper than `_MOST_NESTED`."""
    local, index = _instance_matrices(cloud)
    parts: list[_Leaves] = []
    for r, reference in enumerate(references):
        chosen = np.flatnonzero(index == r)
        if not len(chosen):
            continue
        inner = reference.instances_pointcloud() if isinstance(reference, bpy.types.GeometrySet) else None
        if inner is None:  # what it places
            parts.append(_Leaves(local[chosen], np.zeros(len(chosen), np.int32), [reference], [(cloud, chosen, depth)]))
            continue
        if depth == _MOST_NESTED or any(getattr(reference, part) is not None for part in _OWN_COMPONENT.values()):
            return None
        below = _leaves(inner, list(reference.instance_references()), depth + 1)
        if below is None:
            return None
        count = len(below.index)  # each chosen instance of this level places all of them
        parts.append(_Leaves((local[chosen][:, None] @ below.matrices[None]).reshape(-1, 4, 4),
                             np.tile(below.index, len(chosen)), below.references,
                             [(c, np.tile(at, len(chosen)), d) for c, at, d in below.levels]
                             + [(cloud, np.repeat(chosen, count), depth)], [reference, *below.held]))
    return _join_leaves(parts)


def _join_leaves(parts: list[_Leaves]) -> _Leaves:
    """The instances of `parts` in one `_Leaves`: references renumbered, each level's instances (one
    array per level, a level met in several parts) spread to all, the deepest levels first: an
    instance has one level at each depth it passes, so that is innermost first for every instance."""
    total = sum(len(p.index) for p in parts)
    matrices, index, references, held, start = [], [], [], [], 0
    levels: dict[int, tuple[Any, np.ndarray, int]] = {}  # by the level's pointer (all held: none reused)
    for part in parts:
        matrices.append(part.matrices)
        index.append(part.index + len(references))
        references += part.references
        held += part.held
        for level, at, depth in part.levels:
            full = levels.setdefault(level.as_pointer(), (level, np.full(total, -1, np.int64), depth))[1]
            full[start:start + len(at)] = at
        start += len(part.index)
    return _Leaves(np.concatenate(matrices) if matrices else np.zeros((0, 4, 4)),
                   np.concatenate(index).astype(np.int32) if index else np.zeros(0, np.int32), references,
                   sorted(levels.values(), key=lambda level: -level[2]), held)


class _LevelAttributes:
    """The instance attributes an Attribute node of type Instancer reads for each of `levels`'
    instances, as Cycles finds them (Blender's find_geonode_attribute_rgba): the innermost level that
    has the attribute. Read as `read_values` reads a point cloud's: .attributes.get(name) with
    data_type, domain and data.foreach_get."""

    def __init__(self, levels: list[tuple[Any, np.ndarray, int]], n: int) -> None:
        self.levels, self.n = levels, n
        self.points = range(n)  # len(): the instances, as a point cloud's points
        self.attributes = self

    def get(self, name: str):
        found = [(level, at) for level, at, _ in self.levels if name in level.attributes]
        return None if not found else _LevelAttribute(name, found, self.n)


@dataclass
class _LevelAttribute:
    name: str
    found: list  # (level, which of its instances each instance comes from), innermost first
    n: int
    data_type: str = "FLOAT_COLOR"  # every type read as RGBA (read_values' conversions)
    domain: str = "POINT"

    @property
    def data(self) -> _LevelAttribute:
        return self

    def foreach_get(self, _field: str, out: np.ndarray) -> None:
        rgba = np.zeros((self.n, 4), np.float32)
        done = np.zeros(self.n, bool)
        for level, at in self.found:  # a level below which every instance found it is not read
            take = ~done & (at >= 0)
            if not take.any():
                continue
            values, _ = read_values(level.attributes, (("INSTANCER", self.name),), None,
                                    {"POINT": len(level.points)}, "INSTANCER")
            rgba[take] = values[("INSTANCER", self.name)][at[take]]
            done |= take
        out[:] = rgba.ravel()


class InstanceBatches:
    """The sphere instances seen in one depsgraph walk, by instanced mesh, object and settings."""

    def __init__(self, builder: Builder) -> None:
        self.builder = builder
        self.batches: dict[tuple, _Batch] = {}
        #: Objects whose geometry-nodes instances `take_instancer` made: the walk skips those instances.
        self.instancers: set[int] = set()
        #: Particle systems whose particles are all instances of one sphere-shaped object, to the
        #: batch that `take` gave the first of them: the rest only add their matrices (`skips`).
        self.particles: dict = {}

    def skips(self, inst) -> bool:
        """Whether the walk may pass instance `inst` now: made with its geometry-nodes instancer,
        or a particle of a system in `particles` (its matrix kept here, as `take` would)."""
        if self.instancers and inst.parent.as_pointer() in self.instancers:
            return True
        if not self.particles:
            return False
        batch = self.particles.get(inst.particle_system)  # structs hash and compare by pointer
        if batch is None:
            return False
        batch.matrices.add(inst.matrix_world)
        return True

    def take_instancer(self, obj) -> None:
        """At object `obj` itself (the walk meets it before its instances): if every instance its
        geometry nodes make is a mesh, its instances now, from Blender's own arrays of instance
        transforms (one foreach_get, not a matrix per instance), and `obj` remembered so that the
        walk skips those instances: spheres for sphere-shaped meshes and for point clouds' points,
        other meshes stored once with every instance's matrix. Anything else (collections, objects,
        curves, meshes detected as planes, mesh instances scaled flat) is left to the walk. The
        instances are read as Auto: `obj`'s Primitive is for its own geometry."""
        found = _instances_alone(obj)
        if found is None:
            return
        geometry, cloud, references = found  # kept: the cloud and the references' data live as long
        instances = cloud  # the instance attributes, by instance
        if any(isinstance(r, bpy.types.GeometrySet) and r.instances_pointcloud() is not None for r in references):
            leaves = _leaves(cloud, references)  # nested instances (a molecule's copies): what they place
            if leaves is None:
                return
            local, index, references = leaves.matrices, leaves.index, leaves.references
            instances = _LevelAttributes(leaves.levels, len(index))
            held = leaves.held  # noqa: F841 - kept: the nested clouds' data lives as long
        else:
            local, index = _instance_matrices(cloud)
        read = self._references(obj, references)
        if read is None:
            return
        kinds, mats, meshes = read
        world = np.array(obj.matrix_world, np.float64) @ local
        meshed = [i for i, (shape, _) in enumerate(kinds) if shape.kind == "triangles"]
        if meshed and not are_invertible(world[np.isin(index, meshed)]).all():
            return  # a mesh instance scaled flat: the walk puts it in world space
        # Instance attributes (an Attribute node of type Instancer) colour each instance's sphere.
        n = len(index)
        materials = np.array([material for _, material in kinds], np.int32)[index]
        sphere_mats = [mat if shape.kind == "sphere" else None for mat, (shape, _) in zip(mats, kinds)]
        colors = self.builder.attribute_colors(instances, sphere_mats, index if len(kinds) > 1 else None, materials,
                                               n, {"POINT": n}, where="INSTANCER")
        owner = self.builder.owner(obj)
        for i, (shape, material) in enumerate(kinds):
            chosen = index == i
            if not chosen.any():
                continue
            if shape.kind == "triangles":  # coloured by the mesh's own attributes, if at all
                self.builder.faces_left_out(obj.name_full, shape)
                self.builder.mesh_instances(obj, owner, shape.parts, meshes[i], list(meshes[i].materials),
                                            world[chosen], instances, chosen)
                continue
            if shape.kind == "points":
                self.builder.placed_spheres(owner, world[chosen][:, :3, :], shape.positions[None], shape.radii[None],
                                            material, None if shape.colors is None else shape.colors[None], points=True)
                continue
            self._add_spheres(owner, world[chosen][:, :3, :], shape, material,
                              None if colors is None else colors[chosen][:, None])
        self.instancers.add(obj.as_pointer())

    def _references(self, obj, references) -> tuple[list, list, list] | None:
        """(each reference's shape and Dürer material, its Blender material, its mesh or points)
        when every reference is a sphere or triangle mesh or a point cloud, read as Auto; else None
        (the walk takes the instances one at a time)."""
        kinds, mats, meshes = [], [], []
        for reference in references:
            if not isinstance(reference, bpy.types.GeometrySet) or reference.curves is not None:
                return None
            mesh, points = reference.mesh, reference.pointcloud
            if points is not None:
                if mesh is not None and len(mesh.polygons):  # faces beside the points: left to the walk
                    return None
                mat = points.materials[0] if len(points.materials) else None
                shape, data = self._cloud(points, mat), points
            elif mesh is not None:  # coloured by its own attributes: its triangles, not a sphere of one colour
                own = any(self.builder.reads_geometry(mat) for mat in mesh.materials)
                shape, data = self._shape(mesh, "MESH" if own else "AUTO", len(mesh.materials)), mesh
                if shape.kind not in ("sphere", "triangles"):
                    return None
            else:
                return None
            meshes.append(data)
            slot = shape.slot if shape.kind == "sphere" else 0
            mats.append(data.materials[slot] if len(data.materials) else None)
            kinds.append((shape, self.builder.material(mats[-1], obj)))
        return kinds, mats, meshes

    def take(self, inst, obj, original, mode: str) -> bool:
        """Keep instance `inst` (of mesh object `obj`, whose original is `original`) for `finish`
        if its mesh is a sphere; False if it is not (the caller exports it as before). The
        instance's data is only valid during the walk: what a batch needs of it is read now."""
        key = (mesh_key(obj.data), original.as_pointer() if original is not None else 0, mode)
        batch = self.batches.get(key)
        if batch is None:
            batch = self.batches[key] = self._batch(obj, mode)
        if batch.shape is None:
            return False
        batch.matrices.add(inst.matrix_world)
        system = inst.particle_system
        if system is not None and system not in self.particles:
            self._take_system(system, original, batch)
        return True

    def _take_system(self, system, original, batch: _Batch) -> None:
        """Particle system `system`'s later particles go to `batch` too if they are all instances
        of `original` (an object-rendered system whose object instances nothing itself); a
        collection-rendered system picks an object per particle, so its particles each take the
        walk's full step."""
        settings = system.settings
        instanced = settings.instance_object if settings.render_type == "OBJECT" else None
        if instanced is not None and instanced.original == original and not original.is_instancer:
            self.particles[system] = batch

    def _batch(self, obj, mode: str) -> _Batch:
        mats = object_materials(obj)
        shape = self._shape(obj.data, mode, len(mats))
        if shape.kind != "sphere":
            return _Batch(self.builder.owner(obj), None)
        mat = mats[shape.slot] if mats else None
        self.builder.uncolored(mat, f"the instances of '{obj.name_full}' are spheres of one colour each")
        return _Batch(self.builder.owner(obj), shape, self.builder.material(mat, obj))

    def _cloud(self, pc, mat) -> _Cloud:
        """Point cloud `pc`'s points of positive radius, with the kd its material `mat` reads from
        the cloud's own attributes (every instance of it takes the same)."""
        positions, radii = cloud_points(pc)
        keep = radii > 0
        n = len(radii)
        colors = None if mat is None else \
            self.builder.attribute_colors(pc, [mat], None, self.builder.material(mat, pc), n, {"POINT": n})
        return _Cloud(positions[keep].astype(np.float64), radii[keep].astype(np.float64),
                      None if colors is None else colors[keep])

    def _shape(self, me, mode: str, slot_count: int) -> MeshShape:
        key = (mesh_key(me), mode, slot_count)
        shape = self.builder.shape_cache.get(key)
        if shape is None:
            shape = self.builder.shape_cache[key] = mesh_shape(me, mode, (1.0, 1.0, 1.0), slot_count)
        return shape

    def finish(self) -> None:
        """Every batch's spheres: world-space spheres where an instance's matrix is a uniform scale
        times a rotation, ellipsoids (one transformed group each) where it is not."""
        for batch in self.batches.values():
            if batch.shape is not None and batch.matrices.count:
                self._add_spheres(batch.owner, batch.matrices.rows(), batch.shape, batch.material)

    def _add_spheres(self, owner: int, rows: np.ndarray, shape: MeshShape, material: int, colors=None) -> None:
        """The sphere of `shape` under each matrix (rows: (N, 3, 4)), with its kd (colors (N, 1, 3))."""
        self.builder.placed_spheres(owner, rows, np.asarray(shape.center, np.float64)[None, None],
                                    np.array([[shape.radius]]), material, colors)
