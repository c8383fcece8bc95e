"""The depsgraph walk: every object instance to the builder, through a converter per object type."""

from __future__ import annotations

import math

import numpy as np

from .builder import Builder
from .camera import camera_data
from .data import SceneData
from .instances import InstanceBatches
from .lights import light_data
from .materials import object_materials
from .matrices import uniform_scale, world_matrix
from .nodes import rgb
from .shapes import MeshShape, cloud_points, mesh_key, mesh_shape, metaball_iso_radius
from .world import ambient_occlusion, world_colors

# Object types whose evaluated mesh also appears among the depsgraph's instances.
_CONVERTED_TYPES = {"CURVE", "SURFACE", "FONT", "META"}
# Object types that neither carry geometry nor light the scene.
_NOT_RENDERED = {"CAMERA", "ARMATURE", "LATTICE", "SPEAKER", "LIGHT_PROBE"}
# object.durer primitive modes under which an instanced mesh may be a sphere (instances.py).
_SPHERE_MODES = {"AUTO", "SPHERE"}
# Object › Visibility settings (Cycles') that the core has no counterpart for: the property, the
# value that asks for what Dürer does not do, and what that is; for objects, and for lights. A
# render with any says so. Cycles follows these of an instanced object in each of its instances too.
_IGNORED_VISIBILITY = (
    ("visible_camera", False, "hidden from the camera"),
    ("visible_shadow", False, "casting no shadows"),
    ("visible_glossy", False, "hidden from reflections"),
    ("visible_transmission", False, "hidden from refraction"),
    ("is_shadow_catcher", True, "a shadow catcher"),
)
# Those an object has through the view layer, set on it or on a collection of it (LayerCollection
# Holdout, Indirect Only): the flag (read by `<flag>_get(view_layer=)`), the object's own property
# (the cheaper read where no collection sets the flag) and what it asks for. Cycles takes them of
# an instance's instancer, not of the instanced object.
_IGNORED_LAYER_VISIBILITY = (
    ("holdout", "is_holdout", "a holdout"),
    ("indirect_only", None, "indirect only"),
)
_IGNORED_LIGHT_VISIBILITY = (
    ("visible_camera", True, "shown to the camera (Dürer draws no light itself)"),
    ("visible_diffuse", False, "lighting no diffuse surface"),
    ("visible_glossy", False, "making no highlight nor showing in mirrors"),
)


def _durer_settings(obj, original):
    """object.durer of the original object (evaluated copies can hold stale values; geometry
    instances made by geometry nodes report their instancer as original)."""
    return getattr(original or obj, "durer", None)


def _pointcloud(b: Builder, obj, m: np.ndarray, mode: str, infinite: bool) -> None:
    pc = obj.data
    n = len(pc.points)
    if n == 0:
        return
    attrs = pc.attributes
    pos, radii = cloud_points(pc)
    mats = object_materials(obj)
    index_attr = attrs.get("material_index")
    slots = None
    if index_attr is not None and len(mats) > 1:
        slots = np.empty(n, np.int32)
        index_attr.data.foreach_get("value", slots)
        table = np.array([b.material(mt, obj) for mt in mats], dtype=np.int32)
        materials = table[np.clip(slots, 0, len(mats) - 1)]
    else:
        materials = b.material(mats[0] if mats else None, obj)
    colors = b.attribute_colors(pc, mats, slots, materials, n, {"POINT": n})
    keep = radii > 0
    if not keep.all():
        pos, radii = pos[keep], radii[keep]
        if not np.isscalar(materials):
            materials = materials[keep]
        if colors is not None:
            colors = colors[keep]
    b.placed_spheres(b.owner(obj), m[None, :3], pos[None], radii[None],
                     materials if np.isscalar(materials) else materials[None], None if colors is None else colors[None],
                     points=True)


