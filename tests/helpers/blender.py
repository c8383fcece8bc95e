"""Helpers for the Blender tests: build objects with the real bpy/bmesh (never a mock)."""

from __future__ import annotations

import math

import numpy as np
from helpers.blender_import import blender_module

bpy = blender_module("bpy")
bmesh = blender_module("bmesh")

from durer.blender import point_cloud  # noqa: E402


def link(s, obj):
    s.collection.objects.link(obj)
    return obj


def mesh_object(s, name, build, location=(0, 0, 0), scale=(1, 1, 1), rotation=(0, 0, 0)):
    """A mesh object whose mesh `build(bm)` fills with bmesh."""
    bm = bmesh.new()
    build(bm)
    me = bpy.data.meshes.new(name)
    bm.to_mesh(me)
    bm.free()
    obj = bpy.data.objects.new(name, me)
    obj.location = location
    obj.scale = scale
    obj.rotation_euler = rotation
    return link(s, obj)


def uv_sphere(s, name="Sphere", radius=1.0, **kw):
    return mesh_object(
        s, name, lambda bm: bmesh.ops.create_uvsphere(bm, u_segments=32, v_segments=16, radius=radius), **kw
    )


def ico_sphere(s, name="Ico", radius=1.0, subdivisions=2, **kw):
    return mesh_object(
        s, name, lambda bm: bmesh.ops.create_icosphere(bm, subdivisions=subdivisions, radius=radius), **kw
    )


def cube(s, name="Cube", size=2.0, **kw):
    return mesh_object(s, name, lambda bm: bmesh.ops.create_cube(bm, size=size), **kw)


def quad(s, name="Plane", corners=((-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)), **kw):
    def build(bm):
        verts = [bm.verts.new(c) for c in corners]
        bm.faces.new(verts)

    return mesh_object(s, name, build, **kw)


def grid(s, name="Grid", size=1.0, n=4, **kw):
    return mesh_object(s, name, lambda bm: bmesh.ops.create_grid(bm, x_segments=n, y_segments=n, size=size), **kw)


def vertex_object(s, name, positions, location=(0, 0, 0)):
    """A mesh object of loose vertices at `positions`, linked into scene `s`."""
    obj = point_cloud.vertex_object(s.collection, name, positions)
    obj.location = location
    return obj


def points_object(s, name, positions, radius=0.05, location=(0, 0, 0), scale=(1, 1, 1)):
    """A point cloud made the way most users make one (durer.blender.point_cloud: a vertex mesh
    through a geometry-nodes "Mesh to Points" modifier, evaluated as a point-cloud instance)."""
    obj = point_cloud.point_cloud_object(s.collection, name, positions, radius)
    obj.location = location
    obj.scale = scale
    return obj


def material(name, color=(0.8, 0.8, 0.8), roughness=1.0, emission=None):
    """A Principled BSDF material (diffuse: roughness 1, no specular), or an Emission-only one."""
    mat = bpy.data.materials.new(name)
    tree = mat.node_tree
    bsdf = tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (*color, 1.0)
    bsdf.inputs["Roughness"].default_value = roughness
    bsdf.inputs["Specular IOR Level"].default_value = 0.0
    if emission is not None:
        out = tree.nodes["Material Output"]
        em = tree.nodes.new("ShaderNodeEmission")
        em.inputs["Color"].default_value = (*emission[0], 1.0)
        em.inputs["Strength"].default_value = emission[1]
        tree.links.new(em.outputs[0], out.inputs["Surface"])
    return mat


def world(s, color=(0.0, 0.0, 0.0), strength=1.0):
    w = bpy.data.worlds.new("World")
    bg = w.node_tree.nodes["Background"]
    bg.inputs["Color"].default_value = (*color, 1.0)
    bg.inputs["Strength"].default_value = strength
    s.world = w
    return w


def light(s, kind, name=None, energy=1.0, location=(0, 0, 0), rotation=(0, 0, 0), color=(1, 1, 1), **props):
    data = bpy.data.lights.new(name or kind.title(), kind)
    data.energy = energy
    data.color = color
    for k, v in props.items():
        setattr(data, k, v)
    obj = link(s, bpy.data.objects.new(name or kind.title(), data))
    obj.location = location
    obj.rotation_euler = rotation
    return obj


def export(s):
    from durer.blender.export.depsgraph import export_depsgraph

    return export_depsgraph(bpy.context.evaluated_depsgraph_get())


DEG = math.pi / 180


def pointcloud_object(s, name, positions, radius=0.05, location=(0, 0, 0)):
    """A real POINTCLOUD object (a vertex-only mesh converted by Object > Convert > Point Cloud)."""
    obj = vertex_object(s, name, positions, location)
    for other in bpy.context.view_layer.objects:
        other.select_set(False)
    bpy.context.view_layer.objects.active = obj
    obj.select_set(True)
    assert bpy.ops.object.convert(target="POINTCLOUD") == {"FINISHED"}
    obj = bpy.context.view_layer.objects.active
    assert obj.type == "POINTCLOUD" and len(obj.data.points) == len(positions)
    attr = obj.data.attributes.get("radius") or obj.data.attributes.new("radius", "FLOAT", "POINT")
    radii = np.broadcast_to(np.asarray(radius, np.float32), (len(positions),))
    attr.data.foreach_set("value", np.ascontiguousarray(radii))
    return obj


