"""A Blender mesh as triangles: its loop triangles in bulk numpy arrays, one part per material slot.

Dürer gives a whole mesh one material (``Scene.add_mesh``), so a mesh whose faces use several
material slots becomes one Dürer mesh per slot used. Everything goes through ``foreach_get``: no
Python loop over vertices or faces, whatever the mesh's size.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class TrianglePart:
    """The triangles of one material slot, in the mesh's object space."""

    slot: int  # material slot index (0 when the object has no slots)
    vertices: np.ndarray  # (V, 3) float32, as Blender stores them
    faces: np.ndarray  # (F, 3) int32 indices into `vertices`
    corners: np.ndarray  # (F, 3) int32 the mesh's corner (loop) of each face's vertices
    vertex_ids: np.ndarray | None = None  # (V,) the mesh's vertex of each of `vertices` (None: the same)
    triangles: np.ndarray | None = None  # (F,) the mesh's loop triangle of each face (None: the same)
    #: (F, 3, 3) float32 each face's normals at its corners, as Cycles shades them (smooth faces,
    #: sharp edges, custom normals, flat faces among smooth ones); None when every face is flat.
    normals: np.ndarray | None = None


def mesh_triangles(me) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(vertices (V, 3) float32, faces (T, 3) int32, material slot of each face (T,) int32, corners
    of each face (T, 3) int32) of a mesh's loop triangles (Blender's own triangulation of its
    polygons, n-gons included).

    Read through the attribute arrays and the triangles' corner and polygon indices, which
    ``foreach_get`` copies as raw memory; the triangles' ``vertices`` and ``material_index`` are
    computed per item and cost twice as much."""
    vertices = _attribute(me, "position", "vector", len(me.vertices), 3, np.float32)
    if vertices is None:
        vertices = np.empty(len(me.vertices) * 3, np.float32)
        me.vertices.foreach_get("co", vertices)
    corner_verts = _corner_verts(me)
    tris = me.loop_triangles
    t = len(tris)
    corners = np.empty(t * 3, np.int32)
    tris.foreach_get("loops", corners)
    slots = np.zeros(t, np.int32)
    face_slots = _attribute(me, "material_index", "value", len(me.polygons), 1, np.int32)
    if face_slots is not None:
        polygons = np.empty(t, np.int32)
        me.loop_triangle_polygons.foreach_get("value", polygons)
        slots = face_slots[polygons]
    corners = corners.reshape(t, 3)
    return vertices.reshape(-1, 3), corner_verts[corners], slots, corners


def _corner_verts(me) -> np.ndarray:
    """(L,) int32 the vertex of each corner (loop) of mesh `me`."""
    corner_verts = _attribute(me, ".corner_vert", "value", len(me.loops), 1, np.int32)
    if corner_verts is None:
        corner_verts = np.empty(len(me.loops), np.int32)
        me.loops.foreach_get("vertex_index", corner_verts)
    return corner_verts


def _attribute(me, name: str, field: str, n: int, width: int, dtype) -> np.ndarray | None:
    """A mesh attribute's values (None if the mesh has no such attribute, e.g. no material_index
    when every face uses slot 0)."""
    attribute = me.attributes.get(name)
    if attribute is None or len(attribute.data) != n:
        return None
    values = np.empty(n * width, dtype)
    attribute.data.foreach_get(field, values)
    return values


def clamp_slots(slots: np.ndarray, slot_count: int) -> np.ndarray:
    """The slot each face renders with: indices past the last slot use the last one and negative
    ones the first, as Blender renders them; without slots everything is slot 0."""
    return np.clip(slots, 0, max(slot_count - 1, 0))


def face_slots(me, slot_count: int) -> np.ndarray:
    """The material slot each of the mesh's polygons renders with (`clamp_slots`)."""
    slots = _attribute(me, "material_index", "value", len(me.polygons), 1, np.int32)
    return np.zeros(len(me.polygons), np.int32) if slots is None else clamp_slots(slots, slot_count)


