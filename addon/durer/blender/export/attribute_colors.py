"""Per-primitive colours from geometry attributes: a material's Base Color traced back through its
node graph to Attribute and Color Attribute nodes, compiled into a numpy function of the
attributes' values (`color_source`), and those values read from Blender's geometry in bulk
(`read_values`, one ``foreach_get`` per attribute). Every node is evaluated as Cycles' SVM
evaluates it, so that the colours are the ones Cycles renders. A graph with a node not mapped here
falls back to the material's colour (`Unmapped` says why; the export notes it once).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from .materials import base_color_input
from .nodes import feeding_link

#: An attribute an expression reads: (where, name), where "GEOMETRY" (the shaded geometry's own) or
#: "INSTANCER" (its geometry-nodes instance's, Cycles' Attribute node type Instancer); name "" is the
#: geometry's default colour attribute.
Key = tuple[str, str]
#: Attributes' values as RGBA rows, (N, 4) float32: colours as stored (byte colours decoded from
#: sRGB as Blender renders them), vectors (x, y, z, 1), 2D vectors (x, y, 0, 1), floats, integers
#: and booleans (v, v, v, 1).
Values = dict[Key, np.ndarray]
#: A compiled socket: attribute values -> (N, 3) colours or (N,) values (or constants that broadcast).
Expression = Callable[[Values], np.ndarray]
COLOR, VALUE = "color", "value"
#: Blender's scene-linear (Rec. 709) luminance: Cycles' implicit colour-to-value conversion.
LUMINANCE = np.array([0.2126729, 0.7151522, 0.0721750])
#: Cycles bakes a Color Ramp into this many entries and interpolates linearly between them.
RAMP_TABLE_SIZE = 257
#: The largest colour component the core accepts (durer._core.LIMITS).
COLOR_LIMIT = 1e18

#: Attribute data type -> (foreach_get field, components).
_FIELDS = {"FLOAT_COLOR": ("color", 4), "BYTE_COLOR": ("color", 4), "FLOAT_VECTOR": ("vector", 3), "FLOAT": ("value", 1),
           # read as floats, as Cycles reads them: integers and booleans (0, 1) as a float's
           # (v, v, v), 2D vectors as (x, y, 0)
           "INT": ("value", 1), "INT8": ("value", 1), "BOOLEAN": ("value", 1), "FLOAT2": ("vector", 2)}


class Unmapped(Exception):
    """A node graph or an attribute the export cannot turn into colours (the message says which)."""


@dataclass(frozen=True)
class ColorSource:
    """How a material's kd follows from attributes: kd = expression(attribute values) × scale."""

    material: str
    attributes: tuple[Key, ...]
    expression: Expression
    scale: tuple[float, float, float]

    def colors(self, values: Values, n: int) -> np.ndarray:
        """(n, 3) float64 kd, clamped to what the core accepts (>= 0, finite: NaN becomes 0)."""
        kd = np.empty((n, 3), np.float64)
        np.fmax(np.broadcast_to(self.expression(values), (n, 3)), 0.0, out=kd)  # converts too; NaN -> 0
        if self.scale != (1.0, 1.0, 1.0):
            kd *= self.scale
        return np.fmin(kd, COLOR_LIMIT, out=kd)


def color_source(mat) -> ColorSource | None:
    """The attribute colours of material `mat`'s kd, or None where its colour input is not linked
    (or its shader has no such input). Raises Unmapped for a graph that cannot be mapped."""
    found = base_color_input(mat)
    if found is None:
        return None
    node, name, scale = found
    socket = node.inputs[name]
    if not socket.is_linked:
        return None
    compiler = _Compiler()
    expression = compiler.input(socket, COLOR)
    if not compiler.attributes:
        return None  # a constant: the material's own colour (`constant_input`)
    return ColorSource(mat.name, tuple(compiler.attributes), expression, scale)


def constant_input(socket, kind: str):
    """A linked input's value where its graph reads no attribute and is mapped here (an RGB or a
    Value node, maths on them): (3,) float64 for COLOR, a float for VALUE; None otherwise."""
    compiler = _Compiler()
    try:
        expression = compiler.input(socket, kind)
    except Unmapped:
        return None
    if compiler.attributes:
        return None
    value = np.asarray(expression({}), np.float64)
    return value.reshape(3) if kind == COLOR else float(value)


