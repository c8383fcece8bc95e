"""Blender materials -> Dürer's 6.837 materials (`MaterialData`): Principled BSDF -> Phong, mirror and
refraction parameters, the other BSDFs through `CONVERTERS`, and ``material.durer`` overrides."""

from __future__ import annotations

import numpy as np

from ...material import COURSE_FIELDS
from .data import BLACK, MaterialData
from .nodes import Inputs, feeding_link, linked_value, rgb

#: Roughness at or below which a specular lobe is a mirror (reflection rays) as well as a Phong
#: highlight of the lights (which mirror rays cannot meet); above it, the highlight alone. At 0.2 the
#: GGX width alpha = roughness² is 0.04, the Phong exponent of the same width ~1250: reflections in
#: Cycles are still sharp there.
MIRROR_ROUGHNESS = 0.2
#: Phong exponents are clamped to [1, MAX_EXPONENT] (roughness 1 gives 2/α² − 2 = 0).
MAX_EXPONENT = 1.0e4


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
    """A specular lobe of reflectance `color` (at normal incidence) and Blender roughness: a Phong
    highlight of the lights as wide as the lobe (``exponent = phong_exponent(roughness)``) with the
    peak of a normalised Blinn-Phong BRDF of that reflectance, ``specular = color × (n + 8)/8``
    (Dürer's light colours already include Cycles' 1/π); at roughness <= MIRROR_ROUGHNESS also a
    mirror (``reflective = color``) for what mirror rays meet: the lights are points and directions
    no ray meets, so their glint is the highlight, as Cycles shows a light in a sharp reflection."""
    if not any(color):
        return {}
    n = phong_exponent(roughness)
    lobe = {"specular": _scale3(color, (n + 8.0) / 8.0), "exponent": n}
    if np.float32(roughness) <= np.float32(MIRROR_ROUGHNESS):  # Blender stores float32 roughness
        lobe["reflective"] = rgb(color)
    return lobe


def _principled(mat, inputs: Inputs, viewport) -> MaterialData:
    """Principled BSDF, with b = Base Color, m = Metallic, t = Transmission Weight, r = Roughness:

    * specular reflectance  s = b·m + F0·(1 − m), with the dielectric F0 = fresnel_f0(IOR) × 2 ×
      Specular IOR Level × Specular Tint (0.5 is Blender's "no adjustment"), made a mirror or a
      Phong lobe by `specular_lobe`;
    * kd = b·(1 − m)·(1 − t)·(1 − F0);  transparent = √b·(1 − m)·t·(1 − F0), ior = IOR (any
      roughness): what the specular layer reflects does not reach the layers below, and Cycles
      tints what each surface of Principled glass passes by √b (a ball's two surfaces by b);
    * Emission Color × Strength as emission. Linked inputs use the material's viewport settings.
    """
    base = inputs.color("Base Color", viewport)
    # What varies (a texture) in the emission falls back to the socket's own value, as Blender shows it unlinked.
    emission = _scale3(inputs.color("Emission Color"), inputs.scalar("Emission Strength"))
    return _principled_material(mat.name, base, *_principled_layers(mat, inputs), emission)


def _principled_material(name: str, base, metallic: float, roughness: float, ior: float, transmission: float,
                         f0, below, emission=BLACK) -> MaterialData:
    """`_principled`'s material from the BSDF's values (`_principled_layers`' order)."""
    spec = _add3(_scale3(base, metallic), _scale3(f0, 1.0 - metallic))
    diffuse = _scale3(_scale3(base, (1.0 - metallic) * (1.0 - transmission)), below)
    transparent = BLACK
    if transmission > 0.0 and metallic < 1.0:
        tint = tuple(float(np.sqrt(max(c, 0.0))) for c in base)
        transparent = _scale3(_scale3(tint, (1.0 - metallic) * transmission), below)
    md = MaterialData(name, diffuse, emission, transparent=transparent, ior=ior if any(transparent) else 1.0)
    return _with_lobe(md, spec, roughness)