def use_cycles(s, samples=1, filter_width=0.01, max_bounces=0):
    """Cycles on the CPU as the reference: no denoising, a tiny pixel filter (rays through the
    pixel centres), direct light only."""
    s.render.engine = "CYCLES"
    c = s.cycles
    c.device = "CPU"
    c.samples = samples
    c.use_adaptive_sampling = False
    c.use_denoising = False
    c.filter_width = filter_width
    c.max_bounces = max_bounces
    c.seed = 0
    s.render.threads_mode = "FIXED"
    s.render.threads = 2


def render_passes(s, path, depth=True, normal=True, indexes=False):
    """Render the scene with its engine through bpy.ops.render.render(write_still=True) into an
    uncompressed 32-bit multilayer EXR; return {"color": (H,W,4), "depth": (H,W), "normal":
    (H,W,3)} (top row first), read back from the file; with `indexes`, "IndexOB" and "IndexMA"
    (H,W) too (the view layer's Object and Material Index passes, so named in Blender 5)."""
    from helpers.exr import read_exr

    layer = s.view_layers[0]
    layer.use_pass_z = depth
    layer.use_pass_normal = normal
    layer.use_pass_object_index = layer.use_pass_material_index = indexes
    st = s.render.image_settings
    st.media_type = "MULTI_LAYER_IMAGE"
    st.file_format = "OPEN_EXR_MULTILAYER"
    st.exr_codec = "NONE"
    st.color_depth = "32"
    s.render.filepath = str(path)
    s.render.use_file_extension = False
    assert bpy.ops.render.render(write_still=True) == {"FINISHED"}
    ch = read_exr(path)
    name = layer.name
    out = {"color": np.stack([ch[f"{name}.Combined.{c}"] for c in "RGBA"], axis=-1)}
    if depth:
        out["depth"] = ch[f"{name}.Depth.Z"]
    if normal:
        out["normal"] = np.stack([ch[f"{name}.Normal.{c}"] for c in "XYZ"], axis=-1)
    if indexes:
        out["IndexOB"], out["IndexMA"] = ch[f"{name}.Object Index.X"], ch[f"{name}.Material Index.X"]
    return out


def aim_camera(s, location, target=(0, 0, 0)):
    """Put the scene camera at `location`, looking at `target` (up is +Z)."""
    from mathutils import Vector

    cam = s.camera
    cam.location = location
    cam.rotation_euler = (Vector(target) - Vector(location)).to_track_quat("-Z", "Y").to_euler()
    return cam


def ball_scene(s, width=64, height=48):
    """A lit red ball on a dark world: flat background, smooth shading, a silhouette."""
    s.render.resolution_x, s.render.resolution_y = width, height
    world(s, (0.05, 0.05, 0.05))
    uv_sphere(s, "Ball", radius=1.0).data.materials.append(material("Red", (0.8, 0.1, 0.1)))
    light(s, "SUN", energy=3.0, rotation=(40 * DEG, 0, 20 * DEG))
    aim_camera(s, (0, -6, 0))


MISS = 1e9  # Blender's Depth pass holds 1e10 where nothing is hit


def both(s, tmp_path, **kw):
    """The scene's passes rendered by Cycles (`use_cycles`), then by Dürer."""
    use_cycles(s)
    cycles = render_passes(s, tmp_path / "cycles.exr", **kw)
    s.render.engine = "DURER"
    durer_ = render_passes(s, tmp_path / "durer.exr", **kw)
    return cycles, durer_


def smooth_mask(c_img, d_hit, c_hit, lit_only=True):
    """Pixels whose 3x3 neighbourhood is hit in both renders and has no step in Cycles' brightness
    (no silhouette or shadow edge); `lit_only` also drops pixels Cycles shows in shadow."""
    lum = c_img[..., :3].mean(axis=-1)
    both_hit = d_hit & c_hit
    pad = np.pad(lum, 1, mode="edge")
    hpad = np.pad(both_hit, 1, mode="constant")
    h, w = lum.shape
    lo = np.full((h, w), np.inf)
    hi = np.full((h, w), -np.inf)
    all_hit = np.ones((h, w), bool)
    for dy in range(3):
        for dx in range(3):
            lo = np.minimum(lo, pad[dy : dy + h, dx : dx + w])
            hi = np.maximum(hi, pad[dy : dy + h, dx : dx + w])
            all_hit &= hpad[dy : dy + h, dx : dx + w]
    smooth = all_hit & (hi <= 1.3 * lo + 1e-3)
    return smooth & (lum > 0.01) if lit_only else smooth


def compare_shading(c, d, lit_only=True, min_fraction=0.3):
    """Asserts Dürer's Combined is within 1 % of Cycles' on the smooth pixels; returns their mask."""
    hit_c, hit_d = c["depth"] < MISS, d["depth"] < MISS
    mask = smooth_mask(c["color"], hit_d, hit_c, lit_only)
    assert mask.mean() > min_fraction
    cc, dd = c["color"][mask][:, :3], d["color"][mask][:, :3]
    err = np.abs(dd - cc) - 0.01 * cc
    assert err.max() <= 1e-4, f"{(err > 1e-4).mean():.2%} of compared pixels differ by more than 1 %"
    return mask