def corner_normals(me) -> np.ndarray | None:
    """(L, 3) float32 the normal each corner (loop) of mesh `me` is shaded with, as Cycles shades
    it, or None when its normals are its faces' own (no smooth face, no custom normals). NaN rows:
    a flat face's corners, shaded by each of its triangles' own normal (`_of`)."""
    domain = me.normals_domain
    if domain == "FACE":
        return None
    sharp_edges = _attribute(me, "sharp_edge", "value", len(me.edges), 1, bool)
    if domain == "CORNER" and not me.has_custom_normals and (sharp_edges is None or not sharp_edges.any()):
        # Corner normals only because some faces are flat: Cycles shades the smooth faces with the
        # vertex normals (over flat neighbours too), where Blender's corner normals split at them.
        normals = np.empty(len(me.vertices) * 3, np.float32)
        me.vertex_normals.foreach_get("vector", normals)
        normals = normals.reshape(-1, 3)[_corner_verts(me)]
        flat = _attribute(me, "sharp_face", "value", len(me.polygons), 1, bool)
        if flat is not None:
            totals = np.empty(len(me.polygons), np.int32)
            me.polygons.foreach_get("loop_total", totals)
            normals[np.repeat(flat, totals)] = np.nan
        return normals
    normals = np.empty(len(me.loops) * 3, np.float32)
    me.corner_normals.foreach_get("vector", normals)
    return normals.reshape(-1, 3)


def split_by_slot(vertices: np.ndarray, faces: np.ndarray, slots: np.ndarray, slot_count: int,
                  corners: np.ndarray, normals: np.ndarray | None = None,
                  keep: np.ndarray | None = None) -> list[TrianglePart]:
    """One part per material slot the faces use (`clamp_slots`), in slot order, with the faces'
    corner normals if the mesh has some (`normals`, per corner); only the faces `keep` says, if
    given. A part of a split mesh, or of some faces, keeps only the vertices its faces use."""
    if len(faces) == 0:
        return []
    slots = clamp_slots(slots, slot_count)
    # linear in the face count, unlike np.unique's sort
    used = np.flatnonzero(np.bincount(slots if keep is None else slots[keep], minlength=1))
    if len(used) == 1 and keep is None:
        return [TrianglePart(int(used[0]), vertices, faces, corners, normals=_of(normals, corners, vertices, faces))]
    parts = []
    for slot in used:
        chosen = slots == slot if keep is None else (slots == slot) & keep
        part = faces[chosen]
        # Renumber the vertices the part uses in their original order: a mask and a running count,
        # linear in the mesh's size (no sort).
        uses = np.zeros(len(vertices), bool)
        uses[part] = True
        number = np.cumsum(uses, dtype=np.int32) - 1
        parts.append(TrianglePart(int(slot), vertices[uses], number[part], corners[chosen], np.flatnonzero(uses),
                                  np.flatnonzero(chosen), _of(normals, corners[chosen], vertices, faces[chosen])))
    return parts


def _of(normals: np.ndarray | None, corners: np.ndarray, vertices: np.ndarray, faces: np.ndarray) -> np.ndarray | None:
    """The faces' corner normals (F, 3, 3); a flat face's (NaN), or one with a corner Blender gives
    no direction (a zero-area face's zeros), its own normal at its three corners."""
    if normals is None:
        return None
    at = normals[corners]
    flat = ~(np.abs(at).sum(axis=2) > 0).all(axis=1)  # NaN or zero at a corner
    if flat.any():
        v = vertices[faces[flat]].astype(np.float64)
        own = np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0])
        length = np.linalg.norm(own, axis=1, keepdims=True)
        own = np.where(length > 0, own / np.where(length > 0, length, 1.0), (0.0, 0.0, 1.0))  # a degenerate
        at[flat] = own[:, None, :]  # triangle, never hit, still needs a direction
    return at


def triangle_parts(me, slot_count: int) -> tuple[list[TrianglePart], int]:
    """`split_by_slot` of `mesh_triangles(me)` ([] for a mesh without faces), without the faces that
    have a vertex not finite (Cycles leaves them out: their bounds are not), and how many those were."""
    vertices, faces, slots, corners = mesh_triangles(me)
    keep = None
    if not np.isfinite(vertices.sum(dtype=np.float64)):  # one pass; a sum that overflows checks each
        finite = np.isfinite(vertices).all(axis=1)
        keep = None if finite.all() else finite[faces].all(axis=1)
    parts = split_by_slot(vertices, faces, slots, slot_count, corners, corner_normals(me) if len(faces) else None, keep)
    return parts, 0 if keep is None else int(np.count_nonzero(~keep))
