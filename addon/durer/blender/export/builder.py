"""`Builder`: collects what the depsgraph walk finds into a `SceneData` (spheres joined into one
array, materials deduplicated, meshes kept in object space but a smooth mesh of one user under a
non-uniform scale, turned into world space as Cycles does)."""

from __future__ import annotations

from collections import Counter

import numpy as np

from ..._checks import is_invertible
from .attribute_colors import ColorSource, Unmapped, color_source, part_colors, read_values
from .data import IDENTITY, MeshData, ObjectData, PlaneData, SceneData, TransformedSpheres
from .materials import layers_beyond_diffuse, material_data, object_materials
from .matrices import transform_points, uniform_scale, uniform_scales
from .shapes import MeshShape
from .triangles import TrianglePart


class _Singles:
    """Spheres given one at a time (an object each: sphere meshes, empties, metaball balls) in a
    row of the walk, kept as given and placed all at once at `Builder.finish`: numpy's cost per
    call is what a scene of many objects would pay."""

    def __init__(self) -> None:
        self.owners: list[int] = []
        self.matrices: list[np.ndarray] = []
        self.centers: list[np.ndarray] = []
        self.radii: list[float] = []
        self.materials: list[int] = []


#: A unit normal's component below this is float32 rounding (Blender's matrices), not a tilt.
ROUNDED_ZERO = 8 * float(np.finfo(np.float32).eps)