def _mesh(b: Builder, obj, m: np.ndarray, mode: str, infinite: bool) -> None:
    me = obj.data
    mats = object_materials(obj)
    if mode == "AUTO" and any(b.color_source(mat) for mat in mats):
        mode = "MESH"  # colours vary over it: not one sphere or plane of one colour
    axis_scale = tuple(np.round(np.linalg.norm(m[:3, :3], axis=0), 9)) if mode == "PLANE" else None
    key = (mesh_key(me), mode, axis_scale, len(mats))
    shape = b.shape_cache.get(key)
    if shape is None:
        shape = b.shape_cache[key] = mesh_shape(me, mode, axis_scale or (1.0, 1.0, 1.0), len(mats))
    _add_shape(b, obj, m, shape, infinite, me, mats)


def _add_shape(b: Builder, obj, m: np.ndarray, shape: MeshShape, infinite: bool, me, mats: list) -> None:
    """A detected sphere or plane of `obj` (world matrix m, material slots `mats`) with the material
    of the slot its faces use, or its triangles (of mesh `me`) with their slots' materials; nothing
    for an empty shape."""
    b.faces_left_out(obj.name_full, shape)
    if shape.kind == "triangles":
        b.triangles(obj, m, shape.parts, me)
        return
    if shape.kind == "empty":
        return
    mat = mats[shape.slot] if mats else None
    b.uncolored(mat, f"'{obj.name_full}' is rendered as one {shape.kind}, of one colour")
    if shape.kind == "sphere":
        b.sphere(b.owner(obj), m, shape.center, shape.radius, b.material(mat, obj))
    else:
        b.plane(b.owner(obj), m, shape, b.material(mat, obj), infinite)


def _converted(b: Builder, obj, m: np.ndarray, mode: str, infinite: bool) -> None:
    """Curves, text, surfaces, metaballs...: their evaluated mesh as triangles (Auto, Mesh) or
    forced to a sphere or plane. A type with no mesh (volumes, hair curves) is skipped; a
    curve without faces renders as nothing, as in Cycles."""
    try:
        me = obj.to_mesh()
    except RuntimeError:
        me = None
    if me is None:
        # A curve, surface, text or metaball with no mesh nor curves of its own (its geometry nodes
        # output only instances, say) holds nothing more to render: what else they output (instances,
        # point clouds, volumes) the walk meets as instances of it, and renders or counts there.
        if obj.type not in _CONVERTED_TYPES:
            b.data.skipped[obj.type.lower()] += 1
        return
    try:
        axis_scale = np.linalg.norm(m[:3, :3], axis=0)
        # The arrays are copies (foreach_get), so they outlive the temporary mesh.
        mats = object_materials(obj)
        _add_shape(b, obj, m, mesh_shape(me, mode, axis_scale, len(mats)), infinite, me, mats)
    finally:
        obj.to_mesh_clear()


def _metaball(b: Builder, obj, m: np.ndarray, mode: str, infinite: bool) -> None:
    """Auto: each ball a sphere (capsules and negative elements are skipped); another mode (Mesh
    for a family with instanced balls: `_metaball_families`): the evaluated mesh, as `_converted`."""
    if mode != "AUTO":
        _converted(b, obj, m, mode, infinite)
        return
    mb = obj.data
    basis = b.metaball_bases.get(_split_name_number(obj.name)[0], obj)
    material = b.object_material(basis)
    for el in mb.elements:
        if el.hide:
            continue
        if el.type != "BALL" or el.use_negative:
            b.data.skipped[f"metaball {el.type.lower()}{' (negative)' if el.use_negative else ''}"] += 1
            continue
        r = metaball_iso_radius(el.radius, el.stiffness, basis.data.threshold)
        if r > 0:
            b.sphere(b.owner(obj), m, np.array(el.co), r, material)


def _split_name_number(name: str) -> tuple[str, int]:
    """"Meta.001" -> ("Meta", 1); a name without a numeric suffix -> (name, 0) (Blender's
    BLI_string_split_name_number, which names metaball families)."""
    stem, dot, number = name.rpartition(".")
    return (stem, int(number)) if dot and number.isdigit() else (name, 0)


