"""The scene: geometry in bulk numpy arrays, materials, lights, background and ambient light."""

from __future__ import annotations

import math
import numbers
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from . import _checks, _core


class Scene:
    """What Dürer renders.

    Objects get ids in the order they are added (objects added in bulk get consecutive ids; a mesh
    is one object); `render` and `cast` report hits by these ids. Material 0 exists from the start:
    diffuse 0.8 grey. Every add checks its input and raises ValueError/TypeError naming the argument;
    an add that raises changes nothing.

    Every geometry add takes `transform`: None (world space) or a world-from-object affine matrix,
    (4, 4) with bottom row (0, 0, 0, 1) or (3, 4), column vectors (p_world = M @ [p, 1]), invertible.
    Rays are taken into object space (t stays in world units), normals come back by the inverse
    transpose: a sphere under a non-uniform scale is an ellipsoid. Objects added with the same
    matrix share one transformed group (and its hierarchy).

    A scene pickles (for Dask workers and multiprocessing): it keeps the validated arguments of
    every add, read-only and without copying arrays it made itself, and an unpickled scene replays
    them into a new core scene, so it has the same object ids and renders the same images.
    """

    def __init__(self) -> None:
        self._core = _core.Scene()
        # (core method, validated arguments, validated keyword arguments), in order
        self._adds: list[tuple[str, tuple[Any, ...], dict[str, Any]]] = []

    def _add(self, method: str, *args: Any, **kwargs: Any) -> Any:
        """Calls the core's add method and records it for pickling once it has succeeded."""
        result = getattr(self._core, method)(*args, **kwargs)
        self._adds.append((method, args, kwargs))
        return result

    def __getstate__(self) -> dict[str, Any]:
        return {"adds": self._adds, "shading": self.shading, "background": self.background, "ambient": self.ambient}

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__init__()
        for method, args, kwargs in state["adds"]:
            self._add(method, *args, **kwargs)
        self._core.shading, self._core.background, self._core.ambient = (
            state["shading"], state["background"], state["ambient"])

    # --- materials and objects -------------------------------------------------------------------
    def add_material(
        self,
        diffuse: ArrayLike = (0.8, 0.8, 0.8),
        *,
        emission: ArrayLike = (0.0, 0.0, 0.0),
        specular: ArrayLike = (0.0, 0.0, 0.0),
        exponent: float = 1.0,
        reflective: ArrayLike = (0.0, 0.0, 0.0),
        transparent: ArrayLike = (0.0, 0.0, 0.0),
        ior: float = 1.0,
    ) -> int:
        """Add a material; returns its id. Colours are linear RGB >= 0 (6.837 assignments 2-4):

        diffuse (kd): the flat colour without lights, the diffuse albedo with them;
        emission: added unlit (a light source seen directly; Blender's Emission);
        specular (ks) and exponent: the Phong highlight ks·light·max(N·H, 0)^exponent, lit scenes only
        (on a reflective material, exponent >= _core.MIRROR_GLINT_EXPONENT: the mirror's glint of the
        lights, without the area lights, which the mirror shows along its mirror direction);
        reflective: weight of what the mirror ray sees; transparent: weight of what the refracted ray
        sees, bent by Snell's law with index of refraction `ior` (> 0) inside the object.
        Only the effects some material calls for are simulated (see `render`'s stats["effects"]).
        """
        given = {
            "diffuse": diffuse, "emission": emission, "specular": specular, "exponent": exponent,
            "reflective": reflective, "transparent": transparent, "ior": ior,
        }
        # The core owns the fields (durer._core.MATERIAL_FIELDS) and checks their values.
        return self._add("add_material", **{
            name: _checks.components(given[name], name, components) for name, components, _ in _core.MATERIAL_FIELDS
        })

    def add_spheres(
        self,
        centers: ArrayLike,
        radii: ArrayLike,
        material: ArrayLike = 0,
        *,
        transform: ArrayLike | None = None,
        colors: ArrayLike | None = None,
        one_sided: bool | ArrayLike = False,
    ) -> np.ndarray:
        """Add N spheres. `centers` (N, 3); `radii` (N,) or one radius for all, each finite and > 0;
        `material` one id or (N,) ids. Returns the (N,) int32 object ids. With `transform` (see the
        class docstring) a sphere can become an ellipsoid. `colors` (N, 3), linear RGB, finite and
        >= 0: each sphere's diffuse colour (kd) in place of its material's, lit or flat (the
        material's other fields still apply). `one_sided` (one bool or (N,) bools): spheres met from
        outside only: a ray that starts inside one (camera, mirror, refracted and shadow rays, `cast`
        and `occluded`) passes through it and meets what lies beyond, as Cycles draws a point cloud's
        points (it culls their inside). Two-sided spheres show their inside (a camera in a ball)."""
        given = centers
        centers = _checks.float_array(centers, "centers", (None, 3))
        n = centers.shape[0]
        radii_array = _radii(radii, n)
        materials = _material_ids(material, n)
        matrix = _owned(_checks.transform(transform), transform)
        color_array = _checks.one_of_shapes(colors, "colors", (n, 3))
        sides = _checks.flags(one_sided, "one_sided", n)
        if n == 0:
            return np.empty(0, dtype=np.int32)
        first = self._add("add_spheres", _owned(centers, given), _owned(radii_array, radii), _owned(materials, material),
                          matrix, colors=_owned(color_array, colors), one_sided=sides)
        return np.arange(first, first + n, dtype=np.int32)

    def move_spheres(self, ids: ArrayLike, centers: ArrayLike, radii: ArrayLike | None = None) -> None:
        """Move spheres already added (an animation's next frame): `ids` (N,) object ids that
        add_spheres returned, in any order; `centers` (N, 3) their new centers, in the space they
        were added in (under their transform, if any); `radii` (N,) or one radius for all, or None to
        keep theirs. The next render refits the hierarchy built for the old positions instead of
        building a new one, and rebuilds it only where refitting made it 1.5x as costly to trace
        (by its surface-area cost): renders after a move equal those of a scene built at the new
        positions, pixel for pixel."""
        given = centers
        id_array = _checks.integer_array(ids, "ids", (None,), np.int32)
        n = id_array.shape[0]
        centers = _checks.float_array(centers, "centers", (n, 3))
        radii_array = None if radii is None else _owned(_radii(radii, n), radii)
        if n == 0:
            return
        self._add("move_spheres", _owned(id_array, ids), _owned(centers, given), radii_array)
        # A pickled scene replays only the last move of the same spheres (one per frame would pile up)...
        last = self._adds[-1]
        self._adds[:-1] = [add for add in self._adds[:-1] if not _superseded(add, last)]
        # ... and moves of other sets of spheres each time are merged once they hold twice as many
        # entries as there are spheres: the records stay within a few times the spheres' own size.
        moved = sum(len(args[0]) for method, args, _ in self._adds if method == "move_spheres")
        if moved > 2 * sum(len(args[1]) for method, args, _ in self._adds if method == "add_spheres"):
            self._adds = _merged_moves(self._adds)

    def add_plane(
        self,
        normal: ArrayLike,
        offset: float,
        material: int = 0,
        bounds: tuple[ArrayLike, ArrayLike, ArrayLike] | None = None,
        *,
        transform: ArrayLike | None = None,
    ) -> int:
        """Add the plane of points p with normal·p = offset; returns its object id.

        `normal` need not be unit length (the plane is the same set of points either way). With
        `bounds=(corner, edge1, edge2)` only the parallelogram corner + a·edge1 + b·edge2, a, b in
        [0, 1], is there; the corner must lie on the plane and the edges in it. The normal is the
        shading normal as given: it is not flipped toward the viewer.
        """
        normal3 = _checks.vector3(normal, "normal")
        offset_value = _checks.real(offset, "offset")
        material_id = _material_id(material)
        corners = None
        if bounds is not None:
            try:
                count = len(bounds)
            except TypeError:  # an int, a generator, ...
                raise TypeError(f"bounds must be (corner, edge1, edge2) or None, got {type(bounds).__name__}") from None
            if count != 3:
                raise ValueError(f"bounds must be (corner, edge1, edge2), got {count} items")
            corners = tuple(_checks.vector3(v, f"bounds {part}") for v, part in zip(bounds, ("corner", "edge1", "edge2")))
        return self._add("add_plane", normal3, offset_value, material_id, corners, _owned(_checks.transform(transform), transform))

    def add_triangles(
        self,
        vertices: ArrayLike,
        material: ArrayLike = 0,
        *,
        transform: ArrayLike | None = None,
        colors: ArrayLike | None = None,
    ) -> np.ndarray:
        """Add N triangles, each its own object: `vertices` (N, 3, 3) holds v0, v1, v2 of each.
        The geometric normal normalize((v1 − v0) × (v2 − v0)) follows the winding. The test is
        watertight (a ray through an edge or vertex shared by two triangles hits one of them);
        degenerate triangles are kept and never hit. `colors`: the diffuse colour in place of the
        material's (as in add_spheres), (N, 3) one per triangle or (N, 3, 3) one per corner (at v0,
        v1, v2), interpolated across the triangle by the hit's barycentric coordinates. Returns the
        (N,) int32 object ids."""
        given = vertices
        vertices = _checks.float_array(vertices, "vertices", (None, 3, 3))
        n = vertices.shape[0]
        materials = _material_ids(material, n)
        matrix = _owned(_checks.transform(transform), transform)
        color_array = _checks.one_of_shapes(colors, "colors", (n, 3), (n, 3, 3))
        if n == 0:
            return np.empty(0, dtype=np.int32)
        first = self._add("add_triangles", _owned(vertices, given), _owned(materials, material), matrix,
                          colors=_owned(color_array, colors))
        return np.arange(first, first + n, dtype=np.int32)

    def add_mesh(
        self,
        vertices: ArrayLike,
        faces: ArrayLike,
        material: int = 0,
        *,
        transform: ArrayLike | None = None,
        colors: ArrayLike | None = None,
        normals: ArrayLike | None = None,
    ) -> int:
        """Add a triangle mesh as one object with one material: `vertices` (V, 3), `faces` (F, 3)
        0-based vertex indices, each face a triangle wound as in add_triangles. `colors`: the
        diffuse colour in place of the material's (as in add_spheres), (V, 3) one per vertex or
        (F, 3, 3) one per face corner (a face's own colour: the same at its three corners),
        interpolated across each face. `normals`: a smooth mesh's normals in object space, laid
        out as `colors` (nonzero, of any length; made unit), interpolated across each face and
        shaded and written to the normal pass in place of the face's own; rays still leave and
        meet a face by its own normal (the winding's). Returns its object id."""
        mesh = _mesh_arguments(vertices, faces, material, colors, normals)
        return self._add("add_mesh", *mesh[:3], _owned(_checks.transform(transform), transform), colors=mesh[3],
                         normals=mesh[4])

    def add_mesh_instances(
        self,
        vertices: ArrayLike,
        faces: ArrayLike,
        transforms: ArrayLike,
        material: int = 0,
        *,
        colors: ArrayLike | None = None,
        instance_colors: ArrayLike | None = None,
        normals: ArrayLike | None = None,
    ) -> int:
        """Add the mesh of add_mesh seen through each of `transforms` ((N, 4, 4) or (N, 3, 4)
        world-from-object matrices, each invertible): one object whose triangles and hierarchy are
        stored once and shared by its N instances (instancing a rock a hundred thousand times costs
        one rock and a hierarchy over the instances). `instance_colors` (N, 3): each instance's
        diffuse colour, in place of the material's and of `colors`. `normals`: as in add_mesh.
        Returns its object id, which every instance's hits report."""
        mesh = _mesh_arguments(vertices, faces, material, colors, normals)
        matrices = _checks.transforms(transforms)
        per_instance = _checks.one_of_shapes(instance_colors, "instance_colors", (matrices.shape[0], 3))
        return self._add("add_mesh_instances", *mesh[:3], _owned(matrices, transforms), colors=mesh[3],
                         instance_colors=_owned(per_instance, instance_colors), normals=mesh[4])

    def add_boxes(
        self,
        lo: ArrayLike,
        hi: ArrayLike,
        material: ArrayLike = 0,
        *,
        transform: ArrayLike | None = None,
        colors: ArrayLike | None = None,
    ) -> np.ndarray:
        """Add N axis-aligned boxes [lo, hi] (each (N, 3), lo < hi in every axis), each its own object.
        A ray starting inside a box hits it where it leaves. With `transform` a box can be rotated,
        sheared or scaled. `colors` (N, 3): each box's diffuse colour in place of its material's (as
        in add_spheres). Returns the (N,) int32 object ids."""
        given_lo, given_hi = lo, hi
        lo = _checks.float_array(lo, "lo", (None, 3))
        hi = _checks.float_array(hi, "hi", (lo.shape[0], 3))
        n = lo.shape[0]
        materials = _material_ids(material, n)
        matrix = _owned(_checks.transform(transform), transform)
        color_array = _checks.one_of_shapes(colors, "colors", (n, 3))
        if n == 0:
            return np.empty(0, dtype=np.int32)
        first = self._add("add_boxes", _owned(lo, given_lo), _owned(hi, given_hi), _owned(materials, material), matrix,
                          colors=_owned(color_array, colors))
        return np.arange(first, first + n, dtype=np.int32)

    # --- lights and background ------------------------------------------------------------------
    def add_directional_light(
        self,
        direction: ArrayLike,
        color: ArrayLike,
        *,
        shadows: bool = False,
        angle_degrees: float = 0.0,
        samples: int = 16,
        soft_shadows: bool = True,
    ) -> None:
        """A light infinitely far away. `direction` is the way the light travels (surfaces facing
        -direction are lit); `color` is linear RGB >= 0 and does not fall off. With shadows=True,
        occluders between a point and the light block it (a shadow ray per lit point). A nonzero
        `angle_degrees` (the angular diameter of the light's disc, in [0, 180): Blender's Sun Angle)
        spreads its highlights over the disc (their light kept) and softens its shadows: its light
        times the fraction of `samples` shadow rays, spread over the disc's directions, that
        nothing blocks (soft_shadows=False: hard shadows along `direction`)."""
        angle = _checks.finite_real(angle_degrees, "angle_degrees")
        self._add(
            "add_directional_light",
            _checks.vector3(direction, "direction"), _checks.color(color, "color"), _checks.boolean(shadows, "shadows"),
            math.radians(angle) / 2, _checks.c_int(samples, "samples"), _checks.boolean(soft_shadows, "soft_shadows"),
        )

    def add_point_light(
        self,
        position: ArrayLike,
        color: ArrayLike,
        *,
        attenuation: ArrayLike = (1.0, 0.0, 0.0),
        shadows: bool = False,
        radius: float = 0.0,
        samples: int = 16,
        soft_shadows: bool = True,
    ) -> None:
        """A light at `position`. `color` (linear RGB >= 0) arrives at distance d as
        color / (c0 + c1·d + c2·d²) with attenuation = (c0, c1, c2): (1, 0, 0), the default, is the
        6.837 light without falloff; (0, 0, 1) the physical inverse square of Cycles. With
        shadows=True, occluders strictly between a point and the light block it. A nonzero `radius`
        (Blender's light Radius) makes it a sphere's light: its highlights spread over the sphere
        as a shaded point sees it (their light kept), and its shadows are its light unchanged times
        the fraction of `samples` shadow rays, toward points spread over the sphere, that nothing
        blocks (soft shadows; soft_shadows=False: hard shadows from its centre)."""
        self._add(
            "add_point_light", _checks.vector3(position, "position"), _checks.color(color, "color"),
            _checks.color(attenuation, "attenuation"), _checks.boolean(shadows, "shadows"),
            _checks.real(radius, "radius"), _checks.c_int(samples, "samples"),
            _checks.boolean(soft_shadows, "soft_shadows"),
        )

    def add_spot_light(
        self,
        position: ArrayLike,
        direction: ArrayLike,
        color: ArrayLike,
        *,
        half_angle_degrees: float,
        blend: float = 0.0,
        attenuation: ArrayLike = (1.0, 0.0, 0.0),
        shadows: bool = False,
        radius: float = 0.0,
        samples: int = 16,
        soft_shadows: bool = True,
    ) -> None:
        """A point light that shines along `direction` within a cone of `half_angle_degrees` in
        (0, 180). `blend` in [0, 1] softens the edge as Blender's spot blend does:
        smoothstep((cos θ − cos half) / ((1 − cos half)·blend)); 0 is a hard edge. `attenuation`,
        `shadows`, `radius`, `samples` and `soft_shadows` as for point lights."""
        half = _checks.finite_real(half_angle_degrees, "half_angle_degrees")
        if not 0 < half < 180:
            raise ValueError(f"half_angle_degrees must be in (0, 180), got {half}")
        self._add(
            "add_spot_light",
            _checks.vector3(position, "position"), _checks.vector3(direction, "direction"),
            _checks.color(color, "color"), _checks.color(attenuation, "attenuation"),
            math.cos(math.radians(half)), _checks.real(blend, "blend"), _checks.boolean(shadows, "shadows"),
            _checks.real(radius, "radius"), _checks.c_int(samples, "samples"),
            _checks.boolean(soft_shadows, "soft_shadows"),
        )

    def add_area_light(
        self,
        position: ArrayLike,
        u: ArrayLike,
        v: ArrayLike,
        color: ArrayLike,
        *,
        ellipse: bool = False,
        samples: int = 16,
        shadows: bool = False,
    ) -> None:
        """A one-sided Lambertian light (Blender's area light): the parallelogram centred at
        `position` with edge vectors `u` and `v` (the rectangle of sides |u| and |v| when they are
        perpendicular), or with ellipse=True the ellipse inscribed in it, shining toward u × v.
        `color` (linear RGB >= 0) is its intensity along that normal, in a point light's units with
        inverse-square falloff: far away it lights as a point light of colour color·cos θ (θ off the
        normal), and nothing behind it. Near it, a shaded point receives the integral over the
        surface, estimated from `samples` points on it (at least 1, stratified, new ones for each
        pixel sample); with shadows=True each casts a shadow ray, so shadows are soft. A reflective
        material shows it where its mirror direction meets it: reflective · π·color / area (its
        radiance), unless something stands in the way."""
        self._add(
            "add_area_light",
            _checks.vector3(position, "position"), _checks.vector3(u, "u"), _checks.vector3(v, "v"),
            _checks.color(color, "color"), _checks.boolean(ellipse, "ellipse"), _checks.c_int(samples, "samples"),
            _checks.boolean(shadows, "shadows"),
        )

    @property
    def shading(self) -> str:
        """"auto" (default): lit where the scene has lights, else every hit takes its flat colour
        (diffuse + emission); "flat" always; "lit" always (with no lights: emission + ambient·kd)."""
        return self._core.shading

    @shading.setter
    def shading(self, mode: str) -> None:
        self._core.shading = _checks.string(mode, "shading")

    @property
    def background(self) -> tuple[float, float, float, float]:
        """What rays that meet nothing see (linear RGB) and, as alpha, how much of a pixel whose
        camera ray meets nothing it covers: such pixels are premultiplied, (r·a, g·a, b·a, a),
        while mirrors and glass show (r, g, b) whatever a is (a transparent film still reflects
        the world). Default (0, 0, 0, 1). Set RGB (alpha 1) or RGBA."""
        return tuple(self._core.background)

    @background.setter
    def background(self, value: ArrayLike) -> None:
        rgba = _checks.color(value, "background", (3, 4))
        self._core.background = rgba if len(rgba) == 4 else (*rgba, 1.0)

    @property
    def ambient(self) -> tuple[float, float, float]:
        """Ambient light, linear RGB; used only when the scene has lights (default black)."""
        return tuple(self._core.ambient)

    @ambient.setter
    def ambient(self, value: ArrayLike) -> None:
        self._core.ambient = _checks.color(value, "ambient")

    # --- counts ----------------------------------------------------------------------------------
    @property
    def hierarchy_counts(self) -> dict[str, float]:
        """How the geometry was made ready for tracing over this scene's life: "built" (from
        scratch: a precision's first render or the first after an add), "refitted" (after
        move_spheres), "rebuilt" (sphere hierarchies rebuilt during a refit as moving had degraded
        them), "milliseconds" (all of it)."""
        return self._core.hierarchy_counts

    @property
    def sphere_count(self) -> int:
        return self._core.sphere_count

    @property
    def plane_count(self) -> int:
        return self._core.plane_count

    @property
    def triangle_count(self) -> int:
        """Triangles, counting every face of every mesh (of every instance: as traced)."""
        return self._core.triangle_count

    @property
    def stored_triangle_count(self) -> int:
        """Triangles stored: a mesh of add_mesh_instances once, however many instances it has."""
        return self._core.stored_triangle_count

    @property
    def box_count(self) -> int:
        return self._core.box_count

    @property
    def transform_count(self) -> int:
        """Transforms in use: distinct ones (objects added with the same matrix share one), and each
        instance of add_mesh_instances."""
        return self._core.transform_count

    @property
    def material_count(self) -> int:
        return self._core.material_count

    @property
    def light_count(self) -> int:
        return self._core.light_count

    @property
    def object_count(self) -> int:
        return self._core.object_count

    def __repr__(self) -> str:
        return (
            f"Scene({self.sphere_count} spheres, {self.plane_count} planes, {self.triangle_count} triangles, "
            f"{self.box_count} boxes, {self.transform_count} transforms, {self.material_count} materials, "
            f"{self.light_count} lights)"
        )


