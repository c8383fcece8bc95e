"""The export's plain data: what a Blender scene turns into, before any core object is made."""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass, field

import numpy as np

from ...material import MATERIAL_FIELDS, material_dataclass

BLACK = (0.0, 0.0, 0.0)
IDENTITY = np.eye(4)
#: Dürer's attenuation (c0, c1, c2) for no falloff (6.837's default) and for Cycles' inverse square.
NO_FALLOFF = (1.0, 0.0, 0.0)
INVERSE_SQUARE = (0.0, 0.0, 1.0)


def _material_key(self) -> tuple:
    """Every field but the name: materials with equal keys render alike."""
    return tuple(getattr(self, f.name) for f in MATERIAL_FIELDS)


def _material_effects(self) -> dict:
    """The keyword arguments of Scene.add_material beyond diffuse/emission that differ from
    their defaults (a plain diffuse material needs none, so it asks for no effect)."""
    out = {}
    if any(self.specular):
        out.update(specular=self.specular, exponent=self.exponent)
    if any(self.reflective):
        out["reflective"] = self.reflective
    if any(self.transparent):
        out.update(transparent=self.transparent, ior=self.ior)
    return out


#: Dürer's material (the 6.837 model, durer.material's fields) of a Blender material `name`.
MaterialData = material_dataclass(
    "MaterialData", leading=(("name", str),), module=__name__,
    namespace={
        "__doc__": "Dürer's material of a Blender material: its `name`, then durer.material's fields.",
        "key": property(_material_key),
        "effects": property(_material_effects),
    },
)


@dataclass
class ObjectData:
    """A Blender object that gave Dürer geometry (instances of one object share it)."""

    #: Unique among the file's objects: Blender's `name_full`, a linked object's name followed by
    #: its library's ("Rock [lib.blend]"), as a local object may have the same name.
    name: str
    pass_index: int  # Blender's object.pass_index (Cycles' IndexOB)


@dataclass
class PlaneData:
    name: str
    owner: int  # index into SceneData.objects
    normal: np.ndarray  # (3,) unit, the face normal (Blender's winding)
    offset: float  # normal · p for points p on the plane
    material: int
    bounds: tuple[np.ndarray, np.ndarray, np.ndarray] | None  # (corner, edge1, edge2) or None: infinite


@dataclass
class TransformedSpheres:
    """Spheres in an object's space under its world matrix: a non-uniform scale or a shear makes
    them ellipsoids (the core intersects them exactly in object space)."""

    name: str
    owner: int  # index into SceneData.objects
    centers: np.ndarray  # (N, 3) object space
    radii: np.ndarray  # (N,) object space
    materials: np.ndarray  # (N,) int32 indices into SceneData.materials
    matrix: np.ndarray  # (4, 4) world-from-object
    colors: np.ndarray | None = None  # (N, 3) kd from attributes (attribute_colors.py), or None
    one_sided: bool = False  # a point cloud's points: met from outside only (SceneData.sphere_one_sided)


@dataclass
class MeshData:
    """One material's triangles of an object, in object space (Blender's float32 coordinates, so
    instances of one mesh share the arrays), and the object's world matrix; in world space (float64,
    the identity) when the matrix is singular, or for a smooth mesh of one user under a non-uniform
    scale or shear (Builder.finish)."""

    name: str
    owner: int  # index into SceneData.objects
    vertices: np.ndarray  # (V, 3) float32 (float64 in world space)
    faces: np.ndarray  # (F, 3) int32
    material: int  # index into SceneData.materials
    matrix: np.ndarray  # (4, 4) world-from-object
    colors: np.ndarray | None = None  # kd from attributes: (V, 3) per vertex or (F, 3, 3) per corner, or None
    #: (K, 4, 4) world-from-object matrices, `matrix` first, when the part is instanced K >= 2 times
    #: (Scene.add_mesh_instances: stored once); None for one.
    instances: np.ndarray | None = None
    #: (K, 3) kd of each instance (geometry-nodes instance attributes), in place of `colors`; or None.
    instance_colors: np.ndarray | None = None
    #: (F, 3, 3) each face's normals at its corners, in the vertices' space (a smooth mesh); None: flat faces.
    normals: np.ndarray | None = None

    @property
    def transform(self) -> np.ndarray | None:
        """The matrix for Scene.add_mesh's `transform` (None for the identity: nothing to apply)."""
        return None if np.array_equal(self.matrix, IDENTITY) else self.matrix


