"""File › Import › 6.837 scene (.txt): an MIT 6.837 scene file as Blender objects that Dürer renders
exactly as the ``raytracer`` command does (`durer.course.raytracer.render_scene_file` with the same flags).

The file describes a whole scene (camera, lights, background, objects, render settings), so it
becomes a new Blender scene named after the file, made the window's active scene: nothing of the
scene open before (the startup file's Cube and Light) is rendered with it or changed, and that scene
is one click away in the scene selector. What becomes what (``durer.course.scene_file`` reads the
file; every object goes into a collection named after it):

* Sphere: a smooth UV-sphere mesh of radius 1 (one mesh shared by all), ``object.durer.primitive``
  Sphere, so Dürer renders the exact sphere while the viewport and Cycles see the mesh. Its matrix is
  the primitive's composed 6.837 matrix × translate(center) × scale(radius): under a non-uniform
  Transform, an exact ellipsoid.
* Plane: a square quad on the world-space plane (normal M⁻ᵀn), ``infinite_plane`` on; its winding
  gives the 6.837 normal.
* TriangleMesh: a mesh object (``primitive`` Mesh: triangles as they are, never detected as a sphere
  or plane) per TriangleMesh, instances of one .obj sharing its mesh; the Triangles of one material
  and matrix: one mesh object.
* Shear: a Blender object holds location, rotation and scale, not shear (matrix_world drops it).
  A sheared matrix M = U·S·Vᵀ (SVD) goes to the object as U·S, and Vᵀ, a rotation, into the
  geometry: the mesh's vertices are turned by it (that object gets its own mesh); a sphere needs
  nothing, being round. Mirrors stay in the object's scale, so triangles keep their winding.
* Materials: a Principled BSDF for Cycles and EEVEE; a material the Principled mapping cannot give
  Dürer exactly (Phong, mirror or transparent colours, kd > 1) also gets the ``material.durer``
  override with the 6.837 values.
* Lights: directional → Sun, point → Point light, colour and strength chosen so that the export's
  radiometric conversion yields the 6.837 colour; a point light's attenuation goes to
  ``light.durer`` (Blender lights only fall off as 1/d²). -shadows → each light's Cast Shadow.
* Background colour → the world colour; ambient light → ``scene.durer`` Custom Ambient (the 6.837
  rule: (1, 1, 1) without lights).
* Camera: orientation from direction/up orthonormalised as 6.837 does, Sensor Fit Auto, the
  perspective angle or the orthographic size. 6.837's orthographic rays count hits behind the
  camera's centre (t from −∞); Blender's clip start cannot be negative, so the orthographic camera
  is moved back along its view direction by a distance that clears every object and plane in view,
  stored in the camera's ``durer_6837_depth_offset`` property: the image is the same, the Depth pass
  reads 6.837's t plus that offset. Clip start is Blender's minimum, clip end its maximum.
* Render settings: the resolution option at 100 %, pixel aspect 1, no border; Dürer with 1 sample
  at the pixel centre, double precision, the robust sphere method, and the course flags
  (-shade_back, -bounces, -weight).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import bpy
import numpy as np
from bpy.props import BoolProperty, FloatProperty, IntProperty, StringProperty
from bpy_extras.io_utils import ImportHelper
from mathutils import Matrix

from durer.course.scene_file import SceneCamera, SceneFile, SceneFileError, SceneMaterial, ScenePrimitive, read_scene_file
from durer.material import COURSE_FIELDS

#: Segments of the UV sphere that stands for every 6.837 sphere in the viewport and in Cycles.
SPHERE_SEGMENTS = (32, 16)
#: Blender's smallest and largest camera clip distances (6.837 clips nothing in front of a camera).
CLIP_START = 1e-6
CLIP_END = float(np.finfo(np.float32).max)
#: Relative size of the off-diagonal of MᵀM above which a matrix has shear (composed 6.837
#: matrices without shear have it at rounding level, ~1e-16).
SHEAR_TOLERANCE = 1e-9
#: Camera property holding how far an orthographic camera was moved back (Depth = 6.837 t + this).
DEPTH_OFFSET_PROPERTY = "durer_6837_depth_offset"


@dataclass(frozen=True)
class ImportOptions:
    """The render the imported scene is set up for: the `raytracer` command's -size and flags."""

    width: int = 200
    height: int = 200
    shade_back: bool = False
    shadows: bool = False
    bounces: int = 0
    weight: float = 0.0


