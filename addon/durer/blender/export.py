"""Blender's evaluated depsgraph -> plain numpy data (`SceneData`) that Dürer can render.

Nothing here calls the renderer, so tests can inspect exactly what a Blender scene turns into.
Conventions (verified against Cycles in bpy 5.0.1, see docs/blender.md):

* Geometry comes from ``depsgraph.object_instances`` (geometry-nodes and collection instances
  count). Point clouds become one sphere per point (bulk ``foreach_get``, no per-point Python);
  meshes whose vertices all lie on one sphere become that sphere; empties displayed as spheres and
  metaball balls become spheres; flat quad meshes become bounded planes; every other mesh, curve,
  text and surface becomes triangles (its loop triangles, one Dürer mesh per material slot used,
  in object space with the object's matrix). ``object.durer.primitive`` overrides the detection
  (Auto / Sphere / Plane / Mesh / Ignore); what Dürer cannot render (volumes, hair curves, grease
  pencil, metaball capsules, area lights) is skipped and counted.
* Spheres under a uniform scale are exported in world space; under a non-uniform scale or a
  shear they keep their object-space centre and radius with the object's matrix, which the core
  renders exactly as an ellipsoid.
* Lights are radiometric as in Cycles: a Sun of strength S gives irradiance S, so its Dürer colour
  (which multiplies kd·max(N·L, 0) with no 1/pi) is colour·S/pi; a Point or Spot light of power P
  has intensity colour·P/(4·pi²) with inverse-square falloff (Cycles' diffuse BRDF is kd/pi), or
  with the falloff ``light.durer`` states (6.837's c0 + c1·d + c2·d²).
* Materials become 6.837 materials (see `material_data`): ``material.durer`` states one exactly;
  else Principled metallic and specular
  reflectance make a mirror (roughness <= MIRROR_ROUGHNESS) or a Phong highlight of the same width
  and peak, transmission makes a transparent colour with the IOR. Light "Cast Shadow" -> shadows.
* The camera keeps Blender's parameters (fit, shift in units of the fitted extent, clip range,
  pixel aspect) and the resolved image size.
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass, field

import numpy as np

from .triangles import TrianglePart, triangle_parts

#: Relative tolerance for "all vertices at the same distance from the centroid".
SPHERE_TOLERANCE = 1e-3
#: A sphere mesh's faces must be close to the sphere: every face centre at least this fraction of
#: the radius from the centre (rejects cubes, cylinders and octahedra, whose corners are equidistant).
SPHERE_FACE_FRACTION = 0.85
#: Auto-detected sphere meshes need at least this many vertices (an icosahedron has 12).
SPHERE_MIN_VERTICES = 12
#: Relative tolerance for flatness and for "the faces cover their bounding rectangle".
PLANE_TOLERANCE = 1e-5
#: Relative spread of an object's axis scales above which its scale counts as non-uniform.
SCALE_TOLERANCE = 1e-4

# Object types whose evaluated mesh also appears among the depsgraph's instances.
_CONVERTED_TYPES = {"CURVE", "SURFACE", "FONT", "META"}
# Object types that carry geometry: when Dürer cannot render one, it is listed in the warning.
_GEOMETRY_TYPES = {"MESH", "CURVE", "SURFACE", "FONT", "META", "CURVES", "POINTCLOUD", "VOLUME", "GREASEPENCIL"}
# Object types that Auto renders as the triangles of their evaluated mesh.
_TRIANGULATED_TYPES = {"CURVE", "SURFACE", "FONT"}


#: Roughness at or below which a specular lobe is a mirror (reflection rays); above it, the lobe is
#: a Phong highlight of the lights. At 0.2 the GGX width alpha = roughness² is 0.04, the Phong
#: exponent of the same width ~1250: reflections in Cycles are still sharp there.
MIRROR_ROUGHNESS = 0.2
#: Phong exponents are clamped to [1, MAX_EXPONENT] (roughness 1 gives 2/α² − 2 = 0).
MAX_EXPONENT = 1.0e4

_BLACK = (0.0, 0.0, 0.0)
_IDENTITY = np.eye(4)
#: Dürer's attenuation (c0, c1, c2) for no falloff (6.837's default) and for Cycles' inverse square.
NO_FALLOFF = (1.0, 0.0, 0.0)
INVERSE_SQUARE = (0.0, 0.0, 1.0)


@dataclass
class MaterialData:
    """Dürer's material (the 6.837 model): kd (`diffuse`), emission, Phong ks (`specular`) with
    `exponent`, mirror `reflective` colour, `transparent` colour with index of refraction `ior`."""

    name: str
    diffuse: tuple[float, float, float]
    emission: tuple[float, float, float] = _BLACK
    specular: tuple[float, float, float] = _BLACK
    exponent: float = 1.0
    reflective: tuple[float, float, float] = _BLACK
    transparent: tuple[float, float, float] = _BLACK
    ior: float = 1.0

    @property
    def key(self) -> tuple:
        return (self.diffuse, self.emission, self.specular, self.exponent, self.reflective, self.transparent, self.ior)

    @property
    def effects(self) -> dict:
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


@dataclass
class PlaneData:
    name: str
    normal: np.ndarray  # (3,) unit, the face normal (Blender's winding)
    offset: float  # normal · p for points p on the plane
    material: int
    bounds: tuple[np.ndarray, np.ndarray, np.ndarray] | None  # (corner, edge1, edge2) or None: infinite


@dataclass
class TransformedSpheres:
    """Spheres in an object's space under its world matrix: a non-uniform scale or a shear makes
    them ellipsoids (the core intersects them exactly in object space)."""

    name: str
    centers: np.ndarray  # (N, 3) object space
    radii: np.ndarray  # (N,) object space
    materials: np.ndarray  # (N,) int32 indices into SceneData.materials
    matrix: np.ndarray  # (4, 4) world-from-object


@dataclass
class MeshData:
    """One material's triangles of an object, in object space (Blender's float32 coordinates, so
    instances of one mesh share the arrays), and the object's world matrix."""

    name: str
    vertices: np.ndarray  # (V, 3) float32 (float64 in world space when the matrix is singular)
    faces: np.ndarray  # (F, 3) int32
    material: int  # index into SceneData.materials
    matrix: np.ndarray  # (4, 4) world-from-object

    @property
    def transform(self) -> np.ndarray | None:
        """The matrix for Scene.add_mesh's `transform` (None for the identity: nothing to apply)."""
        return None if np.array_equal(self.matrix, _IDENTITY) else self.matrix


