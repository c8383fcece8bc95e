"""What a mesh is for Dürer: a sphere (all vertices on one), a plane (a flat quad or grid), or its
triangles; forced by ``object.durer.primitive``. Metaball balls' radii."""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from .triangles import TrianglePart, face_slots, triangle_parts

#: Relative tolerance for "all vertices at the same distance from the centroid".
SPHERE_TOLERANCE = 1e-3
#: A sphere mesh's faces must be close to the sphere: every face centre at least this fraction of
#: the radius from the centre (rejects cubes, cylinders and octahedra, whose corners are equidistant).
SPHERE_FACE_FRACTION = 0.85
#: Auto-detected sphere meshes need at least this many vertices (an icosahedron has 12).
SPHERE_MIN_VERTICES = 12
#: Relative tolerance for flatness and for "the faces cover their bounding rectangle".
PLANE_TOLERANCE = 1e-5


def foreach_array(collection, attr: str, n: int, width: int, dtype=np.float32) -> np.ndarray:
    buf = np.empty(n * width, dtype=dtype)
    collection.foreach_get(attr, buf)
    return buf.reshape(n, width) if width > 1 else buf


@dataclass
class MeshShape:
    kind: str  # "sphere", "plane", "triangles" or "empty"
    center: np.ndarray | None = None
    radius: float = 0.0
    corner: np.ndarray | None = None  # plane: local corner, edges and normal direction
    edge1: np.ndarray | None = None
    edge2: np.ndarray | None = None
    parts: list[TrianglePart] = field(default_factory=list)  # triangles: one part per material slot
    left_out: int = 0  # triangles, empty: faces left out, a vertex of each not finite (triangle_parts)
    slot: int = 0  # sphere or plane: the material slot its faces use (forced: most of them)


def cloud_points(pc) -> tuple[np.ndarray, np.ndarray]:
    """A point cloud's (N, 3) float32 positions and (N,) radii (Blender's default 0.01 without a
    `radius` attribute), in object space, each read in one foreach_get."""
    n = len(pc.points)
    positions = np.empty(n * 3, np.float32)
    pc.attributes["position"].data.foreach_get("vector", positions)
    radius = pc.attributes.get("radius")
    if radius is None:
        return positions.reshape(n, 3), np.full(n, 0.01, np.float32)
    radii = np.empty(n, np.float32)
    radius.data.foreach_get("value", radii)
    return positions.reshape(n, 3), radii


def mesh_key(me) -> int:
    """A mesh's identity in one export's caches: Blender's session-wide id of the datablock, never
    given to another (not its address: geometry-nodes instances' meshes are temporary, freed during
    the walk and their memory reused by the next)."""
    return me.session_uid


def _mesh_arrays(me) -> tuple[np.ndarray, int]:
    n = len(me.vertices)
    co = foreach_array(me.vertices, "co", n, 3).astype(np.float64)
    return co, len(me.polygons)


def _face_centers(me, co: np.ndarray) -> np.ndarray:
    npoly = len(me.polygons)
    starts = foreach_array(me.polygons, "loop_start", npoly, 1, np.int32)
    verts = foreach_array(me.loops, "vertex_index", len(me.loops), 1, np.int32)
    totals = foreach_array(me.polygons, "loop_total", npoly, 1, np.int32)
    sums = np.add.reduceat(co[verts], starts, axis=0)
    return sums / totals[:, None]


def _detect_sphere(me, co: np.ndarray, strict: bool = True) -> MeshShape | None:
    """A sphere through all vertices (they are equidistant from their centroid). `strict` (Auto)
    also asks that the faces hug the sphere and the vertices span 3D."""
    if len(co) < SPHERE_MIN_VERTICES or (strict and len(me.polygons) == 0):
        return None
    center = co.mean(axis=0)
    dist = np.linalg.norm(co - center, axis=1)
    radius = float(dist.max())
    if radius <= 0 or float(dist.min()) < radius * (1.0 - SPHERE_TOLERANCE):
        return None
    if not strict:
        return MeshShape("sphere", center=center, radius=float(dist.mean()))
    # Reject shapes whose corners are equidistant but whose faces are far inside (cubes, prisms).
    face_dist = np.linalg.norm(_face_centers(me, co) - center, axis=1)
    if float(face_dist.min()) < SPHERE_FACE_FRACTION * radius:
        return None
    # Reject rings (all vertices in a plane).
    spread = np.linalg.svd(co - center, compute_uv=False)
    if spread[-1] < 0.1 * spread[0]:
        return None
    return MeshShape("sphere", center=center, radius=float(dist.mean()))


