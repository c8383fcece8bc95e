"""`Builder`: collects what the depsgraph walk finds into a `SceneData` (spheres joined into one
array, materials deduplicated, meshes kept in object space)."""

from __future__ import annotations

import numpy as np

from .data import IDENTITY, MeshData, ObjectData, PlaneData, SceneData, TransformedSpheres
from .materials import material_data, object_materials
from .matrices import is_invertible, transform_points, uniform_scale
from .shapes import MeshShape
from .triangles import TrianglePart


class Builder:
    """One export's state: the `SceneData` being filled, sphere chunks to join at the end, the
    material ids given out (by Blender material and by value and pass index), the objects'
    indices (by name) and the shapes of meshes seen."""

    def __init__(self) -> None:
        self.data = SceneData()
        self.centers: list[np.ndarray] = []
        self.radii: list[np.ndarray] = []
        self.mats: list[np.ndarray] = []
        self.sphere_owners: list[np.ndarray] = []
        self.owners: dict[str, int] = {}
        self.material_ids: dict[tuple, int] = {}
        self.blender_materials: dict[int, int] = {}
        self.shape_cache: dict[tuple, MeshShape] = {}

    # materials
    def material(self, mat, obj) -> int:
        key_ptr = mat.as_pointer() if mat is not None else None
        if key_ptr is not None and key_ptr in self.blender_materials:
            return self.blender_materials[key_ptr]
        md = material_data(mat, obj)
        # Materials alike but for their pass index stay apart: the IndexMA pass tells them apart.
        pass_index = mat.pass_index if mat is not None else 0
        mid = self.material_ids.get((md.key, pass_index))
        if mid is None:
            mid = len(self.data.materials)
            self.material_ids[(md.key, pass_index)] = mid
            self.data.materials.append(md)
            self.data.material_pass_indices.append(pass_index)
        if key_ptr is not None:
            self.blender_materials[key_ptr] = mid
        return mid

    def object_material(self, obj) -> int:
        mats = object_materials(obj)
        return self.material(mats[0] if mats else None, obj)

    # objects
    def owner(self, obj) -> int:
        """The index of Blender object `obj` in SceneData.objects (added on first use)."""
        return self.owner_named(obj.name, obj.pass_index)

    def owner_named(self, name: str, pass_index: int) -> int:
        index = self.owners.get(name)
        if index is None:
            index = self.owners[name] = len(self.data.objects)
            self.data.objects.append(ObjectData(name, int(pass_index)))
        return index

    # geometry
    def spheres(self, owner: int, centers: np.ndarray, radii: np.ndarray, materials) -> None:
        n = len(radii)
        if n == 0:
            return
        self.centers.append(np.asarray(centers).reshape(n, 3))
        self.radii.append(np.asarray(radii).reshape(n))
        self.mats.append(np.broadcast_to(np.asarray(materials, dtype=np.int32), (n,)))
        self.sphere_owners.append(np.broadcast_to(np.int32(owner), (n,)))
        self.data.sources[self.data.objects[owner].name] += n

    def sphere(self, owner: int, m: np.ndarray, center, radius: float, material: int) -> None:
        """A sphere in object space: a world-space sphere under a uniform scale, else an ellipsoid."""
        center = np.asarray(center, dtype=np.float64).reshape(1, 3)
        s, uniform = uniform_scale(m)
        if s == 0.0:  # flattened to nothing: no surface to see
            return
        if uniform:
            self.spheres(owner, transform_points(m, center), np.array([radius * s]), material)
        else:
            self.transformed_spheres(owner, m, center, np.array([float(radius)]), material)

    def transformed_spheres(self, owner: int, m: np.ndarray, centers, radii, materials) -> None:
        n = len(radii)
        if n == 0:
            return
        materials = np.broadcast_to(np.asarray(materials, dtype=np.int32), (n,))
        name = self.data.objects[owner].name
        group = TransformedSpheres(name, owner, np.asarray(centers, np.float64), np.asarray(radii, np.float64),
                                   materials, m)
        self.data.transformed_spheres.append(group)
        self.data.sources[name] += n

    def triangles(self, obj, m: np.ndarray, parts: list[TrianglePart]) -> None:
        """A mesh's triangles in object space, one Dürer mesh per material slot used."""
        mats = object_materials(obj)
        owner = self.owner(obj)
        flat = not is_invertible(m)
        for part in parts:
            mat = mats[min(part.slot, len(mats) - 1)] if mats else None
            vertices, matrix = part.vertices, m
            if flat:  # the core needs an invertible transform: a mesh scaled flat goes in world space
                vertices, matrix = transform_points(m, vertices.astype(np.float64)), IDENTITY
            self.data.meshes.append(MeshData(obj.name, owner, vertices, part.faces, self.material(mat, obj), matrix))
            self.data.sources[obj.name] += 1

    def plane(self, owner: int, m: np.ndarray, shape: MeshShape, material: int, infinite: bool) -> None:
        corner = transform_points(m, shape.corner.reshape(1, 3))[0]
        e1 = m[:3, :3] @ shape.edge1
        e2 = m[:3, :3] @ shape.edge2
        normal = np.cross(e1, e2)
        length = float(np.linalg.norm(normal))
        if length == 0:
            return
        normal /= length
        if np.linalg.det(m[:3, :3]) < 0:
            normal = -normal
        bounds = None if infinite else (corner, e1, e2)
        name = self.data.objects[owner].name
        self.data.planes.append(PlaneData(name, owner, normal, float(normal @ corner), material, bounds))
        self.data.sources[name] += 1

    def finish(self) -> SceneData:
        d = self.data
        if self.centers:  # at most one copy into float64, however many objects contributed
            d.sphere_centers = _join(self.centers, np.float64)
            d.sphere_radii = _join(self.radii, np.float64)
            d.sphere_materials = _join(self.mats, np.int32)
            d.sphere_owners = _join(self.sphere_owners, np.int32)
        return d


def _join(chunks: list[np.ndarray], dtype) -> np.ndarray:
    if len(chunks) == 1:
        return np.ascontiguousarray(chunks[0], dtype=dtype)
    return np.concatenate(chunks, dtype=dtype)