class Builder:
    """One export's state: the `SceneData` being filled, sphere chunks to join at the end, the
    material ids given out (by Blender material and by value and pass index), the objects'
    indices (by unique name) and the shapes of meshes seen."""

    def __init__(self) -> None:
        self.data = SceneData()
        self.centers: list[np.ndarray] = []
        self.radii: list[np.ndarray] = []
        self.mats: list[np.ndarray] = []
        self.sphere_owners: list[np.ndarray] = []
        self.owners: dict[str, int] = {}
        self.colors: list[np.ndarray | None] = []  # per sphere chunk: attribute kd, or None
        self.sides: list[bool] = []  # per sphere chunk: whether its spheres are one-sided (a point cloud's)
        self.material_ids: dict[tuple, int] = {}
        self.blender_materials: dict[int, int] = {}
        self.shape_cache: dict[tuple, MeshShape] = {}
        self.metaball_bases: dict[str, object] = {}  # each metaball family's basis (the walk sets it)
        self.color_sources: dict[int, ColorSource | None] = {}  # by Blender material pointer
        self.fallbacks: set[str] = set()  # materials whose attribute colours were not used, noted once
        # Spheres left out for a position or radius not finite, by object (noted at finish, summed).
        self.nonfinite: Counter[str] = Counter()
        self.mesh_colors: dict[tuple, tuple] = {}  # (part, its colours) by (mesh, part, material)
        # A mesh part of one object and material met again under another matrix (an instance) goes
        # into the MeshData first made of it: the core stores it once for all its matrices.
        self.instanced: dict[tuple, tuple[MeshData, list[np.ndarray]]] = {}
        # Each mesh part's users (objects and instances) and the part of each MeshData: Cycles
        # turns a smooth mesh of one user into world space (Builder.finish).
        self.part_users: dict[int, int] = {}
        self.mesh_parts: dict[int, int] = {}

    # materials
    def material(self, mat, obj) -> int:
        key_ptr = mat.as_pointer() if mat is not None else None
        if key_ptr is not None and key_ptr in self.blender_materials:
            return self.blender_materials[key_ptr]
        md = material_data(mat, obj, self.data.notes)
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
        """The index of Blender object `obj` in SceneData.objects (added on first use). Objects
        are told apart by `name_full`: a linked object may share its name with a local one, not
        its library (an evaluated object, and geometry its nodes make, carry the original's)."""
        name = obj.name_full
        index = self.owners.get(name)
        if index is None:
            index = self.owners[name] = len(self.data.objects)
            self.data.objects.append(ObjectData(name, int(obj.pass_index)))
        return index

    # attribute colours
    def color_source(self, mat) -> ColorSource | None:
        """How `mat`'s kd follows from attributes (attribute_colors.py), None if it does not (or
        its graph cannot be mapped: then noted once)."""
        if mat is None:
            return None
        key = mat.as_pointer()
        if key not in self.color_sources:
            try:
                self.color_sources[key] = color_source(mat)
            except Unmapped as reason:
                self.color_sources[key] = None
                self.fallback(mat.name, str(reason))
            layers = layers_beyond_diffuse(mat) if self.color_sources[key] is not None else []
            if layers:
                self.data.notes.append(f"Material '{mat.name}': attribute colours tint its diffuse layer alone; the "
                                       f"Viewport Display colour tints its {' and '.join(layers)} "
                                       f"layer{'s' if len(layers) > 1 else ''}")
        return self.color_sources[key]

    def reads_geometry(self, mat) -> bool:
        """Whether `mat`'s kd reads attributes of the geometry it shades (not only its instancer's)."""
        source = self.color_source(mat)
        return source is not None and any(place == "GEOMETRY" for place, _ in source.attributes)

    def uncolored(self, mat, why: str) -> None:
        """Geometry with material `mat` that takes one colour: noted if `mat` reads attribute colours."""
        if self.color_source(mat) is not None:
            self.fallback(mat.name, why)

    def fallback(self, material: str, reason: str) -> None:
        """Notes once per material that its own colour stands in for its attribute colours."""
        if material not in self.fallbacks:
            self.fallbacks.add(material)
            self.data.notes.append(f"Material '{material}' is drawn in its Viewport Display colour where Cycles "
                                   f"varies its colour: {reason}")

    def attribute_colors(self, geometry, mats: list, slots: np.ndarray | None, materials, n: int,
                         sizes: dict[str, int], where: str = "GEOMETRY") -> np.ndarray | None:
        """(n, 3) kd of n elements of `geometry` (a point cloud: points; an instancer's instances,
        `where` "INSTANCER") whose Blender materials are mats[slots] (slots None: mats[0]) and
        Dürer materials `materials`: attribute colours where their material reads some, the
        material's kd elsewhere; None if none does."""
        sources = [self.color_source(mat) for mat in (mats[:1] if slots is None else mats)]
        default = getattr(getattr(geometry, "color_attributes", None), "default_color_name", None)
        colors = None
        for slot, source in enumerate(sources):
            if source is None:
                continue
            try:
                values, _ = read_values(geometry.attributes, source.attributes, default, sizes, where)
            except Unmapped as reason:
                self.fallback(source.material, str(reason))
                continue
            if slots is None:
                return source.colors(values, n)
            if colors is None:
                kd = np.array([m.diffuse for m in self.data.materials], np.float64)
                colors = kd[materials]
            chosen = np.clip(slots, 0, len(mats) - 1) == slot
            colors[chosen] = source.colors(values, n)[chosen]
        return colors

    def part_colors(self, me, part: TrianglePart, mat) -> np.ndarray | None:
        """A mesh part's kd from attributes: (V, 3) per vertex where every attribute read is on
        vertices, else (F, 3, 3) per face corner; None if its material reads none."""
        source = self.color_source(mat)
        if source is None:
            return None
        # The part is kept with its colours, so that its id stays its own while the export runs.
        key = (me.as_pointer(), id(part), mat.as_pointer())
        if key not in self.mesh_colors:
            try:
                colors = part_colors(me, part, source)
            except Unmapped as reason:
                self.fallback(source.material, str(reason))
                colors = None
            self.mesh_colors[key] = (part, colors)
        return self.mesh_colors[key][1]

    # geometry
    def placed_spheres(self, owners: int | np.ndarray, rows: np.ndarray, centers: np.ndarray, radii: np.ndarray,
                       materials: int | np.ndarray, colors: np.ndarray | None = None, *, points: bool = False) -> None:
        """Spheres given in object space under K world matrices (rows: (K, 3, 4), their top three
        rows): world-space spheres where a matrix is a uniform scale times a rotation, an exact
        ellipsoid group where it is not, nothing where it is singular. Each matrix places P
        spheres: centers (K or 1, P, 3), radii (K or 1, P), materials (a scalar or like radii),
        colors (None or like centers); owners one index or (K,). `points`: a point cloud's points,
        one-sided as Cycles meets them (met from outside only)."""
        self._add_chunk(*self._placed(owners, rows, centers, radii, materials, colors, points), points)

    def _placed(self, owners, rows, centers, radii, materials, colors, points=False) -> tuple:
        """`placed_spheres`' world-space spheres as a chunk; its ellipsoids added meanwhile."""
        linear, offset = rows[:, :, :3], rows[:, :, 3]
        scales, uniform = uniform_scales(linear)
        bad = ~np.isfinite(scales)  # neither kind below: left out, as Cycles does
        if bad.any():
            for owner in np.unique(np.broadcast_to(np.asarray(owners), bad.shape)[bad]):
                self._matrix_left_out(self.data.objects[int(owner)].name)
        for k in np.flatnonzero(~uniform & (scales > 0)):  # sheared or squashed: exact ellipsoids
            self.transformed_spheres(int(_row(owners, k)), np.vstack([rows[k], (0.0, 0.0, 0.0, 1.0)]), _row(centers, k),
                                     _row(radii, k), _row(materials, k), None if colors is None else _row(colors, k),
                                     points)
        chosen = slice(None) if uniform.all() else uniform
        centers, radii, materials = _rows(centers, chosen), _rows(radii, chosen), _rows(materials, chosen)
        colors = None if colors is None else _rows(colors, chosen)
        linear, offset, scales = linear[chosen], offset[chosen], scales[chosen]
        if len(rows) == 1 and np.array_equal(rows[0], IDENTITY[:3]):  # a point cloud as it was made
            world = centers
        else:  # in double precision (Blender stores float32 positions; Dürer intersects in double)
            world = centers @ linear.transpose(0, 2, 1)
            world += offset[:, None, :]
        shape = (len(linear), centers.shape[1])
        n = shape[0] * shape[1]
        return (owners if np.ndim(owners) == 0 else np.repeat(owners[chosen], shape[1]), world.reshape(n, 3),
                (scales[:, None] * radii).reshape(n),
                materials if np.ndim(materials) == 0 else np.broadcast_to(materials, shape).reshape(n),
                None if colors is None else np.broadcast_to(colors, (*shape, 3)).reshape(n, 3))

    def _add_chunk(self, owners, centers, radii, materials, colors, points: bool = False) -> None:
        chunk = self._counted(owners, centers, radii, materials, colors)
        if chunk is not None:
            for chunks, value in zip((self.sphere_owners, self.centers, self.radii, self.mats, self.colors), chunk):
                chunks.append(value)
            self.sides.append(points)

    def _counted(self, owners, centers, radii, materials, colors) -> tuple | None:
        """A chunk's arrays without its spheres of a centre or radius not finite (`_finite`), its
        spheres counted in `SceneData.sources`; None if it has none."""
        n = len(radii)
        if n == 0:
            return None
        centers, radii = np.asarray(centers).reshape(n, 3), np.asarray(radii).reshape(n)
        keep = self._finite(owners, centers, radii)
        if keep is not None:
            owners, materials = _kept(owners, keep), _kept(materials, keep)
            centers, radii, colors = centers[keep], radii[keep], None if colors is None else colors[keep]
            n = len(radii)
            if n == 0:
                return None
        sources, objects = self.data.sources, self.data.objects
        if np.ndim(owners) == 0:  # one owner: no sort of a cloud's ids
            sources[objects[owners].name] += n
        else:
            for owner, count in zip(*np.unique(owners, return_counts=True)):
                sources[objects[owner].name] += int(count)
        return (np.broadcast_to(np.asarray(owners, np.int32), (n,)), centers, radii,
                np.broadcast_to(np.asarray(materials, dtype=np.int32), (n,)), colors)

    def faces_left_out(self, name: str, shape: MeshShape) -> None:
        """Notes the faces of object `name`'s triangles (`shape`) left out for a vertex not finite."""
        if shape.left_out:
            self.data.notes.append(f"Dürer left out {shape.left_out} face(s) of '{name}' with a vertex that is not "
                                   "finite, as Cycles does")

    def _placeable(self, name: str, m: np.ndarray) -> bool:
        """Whether world matrix m of object (or instance) `name` is finite; noted if not."""
        if np.isfinite(m).all():
            return True
        self._matrix_left_out(name)
        return False

    def _matrix_left_out(self, name: str) -> None:
        """Notes that object `name`, or an instance of it, was left out for a matrix not finite."""
        self.data.notes.append(f"Dürer left out '{name}' (or an instance of it) whose matrix is not finite, as Cycles does")

    def _finite(self, owners, centers: np.ndarray, radii: np.ndarray) -> np.ndarray | None:
        """None if every sphere's centre and radius is finite, else which are, the others noted
        by object: Cycles leaves such a point out (its bounds are not finite) and renders the rest,
        where the core would refuse the whole scene."""
        if np.isfinite(centers.sum() + radii.sum()):  # one pass; a sum that overflows checks each
            return None
        keep = np.isfinite(centers).all(axis=1) & np.isfinite(radii)
        if keep.all():
            return None
        left = np.broadcast_to(np.asarray(owners), keep.shape)[~keep]
        for owner, count in zip(*np.unique(left, return_counts=True)):
            self.nonfinite[self.data.objects[owner].name] += int(count)
        return keep

    def sphere(self, owner: int, m: np.ndarray, center, radius: float, material: int) -> None:
        """A sphere in object space under world matrix m, placed at `finish` (`_Singles`)."""
        run = self.centers[-1] if self.centers else None
        if not isinstance(run, _Singles):
            run = _Singles()
            for chunks in (self.centers, self.radii, self.mats, self.sphere_owners, self.colors):
                chunks.append(run)
            self.sides.append(False)
        run.owners.append(owner)
        run.matrices.append(m)
        run.centers.append(np.asarray(center, dtype=np.float64).reshape(3))
        run.radii.append(float(radius))
        run.materials.append(material)

    def _make_singles(self) -> None:
        """Every `_Singles` run's spheres `placed_spheres`' way, where the run stands in the chunks
        (their order is the walk's)."""
        for i, run in enumerate(self.centers):
            if not isinstance(run, _Singles):
                continue
            rows = np.array(run.matrices, np.float64)[:, :3]
            chunk = self._placed(np.array(run.owners, np.int32), rows, np.array(run.centers)[:, None],
                                 np.array(run.radii)[:, None], np.array(run.materials, np.int32)[:, None], None)
            self.sphere_owners[i], self.centers[i], self.radii[i], self.mats[i], self.colors[i] = \
                self._counted(*chunk) or (np.zeros(0, np.int32), np.zeros((0, 3)), np.zeros(0), np.zeros(0, np.int32),
                                          None)

    def transformed_spheres(self, owner: int, m: np.ndarray, centers, radii, materials, colors=None,
                            points: bool = False) -> None:
        centers, radii = np.asarray(centers, np.float64).reshape(-1, 3), np.asarray(radii, np.float64).reshape(-1)
        keep = self._finite(owner, centers, radii)
        if keep is not None:
            centers, radii, materials = centers[keep], radii[keep], _kept(materials, keep)
            colors = None if colors is None else colors[keep]
        n = len(radii)
        if n == 0:
            return
        materials = np.broadcast_to(np.asarray(materials, dtype=np.int32), (n,))
        name = self.data.objects[owner].name
        group = TransformedSpheres(name, owner, centers, radii, materials, m, colors, points)
        self.data.transformed_spheres.append(group)
        self.data.sources[name] += n

    def triangles(self, obj, m: np.ndarray, parts: list[TrianglePart], me) -> None:
        """A mesh's triangles in object space, one Dürer mesh per material slot used, with the
        attribute colours of mesh `me` where the slot's material reads some."""
        mats = object_materials(obj)
        owner = self.owner(obj)
        name = self.data.objects[owner].name
        if not self._placeable(name, m):
            return
        flat = not is_invertible(m)
        for part in parts:
            mat = mats[min(part.slot, len(mats) - 1)] if mats else None
            material = self.material(mat, obj)
            colors = self.part_colors(me, part, mat)
            self.data.sources[name] += 1
            if flat:  # the core needs an invertible transform: a mesh scaled flat goes in world space, flat
                vertices = transform_points(m, part.vertices.astype(np.float64))
                self.data.meshes.append(MeshData(name, owner, vertices, part.faces, material, IDENTITY, colors))
                continue
            self.part_users[id(part)] = self.part_users.get(id(part), 0) + 1
            key = (id(part), owner, material, id(colors))
            if key in self.instanced:
                self.instanced[key][1].append(m)
                continue
            mesh = MeshData(name, owner, part.vertices, part.faces, material, m, colors, normals=part.normals)
            self.data.meshes.append(mesh)
            self.mesh_parts[id(mesh)] = id(part)
            self.instanced[key] = (mesh, [m])

    def mesh_instances(self, obj, owner: int, parts: list[TrianglePart], me, mats: list, matrices: np.ndarray,
                       instancer=None, chosen: np.ndarray | None = None) -> None:
        """Mesh `me`'s triangles (its `parts`, slot materials `mats`) under each of `matrices` ((K, 4, 4)
        world-from-object, invertible), owned by `owner`: one MeshData per part, stored once for all
        K instances (Scene.add_mesh_instances). A part whose material reads Instancer attributes
        takes each instance's colour from `instancer` (the instances' point cloud; `chosen`: which
        of its points these K are), else the mesh's own attribute colours."""
        name = self.data.objects[owner].name
        for part in parts:
            mat = mats[min(part.slot, len(mats) - 1)] if mats else None
            material = self.material(mat, obj)
            source = self.color_source(mat)
            per_instance = None
            if source is not None and instancer is not None and \
                    all(place == "INSTANCER" for place, _ in source.attributes):
                n = len(instancer.points)
                colors = self.attribute_colors(instancer, [mat], None, material, n, {"POINT": n}, where="INSTANCER")
                per_instance = None if colors is None else colors[chosen]
            mesh = MeshData(name, owner, part.vertices, part.faces, material, matrices[0],
                            None if per_instance is not None else self.part_colors(me, part, mat),
                            matrices if len(matrices) > 1 or per_instance is not None else None, per_instance,
                            part.normals)
            self.data.meshes.append(mesh)
            self.mesh_parts[id(mesh)] = id(part)
            self.part_users[id(part)] = self.part_users.get(id(part), 0) + len(matrices)
            self.data.sources[name] += len(matrices)

    def plane(self, owner: int, m: np.ndarray, shape: MeshShape, material: int, infinite: bool) -> None:
        if not self._placeable(self.data.objects[owner].name, m):
            return
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
        point = corner
        if infinite:  # a component within Blender's float32 rounding of a rotation is 0 (else an
            # infinite plane edge-on to an orthographic camera was met 1e8 away: a band across the view)
            normal[np.abs(normal) < ROUNDED_ZERO] = 0.0
            normal /= np.linalg.norm(normal)
            point = corner + 0.5 * (e1 + e2)  # the quad's centre: the rounded tilt moves its corners most
        bounds = None if infinite else (corner, e1, e2)
        name = self.data.objects[owner].name
        self.data.planes.append(PlaneData(name, owner, normal, float(normal @ point), material, bounds))
        self.data.sources[name] += 1

    def finish(self) -> SceneData:
        d = self.data
        self._make_singles()
        for name, count in self.nonfinite.items():
            d.notes.append(f"Dürer left out {count} sphere(s) of '{name}' whose position or radius is not finite, "
                           "as Cycles does")
        for mesh, matrices in self.instanced.values():
            if len(matrices) > 1:
                mesh.instances = np.array(matrices, np.float64)
        for mesh in d.meshes:
            if mesh.normals is not None and mesh.instances is None \
                    and self.part_users.get(self.mesh_parts.get(id(mesh)), 0) == 1 and not uniform_scale(mesh.matrix)[1]:
                _smooth_in_world_space(mesh)
        if self.centers:  # at most one copy into float64, however many objects contributed
            d.sphere_centers = _join(self.centers, np.float64)
            d.sphere_radii = _join(self.radii, np.float64)
            d.sphere_materials = _join(self.mats, np.int32)
            d.sphere_owners = _join(self.sphere_owners, np.int32)
            if any(self.sides):
                d.sphere_one_sided = np.repeat(self.sides, [len(r) for r in self.radii])
            if any(c is not None for c in self.colors):
                kd = np.array([m.diffuse for m in d.materials], np.float64)
                d.sphere_colors = _join([kd[mats] if c is None else c for c, mats in zip(self.colors, self.mats)],
                                        np.float64)
        return d