def _principled_layers(mat, inputs: Inputs) -> tuple:
    """(metallic, roughness, IOR, transmission, dielectric F0 per channel, 1 − F0 per channel) of a
    Principled BSDF (see `_principled`)."""
    metallic = _clamp01(inputs.scalar("Metallic", mat.metallic))
    roughness = _clamp01(inputs.scalar("Roughness", mat.roughness))
    ior = max(inputs.scalar("IOR", 1.5), 1e-3)
    level = max(inputs.scalar("Specular IOR Level", mat.specular_intensity), 0.0)
    tint = inputs.color("Specular Tint", (1.0, 1.0, 1.0))
    transmission = _clamp01(inputs.scalar("Transmission Weight", 0.0))
    return (metallic, roughness, ior, transmission, *_dielectric_layer(ior, level, tint))


def _dielectric_layer(ior: float, level: float, tint) -> tuple:
    """(F0 per channel, 1 − F0 per channel) of a Principled BSDF's dielectric specular layer: what it
    reflects does not reach the diffuse or transmission below."""
    f0 = tuple(min(fresnel_f0(ior) * 2.0 * level * c, 1.0) for c in tint)
    return f0, tuple(1.0 - x for x in f0)


def base_color_input(mat) -> tuple[object, str, tuple[float, float, float]] | None:
    """(surface shader node, its colour input's name, the factors kd = colour × factors) for a
    material whose kd is its shader's colour input times constants (Principled BSDF: Base Color ×
    (1 − m)·(1 − t)·(1 − F0); Diffuse BSDF: Color), without a ``material.durer`` override; else None."""
    if mat is None or mat.node_tree is None:
        return None
    override = getattr(mat.original or mat, "durer", None)
    if override is not None and override.use_override:
        return None
    node = surface_shader(mat.node_tree)
    if node is None:
        return None
    if node.bl_idname == "ShaderNodeBsdfDiffuse":
        return node, BASE_COLOR_INPUTS[node.bl_idname], (1.0, 1.0, 1.0)
    if node.bl_idname == "ShaderNodeBsdfPrincipled":
        metallic, _, _, transmission, _, below = _principled_layers(mat, Inputs(node))
        return node, BASE_COLOR_INPUTS[node.bl_idname], _scale3(below, (1.0 - metallic) * (1.0 - transmission))
    return None


def layers_beyond_diffuse(mat) -> list[str]:
    """The layers of `mat`'s Principled BSDF that its Base Color tints besides the diffuse one
    (metallic, transmission), by name: attribute colours reach the diffuse layer alone."""
    node = surface_shader(mat.node_tree) if mat is not None else None
    if node is None or node.bl_idname != "ShaderNodeBsdfPrincipled":
        return []
    metallic, _, _, transmission, _, _ = _principled_layers(mat, Inputs(node))
    return [name for name, weight in (("metallic", metallic), ("transmission", transmission * (1.0 - metallic)))
            if weight > 0.0]


#: The shaders whose kd is a colour input times constants, to that input (`base_color_input`):
#: attribute colours follow what is linked into it.
BASE_COLOR_INPUTS = {"ShaderNodeBsdfDiffuse": "Color", "ShaderNodeBsdfPrincipled": "Base Color"}


def _with_lobe(md: MaterialData, spec, roughness: float) -> MaterialData:
    lobe = specular_lobe(spec, roughness)
    md.reflective = lobe.get("reflective", BLACK)
    md.specular = lobe.get("specular", BLACK)
    md.exponent = lobe.get("exponent", 1.0)
    return md


def _diffuse(mat, inputs: Inputs, viewport) -> MaterialData:
    return MaterialData(mat.name, inputs.color("Color", viewport))


def _emission(mat, inputs: Inputs, viewport) -> MaterialData:
    """Unlit: colour × strength."""
    return MaterialData(mat.name, BLACK, _scale3(inputs.color("Color"), inputs.scalar("Strength")))


def _roughness(mat, inputs: Inputs) -> float:
    return _clamp01(inputs.scalar("Roughness", mat.roughness))