@dataclass
class LightData:
    kind: str  # "sun", "point" or "spot"
    name: str
    color: np.ndarray  # (3,) Dürer colour: already includes strength and the radiometric factors
    direction: np.ndarray | None = None  # the way the light travels (sun, spot axis)
    position: np.ndarray | None = None  # point, spot
    falloff: str = "none"  # "none" (sun), "inverse_square" (point, spot) or "custom" (light.durer)
    attenuation: tuple[float, float, float] = NO_FALLOFF  # (c0, c1, c2): colour / (c0 + c1·d + c2·d²)
    spot_half_angle: float = math.pi  # radians
    spot_blend: float = 0.0  # Blender's spot_blend: smoothstep over (1 - cos half angle)·blend in cos
    shadows: bool = True  # Blender's light.use_shadow ("Cast Shadow")


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
    #: Spheres under a non-uniform scale or shear (ellipsoids), per object.
    transformed_spheres: list[TransformedSpheres] = field(default_factory=list)
    planes: list[PlaneData] = field(default_factory=list)
    #: Triangle meshes, one per object and material slot used.
    meshes: list[MeshData] = field(default_factory=list)
    materials: list[MaterialData] = field(default_factory=list)
    lights: list[LightData] = field(default_factory=list)
    camera: CameraData | None = None
    background: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 1.0)
    ambient: tuple[float, float, float] = (0.0, 0.0, 0.0)
    #: Number of Dürer objects (spheres, planes, meshes) each Blender object contributed, by name.
    sources: Counter = field(default_factory=Counter)
    #: Geometry Dürer cannot render, counted by a short description ("volume", "area light", ...).
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
        return sum(len(m.faces) for m in self.meshes)

    @property
    def warnings(self) -> list[str]:
        """Messages to show the user once per export (the engine reports them as warnings)."""
        out = []
        if self.skipped:
            listed = ", ".join(f"{n} {kind}" for kind, n in sorted(self.skipped.items()))
            out.append(f"Dürer skipped geometry it cannot render: {listed}")
        out.extend(self.notes)
        return out


# ------------------------------------------------------------------------------------------------
# helpers


def _matrix(m) -> np.ndarray:
    return np.array(m, dtype=np.float64).reshape(4, 4)


def _scale(m: np.ndarray) -> tuple[float, bool]:
    """Uniform scale factor of a 4x4 matrix (geometric mean of the axis scales) and whether the
    linear part is a uniform scale times a rotation."""
    lin = m[:3, :3]
    norms = np.linalg.norm(lin, axis=0)
    det = abs(float(np.linalg.det(lin)))
    s = det ** (1.0 / 3.0)
    if s == 0.0:
        return 0.0, False
    gram = lin.T @ lin / (s * s)
    uniform = bool(np.abs(gram - np.eye(3)).max() <= SCALE_TOLERANCE) and bool(
        np.ptp(norms) <= SCALE_TOLERANCE * norms.max()
    )
    return s, uniform


def _invertible(m: np.ndarray) -> bool:
    """Can the core take `m` as a transform (it maps rays into object space with the inverse)?"""
    return bool(np.linalg.cond(m[:3, :3]) < 1e12)


def _transform_points(m: np.ndarray, p: np.ndarray) -> np.ndarray:
    return p @ m[:3, :3].T + m[:3, 3]


def _get(collection, attr: str, n: int, width: int, dtype=np.float32) -> np.ndarray:
    buf = np.empty(n * width, dtype=dtype)
    collection.foreach_get(attr, buf)
    return buf.reshape(n, width) if width > 1 else buf


def _durer_settings(obj):
    """object.durer of the original object (evaluated copies can hold stale values; geometry
    instances made by geometry nodes report their instancer as original)."""
    original = getattr(obj, "original", None) or obj
    return getattr(original, "durer", None)


def _socket_value(node, name: str):
    sock = node.inputs.get(name)
    if sock is None:
        return None, False
    return sock.default_value, sock.is_linked


