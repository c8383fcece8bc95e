"""Dürer's settings in Blender: ``scene.durer`` (render settings), ``object.durer`` (primitive),
``material.durer`` (a 6.837 material override) and ``light.durer`` (a falloff override)."""

from __future__ import annotations

import inspect

import bpy
import numpy as np
from bpy.props import BoolProperty, EnumProperty, FloatProperty, FloatVectorProperty, IntProperty, PointerProperty

import durer
from durer.material import COURSE_FIELDS, MaterialField
from durer.presets import PRESETS
from durer.render import PRECISIONS, SAMPLERS, SPHERE_METHODS

PRIMITIVE_ITEMS = [
    (
        "AUTO",
        "Auto",
        "Detect sphere meshes, flat quads, point clouds, sphere empties and metaball balls; "
        "other meshes, curves and text render as triangles",
    ),
    (
        "SPHERE",
        "Sphere",
        "Render as a sphere: through the vertices if they are equidistant from their centroid, else the sphere fitting the bounding box",
    ),
    ("PLANE", "Plane", "Render as the flat rectangle of the object's bounding box (thinnest axis is the normal)"),
    ("MESH", "Mesh", "Render the faces as triangles, as they are (no sphere or plane detection)"),
    ("IGNORE", "Ignore", "Do not render this object"),
]


#: Label and tooltip of each sampler (durer.render.SAMPLERS), in the order the menu shows them.
SAMPLER_TEXT = {
    "center": ("Center", "Every sample at the pixel centre: no anti-aliasing (the baseline)"),
    "random": ("Random", "Uniform random positions in the pixel, deterministic for the seed"),
    "stratified": (
        "Stratified",
        "Jittered-stratified positions, one per cell of an nx by ny grid, deterministic for the seed "
        "(1 sample: the pixel centre)",
    ),
    "sobol": (
        "Sobol",
        "Owen-scrambled Sobol low-discrepancy points, scrambled per pixel from the seed: "
        "the error falls fastest with more samples",
    ),
    "adaptive": (
        "Adaptive",
        "Sobol points, Min Samples at first, then twice as many in rounds for the pixels whose estimated "
        "error exceeds Target Error or that sit on an edge their own or their neighbours' samples show, "
        "up to Samples (or until the Time Limit)",
    ),
}
#: Label and tooltip of each precision (durer.render.PRECISIONS).
PRECISION_TEXT = {
    "double": ("Double", "64-bit: exact for large or far-away scenes"),
    "float": ("Single", "32-bit: faster, may show acne on huge or distant spheres"),
}
#: Label and tooltip of each sphere method (durer.render.SPHERE_METHODS).
SPHERE_METHOD_TEXT = {
    "robust": ("Robust", "Numerically careful quadratic (no cancellation, exact far from the origin)"),
    "geometric": ("Geometric", "Geometric (projection) solution"),
    "algebraic": ("Algebraic", "Textbook quadratic formula (for comparison: loses precision)"),
}


def enum_items(names: tuple[str, ...], text: dict[str, tuple[str, str]]) -> list[tuple[str, str, str]]:
    """EnumProperty items for the core's option `names`: identifier NAME (upper case), label and
    tooltip from `text`. Items keep the order of `text`, because a .blend file stores an enum
    setting as its item's index; a name without text is an error (tests/blender check both ways)."""
    missing = [name for name in names if name not in text]
    if missing:
        raise ValueError(f"no label for {', '.join(missing)}")
    order = list(text)
    return [(name.upper(), *text[name]) for name in sorted(names, key=order.index)]


SAMPLER_ITEMS = enum_items(SAMPLERS, SAMPLER_TEXT)
PRECISION_ITEMS = enum_items(PRECISIONS, PRECISION_TEXT)
SPHERE_METHOD_ITEMS = enum_items(SPHERE_METHODS, SPHERE_METHOD_TEXT)

#: durer.render's defaults: the settings start where durer.render does.
RENDER_DEFAULTS = {
    name: p.default
    for name, p in inspect.signature(durer.render).parameters.items()
    if p.default is not inspect.Parameter.empty
}

#: Preset identifiers in the Preset menu and the durer.PRESETS names they stand for.
PRESET_NAMES = {name.upper(): name for name in PRESETS}

#: The scene.durer setting each durer.render keyword of a preset sets, and how its value is stored.
PRESET_FIELDS = {
    "spp": ("samples", int),
    "sampler": ("sampler", str.upper),
    "target_error": ("target_error", float),
    "min_spp": ("min_samples", int),
    "precision": ("precision", str.upper),
    "sphere_method": ("sphere_method", str.upper),
}