def read_values(attributes, keys: tuple[Key, ...], default_name: str | None, sizes: dict[str, int],
                where: str = "GEOMETRY") -> tuple[Values, dict[Key, str]]:
    """The RGBA values of the attributes `keys` in `attributes` (a collection holding those of
    `where`), and each one's domain. Name "" is the default colour attribute (`default_name`).
    `sizes`: the element count of each domain the caller can use (e.g. {"POINT": n}). Raises
    Unmapped for an attribute of another place, a missing one, an unsupported type or a domain not
    in `sizes`."""
    values, domains = {}, {}
    for key in keys:
        place, name = key
        if place != where:
            shown = f"'{name}'" if name else "(the default colour attribute)"
            raise Unmapped(f"it reads the {place.lower()} attribute {shown} where there is none")
        real = default_name if name == "" else name
        attribute = attributes.get(real) if real else None
        if attribute is None:
            raise Unmapped(f"no attribute '{real or '(default colour attribute)'}'")
        field = _FIELDS.get(attribute.data_type)
        if field is None:
            raise Unmapped(f"attribute '{real}' is {attribute.data_type}, not a colour, vector or float")
        if attribute.domain not in sizes:
            raise Unmapped(f"attribute '{real}' is on the {attribute.domain.lower()} domain")
        n = sizes[attribute.domain]
        raw = np.empty(n * field[1], np.float32)
        attribute.data.foreach_get(field[0], raw)
        raw = raw.reshape(n, field[1])
        if field[1] == 4:
            rgba = raw
        else:
            rgba = np.ones((n, 4), np.float32)
            rgba[:, :3] = raw if field[1] != 2 else np.column_stack([raw, np.zeros(n, np.float32)])
        values[key], domains[key] = rgba, attribute.domain
    return values, domains


def part_colors(me, part, source: ColorSource) -> np.ndarray:
    """The kd of a mesh part (triangles.TrianglePart of mesh `me`) from its attributes: (V, 3) per
    vertex where every attribute read is on vertices, else (F, 3, 3) per face corner (a vertex's
    value at each corner that uses it, a face's at its three). Raises Unmapped as read_values."""
    sizes = {"POINT": len(me.vertices), "CORNER": len(me.loops), "FACE": len(me.polygons)}
    values, domains = read_values(me.attributes, source.attributes, me.color_attributes.default_color_name, sizes)
    if part.vertex_ids is not None:
        values = {key: v[part.vertex_ids] if domains[key] == "POINT" else v for key, v in values.items()}
    if all(domain == "POINT" for domain in domains.values()):
        return source.colors(values, len(part.vertices))
    polygons = None
    at_corners = {}
    for key, v in values.items():
        if domains[key] == "POINT":
            at = v[part.faces]
        elif domains[key] == "CORNER":
            at = v[part.corners]
        else:
            if polygons is None:
                polygons = np.empty(len(me.loop_triangle_polygons), np.int32)
                me.loop_triangle_polygons.foreach_get("value", polygons)
                polygons = polygons if part.triangles is None else polygons[part.triangles]
            at = np.repeat(v[polygons][:, None, :], 3, axis=1)
        at_corners[key] = at.reshape(-1, 4)
    return source.colors(at_corners, 3 * len(part.faces)).reshape(-1, 3, 3)


class _Compiler:
    """Compiles sockets into expressions, collecting the attribute names they read."""

    def __init__(self) -> None:
        self.attributes: list[Key] = []

    def input(self, socket, kind: str) -> Expression:
        """An input socket's value as `kind`: its own constant where nothing feeds it
        (`feeding_link`: unlinked, muted, ...), else what is linked."""
        link = feeding_link(socket)
        if link is None:
            value = socket.default_value
            constant = np.array(value[:3], np.float64) if _kind(socket) == COLOR else np.float64(value)
            return _as(lambda values: constant, _kind(socket), kind)
        return _as(*self.output(link.from_node, link.from_socket), kind)

    def output(self, node, socket) -> tuple[Expression, str]:
        compile_node = _NODES.get(node.bl_idname)
        if compile_node is None:
            raise Unmapped(f"node '{node.name}' ({node.bl_label}) is not mapped")
        return compile_node(self, node, socket.identifier)

    def read(self, key: Key, output: str) -> tuple[Expression, str]:
        if key not in self.attributes:
            self.attributes.append(key)
        if output in ("Color", "Vector"):
            return (lambda values: values[key][:, :3]), COLOR
        if output == "Alpha":
            return (lambda values: values[key][:, 3]), VALUE
        return (lambda values: values[key][:, :3].mean(axis=1)), VALUE  # Factor: Cycles' average


