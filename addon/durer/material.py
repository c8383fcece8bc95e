"""A material's fields, in one place: their names, sizes and defaults, in the core's order.

Dürer's material is the 6.837 model: `diffuse` (kd: the flat colour without lights, the diffuse
albedo with them), `emission` (added unlit), Phong `specular` (ks) with `exponent`, mirror
`reflective` colour, `transparent` colour with index of refraction `ior`. The 6.837 reader's
material, the Blender export's `MaterialData` and the Blender material override derive from
`MATERIAL_FIELDS`; `Scene.add_material` is checked against it by a test.
"""

from __future__ import annotations

import dataclasses
from typing import Any, NamedTuple

from . import _core

Vec3 = tuple[float, float, float]


class MaterialField(NamedTuple):
    name: str
    components: int  # 3: a linear RGB colour; 1: a scalar
    default: tuple[float, ...] | float


#: The core's description of `Material` (cpp/include/durer/scene/Material.h), read from the binding.
MATERIAL_FIELDS: tuple[MaterialField, ...] = tuple(MaterialField(*field) for field in _core.MATERIAL_FIELDS)
#: The fields a 6.837 material has (the course's materials do not emit).
COURSE_FIELDS: tuple[MaterialField, ...] = tuple(f for f in MATERIAL_FIELDS if f.name != "emission")


def material_dataclass(
    name: str,
    fields: tuple[MaterialField, ...] = MATERIAL_FIELDS,
    *,
    leading: tuple[tuple[str, type], ...] = (),
    defaults: dict[str, Any] | None = None,
    namespace: dict[str, Any] | None = None,
    frozen: bool = False,
    module: str = __name__,
) -> type:
    """A dataclass `name` with the `leading` fields (no default), then one field per entry of
    `fields` with its default (or the one `defaults` gives), typed Vec3 or float."""
    defaults = defaults or {}
    unknown = set(defaults) - {f.name for f in fields}
    if unknown:
        raise ValueError(f"defaults for fields {name} does not have: {', '.join(sorted(unknown))}")
    spec: list[tuple[str, Any] | tuple[str, Any, Any]] = list(leading)
    for f in fields:
        default = defaults.get(f.name, f.default)
        spec.append((f.name, Vec3 if f.components == 3 else float, dataclasses.field(default=default)))
    return dataclasses.make_dataclass(name, spec, namespace={"__module__": module, **(namespace or {})},
                                      frozen=frozen)
