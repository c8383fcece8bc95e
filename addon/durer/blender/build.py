"""Exported Blender data (`export.SceneData`) -> Dürer's core objects (scene and camera), and
Dürer's passes -> Blender's conventions.

Everything that depends on the core's API lives here, so the export stays plain data.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import asdict, dataclass, fields, is_dataclass
from typing import Any

import numpy as np

import durer

from .export import CameraData, SceneData
from .export.depsgraph import CONVERTERS

#: Blender's Depth pass holds this where no object is hit (Cycles writes 1e10).
DEPTH_MISS = 1.0e10


def make_camera(cam: CameraData) -> durer.OrthographicCamera | durer.PerspectiveCamera:
    """The Dürer camera for Blender's camera parameters (fit, shift, pixel aspect, clip range, depth
    of field)."""
    common = {
        "fit": cam.fit,
        "shift": cam.shift,
        "pixel_aspect": cam.pixel_aspect,
        "t_min": cam.clip_start,
        "t_max": cam.clip_end,
        **asdict(cam.lens),
    }
    center, direction, up = tuple(cam.center), tuple(cam.direction), tuple(cam.up)
    if cam.projection == "orthographic":
        # Cycles starts orthographic rays on the camera plane + clip_start; depth counts from the plane.
        return durer.OrthographicCamera(center, direction, up, size=cam.size, **common)
    # Cycles clips perspective rays at planes along the view axis.
    return durer.PerspectiveCamera(center, direction, up, fov_degrees=cam.fov_degrees, clip_planes=True, **common)


def make_scene(data: SceneData) -> durer.Scene:
    """The Dürer scene: materials (with the Phong, mirror and refraction parameters the export
    mapped from Blender's shaders), spheres, ellipsoids, planes (normals as Blender's winding gives
    them), triangle meshes (spheres and meshes with their attribute colours as kd, where the export
    read some), lights, world. Which side of a surface is shaded is the render's `shade_back`
    setting (the core flips the normal toward the ray, as Cycles does). Materials and objects are
    added in the order `IdTables` relies on (the core numbers them in add order)."""
    scene = durer.Scene()
    # Only the effect parameters a material uses are passed: a diffuse material asks for no effect.
    table = np.array(
        [scene.add_material(diffuse=m.diffuse, emission=m.emission, **m.effects) for m in data.materials],
        dtype=np.int32,
    )
    if data.sphere_count:
        scene.add_spheres(data.sphere_centers, data.sphere_radii, material=table[data.sphere_materials],
                          colors=data.sphere_colors,
                          one_sided=False if data.sphere_one_sided is None else data.sphere_one_sided)
    for g in data.transformed_spheres:
        scene.add_spheres(g.centers, g.radii, material=table[g.materials], transform=g.matrix, colors=g.colors,
                          one_sided=g.one_sided)
    for p in data.planes:
        scene.add_plane(p.normal, p.offset, material=int(table[p.material]), bounds=p.bounds)
    for mesh in data.meshes:
        if mesh.instances is not None:
            scene.add_mesh_instances(mesh.vertices, mesh.faces, mesh.instances, material=int(table[mesh.material]),
                                     colors=mesh.colors, instance_colors=mesh.instance_colors, normals=mesh.normals)
        else:
            scene.add_mesh(mesh.vertices, mesh.faces, material=int(table[mesh.material]), transform=mesh.transform,
                           colors=mesh.colors, normals=mesh.normals)
    for light in data.lights:
        attenuation = light.attenuation
        size, soft = light.size, data.soft_shadows  # the size spreads highlights with soft shadows off too
        if light.kind == "sun":
            scene.add_directional_light(light.direction, light.color, shadows=light.shadows,
                                        angle_degrees=min(math.degrees(size), 179.999), samples=data.light_samples,
                                        soft_shadows=soft)
        elif light.kind == "spot":
            scene.add_spot_light(
                light.position,
                light.direction,
                light.color,
                half_angle_degrees=min(math.degrees(light.spot_half_angle), 179.999),
                blend=min(max(light.spot_blend, 0.0), 1.0),
                attenuation=attenuation,
                shadows=light.shadows,
                radius=size,
                samples=data.light_samples,
                soft_shadows=soft,
            )
        elif light.kind == "area":
            scene.add_area_light(light.position, *light.edges, light.color, ellipse=light.ellipse,
                                 samples=data.light_samples, shadows=light.shadows)
        else:
            scene.add_point_light(light.position, light.color, attenuation=attenuation, shadows=light.shadows,
                                  radius=size, samples=data.light_samples, soft_shadows=soft)
    scene.shading = "lit"  # a Blender scene without lights shows only the world's light, never flat colours
    scene.background = data.background
    scene.ambient = data.ambient
    return scene


@dataclass
class IdTables:
    """The core's ids -> Blender's index passes, as float32 lookup tables indexed by core id + 1
    (entry 0: a miss, -1, which Blender's passes show as 0, as Cycles' background)."""

    #: By core object id: the Blender object's pass_index (IndexOB).
    object_pass_index: np.ndarray
    #: By core object id: the Blender object's Object ID (`object_numbers`); None when not asked for.
    object_number: np.ndarray | None
    #: By core material id: the Blender material's pass_index (IndexMA).
    material_pass_index: np.ndarray

    @classmethod
    def of(cls, data: SceneData, numbers: Mapping[str, int] | None) -> IdTables:
        """The tables of the core scene make_scene(data) builds: material 0 is the core's default
        (unused), then data.materials in order; objects in make_scene's add order (world-space
        spheres, each ellipsoid, planes, meshes), one core object per sphere, plane or mesh.
        `numbers`: the Object ID of every object in data.objects by its name (`object_numbers`), or
        None when the Object ID pass is not wanted."""
        owners = np.concatenate([
            data.sphere_owners,
            *(np.full(len(g.radii), g.owner, np.int32) for g in data.transformed_spheres),
            np.array([p.owner for p in data.planes], np.int32),
            np.array([m.owner for m in data.meshes], np.int32),
        ]).astype(np.intp)
        object_pass = np.array([o.pass_index for o in data.objects], np.float32)
        number = None if numbers is None else np.array([numbers[o.name] for o in data.objects], np.float32)
        return cls(
            object_pass_index=np.concatenate([[0], object_pass[owners]]).astype(np.float32),
            object_number=None if number is None else np.concatenate([[0], number[owners]]).astype(np.float32),
            material_pass_index=np.array([0, 0, *data.material_pass_indices], np.float32),
        )

    @staticmethod
    def lookup(table: np.ndarray, core_ids: np.ndarray) -> np.ndarray:
        """A Blender pass: table[core id + 1] per pixel (core ids -1 on a miss)."""
        return table[core_ids.astype(np.intp) + 1]


def object_numbers(file_objects: Iterable, data: SceneData) -> dict[str, int]:
    """Dürer's Object ID of each object by its unique name (`name_full`): its place, from 1, among
    the names of the file's objects (`bpy.data.objects`) of the types Dürer renders, sorted;
    hidden, excluded or in another scene, each is numbered, so that an object keeps its id on
    every frame, view layer and render of the file while no object is added, removed or renamed.
    The objects `data` holds are numbered too (they are the file's: evaluated objects and the
    geometry their nodes make carry their original's name)."""
    names = {obj.name_full for obj in file_objects if obj.type in CONVERTERS}
    names.update(o.name for o in data.objects)
    return {name: number for number, name in enumerate(sorted(names), 1)}


def update_scene(previous: tuple[SceneData, durer.Scene] | None, data: SceneData) -> tuple[durer.Scene, bool]:
    """The core scene for `data`, and whether it is `previous`'s (the data it was made from, and
    it): reused, its world-space spheres moved, when nothing else differs but the camera (an
    animation's next frame of moving particles: the core refits the sphere hierarchy instead of
    building it again); else made anew."""
    if previous is not None:
        old, scene = previous
        if len(old.sphere_radii) == len(data.sphere_radii) and all(
                same_data(getattr(old, f.name), getattr(data, f.name)) for f in fields(data) if f.name not in _MOVABLE):
            if not (same_data(old.sphere_centers, data.sphere_centers) and same_data(old.sphere_radii, data.sphere_radii)):
                # make_scene adds the world-space spheres first: their object ids are 0..N-1.
                scene.move_spheres(np.arange(data.sphere_count), data.sphere_centers, data.sphere_radii)
            return scene, True
    return make_scene(data), False


#: What update_scene lets differ between two exports of one core scene.
_MOVABLE = {"sphere_centers", "sphere_radii", "camera"}


def same_data(a: Any, b: Any) -> bool:
    """Equality through the export's dataclasses, lists, dicts and numpy arrays."""
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return np.array_equal(a, b)
    if is_dataclass(a):
        return type(a) is type(b) and all(same_data(getattr(a, f.name), getattr(b, f.name)) for f in fields(a))
    if isinstance(a, (list, tuple)):
        return type(a) is type(b) and len(a) == len(b) and all(map(same_data, a, b))
    if isinstance(a, dict):
        return isinstance(b, dict) and a.keys() == b.keys() and all(same_data(a[k], b[k]) for k in a)
    return bool(a == b)


def view_depth(depth: np.ndarray) -> np.ndarray:
    """Dürer's planar depth pass (`durer.render(..., depth="planar")`: the distance along the view
    axis, as Cycles) -> Blender's Depth pass: DEPTH_MISS where no object is hit, top row first."""
    depth = np.asarray(depth, dtype=np.float32)
    return np.where(np.isfinite(depth), depth, np.float32(DEPTH_MISS)).astype(np.float32)