def _glossy(mat, inputs: Inputs, viewport) -> MaterialData:
    """A specular lobe of its Color (no diffuse)."""
    return _with_lobe(MaterialData(mat.name, BLACK), inputs.color("Color", viewport), _roughness(mat, inputs))


def _metallic(mat, inputs: Inputs, viewport) -> MaterialData:
    """A specular lobe of its Base Color (F82 Tint) or of the conductor's F0 (Physical Conductor)."""
    if inputs.node.fresnel_type == "PHYSICAL_CONDUCTOR":
        spec = conductor_f0(inputs.color("IOR"), inputs.color("Extinction"))
    else:
        spec = inputs.color("Base Color", viewport)
    return _with_lobe(MaterialData(mat.name, BLACK), spec, _roughness(mat, inputs))


def _glass(mat, inputs: Inputs, viewport) -> MaterialData:
    """Transparent Color·(1 − F0) with its IOR plus a specular lobe of Color·F0."""
    color = inputs.color("Color", viewport)
    ior = max(inputs.scalar("IOR", 1.5), 1e-3)
    f0 = fresnel_f0(ior)
    transparent = _scale3(color, 1.0 - f0)
    md = MaterialData(mat.name, BLACK, transparent=transparent, ior=ior if any(transparent) else 1.0)
    return _with_lobe(md, _scale3(color, f0), _roughness(mat, inputs))


def _refraction(mat, inputs: Inputs, viewport) -> MaterialData:
    """Transparent Color with its IOR."""
    color = inputs.color("Color", viewport)
    ior = max(inputs.scalar("IOR", 1.5), 1e-3)
    return MaterialData(mat.name, BLACK, transparent=color, ior=ior if any(color) else 1.0)


#: The surface shader node's bl_idname -> its converter (material, its inputs, viewport colour).
CONVERTERS = {
    "ShaderNodeBsdfPrincipled": _principled,
    "ShaderNodeBsdfDiffuse": _diffuse,
    "ShaderNodeEmission": _emission,
    "ShaderNodeBsdfGlossy": _glossy,
    "ShaderNodeBsdfAnisotropic": _glossy,
    "ShaderNodeBsdfMetallic": _metallic,
    "ShaderNodeBsdfGlass": _glass,
    "ShaderNodeBsdfRefraction": _refraction,
}


#: Cycles' surface for geometry without a material (Blender 5's default surface): a Principled BSDF
#: of its defaults, Base Color 0.8, Roughness 0.5, IOR 1.5, Specular IOR Level 0.5.
DEFAULT_SURFACE = _principled_material("(default surface)", (0.8, 0.8, 0.8), 0.0, 0.5, 1.5, 0.0,
                                       *_dielectric_layer(1.5, 0.5, (1.0, 1.0, 1.0)))


def material_data(mat, obj=None, notes: list[str] | None = None) -> MaterialData:
    """Dürer's material for a Blender material of object `obj`. None: Cycles' default surface
    (`DEFAULT_SURFACE`), but an empty drawn as a sphere (which Cycles does not render) takes the
    object's colour.

    ``material.durer`` with its override on comes first: the 6.837 material it states, as is. Else
    the shader linked to the Surface of the Material Output Cycles uses, by its converter in
    `CONVERTERS` (Principled BSDF: see `_principled`); a constant linked into an input (an RGB or
    Value node, maths on them) counts as its value. A colour that varies (a texture) or another
    shader: the material's viewport display colour, said in `notes`. No surface: black, as Cycles.
    """
    if mat is None:
        if getattr(obj, "type", None) == "EMPTY":
            return MaterialData("(object colour)", rgb(obj.color))
        return DEFAULT_SURFACE
    override = getattr(mat.original or mat, "durer", None)
    if override is not None and override.use_override:
        return override_material(mat.name, override)
    viewport = rgb(mat.diffuse_color)
    node = surface_shader(mat.node_tree)
    if node is None:
        return MaterialData(mat.name, BLACK)
    convert = CONVERTERS.get(node.bl_idname)
    if convert is None:
        if notes is not None:
            notes.append(f"Material '{mat.name}': Dürer draws its {node.bl_label} surface in the material's "
                         f"viewport colour")
        return MaterialData(mat.name, viewport)
    ignored = _ignored_inputs(mat, node)
    if ignored and notes is not None:
        notes.append(f"Material '{mat.name}': Dürer ignores its {', '.join(ignored)}")
    exempt = BASE_COLOR_INPUTS.get(node.bl_idname)
    inputs = Inputs(node, exempt)
    md = convert(mat, inputs, viewport)
    if notes is not None:
        # Only inputs the material depends on: another stand-in for each changes it (a textured
        # Specular Tint at Specular IOR Level 0, a textured IOR on a metal change nothing).
        varying = [name for name in inputs.varying if convert(mat, Inputs(node, exempt, probe=name), viewport).key != md.key]
        if varying:
            notes.append(f"Material '{mat.name}': Dürer takes one value for its {', '.join(varying)}, linked to "
                         f"what it cannot evaluate (a texture, attributes, a node group): the material's Viewport "
                         f"Display setting or the socket's own value")
        if any(md.emission):
            notes.append(f"Material '{mat.name}' glows but lights nothing: Dürer draws its emission on its own "
                         f"surface (Cycles lights the scene with it)")
    return md