def _as(expression: Expression, given: str, kind: str) -> Expression:
    """`expression` (of kind `given`) as `kind`, converted as Cycles converts along a link: a colour
    to a value by its luminance, a value to the gray colour."""
    if given == kind:
        return expression
    if kind == VALUE:
        return lambda values: np.asarray(expression(values)) @ LUMINANCE
    return lambda values: np.repeat(np.asarray(expression(values))[..., None], 3, axis=-1)


def _socket(node, identifier: str):
    return next(s for s in node.inputs if s.identifier == identifier)


def _attribute(c: _Compiler, node, output: str) -> tuple[Expression, str]:
    if node.attribute_type not in ("GEOMETRY", "INSTANCER"):
        raise Unmapped(f"Attribute node '{node.name}' is of type {node.attribute_type.title()}")
    return c.read((node.attribute_type, node.attribute_name), output)


def _color_attribute(c: _Compiler, node, output: str) -> tuple[Expression, str]:
    return c.read(("GEOMETRY", node.layer_name), output)


def _rgb(c: _Compiler, node, output: str) -> tuple[Expression, str]:
    constant = np.array(node.outputs[0].default_value[:3], np.float64)
    return (lambda values: constant), COLOR


def _value(c: _Compiler, node, output: str) -> tuple[Expression, str]:
    constant = np.float64(node.outputs[0].default_value)
    return (lambda values: constant), VALUE


def _reroute(c: _Compiler, node, output: str) -> tuple[Expression, str]:
    socket = node.inputs[0]
    return c.input(socket, _kind(socket)), _kind(socket)


def _kind(socket) -> str:
    """What a socket carries: a colour (colour and vector sockets) or a value."""
    return COLOR if socket.type in ("RGBA", "VECTOR") else VALUE


def _lerp(a, b, t):
    return a + t * (b - a)


#: Cycles' svm_mix for colours: (A, B, factor) -> result.
_BLENDS = {
    "MIX": lambda a, b, t: _lerp(a, b, t),
    "ADD": lambda a, b, t: a + t * b,
    "MULTIPLY": lambda a, b, t: a * (1 - t + t * b),
    "SUBTRACT": lambda a, b, t: a - t * b,
    "SCREEN": lambda a, b, t: 1 - (1 - t + t * (1 - b)) * (1 - a),
    "DIFFERENCE": lambda a, b, t: _lerp(a, np.abs(a - b), t),
    "DARKEN": lambda a, b, t: _lerp(a, np.minimum(a, b), t),
    "LIGHTEN": lambda a, b, t: _lerp(a, np.maximum(a, b), t),
}


def _mix(c: _Compiler, node, output: str) -> tuple[Expression, str]:
    if node.data_type == "FLOAT":
        kind, suffix, blend = VALUE, "Float", _BLENDS["MIX"]
    elif node.data_type == "RGBA" and node.blend_type in _BLENDS:
        kind, suffix, blend = COLOR, "Color", _BLENDS[node.blend_type]
    else:
        raise Unmapped(f"Mix node '{node.name}' ({node.data_type.lower()}, {node.blend_type.lower()}) is not mapped")
    factor = c.input(_socket(node, "Factor_Float"), VALUE)
    a, b = c.input(_socket(node, f"A_{suffix}"), kind), c.input(_socket(node, f"B_{suffix}"), kind)
    clamp_factor, clamp_result = node.clamp_factor, node.clamp_result and kind == COLOR

    def mix(values):
        t = np.asarray(factor(values))
        t = np.clip(t, 0, 1) if clamp_factor else t
        result = blend(a(values), b(values), t[..., None] if kind == COLOR else t)
        return np.clip(result, 0, 1) if clamp_result else result

    return mix, kind