def preset_settings(name: str) -> dict:
    """The scene.durer values of preset `name` (e.g. "FINAL"): durer.preset(...)'s samples, sampler,
    target error and precision, with durer.render's defaults for what the preset leaves out (so
    the render equals durer.render(..., **durer.preset(name))). {} for "CUSTOM"."""
    core_name = PRESET_NAMES.get(name)
    if core_name is None:
        return {}
    defaults = {key: RENDER_DEFAULTS[key] for key in ("spp", "sampler", "target_error", "min_spp", "precision")}
    values = {}
    for key, value in {**defaults, **durer.preset(core_name)}.items():
        if key in PRESET_FIELDS:
            field, convert = PRESET_FIELDS[key]
            values[field] = convert(value)
    return values


def _describe_preset(name: str, label: str) -> str:
    """The tooltip, e.g. "Final: Adaptive, up to 64 samples, target error 0.005, double precision"."""
    v = preset_settings(name)
    parts = [v["sampler"].title()]
    if v["sampler"] == "ADAPTIVE":
        parts.append(f"up to {v['samples']} samples, target error {v['target_error']:g}")
    else:
        parts.append(f"{v['samples']} sample" + ("s" if v["samples"] != 1 else ""))
    parts.append(f"{PRECISION_TEXT[v['precision'].lower()][0].lower()} precision")
    return f"{label}: " + ", ".join(parts)


def _preset_items() -> list[tuple[str, str, str]]:
    items = [("CUSTOM", "Custom", "Samples, sampler, target error and precision as set below")]
    for name in PRESET_NAMES:
        label = name.title()
        items.append((name, label, _describe_preset(name, label)))
    return items


_applying_preset = False


def _same(field: str, current, wanted) -> bool:
    if field == "target_error":  # stored as float32
        return bool(np.float32(current) == np.float32(wanted))
    return current == wanted


def preset_matches(settings, name: str) -> bool:
    """Do the settings still hold everything preset `name` sets?"""
    values = preset_settings(name)
    return bool(values) and all(_same(f, getattr(settings, f), v) for f, v in values.items())


def _apply_preset(settings, _context) -> None:
    """Preset update: set samples, sampler, target error and precision to the chosen preset's."""
    global _applying_preset
    values = preset_settings(settings.preset)
    if not values:
        return
    _applying_preset = True
    try:
        for field, value in values.items():
            setattr(settings, field, value)
    finally:
        _applying_preset = False


def _setting_changed(settings, _context) -> None:
    """A setting a preset controls was edited: the preset becomes Custom unless it still holds."""
    if _applying_preset or settings.preset == "CUSTOM":
        return
    if not preset_matches(settings, settings.preset):
        settings.preset = "CUSTOM"


def _option_setting(label: str, description: str, items: list, keyword: str):
    """A menu over one of durer.render's options (`keyword`), starting at its default; editing it
    makes the preset Custom."""
    return EnumProperty(
        name=label,
        description=description,
        items=items,
        default=RENDER_DEFAULTS[keyword].upper(),
        update=_setting_changed,
    )


def _sample_count_setting(label: str, description: str, keyword: str):
    """A count of samples per pixel (durer.render's `keyword`), starting at its default; editing it
    makes the preset Custom."""
    return IntProperty(name=label, description=description, default=RENDER_DEFAULTS[keyword], min=1, soft_max=64,
                       max=4096, update=_setting_changed)


