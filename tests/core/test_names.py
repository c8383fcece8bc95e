"""One home per concept: the core owns the option names and the material's fields; the package,
the stubs and the docs derive from it or are checked against it here."""

from __future__ import annotations

import ast
import importlib
import inspect
import re
from pathlib import Path

import numpy as np
import pytest

import durer
from durer import _checks, _core

render_module = importlib.import_module("durer.render")  # `durer.render` itself is the function
camera_module = importlib.import_module("durer.camera")

STUB = Path(_core.__file__).with_name("_core.pyi")
if not STUB.exists():  # an editable install keeps the stub with the sources
    STUB = Path(durer.__file__).with_name("_core.pyi")

OPTION_TUPLES = ("PRECISIONS", "SPHERE_METHODS", "SAMPLERS", "PASSES", "DEFAULT_PASSES", "DEPTHS", "PROJECTIONS", "FITS",
                 "SHADING_MODES")


def _stub() -> ast.Module:
    return ast.parse(STUB.read_text(encoding="utf-8"))


def _declared(body: list[ast.stmt]) -> set[str]:
    names = set()
    for node in body:
        if isinstance(node, (ast.FunctionDef, ast.ClassDef)):
            names.add(node.name)
        elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            names.add(node.target.id)
    return names


def test_the_stub_declares_exactly_what_the_module_has():
    tree = _stub()
    declared = _declared(tree.body) - {"_Triple"}
    public = {name for name in dir(_core) if not name.startswith("_")}
    assert declared == public
    for node in tree.body:
        if isinstance(node, ast.ClassDef):
            members = _declared(node.body) - {"__init__"}
            cls = getattr(_core, node.name)
            assert members == {m for m in dir(cls) if not m.startswith("_")}, node.name


def test_the_option_tuples_are_what_the_stub_documents():
    # Each tuple's declaration in the stub carries its value as a comment: `NAME: ...  # ("a", "b")`.
    lines = STUB.read_text(encoding="utf-8").splitlines()
    documented = {}
    for line in lines:
        match = re.match(r"^([A-Z_]+): tuple\[str, \.\.\.\]  # (\(.*\))$", line)
        if match:
            documented[match.group(1)] = ast.literal_eval(match.group(2))
    assert set(documented) == set(OPTION_TUPLES)
    for name, value in documented.items():
        assert getattr(_core, name) == value, name


def test_the_package_reads_its_names_from_the_core():
    assert render_module.PRECISIONS is _core.PRECISIONS
    assert render_module.SPHERE_METHODS is _core.SPHERE_METHODS
    assert render_module.SAMPLERS is _core.SAMPLERS
    assert render_module.PASSES is _core.PASSES
    assert render_module.DEFAULT_PASSES is _core.DEFAULT_PASSES
    assert render_module.DEPTHS is _core.DEPTHS
    assert camera_module.FITS is _core.FITS
    # The defaults of the public API are among them.
    params = inspect.signature(durer.render).parameters
    assert params["precision"].default in _core.PRECISIONS
    assert params["sphere_method"].default in _core.SPHERE_METHODS
    assert params["sampler"].default in _core.SAMPLERS
    assert params["depth"].default in _core.DEPTHS
    assert params["passes"].default is _core.DEFAULT_PASSES
    assert set(_core.DEFAULT_PASSES) < set(_core.PASSES)


def test_every_option_name_is_documented_in_the_render_docstring():
    doc = durer.render.__doc__
    for name in _core.SAMPLERS + _core.PRECISIONS + _core.SPHERE_METHODS + _core.DEPTHS:
        assert f'"{name}"' in doc, name


def test_material_fields_are_the_core_structs_and_add_materials_signature():
    fields = _core.MATERIAL_FIELDS
    assert [f[0] for f in fields] == ["diffuse", "emission", "specular", "exponent", "reflective", "transparent", "ior"]
    assert [f[1] for f in fields] == [3, 3, 3, 1, 3, 3, 1]
    assert fields[0][2] == (0.8, 0.8, 0.8) and fields[3][2] == 1.0 and fields[6][2] == 1.0
    for name, components, default in fields:
        assert isinstance(default, tuple if components == 3 else float), name
    params = list(inspect.signature(durer.Scene.add_material).parameters.values())[1:]
    assert [p.name for p in params] == [f[0] for f in fields]
    for p, (name, components, default) in zip(params, fields):
        given = p.default if components == 1 else tuple(float(c) for c in p.default)
        assert given == default, name


def test_the_binding_takes_materials_by_field_name():
    scene = _core.Scene()
    assert scene.add_material(diffuse=(0.1, 0.2, 0.3), ior=1.5) == 1
    assert scene.add_material() == 2  # every field defaulted
    with pytest.raises(TypeError, match="shininess"):
        scene.add_material(shininess=3.0)
    with pytest.raises(ValueError, match="ior"):
        scene.add_material(ior=0.0)
    with pytest.raises(ValueError, match="transparent"):
        scene.add_material(transparent=(0.0, -1.0, 0.0))
    assert scene.material_count == 3  # the rejected adds changed nothing


@pytest.mark.parametrize(
    ("call", "field", "choices"),
    [
        (lambda s, c: durer.render(s, c, 4, 4, precision="half"), "precision", _core.PRECISIONS),
        (lambda s, c: durer.render(s, c, 4, 4, sampler="halton"), "sampler", _core.SAMPLERS),
        (lambda s, c: durer.render(s, c, 4, 4, sphere_method="magic"), "sphere_method", _core.SPHERE_METHODS),
        (lambda s, c: durer.render(s, c, 4, 4, depth="z"), "depth", _core.DEPTHS),
        (lambda s, c: durer.render(s, c, 4, 4, passes=("albedo",)), "passes", _core.PASSES),
        (lambda s, c: setattr(s, "shading", "toon"), "shading", _core.SHADING_MODES),
        (lambda s, c: durer.PerspectiveCamera((0, 0, 5), (0, 0, -1), (0, 1, 0), fit="diagonal"), "fit", _core.FITS),
    ],
)
def test_unknown_option_names_are_rejected_by_the_core_listing_its_table(call, field, choices):
    scene = durer.Scene()
    cam = durer.OrthographicCamera((0, 0, 5), (0, 0, -1), (0, 1, 0))
    with pytest.raises(ValueError, match=field) as error:
        call(scene, cam)
    for name in choices:
        assert f"'{name}'" in str(error.value)