def _color_ramp(c: _Compiler, node, output: str) -> tuple[Expression, str]:
    """Cycles' baked table: Blender's own ramp evaluated at RAMP_TABLE_SIZE points, interpolated
    linearly between them (constant ramps take the entry below)."""
    ramp = node.color_ramp
    table = np.array([ramp.evaluate(i / (RAMP_TABLE_SIZE - 1)) for i in range(RAMP_TABLE_SIZE)], np.float64)
    interpolate = ramp.interpolation != "CONSTANT"
    factor = c.input(node.inputs["Fac"], VALUE)
    channels = slice(0, 3) if output == "Color" else 3

    def lookup(values):
        f = np.clip(np.asarray(factor(values), np.float64), 0, 1) * (RAMP_TABLE_SIZE - 1)
        i = np.clip(f.astype(np.int64), 0, RAMP_TABLE_SIZE - 1)
        result = table[i]
        if interpolate:
            t = (f - i)[..., None]
            result = np.where(t > 0, (1 - t) * result + t * table[np.minimum(i + 1, RAMP_TABLE_SIZE - 1)], result)
        return result[..., channels]

    return lookup, COLOR if output == "Color" else VALUE


def _rgb_to_hsv(rgb: np.ndarray) -> np.ndarray:
    """Cycles' rgb_to_hsv, vectorised."""
    cmax, cmin = rgb.max(axis=-1), rgb.min(axis=-1)
    delta = cmax - cmin
    s = np.where(cmax != 0, delta / np.where(cmax != 0, cmax, 1), 0.0)
    c = (cmax[..., None] - rgb) / np.where(delta != 0, delta, 1)[..., None]
    r, g = rgb[..., 0] == cmax, rgb[..., 1] == cmax
    h = np.where(r, c[..., 2] - c[..., 1], np.where(g, 2 + c[..., 0] - c[..., 2], 4 + c[..., 1] - c[..., 0])) / 6
    h = np.where(h < 0, h + 1, h)
    return np.stack([np.where(s != 0, h, 0.0), s, cmax], axis=-1)


def _hsv_to_rgb(hsv: np.ndarray) -> np.ndarray:
    """Cycles' hsv_to_rgb, vectorised."""
    h, s, v = hsv[..., 0], hsv[..., 1], hsv[..., 2]
    h = np.where(h == 1, 0.0, h) * 6
    i = np.floor(h)
    f = h - i
    p, q, t = v * (1 - s), v * (1 - s * f), v * (1 - s * (1 - f))
    sectors = [(v, t, p), (q, v, p), (p, v, t), (p, q, v), (t, p, v), (v, p, q)]
    k = np.clip(i, 0, 5).astype(np.int64)
    rgb = np.stack([np.choose(k, [sector[channel] for sector in sectors]) for channel in range(3)], axis=-1)
    return np.where((s != 0)[..., None], rgb, v[..., None])


def _hue_saturation(c: _Compiler, node, output: str) -> tuple[Expression, str]:
    hue, saturation, value, factor = (c.input(node.inputs[name], VALUE) for name in ("Hue", "Saturation", "Value", "Fac"))
    color = c.input(node.inputs["Color"], COLOR)

    def hsv(values):
        rgb = np.asarray(color(values), np.float64)
        h = _rgb_to_hsv(rgb)
        h[..., 0] = np.mod(h[..., 0] + hue(values) + 0.5, 1.0)
        h[..., 1] = np.clip(h[..., 1] * saturation(values), 0, 1)
        h[..., 2] = h[..., 2] * value(values)
        t = np.asarray(factor(values))[..., None]
        return np.maximum(t * _hsv_to_rgb(h) + (1 - t) * rgb, 0)

    return hsv, COLOR


def _gamma(c: _Compiler, node, output: str) -> tuple[Expression, str]:
    color, gamma = c.input(node.inputs["Color"], COLOR), c.input(node.inputs["Gamma"], VALUE)

    def power(values):
        rgb, g = np.asarray(color(values), np.float64), np.asarray(gamma(values))[..., None]
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(rgb > 0, np.power(np.maximum(rgb, 0), g), rgb)

    return power, COLOR


def _separate(c: _Compiler, node, output: str) -> tuple[Expression, str]:
    if node.mode != "RGB":
        raise Unmapped(f"Separate Color node '{node.name}' is in {node.mode} mode")
    color, channel = c.input(node.inputs["Color"], COLOR), ("Red", "Green", "Blue").index(output)
    return (lambda values: np.asarray(color(values))[..., channel]), VALUE


def _combine(c: _Compiler, node, output: str) -> tuple[Expression, str]:
    if node.mode != "RGB":
        raise Unmapped(f"Combine Color node '{node.name}' is in {node.mode} mode")
    red, green, blue = (c.input(node.inputs[name], VALUE) for name in ("Red", "Green", "Blue"))
    return (lambda values: np.stack(np.broadcast_arrays(red(values), green(values), blue(values)), axis=-1)), COLOR