class DurerSceneSettings(bpy.types.PropertyGroup):
    preset: EnumProperty(
        name="Preset",
        description="Quality preset (durer.PRESETS): sets Samples, Sampler, Target Error and Precision; "
        "editing any of them makes it Custom",
        items=_preset_items(),
        default="CUSTOM",
        update=_apply_preset,
    )
    samples: _sample_count_setting("Samples", "Camera rays per pixel (Adaptive: the most a pixel gets)", "spp")
    seed: IntProperty(name="Seed", description="Seed of the pixel sampler", default=RENDER_DEFAULTS["seed"], min=0)
    sampler: _option_setting("Sampler", "Where a pixel's rays go", SAMPLER_ITEMS, "sampler")
    target_error: FloatProperty(
        name="Target Error",
        description="Adaptive: a pixel gets more samples while the estimated RMS error of its colour "
        "(or of its neighbourhood's) exceeds this",
        default=RENDER_DEFAULTS["target_error"],
        min=1e-5,
        soft_min=0.001,
        max=1.0,
        precision=4,
        step=0.1,
        update=_setting_changed,
    )
    min_samples: _sample_count_setting(
        "Min Samples", "Adaptive: samples every pixel takes before any is judged (more finds smaller details)", "min_spp"
    )
    time_limit: FloatProperty(
        name="Time Limit",
        description="Adaptive: stop refining after this long, the worst tiles refined first (0: no limit); "
        "the first Min Samples of every pixel are always taken",
        default=0.0,
        min=0.0,
        soft_max=600.0,
        subtype="TIME_ABSOLUTE",
        unit="TIME_ABSOLUTE",
    )
    precision: _option_setting(
        "Precision", "Floating-point precision of the intersection arithmetic", PRECISION_ITEMS, "precision"
    )
    sphere_method: _option_setting(
        "Sphere Method", "How ray-sphere intersections are solved", SPHERE_METHOD_ITEMS, "sphere_method"
    )
    threads: IntProperty(name="Threads", description="Render threads (0: all cores)", default=0, min=0, max=1024)
    max_bounces: IntProperty(
        name="Max Bounces",
        description="Reflection and refraction rays followed from a camera ray at most "
        "(0: direct lighting only). Only mirror-like and transmissive materials spawn them",
        default=RENDER_DEFAULTS["max_bounces"],
        min=0,
        soft_max=16,
        max=durer._core.RENDER_LIMITS["max_bounces"],
    )
    min_weight: FloatProperty(
        name="Min Weight",
        description="A reflection or refraction ray is not traced when its contribution to the pixel "
        "(the product of reflective/transparent colours along the path, largest channel) is below this",
        default=RENDER_DEFAULTS["min_weight"],
        min=0.0,
        max=1.0,
        precision=4,
        step=0.1,
    )
    use_world_lighting: BoolProperty(
        name="World Lighting",
        description="Light diffuse surfaces with the world colour as ambient light "
        "(like Cycles' uniform world, without occlusion)",
        default=True,
    )
    use_custom_ambient: BoolProperty(
        name="Custom Ambient",
        description="Use the Ambient colour below as ambient light instead of the world colour "
        "(6.837 scenes set background and ambient light separately)",
        default=False,
    )
    ambient: FloatVectorProperty(
        name="Ambient",
        description="Ambient light (linear RGB) when Custom Ambient is on: adds ambient × diffuse colour",
        subtype="COLOR",
        size=3,
        default=(0.0, 0.0, 0.0),
        min=0.0,
        soft_max=1.0,
    )
    ambient_occlusion: EnumProperty(
        name="Ambient Occlusion",
        description="Darken the ambient (world) light where nearby surfaces block it: durer.render's "
        "ambient_occlusion",
        items=[
            ("AUTO", "From Fast GI", "On when Cycles' Fast GI Approximation is on "
             "(Render Properties › Light Paths, in Cycles)"),
            ("ON", "On", "Always"),
            ("OFF", "Off", "Never: no occlusion rays"),
        ],
        default="AUTO",
    )
    ao_samples: IntProperty(
        name="AO Samples",
        description="Occlusion rays per shaded point (per camera sample): noise falls as samples grow",
        default=16,
        min=1,
        soft_max=256,
        max=durer._core.RENDER_LIMITS["rays_per_hit"],
    )
    soft_shadows: BoolProperty(
        name="Soft Shadows",
        description="Point and Spot lights' Radius and Suns' Angle soften their shadows as in Cycles, with "
        "Light Samples shadow rays per shaded point; off: hard shadows from the light's centre, one ray "
        "(Area lights' shadows are always soft; the Radius and Angle spread highlights either way)",
        default=False,
    )
    light_samples: IntProperty(
        name="Light Samples",
        description="Points on each area light, or shadow rays toward each light of some size with Soft "
        "Shadows, per shaded point (per camera sample): the noise of their light and soft shadows falls "
        "as samples grow",
        default=16,
        min=1,
        soft_max=256,
        max=durer._core.RENDER_LIMITS["rays_per_hit"],
    )
    use_world_ao_distance: BoolProperty(
        name="World AO Distance",
        description="Occluders count within the World's AO Distance (World › Light Settings, "
        "Cycles' Fast GI AO distance) instead of AO Distance below",
        default=True,
    )
    ao_distance: FloatProperty(
        name="AO Distance",
        description="How far a surface occludes the ambient light, when World AO Distance is off",
        default=10.0,
        min=1e-6,
        soft_max=100.0,
        subtype="DISTANCE",
    )
    shade_back: BoolProperty(
        name="Shade Back Faces",
        description="Shade back faces with the flipped normal, as Cycles does (6.837's -shade_back); "
        "off: with the normal as stored, so a back face gets no direct light",
        default=True,
    )


class DurerObjectSettings(bpy.types.PropertyGroup):
    primitive: EnumProperty(
        name="Primitive",
        description="How Dürer renders this object",
        items=PRIMITIVE_ITEMS,
        default="AUTO",
    )
    infinite_plane: BoolProperty(
        name="Infinite Plane",
        description="When this object is rendered as a plane, extend it to infinity",
        default=False,
    )