@pytest.mark.parametrize(
    ("call", "field"),
    [
        (lambda s: s.add_spheres(np.zeros((2, 2)), np.ones(2), np.zeros(1, np.int32), None), "centers"),
        (lambda s: s.add_spheres(np.zeros((3, 3)), np.ones(2), np.zeros(1, np.int32), None), "centers"),
        (lambda s: s.add_spheres(np.zeros((2, 3)), np.ones(2), np.zeros(3, np.int32), None), "material"),
        (lambda s: s.add_triangles(np.zeros((2, 3, 2)), np.zeros(1, np.int32), None), "vertices"),
        (lambda s: s.add_mesh(np.zeros((3, 3)), np.zeros((1, 4), np.int64), 0, None), "faces"),
        (lambda s: s.add_boxes(np.zeros((2, 3)), np.ones((1, 3)), np.zeros(1, np.int32), None), "hi"),
        (lambda s: s.add_spheres(np.zeros((1, 3)), np.ones(1), np.zeros(1, np.int32), np.eye(4)), "transform"),
        (lambda s: _core.cast(s, np.zeros((2, 3)), np.ones((3, 3)), 0.0, 1.0, "double", "robust", 1, lambda f: False,
                              False), "directions"),
    ],
)
def test_the_binding_checks_shapes_when_called_directly(call, field):
    # Anchored: a bare "hi" would match any message containing those letters ("within", "this").
    with pytest.raises(ValueError, match=f"^{field} must have shape "):
        call(_core.Scene())


SHEARED_FLAT = np.array([[1.0, 0, 0, 0], [0, 1, 0, 0], [1, 0, 1e-13, 0]])  # |det| / Hadamard bound ~ 1e-13


@pytest.mark.parametrize(
    ("matrix", "invertible"),
    [
        (np.hstack([np.eye(3), np.ones((3, 1))]), True),
        (np.diag([1.0, 1.0, 1e-200, 1.0])[:3], True),  # an axis scale, however small, is invertible (scale-free)
        (np.diag([1.0, 1.0, 1e-310, 1.0])[:3], False),  # ... unless its inverse overflows
        (SHEARED_FLAT, False),
        (np.where(SHEARED_FLAT == 1e-13, 1e-11, SHEARED_FLAT), True),
        (np.diag([1.0, 1.0, 0.0, 1.0])[:3], False),
    ],
)
def test_invertibility_is_one_rule_for_the_core_and_the_package(matrix, invertible):
    assert _core.is_invertible(np.ascontiguousarray(matrix)) is invertible
    assert _checks.is_invertible(matrix) is invertible
    four = np.vstack([matrix, [0, 0, 0, 1]])
    if invertible:
        assert _checks.transform(four).shape == (3, 4)
        durer.Scene().add_spheres([[0, 0, 0]], 1.0, transform=four)
    else:
        with pytest.raises(ValueError, match="transform"):
            _checks.transform(four)
        with pytest.raises(ValueError, match="transform"):
            durer.Scene().add_spheres([[0, 0, 0]], 1.0, transform=four)


def test_is_invertible_has_one_home_and_asks_what_a_scene_asks():
    from durer.blender.export import matrices
    from durer.course import scene_file

    # the export (what it asks of matrix_world) and the course reader call _checks' own
    assert not hasattr(matrices, "is_invertible") and not hasattr(scene_file, "is_invertible")
    projective = np.eye(4)
    projective[3] = (1, 0, 0, 1)  # invertible, but not affine: no Scene takes it
    with pytest.raises(ValueError, match="^transform must be affine"):
        durer.Scene().add_spheres([[0, 0, 0]], 1.0, transform=projective)
    assert not _checks.is_invertible(projective)
    assert not _checks.is_invertible(np.full((4, 4), np.nan)) and not _checks.is_invertible(np.eye(3))


def test_the_largest_image_side_is_the_cores():
    # The package reads the core's limit (RENDER_LIMITS); the core's own check, when render's are
    # bypassed, says the same number.
    side = _checks.MAX_IMAGE_SIDE
    assert side == _core.RENDER_LIMITS["side"] == 2**20
    spec = durer.OrthographicCamera((0, 0, 5), (0, 0, -1), (0, 1, 0))._spec
    with pytest.raises(ValueError, match=rf"^width must be in \[1, {side}\], got {side + 1}$"):
        _core.render(_core.Scene(), spec, side + 1, 1, 1, 0, "center", 0.01, 1, 0.0, "double", "robust", ["depth"],
                     "ray", 1, False, 0, 0.01, None, lambda f: False, {}, (0, 0, 0, 0))
    assert durer.render(durer.Scene(), durer.OrthographicCamera((0, 0, 5), (0, 0, -1), (0, 1, 0)), side, 1,
                        passes=("depth",), region=(side - 1, 0, 1, 1)).depth.shape == (1, 1)
    with pytest.raises(ValueError, match=f"^width must be <= {side}, got {side + 1}$"):
        durer.render(durer.Scene(), durer.OrthographicCamera((0, 0, 5), (0, 0, -1), (0, 1, 0)), side + 1, 1)
