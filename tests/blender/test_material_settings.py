"""The Blender side of durer.material: the export's MaterialData and the material.durer override
(its bpy properties, its panel, what the export makes of it) have durer.material's fields."""

from __future__ import annotations

import dataclasses

import pytest

from helpers.blender_import import blender_module

bpy = blender_module("bpy")

from durer.blender import properties
from durer.blender.export.data import MaterialData
from durer.blender.export.materials import material_data
from durer.material import COURSE_FIELDS, MATERIAL_FIELDS

pytestmark = pytest.mark.blender


def test_material_data_has_a_name_and_the_fields():
    assert [f.name for f in dataclasses.fields(MaterialData)] == ["name", *(f.name for f in MATERIAL_FIELDS)]
    m = MaterialData("m", (0.1, 0.2, 0.3), ior=1.5)
    assert m.key == ((0.1, 0.2, 0.3), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), 1.0, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), 1.5)
    assert m.effects == {}  # ior alone, without a transparent colour, asks for no refraction


def test_override_properties_are_the_course_fields(scene):
    assert set(properties.MATERIAL_TEXT) == {f.name for f in COURSE_FIELDS}
    rna = bpy.types.Material.bl_rna.properties["durer"].fixed_type.properties
    assert [name for name in rna.keys() if name not in ("rna_type", "name", "use_override")] == \
        [f.name for f in COURSE_FIELDS]
    for f in COURSE_FIELDS:
        prop = rna[f.name]
        assert (prop.name, prop.description) == properties.MATERIAL_TEXT[f.name]
        if f.components == 3:
            assert prop.subtype == "COLOR" and tuple(prop.default_array) == pytest.approx(f.default)
        else:
            assert prop.array_length == 0 and prop.default == pytest.approx(f.default)


def test_override_reaches_the_export_field_by_field(scene):
    mat = bpy.data.materials.new("Override")
    settings = mat.durer
    settings.use_override = True
    values = {"diffuse": (0.5, 0.25, 0.125), "specular": (0.75, 0.5, 0.25), "exponent": 32.0,
              "reflective": (0.25, 0.5, 0.75), "transparent": (0.5, 0.5, 0.5), "ior": 1.5}
    assert set(values) == {f.name for f in COURSE_FIELDS}
    for name, value in values.items():
        setattr(settings, name, value)
    exported = material_data(mat)
    assert exported.name == "Override" and exported.emission == (0.0, 0.0, 0.0)
    for name, value in values.items():
        assert getattr(exported, name) == pytest.approx(value), name
    settings.transparent = (0.0, 0.0, 0.0)  # without refraction the index is not asked for
    assert material_data(mat).ior == 1.0