@dataclass
class LightData:
    kind: str  # "sun", "point", "spot" or "area"
    name: str
    color: np.ndarray  # (3,) Dürer colour: already includes strength and the radiometric factors
    direction: np.ndarray | None = None  # the way the light travels (sun, spot axis)
    position: np.ndarray | None = None  # point, spot; area: its centre
    falloff: str = "none"  # "none" (sun), "inverse_square" (point, spot) or "custom" (light.durer)
    attenuation: tuple[float, float, float] = NO_FALLOFF  # (c0, c1, c2): colour / (c0 + c1·d + c2·d²)
    spot_half_angle: float = math.pi  # radians
    spot_blend: float = 0.0  # Blender's spot_blend: smoothstep over (1 - cos half angle)·blend in cos
    shadows: bool = True  # Blender's light.use_shadow ("Cast Shadow")
    size: float = 0.0  # point, spot: the Radius (shadow_soft_size); sun: the Angle (radians, the disc's diameter)
    #: area: the world-space edge vectors u, v of its rectangle (u × v the way it shines), and
    #: whether it is the ellipse inscribed in it (Disk, Ellipse). Its colour is its intensity along u × v.
    edges: tuple[np.ndarray, np.ndarray] | None = None
    ellipse: bool = False


@dataclass
class LensData:
    """A camera's thin lens, as Cycles reads Blender's Depth of Field; the defaults are a pinhole
    (durer's cameras' aperture fields, which these are named after)."""

    aperture_radius: float = 0.0  # world units
    focus_distance: float | None = None  # the plane of focus along the view axis; None without an aperture
    aperture_blades: int = 0  # 0: a disc; >= 3: a regular polygon
    aperture_rotation: float = 0.0  # radians
    aperture_ratio: float = 1.0  # > 1 narrows the aperture horizontally (an anamorphic lens)


@dataclass
class CameraData:
    name: str
    projection: str  # "orthographic" or "perspective"
    center: np.ndarray
    direction: np.ndarray  # unit view axis (the camera's -Z)
    up: np.ndarray  # unit (the camera's +Y)
    size: float  # orthographic: ortho_scale; perspective: unused (see fov_degrees)
    fov_degrees: float  # perspective: the angle the fitted extent spans
    fit: str  # resolved: "horizontal" or "vertical" (Blender's AUTO resolved like Blender does)
    sensor_fit: str  # Blender's setting: "AUTO", "HORIZONTAL" or "VERTICAL"
    shift: tuple[float, float]  # in units of the fitted extent (Blender's shift_x, shift_y)
    clip_start: float
    clip_end: float
    width: int  # pixels, after resolution percentage
    height: int
    pixel_aspect: float  # pixel height / pixel width (Blender's pixel_aspect_y / pixel_aspect_x)
    lens: LensData = field(default_factory=LensData)  # depth of field (the default: none)

    @property
    def extent(self) -> float:
        """Fitted image-plane extent: world units (orthographic) or at unit distance (perspective)."""
        if self.projection == "orthographic":
            return self.size
        return 2.0 * math.tan(math.radians(self.fov_degrees) / 2.0)

    def view_plane(self) -> tuple[float, float, float, float]:
        """(left, right, bottom, top) of the image window in camera units, shift included:
        world units for orthographic, at unit distance for perspective (Blender's view frame)."""
        extent = self.extent
        aspect_h = self.height * self.pixel_aspect
        if self.fit == "horizontal":
            w, h = extent, extent * aspect_h / self.width
        else:
            w, h = extent * self.width / aspect_h, extent
        sx, sy = self.shift[0] * extent, self.shift[1] * extent
        return (-w / 2 + sx, w / 2 + sx, -h / 2 + sy, h / 2 + sy)


