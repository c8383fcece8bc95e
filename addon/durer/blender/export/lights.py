"""Blender lights -> `LightData`, radiometric as in Cycles: a Sun of strength S gives irradiance S, so
its Dürer colour (which multiplies kd·max(N·L, 0) with no 1/π) is colour·S/π; a Point or Spot light
of power P has intensity colour·P/(4·π²) with inverse-square falloff (Cycles' diffuse BRDF is kd/π;
not Normalized: times 4πr² for radius r, 4 at radius 0), or the falloff ``light.durer`` states
(6.837's c0 + c1·d + c2·d²). An Area light of power P is a one-sided Lambertian emitter of radiance
P/(π·A) over its world-space area A (P/π when not Normalized), so its intensity along its normal is
colour·P/π² (times A when not Normalized)."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from .data import INVERSE_SQUARE, LightData
from .nodes import rgb


def light_data(obj, m: np.ndarray) -> LightData | None:
    """The Dürer light of a light object with world matrix `m`; None for one that gives no light
    Dürer can render (an area light scaled to no area)."""
    convert = CONVERTERS.get(obj.data.type)
    return None if convert is None else convert(obj, m)


def _color_power(light) -> np.ndarray:
    color = np.array(rgb(light.color), dtype=np.float64)
    if light.use_temperature:
        color = color * np.array(rgb(light.temperature_color))
    power = float(light.energy) * 2.0 ** float(light.exposure)
    return color * power


def _axis(m: np.ndarray) -> np.ndarray:
    """The way the light points: its object's -Z."""
    return -m[:3, 2] / np.linalg.norm(m[:3, 2])


def _falloff(light) -> dict:
    """The falloff ``light.durer`` states, else Cycles': the inverse square, which Soft Falloff (on by
    default) turns into 1 / (d² + r²) for a light of radius r (measured in Cycles 5.0: a floor 1 m
    below a 0.5 m light 20 % darker than the inverse square says)."""
    settings = getattr(light.original or light, "durer", None)
    if settings is not None and settings.use_attenuation:
        return {"falloff": "custom", "attenuation": tuple(float(c) for c in settings.attenuation)}
    radius = float(light.shadow_soft_size)
    if getattr(light, "use_soft_falloff", False) and radius > 0:
        return {"falloff": "inverse_square", "attenuation": (radius * radius, 0.0, 1.0)}
    return {"falloff": "inverse_square", "attenuation": INVERSE_SQUARE}


def _sun(obj, m: np.ndarray) -> LightData:
    light = obj.data
    color = _color_power(light) / math.pi
    return LightData("sun", obj.name_full, color, direction=_axis(m), shadows=bool(light.use_shadow),
                     size=float(light.angle))


def _unnormalized(light) -> float:
    """How much brighter Cycles makes a Point or Spot light that is not Normalized: its power is
    then that of each unit of its sphere's area, 4πr² (4 at radius 0; measured in Cycles 5.0)."""
    if getattr(light, "normalize", True):
        return 1.0
    radius = float(light.shadow_soft_size)
    return 4.0 * math.pi * radius**2 if radius > 0 else 4.0


def _point(obj, m: np.ndarray) -> LightData:
    light = obj.data
    intensity = _color_power(light) / (4.0 * math.pi**2) * _unnormalized(light)
    return LightData("point", obj.name_full, intensity, position=m[:3, 3].copy(), shadows=bool(light.use_shadow),
                     size=float(light.shadow_soft_size), **_falloff(light))


def _spot(obj, m: np.ndarray) -> LightData:
    light = obj.data
    intensity = _color_power(light) / (4.0 * math.pi**2) * _unnormalized(light)
    return LightData("spot", obj.name_full, intensity, direction=_axis(m), position=m[:3, 3].copy(),
                     spot_half_angle=float(light.spot_size) / 2.0, spot_blend=float(light.spot_blend),
                     shadows=bool(light.use_shadow), size=float(light.shadow_soft_size), **_falloff(light))


#: Area light shape -> (uses size_y, the inscribed ellipse).
AREA_SHAPES: dict[str, tuple[bool, bool]] = {
    "SQUARE": (False, False), "RECTANGLE": (True, False), "DISK": (False, True), "ELLIPSE": (True, True),
}


def _area(obj, m: np.ndarray) -> LightData | None:
    """The rectangle (or inscribed ellipse) of sides size × size_y along the object's X and Y, as
    its matrix stretches them, shining along its -Z; None when scaled to no area."""
    light = obj.data
    own_y, ellipse = AREA_SHAPES[light.shape]
    u = m[:3, 0] * float(light.size)
    v = m[:3, 1] * float(light.size_y if own_y else light.size)
    normal = np.cross(u, v)
    area = float(np.linalg.norm(normal)) * (math.pi / 4 if ellipse else 1.0)
    if not area > 0:
        return None
    if np.dot(normal, -m[:3, 2]) < 0:  # u × v must point the way it shines (a mirrored object's too)
        v = -v
    intensity = _color_power(light) / math.pi**2
    if not getattr(light, "normalize", True):
        intensity = intensity * area
    return LightData("area", obj.name_full, intensity, position=m[:3, 3].copy(), edges=(u, v), ellipse=ellipse,
                     shadows=bool(light.use_shadow))


#: Blender light type -> its converter.
CONVERTERS: dict[str, Callable[..., LightData | None]] = {"SUN": _sun, "POINT": _point, "SPOT": _spot, "AREA": _area}