def _owned(array: np.ndarray | None, given: Any) -> np.ndarray | None:
    """`array` (validated from `given`) as the scene's own read-only record: copied unless it is memory
    our conversion made, so that the caller changing what it passed (an ndarray, a memoryview, an
    array.array, any object numpy views without copying) changes neither renders nor pickles."""
    if array is None:
        return None
    # A list or tuple is always converted into new memory; anything else may be viewed, and np.asarray
    # views it as our conversion did (may_share_memory errs towards a needless copy, never an alias).
    if not isinstance(given, (list, tuple)) and np.may_share_memory(array, np.asarray(given)):
        array = array.copy()
    array.flags.writeable = False
    return array


def _superseded(add: tuple[str, tuple[Any, ...], dict[str, Any]], move: tuple[str, tuple[Any, ...], dict[str, Any]]) -> bool:
    """Whether `move` leaves nothing of an earlier `add` (a move of the same spheres that sets
    their radii, or keeps radii the earlier one kept too)."""
    method, args, _ = add
    return (method == "move_spheres" and np.array_equal(args[0], move[1][0])
            and (move[1][2] is not None or args[2] is None))


def _merged_moves(adds: list[tuple[str, tuple[Any, ...], dict[str, Any]]]) -> list:
    """`adds` with their moves replaced by at most two at the end that leave every sphere where they
    left it: one with radii for the spheres some move gave a radius (its last), one without for the
    others (every id existed by the end of `adds`; the spheres' final state is all a replay keeps)."""
    moves = [args for method, args, _ in adds if method == "move_spheres"]
    ids = np.concatenate([m[0] for m in moves])
    centers = np.concatenate([m[1] for m in moves])
    sized = any(m[2] is not None for m in moves)
    radii = np.concatenate([np.full(len(m[0]), np.nan) if m[2] is None else m[2] for m in moves]) if sized else None
    unique, last = _last_of_each(ids)
    given = np.flatnonzero(~np.isnan(radii)) if sized else np.zeros(0, np.int64)  # the entries that set a radius
    radius_ids, last_radius = _last_of_each(ids[given])
    with_radius = np.isin(unique, radius_ids, assume_unique=True)  # both sorted: aligned
    merged = [add for add in adds if add[0] != "move_spheres"]
    for chosen, sizes in ((with_radius, radii[given[last_radius]] if sized else None), (~with_radius, None)):
        if chosen.any():
            args = (unique[chosen], centers[last[chosen]], sizes)
            for array in args:
                if array is not None:
                    array.flags.writeable = False  # read-only, as every recorded array
            merged.append(("move_spheres", args, {}))
    return merged