#: Principled BSDF layers Dürer does not draw (docs/blender.md), by their weight input.
_IGNORED_LAYERS = ("Coat Weight", "Sheen Weight", "Subsurface Weight")


def _ignored_inputs(mat, node) -> list[str]:
    """What a converted surface sets that its Dürer material leaves out: a bump or normal map, a
    Principled BSDF's alpha below 1 (drawn opaque) and coat, sheen and subsurface layers, and the
    output's displacement."""
    ignored = []
    normal = node.inputs.get("Normal")
    bump = None if normal is None else _source_node(normal)
    if bump is not None and bump.bl_idname in ("ShaderNodeBump", "ShaderNodeNormalMap"):
        ignored.append("Normal input (bump or normal map)")
    if node.bl_idname == "ShaderNodeBsdfPrincipled":
        # A constant linked in counts as its value; one that varies (None) as set.
        alpha = linked_value(node, "Alpha", "value")
        if alpha is None or alpha < 1.0:
            ignored.append("Alpha (drawn opaque)")
        ignored += [name.removesuffix(" Weight") for name in _IGNORED_LAYERS
                    if (weight := linked_value(node, name, "value")) is None or weight > 0.0]
    output = mat.node_tree.get_output_node("CYCLES")
    if output is not None and _source_node(output.inputs["Displacement"]) is not None:
        ignored.append("Displacement")
    return ignored


def surface_shader(tree):
    """The shader node Cycles renders a material with: the one linked (through reroutes) to the
    Surface of the tree's active Cycles output; None where there is none (a muted link or node,
    nothing linked)."""
    output = tree.get_output_node("CYCLES") if tree is not None else None
    return None if output is None else _source_node(output.inputs["Surface"])


def _source_node(socket):
    """The node whose output reaches input `socket`, through reroutes and muted nodes as Cycles
    follows them (`feeding_link`: a muted Mix Shader passes its first linked shader); None where
    nothing does."""
    while (link := feeding_link(socket)) is not None:
        if link.from_node.bl_idname != "NodeReroute":
            return link.from_node
        socket = link.from_node.inputs[0]
    return None


def override_material(name: str, settings) -> MaterialData:
    """The 6.837 material a ``material.durer`` override states (no emission: 6.837 has none)."""
    values = {f.name: rgb(getattr(settings, f.name)) if f.components == 3 else float(getattr(settings, f.name))
              for f in COURSE_FIELDS}
    if not any(values["transparent"]):
        values["ior"] = 1.0
    return MaterialData(name, **values)


def object_materials(obj) -> list:
    """The materials of the object's slots, else of its data (none for data without materials)."""
    if len(obj.material_slots):
        return [slot.material for slot in obj.material_slots]
    return list(getattr(obj.data, "materials", ()))