def _metaball_families(depsgraph, shown: str) -> tuple[dict[str, object], set[str]]:
    """Each metaball family's basis, as Blender finds it (BKE_mball_basis_find): of the metaball
    objects named Name, Name.001, Name.002, ..., the one of the lowest number. Blender draws the
    whole family as the basis's surface, with the basis's material and threshold. And the families
    whose balls are instanced too: a member instanced on its parent's vertices or faces, or by a
    particle system (itself or a collection holding it; `shown`: as in `_particle_settings`).
    Blender puts such instances' balls into the basis's surface as well (the walk never meets
    them), so those families render as that mesh; it leaves collection instances' balls out."""
    bases: dict[str, tuple[int, object]] = {}
    members = []
    for obj in depsgraph.objects:
        if obj.type == "META":
            name, number = _split_name_number(obj.name)
            members.append((name, obj))
            if name not in bases or number < bases[name][0]:
                bases[name] = (number, obj)
    instanced = set()
    if members:
        by_particles = _particle_instanced(depsgraph, shown)
        for name, obj in members:
            parent = obj.parent
            if (parent is not None and parent.instance_type in {"VERTS", "FACES"}) or obj.name_full in by_particles:
                instanced.add(name)
    return {name: obj for name, (_, obj) in bases.items()}, instanced


def _particle_settings(obj, shown: str) -> list:
    """The settings of object `obj`'s particle systems whose modifier is enabled (`shown`: its
    show_render in a render, show_viewport in the viewport); the modifiers are read only where `obj`
    has a particle system (most objects have none: one read)."""
    if not obj.particle_systems:
        return []
    return [modifier.particle_system.settings for modifier in obj.modifiers
            if modifier.type == "PARTICLE_SYSTEM" and getattr(modifier, shown)]


def _count_hair(b: Builder, obj, shown: str) -> None:
    """Counts as skipped each of object `obj`'s particle systems that Cycles draws as strands (Hair
    rendered as Path): Dürer has no curve primitive."""
    for settings in _particle_settings(obj, shown):
        if settings.type == "HAIR" and settings.render_type == "PATH":
            b.data.skipped["hair particle system"] += 1


def _particle_instanced(depsgraph, shown: str) -> set[str]:
    """The metaball objects (by `name_full`) that particle systems render, as an object or in a collection."""
    found = set()
    for obj in depsgraph.objects:
        for settings in _particle_settings(obj, shown):
            if settings.render_type == "OBJECT" and settings.instance_object is not None:
                rendered = [settings.instance_object]
            elif settings.render_type == "COLLECTION" and settings.instance_collection is not None:
                rendered = settings.instance_collection.all_objects
            else:
                continue
            found.update(o.name_full for o in rendered if o.type == "META")
    return found


def _light(b: Builder, obj, m: np.ndarray) -> None:
    if getattr(getattr(obj.data, "cycles", None), "is_portal", False):
        return  # a portal guides Cycles' world light and emits nothing itself
    light = light_data(obj, m)
    if light is None:
        b.data.notes.append(f"Area light '{obj.name_full}' has no area (its size or scale is 0): Dürer leaves it out")
        return
    if min(light.color) < 0:
        b.data.notes.append(f"Light '{obj.name_full}' has a negative power or colour: Dürer leaves it out "
                            f"(Cycles takes its light away)")
        return
    b.data.lights.append(light)
    if light.kind == "spot" and not uniform_scale(m)[1]:
        b.data.notes.append(f"Spot light '{obj.name_full}' is scaled unevenly: Cycles stretches its cone, "
                            f"Dürer keeps it round")
    if obj.data.use_nodes:
        b.data.notes.append(f"Light '{obj.name_full}' uses shader nodes: Dürer takes its colour and power alone")
    if light.kind == "area" and abs(np.dot(*light.edges)) > 1e-6 * np.prod([np.linalg.norm(e) for e in light.edges]):
        b.data.notes.append(f"Area light '{obj.name_full}' is sheared (a parent's uneven scale turned with it): "
                            f"Dürer shines the parallelogram, Cycles otherwise (measured 5-18 % brighter)")
    if light.kind == "area" and obj.data.spread < math.pi - 1e-6:
        b.data.notes.append(f"Area light '{obj.name_full}' has a Spread of {math.degrees(obj.data.spread):.4g}°: "
                            f"Dürer spreads its light as at 180° (Lambertian)")