def _last_of_each(ids: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The distinct `ids` (object ids, >= 0), sorted, and the index of each one's last entry: a
    maximum per id, linear (a sort took ten times as long)."""
    last = np.full(int(ids.max(initial=-1)) + 1, -1, np.int64)
    np.maximum.at(last, ids, np.arange(len(ids)))
    unique = np.flatnonzero(last >= 0)
    return unique.astype(ids.dtype), last[unique]


def _radii(radii: Any, n: int) -> np.ndarray:
    """(n,) float64 radii from (n,) values or one for all (the core checks they are finite and > 0)."""
    array = _checks._numeric_array(radii, "radii")
    if array.ndim == 0:
        array = np.full(n, array, dtype=np.float64)
    return _checks.float_array(array, "radii", (n,), finite=False)


def _material_id(material: Any) -> int:
    """Every add's rule for one material id: an integer (Python's or numpy's, or a 0-d integer array)
    that fits the core's int (the core checks that the material exists)."""
    if isinstance(material, np.ndarray) and material.ndim == 0:
        material = material[()]
    return _checks.c_int(material, "material")


def _material_ids(material: Any, n: int) -> np.ndarray:
    """The materials of an add of n objects as the core takes them: one id for all (as `_material_id`),
    passed as (1,), or (n,) ids."""
    if isinstance(material, numbers.Number) or (isinstance(material, np.ndarray) and material.ndim == 0):
        return np.array([_material_id(material)], dtype=np.int32)
    return _checks.integer_array(material, "material", (n,), np.int32)


def _mesh_arguments(vertices: ArrayLike, faces: ArrayLike, material: int, colors: ArrayLike | None,
                    normals: ArrayLike | None) -> tuple:
    """add_mesh's vertices, faces, material, colors and normals, checked, as the core takes them."""
    given = vertices
    vertices = _checks.float_array(vertices, "vertices", (None, 3))
    face_array = _checks.integer_array(faces, "faces", ("F", 3), np.int64)  # vertex indices: the core checks them
    shapes = (vertices.shape[0], 3), (face_array.shape[0], 3, 3)
    color_array = _checks.one_of_shapes(colors, "colors", *shapes)
    normal_array = _checks.one_of_shapes(normals, "normals", *shapes)
    return (_owned(vertices, given), _owned(face_array, faces), _material_id(material), _owned(color_array, colors),
            _owned(normal_array, normals))