def _passes_changed(settings, _context) -> None:
    """Blender asks the engine for a view layer's passes again (the compositor's Render Layers
    sockets) when one of its own pass switches changes, not ours: tell it."""
    for layer in settings.id_data.view_layers:
        if layer.durer.as_pointer() == settings.as_pointer():
            layer.update_render_passes()


class DurerViewLayerSettings(bpy.types.PropertyGroup):
    use_pass_object_id: BoolProperty(
        name="Object ID",
        description="Dürer's Object ID pass: the file's objects numbered 1, 2, ... in the order of their "
        "names, the same on every frame (0 where nothing is hit), whatever their Pass Index; the table of "
        "names is saved with the image (metadata durer.object_ids) and in "
        "durer.blender.engine.last_render.object_ids",
        default=False,
        update=_passes_changed,
    )


#: Label and tooltip of each field of a material override (durer.material.COURSE_FIELDS).
MATERIAL_TEXT = {
    "diffuse": ("Diffuse", "kd"),
    "specular": ("Specular", "ks of the Phong highlight ks·light·max(N·H, 0)^exponent"),
    "exponent": ("Exponent", "Phong exponent"),
    "reflective": ("Reflective", "Weight of the mirror ray"),
    "transparent": ("Transparent", "Weight of the refracted ray"),
    "ior": ("IOR", "Index of refraction inside the object"),
}
#: (min, soft max) of the scalar fields; colours are >= 0, up to 1 on the slider.
MATERIAL_SCALAR_LIMITS = {"exponent": (0.0, 1000.0), "ior": (1e-3, 3.0)}


def material_property(f: MaterialField):
    """The bpy property of a material field: a colour (FloatVectorProperty) or a number."""
    label, description = MATERIAL_TEXT[f.name]
    if f.components == 3:
        return FloatVectorProperty(name=label, description=description, subtype="COLOR", size=3, default=f.default,
                                   min=0.0, soft_max=1.0)
    low, soft_high = MATERIAL_SCALAR_LIMITS[f.name]
    return FloatProperty(name=label, description=description, default=f.default, min=low, soft_max=soft_high)


class DurerMaterialSettings(bpy.types.PropertyGroup):
    """A 6.837 material stated directly, for what the shader nodes cannot express exactly
    (independent diffuse, Phong, mirror and transparent colours); the 6.837 importer sets it.
    Its fields are durer.material.COURSE_FIELDS, with Dürer's defaults."""

    use_override: BoolProperty(
        name="6.837 Material",
        description="Dürer renders this material with the values below instead of converting its shader "
        "(Cycles and EEVEE still use the shader)",
        default=False,
    )


DurerMaterialSettings.__annotations__.update({f.name: material_property(f) for f in COURSE_FIELDS})


class DurerLightSettings(bpy.types.PropertyGroup):
    """A point or spot light's falloff for Dürer, where Blender's physical inverse square is not
    wanted (6.837 point lights: colour / (c0 + c1·d + c2·d²), by default no falloff at all)."""

    use_attenuation: BoolProperty(
        name="Custom Falloff",
        description="Dürer divides the light by c0 + c1·d + c2·d² (the Attenuation below) instead of "
        "Cycles' inverse square d²; the light's colour × power / (4π²) is what arrives where that is 1",
        default=False,
    )
    attenuation: FloatVectorProperty(
        name="Attenuation",
        description="(c0, c1, c2): constant, linear and quadratic falloff; (1, 0, 0) is none",
        size=3,
        default=(1.0, 0.0, 0.0),
        min=0.0,
    )


CLASSES = (DurerSceneSettings, DurerObjectSettings, DurerMaterialSettings, DurerLightSettings, DurerViewLayerSettings)


def register() -> None:
    for cls in CLASSES:
        bpy.utils.register_class(cls)
    bpy.types.Scene.durer = PointerProperty(type=DurerSceneSettings, name="Dürer")
    bpy.types.Object.durer = PointerProperty(type=DurerObjectSettings, name="Dürer")
    bpy.types.Material.durer = PointerProperty(type=DurerMaterialSettings, name="Dürer")
    bpy.types.Light.durer = PointerProperty(type=DurerLightSettings, name="Dürer")
    bpy.types.ViewLayer.durer = PointerProperty(type=DurerViewLayerSettings, name="Dürer")


def unregister() -> None:
    del bpy.types.ViewLayer.durer
    del bpy.types.Light.durer
    del bpy.types.Material.durer
    del bpy.types.Object.durer
    del bpy.types.Scene.durer
    for cls in reversed(CLASSES):
        bpy.utils.unregister_class(cls)