def build_scene(scene_file: SceneFile, options: ImportOptions = ImportOptions()) -> bpy.types.Scene:
    """A new scene named after `scene_file` with its objects (in a collection named after it too),
    materials, lights, world, camera and render settings. Anything that fails halfway is removed again."""
    builder = _Builder(scene_file)
    try:
        return builder.build(options)
    except Exception:
        builder.remove_created()
        raise


# --- geometry helpers ----------------------------------------------------------------------------


def sphere_matrix(primitive: ScenePrimitive) -> np.ndarray:
    """World-from-unit-sphere: the primitive's matrix × translate(center) × scale(radius)."""
    local = np.diag([primitive.radius] * 3 + [1.0])
    local[:3, 3] = primitive.center
    return primitive.matrix @ local


def has_shear(matrix: np.ndarray) -> bool:
    """Are the columns of the linear part not orthogonal? Then no location, rotation and scale
    give the matrix: Blender objects have no shear (setting matrix_world drops it)."""
    gram = matrix[:3, :3].T @ matrix[:3, :3]
    scale = np.sqrt(np.outer(np.diag(gram), np.diag(gram)))
    return bool(np.abs(gram - np.diag(np.diag(gram))).max() > SHEAR_TOLERANCE * scale.max())


def split_shear(matrix: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(object, rotation) with matrix = object @ rotation, `object` a translation × rotation ×
    scale (negative for a mirror) that a Blender object holds exactly, `rotation` a proper rotation
    (det +1) to apply to the geometry itself. From the SVD M = U·S·Vᵀ: object = U·S, rotation = Vᵀ,
    any reflection moved into S (a reflection in the geometry would flip the triangles' winding,
    hence their normals)."""
    u, s, vt = np.linalg.svd(matrix[:3, :3])
    mirror = np.diag([1.0, 1.0, -1.0])
    if np.linalg.det(vt) < 0:
        vt, s = mirror @ vt, s * [1, 1, -1]
    if np.linalg.det(u) < 0:
        u, s = u @ mirror, s * [1, 1, -1]
    obj, rotation = np.eye(4), np.eye(4)
    obj[:3, :3], obj[:3, 3] = u * s, matrix[:3, 3]
    rotation[:3, :3] = vt
    return obj, rotation


def plane_frame(normal, offset: float) -> np.ndarray:
    """A rigid frame whose XY plane is {p : p·normal = offset} and whose +Z is the unit normal, so
    a quad wound counter-clockwise in XY faces along the 6.837 normal."""
    n = np.asarray(normal, dtype=np.float64)
    length = float(np.linalg.norm(n))
    z = n / length
    helper = np.eye(3)[int(np.argmin(np.abs(z)))]  # the axis least parallel to the normal
    x = np.cross(helper, z)
    x /= np.linalg.norm(x)
    frame = np.eye(4)
    frame[:3, 0], frame[:3, 1], frame[:3, 2] = x, np.cross(z, x), z
    frame[:3, 3] = z * (offset / length)  # the point of the plane nearest the origin
    return frame


def world_plane(primitive: ScenePrimitive) -> tuple[np.ndarray, float]:
    """The plane in world space: normal M⁻ᵀn and offset, for P·normal = offset."""
    m = primitive.matrix
    normal = np.linalg.inv(m[:3, :3]).T @ np.asarray(primitive.normal, dtype=np.float64)
    n = np.asarray(primitive.normal, dtype=np.float64)
    point = m[:3, :3] @ (n * (primitive.offset / float(n @ n))) + m[:3, 3]
    return normal, float(normal @ point)


def world_points(scene_file: SceneFile) -> np.ndarray:
    """Points whose convex hull holds every bounded primitive in world space (a sphere by the
    corners of its transformed bounding cube). (0, 3) when there are only planes."""
    chunks = [np.empty((0, 3))]
    corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=np.float64)
    for p in scene_file.primitives:
        if p.kind == "sphere":
            local = np.asarray(p.center) + p.radius * corners
        elif p.kind in {"triangle", "mesh"}:
            local = np.asarray(p.vertices, dtype=np.float64).reshape(-1, 3)
        else:
            continue
        chunks.append(local @ p.matrix[:3, :3].T + p.matrix[:3, 3])
    return np.concatenate(chunks)


def basis(direction, up) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(direction, horizontal, up') unit vectors as 6.837 builds a camera's: horizontal =
    normalize(direction × up), up' = horizontal × direction."""
    d = np.asarray(direction, dtype=np.float64)
    d = d / np.linalg.norm(d)
    h = np.cross(d, np.asarray(up, dtype=np.float64))
    h /= np.linalg.norm(h)
    return d, h, np.cross(h, d)


def look_matrix(direction, up, location) -> np.ndarray:
    """A Blender camera or light matrix looking (−Z) along `direction`, +Y = up' and +X =
    horizontal of `basis`, at `location`."""
    d, h, up = basis(direction, up)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = h, up, -d, location
    return m


def ortho_depth_offset(scene_file: SceneFile) -> float:
    """How far to move an orthographic camera back along its view direction so that, with a clip
    start of almost 0, it sees everything 6.837's t ≥ −∞ sees: past the farthest point behind the
    centre of any bounded primitive, and of any plane over the view square (a plane's t is linear
    across it, so its corners bound it), plus a margin of max(1, size)."""
    camera = scene_file.camera
    d, h, up = basis(camera.direction, camera.up)
    center = np.asarray(camera.center, dtype=np.float64)
    ts = [0.0]
    points = world_points(scene_file)
    if len(points):
        ts.append(float(((points - center) @ d).min()))
    half = camera.size / 2.0
    window = [center + sx * half * h + sy * half * up for sx in (-1, 1) for sy in (-1, 1)]
    for p in scene_file.primitives:
        if p.kind != "plane":
            continue
        normal, offset = world_plane(p)
        along = float(normal @ d)
        if along != 0.0:  # a plane parallel to the rays is never hit
            ts.extend((offset - float(normal @ o)) / along for o in window)
    return max(0.0, -min(ts)) + max(1.0, camera.size)


def plane_half_size(scene_file: SceneFile) -> float:
    """Half the side of the quad that shows an infinite plane in the viewport: a few times the size
    of the bounded geometry and the camera's distance, so it reads as a floor (Dürer ignores it)."""
    points = world_points(scene_file)
    if scene_file.camera is not None:
        points = np.vstack([points, np.asarray(scene_file.camera.center, dtype=np.float64)])
    if len(points) == 0:
        return 100.0
    extent = float(np.linalg.norm(points - points.mean(axis=0), axis=1).max())
    return max(10.0, 4.0 * extent)


def needs_override(material: SceneMaterial) -> bool:
    """Can the export's Principled mapping not give this material exactly? It gives kd = Base Color
    exactly only for a plain diffuse material (Specular IOR Level 0, Metallic 0, no transmission)
    with kd in [0, 1]."""
    effects = any(material.specular) or any(material.reflective) or any(material.transparent)
    return effects or max(material.diffuse) > 1.0


def roughness_for_exponent(exponent: float) -> float:
    """Blender roughness whose lobe is as wide as a Phong lobe of `exponent`, inverting the export's
    n = 2/r⁴ − 2 (for the Principled look in Cycles; Dürer uses the override's exponent)."""
    return min(max((2.0 / (max(exponent, 0.0) + 2.0)) ** 0.25, 0.0), 1.0)


# --- building ------------------------------------------------------------------------------------


class _Builder:
    def __init__(self, scene_file: SceneFile) -> None:
        self.file = scene_file
        self.scene = None
        self.stem = scene_file.path.stem
        self.created: list[tuple[object, object]] = []  # (bpy.data collection, datablock), newest last
        self.collection = None
        self.materials: list = []
        self.sphere_mesh = None
        self.points = world_points(scene_file)

    def new(self, datablocks, name: str, *args):
        block = datablocks.new(name, *args)
        self.created.append((datablocks, block))
        return block

    def remove_created(self) -> None:
        for datablocks, block in reversed(self.created):  # objects before the data they use
            datablocks.remove(block)
        self.created.clear()

    def build(self, options: ImportOptions) -> bpy.types.Scene:
        self.scene = self.new(bpy.data.scenes, self.stem)
        self.collection = self.new(bpy.data.collections, self.stem)
        self.scene.collection.children.link(self.collection)
        self.materials = [self.material(i, m) for i, m in enumerate(self.file.materials)]
        half = plane_half_size(self.file)
        triangles: dict[tuple[int, bytes], list[ScenePrimitive]] = {}
        meshes: dict[Path, object] = {}
        for p in self.file.primitives:
            if p.kind == "sphere":
                self.sphere(p)
            elif p.kind == "plane":
                self.plane(p, half)
            elif p.kind == "mesh":
                self.triangle_mesh(p, meshes)
            else:
                triangles.setdefault((p.material, p.matrix.tobytes()), []).append(p)
        for batch in triangles.values():
            self.triangles(batch)
        for i, light in enumerate(self.file.lights):
            self.light(i, light, options.shadows)
        self.scene.world = self.world()
        if self.file.camera is not None:
            self.scene.camera = self.camera(self.file.camera)
        self.render_settings(options)
        return self.scene

    # objects
    def link(self, name: str, data, matrix: np.ndarray, material: int | None = None):
        obj = self.new(bpy.data.objects, name, data)
        self.collection.objects.link(obj)
        obj.matrix_world = Matrix(matrix.tolist())
        if material is not None:
            slot = obj.material_slots[0]
            slot.link = "OBJECT"  # shared mesh data, a material per object
            slot.material = self.materials[material]
        return obj

    def mesh(self, name: str, vertices: np.ndarray, faces: np.ndarray):
        """A mesh of triangles from arrays (bulk foreach_set), flat shaded as 6.837 shades them."""
        me = self.new(bpy.data.meshes, name)
        me.vertices.add(len(vertices))
        me.vertices.foreach_set("co", np.ascontiguousarray(vertices, dtype=np.float32).ravel())
        me.loops.add(faces.size)
        me.loops.foreach_set("vertex_index", np.ascontiguousarray(faces, dtype=np.int32).ravel())
        me.polygons.add(len(faces))
        me.polygons.foreach_set("loop_start", np.arange(0, faces.size, 3, dtype=np.int32))
        me.polygons.foreach_set("use_smooth", np.zeros(len(faces), bool))  # without it, faces are smooth
        me.update(calc_edges=True)
        me.materials.append(None)  # one slot, filled per object
        return me

    def sphere(self, p: ScenePrimitive) -> None:
        if self.sphere_mesh is None:
            import bmesh

            bm = bmesh.new()
            bmesh.ops.create_uvsphere(bm, u_segments=SPHERE_SEGMENTS[0], v_segments=SPHERE_SEGMENTS[1], radius=1.0)
            for face in bm.faces:
                face.smooth = True
            self.sphere_mesh = self.new(bpy.data.meshes, f"{self.stem} sphere")
            bm.to_mesh(self.sphere_mesh)
            bm.free()
            self.sphere_mesh.materials.append(None)
        matrix = sphere_matrix(p)
        if has_shear(matrix):  # a sheared sphere is an ellipsoid: turning the unit sphere first changes nothing
            matrix = split_shear(matrix)[0]
        obj = self.link("Sphere", self.sphere_mesh, matrix, p.material)
        obj.durer.primitive = "SPHERE"

    def plane(self, p: ScenePrimitive, half: float) -> None:
        quad = np.array([[-half, -half, 0], [half, -half, 0], [half, half, 0], [-half, half, 0]])
        faces = np.array([[0, 1, 2, 3]], dtype=np.int32)
        me = self.new(bpy.data.meshes, "Plane")
        me.from_pydata(quad.tolist(), [], faces.tolist())
        me.materials.append(None)
        obj = self.link("Plane", me, plane_frame(*world_plane(p)), p.material)  # rigid: never sheared
        obj.durer.primitive = "PLANE"
        obj.durer.infinite_plane = True

    def triangle_mesh(self, p: ScenePrimitive, meshes: dict) -> None:
        """A mesh object; objects of one .obj share its mesh, except under a sheared matrix (their
        vertices are turned by the part of the matrix that Blender's object cannot hold)."""
        path = p.mesh_path or Path(p.source)
        matrix, rotation = split_shear(p.matrix) if has_shear(p.matrix) else (p.matrix, None)
        key = (path, None if rotation is None else rotation.tobytes())
        me = meshes.get(key)
        if me is None:
            me = meshes[key] = self.mesh(path.stem, _rotated(p.vertices, rotation), p.faces)
        obj = self.link(path.stem, me, matrix, p.material)
        obj.durer.primitive = "MESH"

    def triangles(self, batch: list[ScenePrimitive]) -> None:
        """The Triangles of one material and matrix as one mesh (each with its own three vertices)."""
        vertices = np.concatenate([np.asarray(p.vertices, dtype=np.float64) for p in batch])
        faces = np.arange(len(vertices), dtype=np.int32).reshape(-1, 3)
        matrix, rotation = split_shear(batch[0].matrix) if has_shear(batch[0].matrix) else (batch[0].matrix, None)
        me = self.mesh("Triangles", _rotated(vertices, rotation), faces)
        obj = self.link("Triangles", me, matrix, batch[0].material)
        obj.durer.primitive = "MESH"

    # materials, lights, world, camera
    def material(self, index: int, m: SceneMaterial):
        mat = self.new(bpy.data.materials, f"{self.stem} material {index}")
        kd = tuple(min(c, 1.0) for c in m.diffuse)
        mat.diffuse_color = (*kd, 1.0)
        inputs = mat.node_tree.nodes["Principled BSDF"].inputs
        inputs["Base Color"].default_value = (*kd, 1.0)
        inputs["Metallic"].default_value = 0.0
        inputs["Roughness"].default_value = 1.0
        inputs["Specular IOR Level"].default_value = 0.0
        if not needs_override(m):
            return mat  # the export's Principled mapping gives exactly kd = Base Color
        # A look for Cycles and EEVEE only: Dürer renders the override's exact values.
        if any(m.specular):
            inputs["Roughness"].default_value = roughness_for_exponent(m.exponent)
            inputs["Specular IOR Level"].default_value = 0.5
            inputs["Specular Tint"].default_value = (*(min(c, 1.0) for c in m.specular), 1.0)
        if any(m.reflective):
            inputs["Metallic"].default_value = min(max(m.reflective), 1.0)
            inputs["Roughness"].default_value = 0.0
        if any(m.transparent):
            inputs["Transmission Weight"].default_value = min(max(m.transparent), 1.0)
            inputs["IOR"].default_value = m.ior
        settings = mat.durer
        settings.use_override = True
        for field in COURSE_FIELDS:
            setattr(settings, field.name, getattr(m, field.name))
        return mat

    def light(self, index: int, light, shadows: bool) -> None:
        """Blender colour c/max(c) and a strength that the export turns back into c: colour·S/π for
        a Sun, colour·P/(4π²) for a Point light (with the 6.837 attenuation instead of 1/d²)."""
        peak = max(light.color)
        if light.kind == "directional":
            data = self.new(bpy.data.lights, f"{self.stem} directional light {index}", "SUN")
            data.energy = math.pi * peak
            data.angle = 0.0  # a 6.837 light is a direction: hard shadows in Cycles too
            d = np.asarray(light.direction, dtype=np.float64)
            anchor = self.points.mean(axis=0) if len(self.points) else np.zeros(3)  # where a Sun is drawn
            matrix = look_matrix(d, np.eye(3)[int(np.argmin(np.abs(d)))], anchor)  # any roll will do
            name = f"DirectionalLight {index}"
        else:
            data = self.new(bpy.data.lights, f"{self.stem} point light {index}", "POINT")
            data.energy = 4.0 * math.pi**2 * peak
            data.shadow_soft_size = 0.0
            data.durer.use_attenuation = True
            data.durer.attenuation = light.attenuation
            matrix = np.eye(4)
            matrix[:3, 3] = light.position
            name = f"PointLight {index}"
        data.color = tuple(c / peak for c in light.color) if peak > 0 else (1.0, 1.0, 1.0)
        data.use_shadow = shadows
        self.link(name, data, matrix)

    def world(self):
        world = self.new(bpy.data.worlds, self.stem)
        background = world.node_tree.nodes["Background"]
        background.inputs["Color"].default_value = (*self.file.background, 1.0)
        background.inputs["Strength"].default_value = 1.0
        world.color = self.file.background
        return world

    def camera(self, camera: SceneCamera):
        data = self.new(bpy.data.cameras, self.stem)
        data.sensor_fit = "AUTO"
        data.clip_start, data.clip_end = CLIP_START, CLIP_END
        offset = 0.0
        if camera.projection == "orthographic":
            data.type = "ORTHO"
            data.ortho_scale = camera.size
            offset = ortho_depth_offset(self.file)
        else:
            data.type = "PERSP"
            data.lens_unit = "FOV"
            data.angle = math.radians(camera.size)  # over the sensor width, which Auto fits to the larger side
        location = np.asarray(camera.center) - offset * basis(camera.direction, camera.up)[0]
        obj = self.link("Camera", data, look_matrix(camera.direction, camera.up, location))
        obj[DEPTH_OFFSET_PROPERTY] = offset
        return obj

    def render_settings(self, options: ImportOptions) -> None:
        render = self.scene.render
        render.engine = "DURER"
        render.resolution_x, render.resolution_y = options.width, options.height
        render.resolution_percentage = 100
        render.pixel_aspect_x = render.pixel_aspect_y = 1.0
        render.use_border = False
        render.film_transparent = False
        settings = self.scene.durer
        settings.preset = "CUSTOM"
        settings.samples, settings.sampler = 1, "CENTER"  # the pixel centre, as the course
        settings.precision, settings.sphere_method = "DOUBLE", "ROBUST"
        settings.shade_back = options.shade_back
        settings.max_bounces, settings.min_weight = options.bounces, options.weight
        settings.use_custom_ambient = True
        settings.ambient = self.file.effective_ambient


def _rotated(vertices: np.ndarray, rotation: np.ndarray | None) -> np.ndarray:
    """Vertices turned by a 4 × 4 rotation (in double precision, before Blender's float32)."""
    vertices = np.asarray(vertices, dtype=np.float64)
    return vertices if rotation is None else vertices @ rotation[:3, :3].T


# --- the operator --------------------------------------------------------------------------------


class DURER_OT_import_6837(bpy.types.Operator, ImportHelper):
    """Import an MIT 6.837 scene file (assignments 1-4) as a new scene, set up to render with Dürer as
    the course's raytracer command does"""

    bl_idname = "import_scene.durer_6837"
    bl_label = "Import 6.837 Scene"
    bl_options = {"REGISTER", "UNDO", "PRESET"}

    filename_ext = ".txt"
    filter_glob: StringProperty(default="*.txt", options={"HIDDEN"})
    resolution_x: IntProperty(name="Width", description="Render width in pixels (-size)", default=200, min=1)
    resolution_y: IntProperty(name="Height", description="Render height in pixels (-size)", default=200, min=1)
    shade_back: BoolProperty(
        name="Shade Back", description="Shade back faces with the flipped normal (-shade_back)", default=False
    )
    shadows: BoolProperty(name="Shadows", description="Every light casts shadows (-shadows)", default=False)
    bounces: IntProperty(
        name="Bounces", description="Reflection and refraction depth (-bounces)", default=0, min=0, soft_max=16
    )
    weight: FloatProperty(
        name="Weight",
        description="Secondary rays whose weight in the pixel falls below this are not traced (-weight)",
        default=0.0,
        min=0.0,
        max=1.0,
        precision=4,
    )

    def execute(self, context):
        options = ImportOptions(
            self.resolution_x, self.resolution_y, self.shade_back, self.shadows, self.bounces, self.weight
        )
        try:
            scene_file = read_scene_file(self.filepath)
        except SceneFileError as error:
            self.report({"ERROR"}, str(error))
            return {"CANCELLED"}
        except OSError as error:
            self.report({"ERROR"}, f"Cannot read {self.filepath}: {error.strerror or error}")
            return {"CANCELLED"}
        scene = build_scene(scene_file, options)
        # A window-less context (a timer, a handler) renders the first window's scene.
        window = context.window or next(iter(context.window_manager.windows), None)
        if window is not None:
            window.scene = scene
        if scene_file.camera is None:
            self.report({"WARNING"}, f"{scene_file.path.name} has no camera: add one to '{scene.name}' to render it")
        if scene_file.nothing_to_render:
            self.report({"WARNING"}, scene_file.nothing_to_render)
        self.report({"INFO"}, f"Imported {len(scene.objects)} objects into the new scene '{scene.name}' (the scene "
                              "open before is unchanged)")
        return {"FINISHED"}


def menu_import(self, _context) -> None:
    self.layout.operator(DURER_OT_import_6837.bl_idname, text="6.837 scene (.txt)")


def register() -> None:
    bpy.utils.register_class(DURER_OT_import_6837)
    bpy.types.TOPBAR_MT_file_import.append(menu_import)


def unregister() -> None:
    bpy.types.TOPBAR_MT_file_import.remove(menu_import)
    bpy.utils.unregister_class(DURER_OT_import_6837)