def _bbox_plane(me, co: np.ndarray, axis_scale=(1.0, 1.0, 1.0)) -> MeshShape:
    """The rectangle of the local bounding box, normal along its thinnest axis (after the
    object's axis scales)."""
    lo, hi = co.min(axis=0), co.max(axis=0)
    ext = hi - lo
    axis = int(np.argmin(ext * np.asarray(axis_scale)))
    a, b = [i for i in range(3) if i != axis]
    normal = np.zeros(3)
    normal[axis] = 1.0
    if len(me.polygons):
        npoly = len(me.polygons)
        normals = foreach_array(me.polygons, "normal", npoly, 3).astype(np.float64)
        areas = foreach_array(me.polygons, "area", npoly, 1).astype(np.float64)
        if float((normals[:, axis] * areas).sum()) < 0:
            normal[axis] = -1.0
    mid = (lo + hi) / 2.0
    corner = lo.copy()
    corner[axis] = mid[axis]
    e1 = np.zeros(3)
    e1[a] = ext[a]
    e2 = np.zeros(3)
    e2[b] = ext[b]
    if float(np.dot(np.cross(e1, e2), normal)) < 0:
        e1, e2 = e2, e1
    return MeshShape("plane", corner=corner, edge1=e1, edge2=e2)


def _detect_plane(me, co: np.ndarray) -> MeshShape | None:
    npoly = len(me.polygons)
    if npoly == 0:
        return None
    ext = co.max(axis=0) - co.min(axis=0)
    size = float(ext.max())
    if size <= 0:
        return None
    if npoly == 1 and len(co) == 4 and len(me.loops) == 4:
        order = foreach_array(me.loops, "vertex_index", 4, 1, np.int32)
        v = co[order]
        if np.abs(v[0] + v[2] - v[1] - v[3]).max() <= PLANE_TOLERANCE * size:
            e1, e2 = v[1] - v[0], v[3] - v[0]
            if np.linalg.norm(np.cross(e1, e2)) > 0:
                return MeshShape("plane", corner=v[0], edge1=e1, edge2=e2)
        return None
    # Grids and subdivided planes: flat along a local axis and covering their bounding rectangle.
    axis = int(np.argmin(ext))
    if ext[axis] > PLANE_TOLERANCE * size:
        return None
    a, b = [i for i in range(3) if i != axis]
    areas = foreach_array(me.polygons, "area", npoly, 1).astype(np.float64)
    rect = float(ext[a] * ext[b])
    if rect <= 0 or abs(float(areas.sum()) - rect) > 1e-4 * rect:
        return None
    return _bbox_plane(me, co)


def _bbox_sphere(co: np.ndarray) -> MeshShape:
    lo, hi = co.min(axis=0), co.max(axis=0)
    return MeshShape("sphere", center=(lo + hi) / 2.0, radius=float(np.mean((hi - lo) / 2.0)))


def _triangles(me, slot_count: int) -> MeshShape:
    """The mesh's triangles, one part per material slot used ("empty" without faces: loose
    vertices and edges, like a curve without bevel, render as nothing in Cycles either)."""
    parts, left_out = triangle_parts(me, slot_count)
    return MeshShape("triangles" if parts else "empty", parts=parts, left_out=left_out)


def mesh_shape(me, mode: str, axis_scale, slot_count: int) -> MeshShape:
    """What a mesh (in its local coordinates) is for Dürer under the override `mode`: a sphere, a
    plane, or its triangles (Auto, when it is neither, and Mesh). `axis_scale`: the object's scale
    along the local axes (picks a forced plane's normal); `slot_count`: the material slots of the
    object it belongs to. Auto takes a mesh whose faces use several slots for triangles: a sphere
    or plane has one material."""
    co, _ = _mesh_arrays(me)
    if len(co) == 0:
        return MeshShape("empty")
    finite = bool(np.isfinite(co.sum()))  # one pass; a sum that overflows checks each
    if not finite:  # a vertex not finite: not a sphere or plane of Auto's; a forced one of the others
        co = co[np.isfinite(co).all(axis=1)]
        if mode == "AUTO" or len(co) == 0:
            mode = "MESH"
    if mode == "MESH":
        return _triangles(me, slot_count)
    uses = np.bincount(face_slots(me, slot_count), minlength=1)
    if mode == "SPHERE":
        shape = _detect_sphere(me, co, strict=False) or _bbox_sphere(co)
    elif mode == "PLANE":
        shape = (finite and _detect_plane(me, co)) or _bbox_plane(me, co, axis_scale)
    elif np.count_nonzero(uses) > 1:
        return _triangles(me, slot_count)
    else:
        shape = _detect_plane(me, co) or _detect_sphere(me, co) or _triangles(me, slot_count)
    return replace(shape, slot=int(uses.argmax())) if shape.kind in ("sphere", "plane") else shape


def metaball_iso_radius(radius: float, stiffness: float, threshold: float) -> float:
    """Radius of the surface of an isolated metaball ball (Blender's field s·(1 − d²/R²)³)."""
    if stiffness <= threshold or radius <= 0:
        return 0.0
    return radius * math.sqrt(1.0 - (threshold / stiffness) ** (1.0 / 3.0))