def _safe_divide(a, b):
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(b != 0, a / np.where(b != 0, b, 1), 0.0)


#: Cycles' svm_math for the operations a factor usually goes through: (a, b, c) -> result.
_MATH = {
    "ADD": lambda a, b, c: a + b,
    "SUBTRACT": lambda a, b, c: a - b,
    "MULTIPLY": lambda a, b, c: a * b,
    "DIVIDE": lambda a, b, c: _safe_divide(a, b),
    "MULTIPLY_ADD": lambda a, b, c: a * b + c,
    "MINIMUM": lambda a, b, c: np.minimum(a, b),
    "MAXIMUM": lambda a, b, c: np.maximum(a, b),
}


def _math(c: _Compiler, node, output: str) -> tuple[Expression, str]:
    operation = _MATH.get(node.operation)
    if operation is None:
        raise Unmapped(f"Math node '{node.name}' ({node.operation.lower()}) is not mapped")
    a, b, third = (c.input(socket, VALUE) for socket in node.inputs[:3])
    clamp = node.use_clamp

    def evaluate(values):
        result = operation(np.asarray(a(values)), np.asarray(b(values)), np.asarray(third(values)))
        return np.clip(result, 0, 1) if clamp else result

    return evaluate, VALUE


def _map_range(c: _Compiler, node, output: str) -> tuple[Expression, str]:
    if node.data_type != "FLOAT" or node.interpolation_type != "LINEAR":
        raise Unmapped(f"Map Range node '{node.name}' ({node.data_type.lower()}, "
                       f"{node.interpolation_type.lower()}) is not mapped")
    value, from_min, from_max, to_min, to_max = (
        c.input(_socket(node, name), VALUE) for name in ("Value", "From Min", "From Max", "To Min", "To Max"))
    clamp = node.clamp

    def map_range(values):
        low, high, a, b = from_min(values), from_max(values), to_min(values), to_max(values)
        result = a + _safe_divide(np.asarray(value(values)) - low, np.asarray(high - low)) * (b - a)
        return np.clip(result, np.minimum(a, b), np.maximum(a, b)) if clamp else result

    return map_range, VALUE


def _clamp(c: _Compiler, node, output: str) -> tuple[Expression, str]:
    value, low, high = (c.input(node.inputs[name], VALUE) for name in ("Value", "Min", "Max"))
    swap = node.clamp_type == "RANGE"

    def clamp(values):
        a, b = np.asarray(low(values)), np.asarray(high(values))
        if swap:
            a, b = np.minimum(a, b), np.maximum(a, b)
        return np.minimum(np.maximum(value(values), a), b)

    return clamp, VALUE


def _invert(c: _Compiler, node, output: str) -> tuple[Expression, str]:
    factor, color = c.input(node.inputs["Fac"], VALUE), c.input(node.inputs["Color"], COLOR)
    return (lambda values: _lerp(color(values), 1 - color(values), np.asarray(factor(values))[..., None])), COLOR


def _bright_contrast(c: _Compiler, node, output: str) -> tuple[Expression, str]:
    color, bright, contrast = (c.input(node.inputs[name], kind)
                               for name, kind in (("Color", COLOR), ("Bright", VALUE), ("Contrast", VALUE)))

    def adjust(values):
        k = np.asarray(contrast(values))[..., None]
        return np.maximum((1 + k) * color(values) + (np.asarray(bright(values))[..., None] - k * 0.5), 0)

    return adjust, COLOR


_NODES = {
    "ShaderNodeAttribute": _attribute,
    "ShaderNodeVertexColor": _color_attribute,
    "NodeReroute": _reroute,
    "ShaderNodeRGB": _rgb,
    "ShaderNodeValue": _value,
    "ShaderNodeMix": _mix,
    "ShaderNodeValToRGB": _color_ramp,
    "ShaderNodeHueSaturation": _hue_saturation,
    "ShaderNodeGamma": _gamma,
    "ShaderNodeSeparateColor": _separate,
    "ShaderNodeCombineColor": _combine,
    "ShaderNodeMath": _math,
    "ShaderNodeMapRange": _map_range,
    "ShaderNodeClamp": _clamp,
    "ShaderNodeInvert": _invert,
    "ShaderNodeBrightContrast": _bright_contrast,
}