def _empty(b: Builder, obj, m: np.ndarray, mode: str, infinite: bool) -> None:
    """An empty displayed as a sphere is a sphere of its display size (not a collection instancer)."""
    if obj.empty_display_type == "SPHERE" and mode in {"AUTO", "SPHERE"} and obj.instance_type != "COLLECTION":
        b.sphere(b.owner(obj), m, np.zeros(3), float(obj.empty_display_size), b.object_material(obj))


def _made_by_nodes(obj, original, depsgraph) -> bool:
    """Whether instance `obj` is geometry that the geometry nodes of `original` (which such
    instances report as theirs) made: data other than that object's own evaluated data."""
    data = obj.data
    return data is not None and original is not None and data != original.evaluated_get(depsgraph).data


def _collection_flags(layer) -> set[str]:
    """Which of `_IGNORED_LAYER_VISIBILITY`'s flags a collection of view layer `layer` sets."""
    found, stack = set(), [layer.layer_collection]
    while stack:
        collection = stack.pop()
        found.update(flag for flag, _, _ in _IGNORED_LAYER_VISIBILITY if getattr(collection, flag))
        stack.extend(collection.children)
    return found


def _ignored_visibility(depsgraph, instanced: dict) -> str | None:
    """A note naming the objects whose Visibility settings Dürer does not follow, or None: the
    depsgraph's objects, and the originals of objects the walk met as instances (`instanced`, in
    the walk's order; some reach the render only so: a vertex instancer's child, a collection's
    object instanced from an excluded collection), whose own settings Cycles follows in each copy."""
    found: dict[str, list[str]] = {}
    layer = depsgraph.view_layer_eval
    by_collection = _collection_flags(layer)
    rest = dict(instanced)
    for obj in depsgraph.objects:
        linking = getattr(obj, "light_linking", None)  # Blender 4.0 and later
        if linking is not None and (linking.receiver_collection or linking.blocker_collection):
            found.setdefault("linking lights or shadows", []).append(obj.name_full)
        if obj.type in _NOT_RENDERED:
            continue
        original = obj.original
        rest.pop(original, None)
        if not _own_visibility(obj, original, found) or obj.type == "LIGHT":
            continue
        for flag, own, what in _IGNORED_LAYER_VISIBILITY:
            if getattr(obj, f"{flag}_get")(view_layer=layer) if flag in by_collection else own and getattr(obj, own):
                found.setdefault(what, []).append(obj.name_full)
    for original in rest:
        _own_visibility(original, original, found)
    if not found:
        return None
    listed = "; ".join(f"{', '.join(repr(n) for n in names[:3])}{' and others' if len(names) > 3 else ''} {what}"
                       for what, names in found.items())
    return (f"Dürer renders every object as seen by every ray and lit by every light; it does not follow "
            f"Object › Visibility or light linking for {listed}")


def _own_visibility(obj, original, found: dict[str, list[str]]) -> bool:
    """Adds object `obj` (original `original`) to `found` under each of its own Visibility settings
    Dürer does not follow, if it is rendered: False where its Primitive is Ignore (nothing to say)."""
    settings = _durer_settings(obj, original)
    if settings is not None and settings.primitive == "IGNORE":
        return False
    for name, asks, what in _IGNORED_LIGHT_VISIBILITY if obj.type == "LIGHT" else _IGNORED_VISIBILITY:
        if getattr(obj, name) == asks:
            found.setdefault(what, []).append(obj.name_full)
    return True