def _smooth_in_world_space(mesh: MeshData) -> None:
    """A smooth mesh of one user under a non-uniform scale or a shear, in world space with its
    normals turned there and made unit, as Cycles shades it (its normals interpolated in object
    space and turned after differed by up to 21 degrees); Cycles keeps a mesh of several users
    (objects or instances) in its own space, as Dürer does."""
    linear = mesh.matrix[:3, :3]
    normals = mesh.normals.astype(np.float64) @ np.linalg.inv(linear)  # each corner's n @ M^-1 = M^-T n
    mesh.normals = normals / np.linalg.norm(normals, axis=-1, keepdims=True)
    mesh.vertices = transform_points(mesh.matrix, mesh.vertices.astype(np.float64))
    mesh.matrix = IDENTITY
    if np.linalg.det(linear) < 0:  # a mirror reverses the winding in world space: wound back, corners alike
        mesh.faces = mesh.faces[:, ::-1]
        mesh.normals = mesh.normals[:, ::-1]
        if mesh.colors is not None and mesh.colors.ndim == 3:
            mesh.colors = mesh.colors[:, ::-1]


def _row(a, k: int):
    """Matrix k's part of `a` (one row of K, or the one row all matrices share), or a scalar."""
    return a if np.ndim(a) == 0 else a[0 if len(a) == 1 else k]


def _kept(a, keep: np.ndarray):
    """The entries of `a` (a scalar for all, or one per sphere) of the spheres kept."""
    return a if np.ndim(a) == 0 else np.asarray(a)[keep]


def _rows(a, chosen):
    """The rows of `a` for the matrices chosen (a row all matrices share stays one)."""
    return a if np.ndim(a) == 0 or len(a) == 1 else a[chosen]


def _join(chunks: list[np.ndarray], dtype) -> np.ndarray:
    if len(chunks) == 1:
        return np.ascontiguousarray(chunks[0], dtype=dtype)
    return np.concatenate(chunks, dtype=dtype)
