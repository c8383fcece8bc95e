"""durer.material.MATERIAL_FIELDS is the one list of a material's fields: Scene.add_material, the 6.837
reader's SceneMaterial and the Blender export's MaterialData agree with it."""

from __future__ import annotations

import dataclasses
import inspect

import numpy as np
import pytest

import durer
from durer.course.scene_file import SceneMaterial
from durer.material import COURSE_FIELDS, MATERIAL_FIELDS, material_dataclass


def test_fields_in_the_core_order():
    assert [f.name for f in MATERIAL_FIELDS] == [
        "diffuse", "emission", "specular", "exponent", "reflective", "transparent", "ior"]
    for f in MATERIAL_FIELDS:
        if f.components == 3:
            assert len(f.default) == 3 and all(isinstance(c, float) for c in f.default)
        else:
            assert f.components == 1 and isinstance(f.default, float)
    assert [f.name for f in COURSE_FIELDS] == [f.name for f in MATERIAL_FIELDS if f.name != "emission"]


def test_add_material_takes_the_fields_with_their_defaults():
    parameters = list(inspect.signature(durer.Scene.add_material).parameters.values())[1:]
    assert [(p.name, p.default) for p in parameters] == [(f.name, f.default) for f in MATERIAL_FIELDS]


def test_the_default_material_renders_with_the_default_diffuse():
    # No lights: a flat render shows the diffuse colour, 0.8 grey, wherever the sphere is hit.
    scene = durer.Scene()
    scene.add_spheres([[0.0, 0.0, 0.0]], [1.0], material=scene.add_material())
    camera = durer.OrthographicCamera(center=(0, 0, 5), direction=(0, 0, -1), up=(0, 1, 0), size=1.0)
    color = durer.render(scene, camera, 4, 4, sampler="center").color
    diffuse = next(f.default for f in MATERIAL_FIELDS if f.name == "diffuse")
    np.testing.assert_allclose(color[..., :3], np.broadcast_to(diffuse, (4, 4, 3)), rtol=1e-6)


def test_scene_material_is_the_course_fields_with_a_white_diffuse():
    fields = dataclasses.fields(SceneMaterial)
    assert [f.name for f in fields] == [f.name for f in COURSE_FIELDS]
    defaults = {f.name: f.default for f in fields}
    assert defaults.pop("diffuse") == (1.0, 1.0, 1.0)  # the course parser's default, not Dürer's
    assert defaults == {f.name: f.default for f in COURSE_FIELDS if f.name != "diffuse"}
    with pytest.raises(dataclasses.FrozenInstanceError):
        SceneMaterial().ior = 2.0


def test_material_dataclass():
    Material = material_dataclass("Material", leading=(("name", str),), defaults={"ior": 1.5})
    m = Material("glass")
    assert m.name == "glass" and m.ior == 1.5 and m.diffuse == (0.8, 0.8, 0.8) and m.emission == (0.0, 0.0, 0.0)
    assert [f.name for f in dataclasses.fields(m)] == ["name", *(f.name for f in MATERIAL_FIELDS)]
    with pytest.raises(ValueError, match="does not have: shininess"):
        material_dataclass("Bad", defaults={"shininess": 3.0})
    with pytest.raises(ValueError, match="does not have: emission"):
        material_dataclass("Course", COURSE_FIELDS, defaults={"emission": (1.0, 1.0, 1.0)})