def _ignored_camera_settings(scene) -> list[str]:
    """Notes on what the camera sees that Dürer does not simulate: motion blur, a world hidden from
    the camera."""
    notes = []
    if scene.render.use_motion_blur:
        notes.append("Motion blur is on: Dürer renders each frame at one instant")
    visibility = getattr(scene.world, "cycles_visibility", None)  # with the Cycles add-on enabled
    if visibility is not None and not visibility.camera:
        notes.append(f"World '{scene.world.name}' is hidden from the camera: Dürer shows it behind the objects")
    return notes


def _mesh_or_skip(b: Builder, obj, m: np.ndarray, mode: str, infinite: bool) -> None:
    """Hair curves, volumes and grease pencil: skipped (and counted) under Auto; a forced primitive
    uses their evaluated mesh, if they have one."""
    if mode == "AUTO":
        b.data.skipped[obj.type.lower()] += 1
    else:
        _converted(b, obj, m, mode, infinite)


#: Object type -> its converter (builder, evaluated object, world matrix, object.durer's primitive
#: mode, infinite plane?). Types not listed here, lights apart, are not rendered.
CONVERTERS = {
    "MESH": _mesh,
    "POINTCLOUD": _pointcloud,
    "EMPTY": _empty,
    "META": _metaball,
    "CURVE": _converted,
    "SURFACE": _converted,
    "FONT": _converted,
    "CURVES": _mesh_or_skip,
    "VOLUME": _mesh_or_skip,
    "GREASEPENCIL": _mesh_or_skip,
}


#: A view layer's `use_pass_*` settings that ask for no pass of their own.
_NOT_PASSES = {"Cryptomatte Accurate"}


def _unwritten_passes(layer) -> list[str]:
    """The passes view layer `layer` asks for (its and its Cycles settings' `use_pass_*`, AOVs, light
    groups, denoising data) that Dürer does not write, by Blender's names: those beyond Combined and
    the engine's `PASS_LAYOUTS`."""
    from ..engine import PASS_LAYOUTS  # the engine imports this module

    written = {"Combined", *PASS_LAYOUTS}
    asked = [prop.name for settings in (layer, getattr(layer, "cycles", None)) if settings is not None
             for prop in settings.bl_rna.properties
             if prop.identifier.startswith("use_pass_") and getattr(settings, prop.identifier)]
    if getattr(getattr(layer, "cycles", None), "denoising_store_passes", False):
        asked.append("Denoising Data")
    asked += [f"AOV '{aov.name}'" for aov in getattr(layer, "aovs", ())]
    asked += [f"Light Group '{group.name}'" for group in getattr(layer, "lightgroups", ())]
    return [name for name in asked if name not in written and name not in _NOT_PASSES]


def _ignored_view_layer(layer) -> list[str]:
    """Notes on the view layer's settings Dürer does not follow: overrides, filters, passes."""
    notes = []
    for name, what in (("material_override", "material"), ("world_override", "world")):
        override = getattr(layer, name, None)
        if override is not None:
            notes.append(f"View layer '{layer.name}' overrides every {what} with '{override.name}': Dürer "
                         f"renders each with its own")
    hidden = [what for name, what in (("use_sky", "Environment"), ("use_solid", "Surfaces")) if not getattr(layer, name)]
    if hidden:
        notes.append(f"View layer '{layer.name}' filters out {' and '.join(hidden)}: Dürer renders them")
    unwritten = _unwritten_passes(layer)
    if unwritten:
        notes.append(f"View layer '{layer.name}' asks for passes Dürer does not write: {', '.join(unwritten)}")
    return notes