@dataclass
class SceneData:
    sphere_centers: np.ndarray = field(default_factory=lambda: np.empty((0, 3)))
    sphere_radii: np.ndarray = field(default_factory=lambda: np.empty(0))
    sphere_materials: np.ndarray = field(default_factory=lambda: np.empty(0, np.int32))
    #: The Blender object of each world-space sphere: (N,) int32 indices into `objects`.
    sphere_owners: np.ndarray = field(default_factory=lambda: np.empty(0, np.int32))
    #: (N, 3) kd of each world-space sphere where some have attribute colours (the others: their
    #: material's kd), else None.
    sphere_colors: np.ndarray | None = None
    #: (N,) bool: which world-space spheres are a point cloud's points, met from outside only as
    #: Cycles meets them (a camera or clip start inside one sees what lies beyond); None if none is.
    sphere_one_sided: np.ndarray | None = None
    #: Spheres under a non-uniform scale or shear (ellipsoids), per object.
    transformed_spheres: list[TransformedSpheres] = field(default_factory=list)
    planes: list[PlaneData] = field(default_factory=list)
    #: Triangle meshes, one per object and material slot used.
    meshes: list[MeshData] = field(default_factory=list)
    materials: list[MaterialData] = field(default_factory=list)
    #: Blender's material.pass_index of each of `materials` (Cycles' IndexMA; 0 without a material).
    material_pass_indices: list[int] = field(default_factory=list)
    #: The Blender objects that gave geometry, in the order they first did.
    objects: list[ObjectData] = field(default_factory=list)
    lights: list[LightData] = field(default_factory=list)
    camera: CameraData | None = None
    background: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 1.0)
    ambient: tuple[float, float, float] = (0.0, 0.0, 0.0)
    #: durer.render's ambient_occlusion=(samples, distance), None when off.
    ambient_occlusion: tuple[int, float] | None = None
    #: Points sampled on each area light, or shadow rays toward a light of some size, per shaded hit
    #: (scene.durer.light_samples).
    light_samples: int = 16
    #: Whether point and spot lights' Radius and suns' Angle soften their shadows (scene.durer.soft_shadows).
    soft_shadows: bool = False
    #: Number of Dürer objects (spheres, planes, meshes) each Blender object contributed, by its
    #: unique name (ObjectData.name).
    sources: Counter = field(default_factory=Counter)
    #: Geometry Dürer cannot render, counted by a short description ("volume", "hair curves", ...).
    skipped: Counter = field(default_factory=Counter)
    #: Other messages for the user (unsupported world or light settings, ...).
    notes: list[str] = field(default_factory=list)

    @property
    def sphere_count(self) -> int:
        """World-space spheres (`sphere_centers`); `transformed_spheres` are counted apart."""
        return len(self.sphere_radii)

    @property
    def ellipsoid_count(self) -> int:
        return sum(len(g.radii) for g in self.transformed_spheres)

    @property
    def triangle_count(self) -> int:
        """Triangles as rendered: an instanced part's once per instance."""
        return sum(len(m.faces) * (1 if m.instances is None else len(m.instances)) for m in self.meshes)

    @property
    def warnings(self) -> list[str]:
        """Messages to show the user once per export (the engine reports them as warnings)."""
        out = []
        if self.skipped:
            listed = ", ".join(f"{n} {kind}" for kind, n in sorted(self.skipped.items()))
            out.append(f"Dürer skipped geometry it cannot render: {listed}")
        out.extend(dict.fromkeys(self.notes))  # once each: a light or material met many times says it once
        return out