def _rgb(value) -> tuple[float, float, float]:
    return (float(value[0]), float(value[1]), float(value[2]))


def _color_input(node, name: str, fallback) -> tuple[float, float, float]:
    """An unlinked colour socket's value; `fallback` when linked (a texture) or absent."""
    value, linked = _socket_value(node, name)
    return _rgb(fallback) if value is None or linked else _rgb(value)


def _scalar_input(node, name: str, fallback: float) -> float:
    """An unlinked value socket's value; `fallback` when linked or absent."""
    value, linked = _socket_value(node, name)
    return float(fallback) if value is None or linked else float(value)


def _clamp01(x: float) -> float:
    return min(max(float(x), 0.0), 1.0)


def _scale3(c, k) -> tuple[float, float, float]:
    """c × k, k a number or an RGB triple."""
    k = (k, k, k) if isinstance(k, (int, float)) else k
    return (float(c[0] * k[0]), float(c[1] * k[1]), float(c[2] * k[2]))


def _add3(a, b) -> tuple[float, float, float]:
    return (float(a[0] + b[0]), float(a[1] + b[1]), float(a[2] + b[2]))


def fresnel_f0(ior: float) -> float:
    """Reflectance at normal incidence of a dielectric of index `ior` in air: ((n − 1)/(n + 1))²."""
    n = max(float(ior), 0.0)
    return ((n - 1.0) / (n + 1.0)) ** 2


def conductor_f0(ior, extinction) -> tuple[float, float, float]:
    """Reflectance at normal incidence of a conductor (complex index n + ik), per channel."""
    return tuple(float(((n - 1) ** 2 + k * k) / ((n + 1) ** 2 + k * k)) for n, k in zip(ior, extinction))


def phong_exponent(roughness: float) -> float:
    """The Blinn-Phong exponent whose lobe is as wide as a microfacet lobe of Blender's roughness
    r: α = r² (Blender's GGX/Beckmann width) and n = 2/α² − 2 (Walter et al. 2007), in [1, MAX_EXPONENT]."""
    alpha = max(float(roughness), 0.0) ** 2
    if alpha <= 0.0:
        return MAX_EXPONENT
    return min(max(2.0 / (alpha * alpha) - 2.0, 1.0), MAX_EXPONENT)


def specular_lobe(color, roughness: float) -> dict:
    """A specular lobe of reflectance `color` (at normal incidence) and Blender roughness:
    a mirror (``reflective = color``) at roughness <= MIRROR_ROUGHNESS, else a Phong highlight of
    the same width (``exponent = phong_exponent(roughness)``) and the same peak as a normalised
    Blinn-Phong BRDF of that reflectance, ``specular = color × (n + 8)/8`` (Dürer's light colours
    already include Cycles' 1/π)."""
    if not any(color):
        return {}
    if np.float32(roughness) <= np.float32(MIRROR_ROUGHNESS):  # Blender stores float32 roughness
        return {"reflective": _rgb(color)}
    n = phong_exponent(roughness)
    return {"specular": _scale3(color, (n + 8.0) / 8.0), "exponent": n}


def _principled(mat, node, viewport) -> MaterialData:
    """Principled BSDF, with b = Base Color, m = Metallic, t = Transmission Weight, r = Roughness:

    * specular reflectance  s = b·m + F0·(1 − m), with the dielectric F0 = fresnel_f0(IOR) × 2 ×
      Specular IOR Level × Specular Tint (0.5 is Blender's "no adjustment"), made a mirror or a
      Phong lobe by `specular_lobe`;
    * kd = b·(1 − m)·(1 − t)·(1 − F0);  transparent = b·(1 − m)·t·(1 − F0), ior = IOR (any
      roughness): what the specular layer reflects does not reach the layers below;
    * Emission Color × Strength as emission. Linked inputs use the material's viewport settings.
    """
    base = _color_input(node, "Base Color", viewport)
    metallic = _clamp01(_scalar_input(node, "Metallic", getattr(mat, "metallic", 0.0)))
    roughness = _clamp01(_scalar_input(node, "Roughness", getattr(mat, "roughness", 0.5)))
    ior = max(_scalar_input(node, "IOR", 1.5), 1e-3)
    level = max(_scalar_input(node, "Specular IOR Level", getattr(mat, "specular_intensity", 0.5)), 0.0)
    tint = _color_input(node, "Specular Tint", (1.0, 1.0, 1.0))
    transmission = _clamp01(_scalar_input(node, "Transmission Weight", 0.0))
    f0 = tuple(min(fresnel_f0(ior) * 2.0 * level * c, 1.0) for c in tint)
    spec = _add3(_scale3(base, metallic), _scale3(f0, 1.0 - metallic))
    # What the dielectric specular layer reflects does not reach the diffuse or transmission below.
    below = tuple(1.0 - x for x in f0)
    diffuse = _scale3(_scale3(base, (1.0 - metallic) * (1.0 - transmission)), below)
    transparent = _BLACK
    if transmission > 0.0 and metallic < 1.0:
        transparent = _scale3(_scale3(base, (1.0 - metallic) * transmission), below)
    ecol, elinked = _socket_value(node, "Emission Color")
    estr, _ = _socket_value(node, "Emission Strength")
    emission = _BLACK
    if ecol is not None and estr and not elinked:
        emission = tuple(c * float(estr) for c in _rgb(ecol))
    md = MaterialData(mat.name, diffuse, emission, transparent=transparent, ior=ior if any(transparent) else 1.0)
    return _with_lobe(md, spec, roughness)