def export_depsgraph(depsgraph, camera=None, *, with_camera: bool = True) -> SceneData:
    """Everything Dürer renders, from an evaluated depsgraph (render or viewport).

    `camera`: the camera object (default: the scene's camera); `with_camera` False: none (the
    viewport renders its own view, whatever the scene's camera is).
    """
    scene = depsgraph.scene_eval
    b = Builder()
    shown = "show_render" if depsgraph.mode == "RENDER" else "show_viewport"  # a modifier enabled
    b.metaball_bases, polygonized = _metaball_families(depsgraph, shown)
    batches = InstanceBatches(b)
    # The originals of the objects met as instances, in the walk's order (bpy structs hash by pointer):
    # their Visibility settings are said too. Instances `skips` passes add none (their instancer or
    # their particle system's first particle did).
    instanced: dict = {}
    for inst in depsgraph.object_instances:
        is_instance = inst.is_instance
        if is_instance and batches.skips(inst):
            continue  # made in bulk with its instancer, or kept with its particle system's others
        obj = inst.object
        kind = obj.type
        if kind in _NOT_RENDERED:
            continue
        original = obj.original  # read once: the walk's per-instance cost is in such reads
        if is_instance:
            instanced[original] = None
        if kind == "LIGHT":
            if inst.show_self:
                _light(b, obj, world_matrix(inst.matrix_world))
            continue
        settings = _durer_settings(obj, original)
        mode = settings.primitive if settings is not None else "AUTO"
        if mode == "IGNORE":
            continue  # and all its geometry nodes make
        if mode != "AUTO" and is_instance and _made_by_nodes(obj, original, depsgraph):
            settings, mode = None, "AUTO"  # the Primitive is for the object's own geometry
        if not is_instance:
            batches.take_instancer(obj)
            # Strands Cycles draws, whether the emitter is drawn or not (Show Emitter); the guard
            # is the one read most objects (no particle system) cost.
            if obj.particle_systems:
                _count_hair(b, obj, shown)
        if kind == "META" and mode == "AUTO" and _split_name_number(obj.name)[0] in polygonized:
            mode = "MESH"  # its instanced balls are in the basis's mesh alone: no sphere per ball
        if not inst.show_self:
            continue  # an instancer Blender does not draw itself (a particle emitter with Show Emitter off)
        if kind == "MESH":
            if original is not None and original.type in _CONVERTED_TYPES:
                continue  # the mesh Blender made of a curve, text, surface or metaball: handled as that
            if is_instance and mode in _SPHERE_MODES and batches.take(inst, obj, original, mode):
                continue
        infinite = bool(settings.infinite_plane) if settings is not None else False
        convert = CONVERTERS.get(kind)
        if convert is not None:
            convert(b, obj, world_matrix(inst.matrix_world), mode, infinite)
    batches.finish()
    data = b.finish()
    cam_obj = (camera if camera is not None else scene.camera) if with_camera else None
    if cam_obj is not None:
        try:
            cam_obj = cam_obj.evaluated_get(depsgraph)
        except (RuntimeError, TypeError):
            pass
        data.camera = camera_data(scene, cam_obj)

    world_rgb, world_note = world_colors(scene.world)
    data.notes.extend(note for note in (_ignored_visibility(depsgraph, instanced), world_note) if note)
    data.notes.extend(_ignored_camera_settings(scene))
    data.notes.extend(_ignored_view_layer(depsgraph.view_layer))
    # A transparent film: no world behind the objects, but mirrors and glass still show it.
    data.background = world_rgb + (0.0 if scene.render.film_transparent else 1.0,)
    settings = getattr(scene, "durer", None)
    if settings is not None and settings.use_custom_ambient:
        data.ambient = rgb(settings.ambient)
    elif settings is None or settings.use_world_lighting:
        data.ambient = world_rgb
    data.ambient_occlusion = ambient_occlusion(scene)
    if settings is not None:
        data.light_samples = int(scene.original.durer.light_samples)
        data.soft_shadows = bool(scene.original.durer.soft_shadows)
    return data