def _with_lobe(md: MaterialData, spec, roughness: float) -> MaterialData:
    lobe = specular_lobe(spec, roughness)
    md.reflective = lobe.get("reflective", _BLACK)
    md.specular = lobe.get("specular", _BLACK)
    md.exponent = lobe.get("exponent", 1.0)
    return md


def material_data(mat, obj=None) -> MaterialData:
    """Dürer's material for a Blender material (None: the object's colour).

    Principled BSDF: see `_principled`. Diffuse BSDF: Color. Glossy BSDF: a specular lobe of its
    Color (no diffuse). Metallic BSDF: a specular lobe of its Base Color (F82 Tint) or of the
    conductor's F0 (Physical Conductor). Glass BSDF: transparent Color·(1 − F0) with its IOR plus a
    specular lobe of Color·F0. Refraction BSDF: transparent Color with its IOR. An Emission shader
    alone: unlit, colour × strength. A linked colour (texture) or another shader: the material's
    viewport display colour. ``material.durer`` with its override on comes first: the 6.837
    material it states, as is.
    """
    if mat is None:
        color = _rgb(obj.color) if obj is not None else (0.8, 0.8, 0.8)
        return MaterialData("(object colour)", color)
    override = getattr(getattr(mat, "original", None) or mat, "durer", None)
    if override is not None and override.use_override:
        return override_material(mat.name, override)
    viewport = _rgb(mat.diffuse_color)
    tree = mat.node_tree
    if tree is None:
        return MaterialData(mat.name, viewport)
    outputs = [n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputMaterial"]
    output = next((n for n in outputs if n.is_active_output), outputs[0] if outputs else None)
    if output is None or not output.inputs["Surface"].is_linked:
        return MaterialData(mat.name, viewport)
    node = output.inputs["Surface"].links[0].from_node
    kind = node.bl_idname
    if kind == "ShaderNodeBsdfPrincipled":
        return _principled(mat, node, viewport)
    if kind == "ShaderNodeBsdfDiffuse":
        return MaterialData(mat.name, _color_input(node, "Color", viewport))
    if kind == "ShaderNodeEmission":
        col = _color_input(node, "Color", viewport)
        strength, _ = _socket_value(node, "Strength")
        strength = float(strength)
        return MaterialData(mat.name, _BLACK, tuple(c * strength for c in col))
    roughness = _clamp01(_scalar_input(node, "Roughness", getattr(mat, "roughness", 0.5)))
    if kind in {"ShaderNodeBsdfGlossy", "ShaderNodeBsdfAnisotropic"}:
        return _with_lobe(MaterialData(mat.name, _BLACK), _color_input(node, "Color", viewport), roughness)
    if kind == "ShaderNodeBsdfMetallic":
        if getattr(node, "fresnel_type", "F82") == "PHYSICAL_CONDUCTOR":
            n, nl = _socket_value(node, "IOR")
            k, kl = _socket_value(node, "Extinction")
            spec = viewport if nl or kl else conductor_f0(n, k)
        else:
            spec = _color_input(node, "Base Color", viewport)
        return _with_lobe(MaterialData(mat.name, _BLACK), spec, roughness)
    if kind in {"ShaderNodeBsdfGlass", "ShaderNodeBsdfRefraction"}:
        color = _color_input(node, "Color", viewport)
        ior = max(_scalar_input(node, "IOR", 1.5), 1e-3)
        if kind == "ShaderNodeBsdfRefraction":
            return MaterialData(mat.name, _BLACK, transparent=color, ior=ior if any(color) else 1.0)
        f0 = fresnel_f0(ior)
        transparent = _scale3(color, 1.0 - f0)
        md = MaterialData(mat.name, _BLACK, transparent=transparent, ior=ior if any(transparent) else 1.0)
        return _with_lobe(md, _scale3(color, f0), roughness)
    return MaterialData(mat.name, viewport)


def override_material(name: str, settings) -> MaterialData:
    """The 6.837 material a ``material.durer`` override states (no emission: 6.837 has none)."""
    transparent = _rgb(settings.transparent)
    return MaterialData(
        name,
        _rgb(settings.diffuse),
        specular=_rgb(settings.specular),
        exponent=float(settings.exponent),
        reflective=_rgb(settings.reflective),
        transparent=transparent,
        ior=float(settings.ior) if any(transparent) else 1.0,
    )


def _object_materials(obj) -> list:
    slots = getattr(obj, "material_slots", None)
    if slots is not None and len(slots):
        return [slot.material for slot in slots]
    data = getattr(obj, "data", None)
    mats = getattr(data, "materials", None)
    return list(mats) if mats is not None else []


def world_colors(world) -> tuple[tuple[float, float, float], str | None]:
    """Linear RGB of a uniform world (Background colour × strength) and a note if the world is
    not uniform (then its viewport colour is used)."""
    if world is None:
        return (0.0, 0.0, 0.0), None
    tree = world.node_tree
    if tree is None:
        return _rgb(world.color), None
    outputs = [n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputWorld"]
    output = next((n for n in outputs if n.is_active_output), outputs[0] if outputs else None)
    if output is None or not output.inputs["Surface"].is_linked:
        return (0.0, 0.0, 0.0), None
    node = output.inputs["Surface"].links[0].from_node
    if node.bl_idname == "ShaderNodeBackground":
        col, linked = _socket_value(node, "Color")
        strength, slinked = _socket_value(node, "Strength")
        if not linked and not slinked:
            return tuple(c * float(strength) for c in _rgb(col)), None
    return _rgb(world.color), f"World '{world.name}' is not a plain colour: Dürer uses its viewport colour"


# ------------------------------------------------------------------------------------------------
# camera


def camera_data(scene, cam_obj) -> CameraData:
    """The camera parameters Dürer needs, from Blender's camera object and render settings."""
    render = scene.render
    width = int(render.resolution_x * render.resolution_percentage // 100)
    height = int(render.resolution_y * render.resolution_percentage // 100)
    if width < 1 or height < 1:
        raise ValueError(f"Render resolution {width}x{height} is empty")
    xasp, yasp = float(render.pixel_aspect_x), float(render.pixel_aspect_y)
    cam = cam_obj.data
    if cam.type not in {"ORTHO", "PERSP"}:
        raise ValueError(
            f"Camera '{cam_obj.name}' is {cam.type.lower()}: Dürer renders orthographic and perspective cameras"
        )
    # Blender (BKE_camera_params_compute_viewplane): AUTO fits the larger of xasp·W and yasp·H.
    if cam.sensor_fit == "AUTO":
        fit = "horizontal" if xasp * width >= yasp * height else "vertical"
    else:
        fit = cam.sensor_fit.lower()
    m = _matrix(cam_obj.matrix_world)
    lin = m[:3, :3]
    direction = -lin[:, 2] / np.linalg.norm(lin[:, 2])
    up = lin[:, 1] / np.linalg.norm(lin[:, 1])
    # Perspective: AUTO and HORIZONTAL use the sensor width, VERTICAL the sensor height.
    sensor = cam.sensor_height if cam.sensor_fit == "VERTICAL" else cam.sensor_width
    fov = math.degrees(2.0 * math.atan(0.5 * sensor / cam.lens))
    return CameraData(
        name=cam_obj.name,
        projection="orthographic" if cam.type == "ORTHO" else "perspective",
        center=m[:3, 3].copy(),
        direction=direction,
        up=up,
        size=float(cam.ortho_scale),
        fov_degrees=fov,
        fit=fit,
        sensor_fit=cam.sensor_fit,
        shift=(float(cam.shift_x), float(cam.shift_y)),
        clip_start=float(cam.clip_start),
        clip_end=float(cam.clip_end),
        width=width,
        height=height,
        pixel_aspect=yasp / xasp,
    )


# ------------------------------------------------------------------------------------------------
# geometry


@dataclass
class _MeshShape:
    kind: str  # "sphere", "plane", "triangles" or "empty"
    center: np.ndarray | None = None
    radius: float = 0.0
    corner: np.ndarray | None = None  # plane: local corner, edges and normal direction
    edge1: np.ndarray | None = None
    edge2: np.ndarray | None = None
    parts: list[TrianglePart] = field(default_factory=list)  # triangles: one part per material slot


def _mesh_arrays(me) -> tuple[np.ndarray, int]:
    n = len(me.vertices)
    co = _get(me.vertices, "co", n, 3).astype(np.float64)
    return co, len(me.polygons)


def _face_centers(me, co: np.ndarray) -> np.ndarray:
    npoly = len(me.polygons)
    starts = _get(me.polygons, "loop_start", npoly, 1, np.int32)
    verts = _get(me.loops, "vertex_index", len(me.loops), 1, np.int32)
    totals = _get(me.polygons, "loop_total", npoly, 1, np.int32)
    sums = np.add.reduceat(co[verts], starts, axis=0)
    return sums / totals[:, None]


def _detect_sphere(me, co: np.ndarray, strict: bool = True) -> _MeshShape | None:
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
        return _MeshShape("sphere", center=center, radius=float(dist.mean()))
    # Reject shapes whose corners are equidistant but whose faces are far inside (cubes, prisms).
    face_dist = np.linalg.norm(_face_centers(me, co) - center, axis=1)
    if float(face_dist.min()) < SPHERE_FACE_FRACTION * radius:
        return None
    # Reject rings (all vertices in a plane).
    spread = np.linalg.svd(co - center, compute_uv=False)
    if spread[-1] < 0.1 * spread[0]:
        return None
    return _MeshShape("sphere", center=center, radius=float(dist.mean()))


def _bbox_plane(me, co: np.ndarray, axis_scale=(1.0, 1.0, 1.0)) -> _MeshShape:
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
        normals = _get(me.polygons, "normal", npoly, 3).astype(np.float64)
        areas = _get(me.polygons, "area", npoly, 1).astype(np.float64)
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
    return _MeshShape("plane", corner=corner, edge1=e1, edge2=e2)


def _detect_plane(me, co: np.ndarray) -> _MeshShape | None:
    npoly = len(me.polygons)
    if npoly == 0:
        return None
    ext = co.max(axis=0) - co.min(axis=0)
    size = float(ext.max())
    if size <= 0:
        return None
    if npoly == 1 and len(co) == 4 and len(me.loops) == 4:
        order = _get(me.loops, "vertex_index", 4, 1, np.int32)
        v = co[order]
        if np.abs(v[0] + v[2] - v[1] - v[3]).max() <= PLANE_TOLERANCE * size:
            e1, e2 = v[1] - v[0], v[3] - v[0]
            if np.linalg.norm(np.cross(e1, e2)) > 0:
                return _MeshShape("plane", corner=v[0], edge1=e1, edge2=e2)
        return None
    # Grids and subdivided planes: flat along a local axis and covering their bounding rectangle.
    axis = int(np.argmin(ext))
    if ext[axis] > PLANE_TOLERANCE * size:
        return None
    a, b = [i for i in range(3) if i != axis]
    areas = _get(me.polygons, "area", npoly, 1).astype(np.float64)
    rect = float(ext[a] * ext[b])
    if rect <= 0 or abs(float(areas.sum()) - rect) > 1e-4 * rect:
        return None
    return _bbox_plane(me, co)


def _bbox_sphere(co: np.ndarray) -> _MeshShape:
    lo, hi = co.min(axis=0), co.max(axis=0)
    return _MeshShape("sphere", center=(lo + hi) / 2.0, radius=float(np.mean((hi - lo) / 2.0)))


def _triangles(me) -> _MeshShape:
    """The mesh's triangles, one part per material slot used ("empty" without faces: loose
    vertices and edges, like a curve without bevel, render as nothing in Cycles either)."""
    parts = triangle_parts(me, len(me.materials))
    return _MeshShape("triangles", parts=parts) if parts else _MeshShape("empty")


def mesh_shape(me, mode: str = "AUTO", axis_scale=(1.0, 1.0, 1.0)) -> _MeshShape:
    """What a mesh (in its local coordinates) is for Dürer under the override `mode`: a sphere, a
    plane, or its triangles (Auto, when it is neither, and Mesh). `axis_scale`: the object's scale
    along the local axes (picks a forced plane's normal)."""
    co, _ = _mesh_arrays(me)
    if len(co) == 0:
        return _MeshShape("empty")
    if mode == "SPHERE":
        return _detect_sphere(me, co, strict=False) or _bbox_sphere(co)
    if mode == "PLANE":
        return _detect_plane(me, co) or _bbox_plane(me, co, axis_scale)
    if mode == "MESH":
        return _triangles(me)
    return _detect_plane(me, co) or _detect_sphere(me, co) or _triangles(me)


def metaball_iso_radius(radius: float, stiffness: float, threshold: float) -> float:
    """Radius of the surface of an isolated metaball ball (Blender's field s·(1 − d²/R²)³)."""
    if stiffness <= threshold or radius <= 0:
        return 0.0
    return radius * math.sqrt(1.0 - (threshold / stiffness) ** (1.0 / 3.0))


class _Builder:
    def __init__(self) -> None:
        self.data = SceneData()
        self.centers: list[np.ndarray] = []
        self.radii: list[np.ndarray] = []
        self.mats: list[np.ndarray] = []
        self.material_ids: dict[tuple, int] = {}
        self.blender_materials: dict[int, int] = {}
        self.shape_cache: dict[tuple, _MeshShape] = {}

    # materials
    def material(self, mat, obj) -> int:
        key_ptr = mat.as_pointer() if mat is not None else None
        if key_ptr is not None and key_ptr in self.blender_materials:
            return self.blender_materials[key_ptr]
        md = material_data(mat, obj)
        mid = self.material_ids.get(md.key)
        if mid is None:
            mid = len(self.data.materials)
            self.material_ids[md.key] = mid
            self.data.materials.append(md)
        if key_ptr is not None:
            self.blender_materials[key_ptr] = mid
        return mid

    def object_material(self, obj) -> int:
        mats = _object_materials(obj)
        return self.material(mats[0] if mats else None, obj)

    # geometry
    def spheres(self, name: str, centers: np.ndarray, radii: np.ndarray, materials) -> None:
        n = len(radii)
        if n == 0:
            return
        self.centers.append(np.asarray(centers).reshape(n, 3))
        self.radii.append(np.asarray(radii).reshape(n))
        self.mats.append(np.broadcast_to(np.asarray(materials, dtype=np.int32), (n,)))
        self.data.sources[name] += n

    def sphere(self, name: str, m: np.ndarray, center, radius: float, material: int) -> None:
        """A sphere in object space: a world-space sphere under a uniform scale, else an ellipsoid."""
        center = np.asarray(center, dtype=np.float64).reshape(1, 3)
        s, uniform = _scale(m)
        if s == 0.0:  # flattened to nothing: no surface to see
            return
        if uniform:
            self.spheres(name, _transform_points(m, center), np.array([radius * s]), material)
        else:
            self.transformed_spheres(name, m, center, np.array([float(radius)]), material)

    def transformed_spheres(self, name: str, m: np.ndarray, centers, radii, materials) -> None:
        n = len(radii)
        if n == 0:
            return
        materials = np.broadcast_to(np.asarray(materials, dtype=np.int32), (n,))
        group = TransformedSpheres(name, np.asarray(centers, np.float64), np.asarray(radii, np.float64), materials, m)
        self.data.transformed_spheres.append(group)
        self.data.sources[name] += n

    def triangles(self, obj, m: np.ndarray, parts: list[TrianglePart]) -> None:
        """A mesh's triangles in object space, one Dürer mesh per material slot used."""
        mats = _object_materials(obj)
        flat = not _invertible(m)
        for part in parts:
            mat = mats[min(part.slot, len(mats) - 1)] if mats else None
            vertices, matrix = part.vertices, m
            if flat:  # the core needs an invertible transform: a mesh scaled flat goes in world space
                vertices, matrix = _transform_points(m, vertices.astype(np.float64)), _IDENTITY
            self.data.meshes.append(MeshData(obj.name, vertices, part.faces, self.material(mat, obj), matrix))
            self.data.sources[obj.name] += 1

    def plane(self, name: str, m: np.ndarray, shape: _MeshShape, material: int, infinite: bool) -> None:
        corner = _transform_points(m, shape.corner.reshape(1, 3))[0]
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
        self.data.planes.append(PlaneData(name, normal, float(normal @ corner), material, bounds))
        self.data.sources[name] += 1

    def finish(self) -> SceneData:
        d = self.data
        if self.centers:  # at most one copy into float64, however many objects contributed
            d.sphere_centers = _join(self.centers, np.float64)
            d.sphere_radii = _join(self.radii, np.float64)
            d.sphere_materials = _join(self.mats, np.int32)
        return d


def _join(chunks: list[np.ndarray], dtype) -> np.ndarray:
    if len(chunks) == 1:
        return np.ascontiguousarray(chunks[0], dtype=dtype)
    return np.concatenate(chunks, dtype=dtype)


def _pointcloud(b: _Builder, obj, m: np.ndarray) -> None:
    pc = obj.data
    n = len(pc.points)
    if n == 0:
        return
    attrs = pc.attributes
    pos = np.empty(n * 3, np.float32)
    attrs["position"].data.foreach_get("vector", pos)
    pos = pos.reshape(n, 3)
    radius_attr = attrs.get("radius")
    if radius_attr is not None:
        radii = np.empty(n, np.float32)
        radius_attr.data.foreach_get("value", radii)
    else:
        radii = np.full(n, 0.01, np.float32)  # Blender's default point radius
    mats = _object_materials(obj)
    index_attr = attrs.get("material_index")
    if index_attr is not None and len(mats) > 1:
        idx = np.empty(n, np.int32)
        index_attr.data.foreach_get("value", idx)
        table = np.array([b.material(mt, obj) for mt in mats], dtype=np.int32)
        materials = table[np.clip(idx, 0, len(mats) - 1)]
    else:
        materials = b.material(mats[0] if mats else None, obj)
    keep = radii > 0
    if not keep.all():
        pos, radii = pos[keep], radii[keep]
        if not np.isscalar(materials):
            materials = materials[keep]
    s, uniform = _scale(m)
    if s == 0.0:  # flattened to nothing
        return
    if not uniform:  # ellipsoids: the points stay in object space under the object's matrix
        b.transformed_spheres(obj.name, m, pos, radii, materials)
        return
    # Transform in double precision (Blender stores float32 positions; Dürer intersects in double).
    if np.array_equal(m, _IDENTITY):
        centers = pos
    else:
        centers = pos.astype(np.float64) @ m[:3, :3].T
        centers += m[:3, 3]
    radii = radii * s if s != 1.0 else radii
    b.spheres(obj.name, centers, radii, materials)


def _mesh(b: _Builder, obj, m: np.ndarray, mode: str, infinite: bool) -> None:
    me = obj.data
    axis_scale = tuple(np.round(np.linalg.norm(m[:3, :3], axis=0), 9)) if mode == "PLANE" else None
    key = (me.as_pointer(), len(me.vertices), len(me.polygons), mode, axis_scale)
    shape = b.shape_cache.get(key)
    if shape is None:
        shape = b.shape_cache[key] = mesh_shape(me, mode, axis_scale or (1.0, 1.0, 1.0))
    _add_shape(b, obj, m, shape, infinite)


def _add_shape(b: _Builder, obj, m: np.ndarray, shape: _MeshShape, infinite: bool) -> None:
    """A detected sphere or plane of `obj` (world matrix m) with the object's material, or its
    triangles with their slots' materials; nothing for an empty shape."""
    if shape.kind == "triangles":
        b.triangles(obj, m, shape.parts)
    elif shape.kind == "sphere":
        b.sphere(obj.name, m, shape.center, shape.radius, b.object_material(obj))
    elif shape.kind == "plane":
        b.plane(obj.name, m, shape, b.object_material(obj), infinite)


def _converted(b: _Builder, obj, m: np.ndarray, mode: str, infinite: bool) -> None:
    """Curves, text, surfaces, metaballs...: their evaluated mesh as triangles (Auto, Mesh) or
    forced to a sphere or plane. A type with no mesh (volumes, hair curves) is skipped; a
    curve without faces renders as nothing, as in Cycles."""
    try:
        me = obj.to_mesh()
    except RuntimeError:
        me = None
    if me is None:
        b.data.skipped[obj.type.lower()] += 1
        return
    try:
        axis_scale = np.linalg.norm(m[:3, :3], axis=0)
        # The arrays are copies (foreach_get), so they outlive the temporary mesh.
        _add_shape(b, obj, m, mesh_shape(me, mode, axis_scale), infinite)
    finally:
        obj.to_mesh_clear()


def _metaball(b: _Builder, obj, m: np.ndarray) -> None:
    mb = obj.data
    material = b.object_material(obj)
    for el in mb.elements:
        if el.hide:
            continue
        if el.type != "BALL" or el.use_negative:
            b.data.skipped[f"metaball {el.type.lower()}{' (negative)' if el.use_negative else ''}"] += 1
            continue
        r = metaball_iso_radius(el.radius, el.stiffness, mb.threshold)
        if r > 0:
            b.sphere(obj.name, m, np.array(el.co), r, material)


def _light(b: _Builder, obj, m: np.ndarray) -> None:
    light = obj.data
    color = np.array(_rgb(light.color), dtype=np.float64)
    if getattr(light, "use_temperature", False):
        color = color * np.array(_rgb(light.temperature_color))
    power = float(getattr(light, "energy", 0.0)) * 2.0 ** float(getattr(light, "exposure", 0.0))
    lin = m[:3, :3]
    axis = -lin[:, 2] / np.linalg.norm(lin[:, 2])
    position = m[:3, 3].copy()
    shadows = bool(getattr(light, "use_shadow", True))
    settings = getattr(getattr(light, "original", None) or light, "durer", None)
    custom = settings is not None and settings.use_attenuation
    falloff = "custom" if custom else "inverse_square"
    attenuation = tuple(float(c) for c in settings.attenuation) if custom else INVERSE_SQUARE
    if light.type == "SUN":
        b.data.lights.append(LightData("sun", obj.name, color * power / math.pi, direction=axis, shadows=shadows))
    elif light.type in {"POINT", "SPOT"}:
        intensity = color * power / (4.0 * math.pi**2)
        if light.type == "POINT":
            b.data.lights.append(
                LightData(
                    "point",
                    obj.name,
                    intensity,
                    position=position,
                    falloff=falloff,
                    attenuation=attenuation,
                    shadows=shadows,
                )
            )
        else:
            b.data.lights.append(
                LightData(
                    "spot",
                    obj.name,
                    intensity,
                    direction=axis,
                    position=position,
                    falloff=falloff,
                    attenuation=attenuation,
                    spot_half_angle=float(light.spot_size) / 2.0,
                    spot_blend=float(light.spot_blend),
                    shadows=shadows,
                )
            )
    else:
        b.data.skipped[f"{light.type.lower()} light"] += 1


def export_depsgraph(depsgraph, camera=None) -> SceneData:
    """Everything Dürer renders, from an evaluated depsgraph (render or viewport).

    `camera`: the camera object (default: the scene's camera).
    """
    scene = depsgraph.scene_eval if hasattr(depsgraph, "scene_eval") else depsgraph.scene
    b = _Builder()
    for inst in depsgraph.object_instances:
        obj = inst.object
        kind = obj.type
        if kind in {"CAMERA", "ARMATURE", "LATTICE", "SPEAKER", "LIGHT_PROBE"}:
            continue
        m = _matrix(inst.matrix_world)
        if kind == "LIGHT":
            _light(b, obj, m)
            continue
        settings = _durer_settings(obj)
        mode = settings.primitive if settings is not None else "AUTO"
        infinite = bool(settings.infinite_plane) if settings is not None else False
        if mode == "IGNORE":
            continue
        if kind == "MESH" and obj.original is not None and obj.original.type in _CONVERTED_TYPES:
            continue  # the mesh Blender made of a curve, text, surface or metaball: handled as that
        if kind == "EMPTY":
            if obj.empty_display_type == "SPHERE" and mode in {"AUTO", "SPHERE"} and obj.instance_type != "COLLECTION":
                b.sphere(obj.name, m, np.zeros(3), float(obj.empty_display_size), b.object_material(obj))
            continue
        if kind == "POINTCLOUD":
            _pointcloud(b, obj, m)
        elif kind == "MESH":
            _mesh(b, obj, m, mode, infinite)
        elif kind == "META" and mode == "AUTO":
            _metaball(b, obj, m)
        elif kind in _GEOMETRY_TYPES and (mode != "AUTO" or kind in _TRIANGULATED_TYPES):
            _converted(b, obj, m, mode, infinite)
        elif kind in _GEOMETRY_TYPES:
            b.data.skipped[kind.lower()] += 1
    data = b.finish()

    cam_obj = camera if camera is not None else scene.camera
    if cam_obj is not None:
        try:
            cam_obj = cam_obj.evaluated_get(depsgraph)
        except (RuntimeError, TypeError):
            pass
        data.camera = camera_data(scene, cam_obj)

    world_rgb, note = world_colors(scene.world)
    if note:
        data.notes.append(note)
    alpha = 0.0 if scene.render.film_transparent else 1.0
    data.background = ((0.0, 0.0, 0.0) if alpha == 0.0 else world_rgb) + (alpha,)
    settings = getattr(scene, "durer", None)
    if settings is not None and settings.use_custom_ambient:
        data.ambient = _rgb(settings.ambient)
    elif settings is None or settings.use_world_lighting:
        data.ambient = world_rgb
    return data
