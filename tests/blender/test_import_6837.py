"""File › Import › 6.837 scene (.txt): every corpus scene imports into a new scene of its own,
exports back to exactly the file's numbers, and renders with Dürer as
`durer.course.raytracer.render_scene_file` renders it with the same flags, from an empty file or
Blender's startup file alike; a malformed file is an ERROR report that creates nothing."""

from __future__ import annotations

import shlex

import numpy as np
import pytest
from helpers.blender import export

from helpers.blender_import import blender_module

bpy = blender_module("bpy")

import durer
import durer.blender
from durer.blender import engine
from durer.blender import import_6837 as imp
from durer.course.scene_file import read_scene_file
from helpers import CORPUS

pytestmark = pytest.mark.blender

SCENES = sorted(CORPUS.glob("scene*.txt"))
SIZE = 200
#: The import must match the raytracer on this fraction of pixels, within 1/255 on linear colour.
MATCH = 0.995


def official_runs() -> list[tuple[str, dict]]:
    """(scene file name, flags) of every distinct official command line in scenes/6837/commands.txt
    (the -tessellation/-gouraud variants of one scene are one run: they only change the OpenGL preview)."""
    runs: dict[tuple, tuple[str, dict]] = {}
    for line in (CORPUS / "commands.txt").read_text().splitlines():
        words = shlex.split(line, comments=True)
        if not words:
            continue
        flags = {"shade_back": False, "shadows": False, "bounces": 0, "weight": 0.0}
        name = words[words.index("-input") + 1]
        for i, word in enumerate(words):
            if word in ("-shade_back", "-shadows"):
                flags[word[1:]] = True
            elif word == "-bounces":
                flags["bounces"] = int(words[i + 1])
            elif word == "-weight":
                flags["weight"] = float(words[i + 1])
        runs.setdefault((name, *flags.values()), (name, flags))
    return list(runs.values())


RUNS = official_runs()
def run_id(run) -> str:
    name, flags = run
    on = [k if v is True else f"{k}{v}" for k, v in flags.items() if v]
    return "-".join([name.removesuffix(".txt"), *on])


@pytest.fixture
def empty():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    durer.blender.register()
    return bpy.context.scene


def import_file(path, **options):
    """Import through the operator; the new scene it makes active."""
    result = bpy.ops.import_scene.durer_6837(filepath=str(path), resolution_x=SIZE, resolution_y=SIZE, **options)
    assert result == {"FINISHED"}
    return bpy.context.scene


def durer_render() -> np.ndarray:
    """F12 with the scene's settings; the Combined RGB, top row first."""
    assert bpy.ops.render.render() == {"FINISHED"}
    assert engine.last_render.error is None, engine.last_render.error
    image = bpy.data.images[engine.IMAGE_NAME]
    w, h = image.size
    px = np.empty(w * h * 4, np.float32)
    image.pixels.foreach_get(px)
    return px.reshape(h, w, 4)[::-1, :, :3]


def match_fraction(a: np.ndarray, b: np.ndarray) -> float:
    """Fraction of pixels whose linear RGB channels all agree within 1/255."""
    return float((np.abs(a - b).max(axis=-1) <= 1 / 255).mean())


# --- import and export -----------------------------------------------------------------------------


def test_the_menu_has_the_importer(empty):
    assert imp.menu_import in bpy.types.TOPBAR_MT_file_import._dyn_ui_initialize()
    assert bpy.ops.import_scene.durer_6837.get_rna_type().name == "Import 6.837 Scene"


@pytest.mark.parametrize("path", SCENES, ids=lambda p: p.stem)
def test_every_corpus_scene_imports_and_exports_its_numbers(empty, path):
    f = read_scene_file(path)
    scene = import_file(path)
    collection = bpy.data.collections[path.stem]
    kinds = [p.kind for p in f.primitives]
    d = export(scene)
    assert not d.warnings and not d.skipped
    assert d.sphere_count + d.ellipsoid_count == kinds.count("sphere")
    assert len(d.planes) == kinds.count("plane") and all(p.bounds is None for p in d.planes)
    expected_triangles = kinds.count("triangle") + sum(len(p.faces) for p in f.primitives if p.kind == "mesh")
    assert d.triangle_count == expected_triangles
    # Lights: exactly the file's colours (float32 strengths), directions, positions, attenuations.
    assert len(d.lights) == len(f.lights)
    for light, data in zip(f.lights, sorted(d.lights, key=lambda l: int(l.name.split()[-1]))):
        np.testing.assert_allclose(data.color, light.color, rtol=1e-6, atol=1e-7)
        if light.kind == "directional":
            assert data.kind == "sun"
            np.testing.assert_allclose(data.direction, np.array(light.direction) / np.linalg.norm(light.direction), atol=1e-6)
        else:
            assert data.kind == "point" and data.attenuation == pytest.approx(light.attenuation)
            np.testing.assert_allclose(data.position, light.position, rtol=1e-6)
    # Background and ambient light as 6.837 has them; the camera's view.
    assert d.background[:3] == pytest.approx(f.background) and d.ambient == pytest.approx(f.effective_ambient)
    cam = d.camera
    assert (cam.width, cam.height, cam.fit) == (SIZE, SIZE, "horizontal")
    direction = np.array(f.camera.direction) / np.linalg.norm(f.camera.direction)
    np.testing.assert_allclose(cam.direction, direction, atol=1e-6)
    offset = scene.camera[imp.DEPTH_OFFSET_PROPERTY]
    np.testing.assert_allclose(cam.center + offset * cam.direction, f.camera.center, atol=1e-5)
    if f.camera.projection == "orthographic":
        assert cam.projection == "orthographic" and cam.size == pytest.approx(f.camera.size) and offset >= 1
    else:
        assert cam.fov_degrees == pytest.approx(f.camera.size, rel=1e-6) and offset == 0
        assert cam.clip_start == pytest.approx(imp.CLIP_START)
    # Every material that a primitive uses exports to exactly the file's numbers (as float32).
    exported = {_numbers(d.materials[i]) for i in _used_materials(d)}
    assert all(not any(d.materials[i].emission) for i in _used_materials(d))
    assert exported == {_numbers(f.materials[p.material]) for p in f.primitives}
    # One object per primitive, light and the camera; the Triangles of one material and matrix are one.
    triangles = [p for p in f.primitives if p.kind == "triangle"]
    merged = len(triangles) - len({(p.material, p.matrix.tobytes()) for p in triangles})
    assert len(collection.objects) == len(f.primitives) - merged + len(f.lights) + 1


def _used_materials(d) -> set[int]:
    ids = set(d.sphere_materials.tolist()) | {p.material for p in d.planes} | {m.material for m in d.meshes}
    for g in d.transformed_spheres:
        ids |= set(g.materials.tolist())
    return ids


def _numbers(m) -> tuple:
    """A material's 6.837 numbers (exported MaterialData or file SceneMaterial) rounded to float32:
    kd, ks and exponent (1 without ks), reflective, transparent and ior (1 if not transparent)."""
    def f32(values):
        return tuple(float(np.float32(v)) for v in np.atleast_1d(values))

    specular = any(m.specular)
    return (f32(m.diffuse), f32(m.specular), f32(m.exponent if specular else 1.0), f32(m.reflective),
            f32(m.transparent), f32(m.ior if any(m.transparent) else 1.0))


def test_from_the_startup_file_only_the_file_renders_and_the_startup_scene_stays(tmp_path):
    """The README's steps in Blender's startup file (its Cube, Light and Camera): register, import,
    F12. The import is a new scene named after the file, made the window's scene, so F12 renders
    exactly what the raytracer writes, and the startup scene keeps its objects, world and camera."""
    from durer.course.raytracer import render_scene_file

    bpy.ops.wm.read_factory_settings()  # the startup file, not use_empty
    durer.blender.register()
    startup = bpy.context.scene
    objects, world, camera = set(startup.objects), startup.world, startup.camera
    assert {o.name for o in objects} == {"Cube", "Light", "Camera"}
    path = CORPUS / "scene2_15_crazy_transforms.txt"
    scene = import_file(path)
    assert scene != startup and scene.name == path.stem and bpy.context.window.scene == scene
    assert set(scene.objects).isdisjoint(objects) and len(scene.objects) == len(bpy.data.collections[path.stem].objects)
    reference = render_scene_file(path, SIZE, SIZE, passes="color").color[..., :3]
    assert match_fraction(durer_render(), reference) == 1.0
    assert (set(startup.objects), startup.world, startup.camera) == (objects, world, camera)


def test_a_file_with_nothing_to_render_imports_with_a_warning(empty, tmp_path, capfd):
    path = tmp_path / "nothing.txt"
    path.write_text("OrthographicCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 size 5 }\nGroup { numObjects 0 }\n")
    scene = import_file(path)
    assert f"Warning: {path}: nothing to render: " in capfd.readouterr().out
    assert [o.type for o in scene.objects] == ["CAMERA"]


def test_options_reach_the_render_settings(empty):
    scene = import_file(CORPUS / "scene4_04_reflective_sphere.txt", shade_back=True, shadows=True, bounces=3,
                        weight=0.05)
    s = scene.durer
    assert (s.shade_back, s.max_bounces, s.samples, s.sampler, s.precision) == (True, 3, 1, "CENTER", "DOUBLE")
    assert s.min_weight == pytest.approx(0.05) and scene.render.engine == "DURER"
    assert all(light.use_shadow for light in bpy.data.lights)
    kwargs = engine.render_kwargs(s)
    assert kwargs["shade_back"] is True and kwargs["min_weight"] == 0.05 and kwargs["max_bounces"] == 3


def test_spheres_planes_and_meshes_keep_the_file_geometry(empty):
    """scene2_13's squashed, rotated sphere is an ellipsoid under the file's matrix; scene2_06's
    plane is y = -2 with normal +y; scene2_14's cubes share one mesh with the file's matrices."""
    scene = import_file(CORPUS / "scene2_13_rotated_squashed_sphere.txt")
    f = read_scene_file(CORPUS / "scene2_13_rotated_squashed_sphere.txt")
    (g,) = export(scene).transformed_spheres
    np.testing.assert_allclose(g.matrix @ np.diag([g.radii[0]] * 3 + [1]), imp.sphere_matrix(f.primitives[0]),
                               atol=1e-6)
    np.testing.assert_allclose(g.centers, 0, atol=1e-7)
    (plane,) = export(import_file(CORPUS / "scene2_06_plane.txt")).planes
    np.testing.assert_allclose(plane.normal, [0, 1, 0], atol=1e-7)
    assert plane.offset == pytest.approx(-2, abs=1e-6)
    scene = import_file(CORPUS / "scene2_14_axes_cube.txt")
    f = read_scene_file(CORPUS / "scene2_14_axes_cube.txt")
    meshes = export(scene).meshes
    assert len(meshes) == 4 and all(m.vertices is meshes[0].vertices for m in meshes)
    np.testing.assert_allclose(sorted(m.matrix.ravel().tolist() for m in meshes),
                               sorted(p.matrix.ravel().tolist() for p in f.primitives), atol=1e-6)


# --- errors ----------------------------------------------------------------------------------------


def _datablock_counts() -> dict[str, int]:
    kinds = ("scenes", "objects", "meshes", "materials", "lights", "cameras", "worlds", "collections")
    return {k: len(getattr(bpy.data, k)) for k in kinds}


@pytest.mark.parametrize(
    "text, message",
    [
        ("Group {\n numObjects 1\n MaterialIndex 0\n Sphere { center 0 0 0 radius 1 }\n", "not closed"),
        ("Materials { numMaterials 1 Material { diffuseColor 1 0 } }\n", "expected"),
        ("Group { numObjects 1 MaterialIndex 0 TriangleMesh { obj_file missing.obj } }\n", "missing.obj"),
    ],
    ids=["missing-brace", "bad-number", "missing-obj"],
)
def test_a_malformed_file_is_an_error_report_and_creates_nothing(empty, tmp_path, text, message):
    scene = import_file(CORPUS / "scene1_01.txt")  # something already there must stay as it is
    before, world, camera = _datablock_counts(), scene.world, scene.camera
    bad = tmp_path / "bad.txt"
    bad.write_text("OrthographicCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 size 5 }\n"
                   "Materials { numMaterials 1 Material { diffuseColor 1 0 0 } }\n" * ("Materials" not in text) + text)
    with pytest.raises(RuntimeError, match=rf"Error: {bad}:\d+: .*{message}"):
        import_file(bad)
    assert _datablock_counts() == before and bpy.context.scene == scene
    assert scene.world == world and scene.camera == camera


def test_a_failure_while_building_removes_the_new_scene_and_all_it_made(empty, monkeypatch):
    def fail(*_):
        raise RuntimeError("the camera failed")

    monkeypatch.setattr(imp._Builder, "camera", fail)  # the last object made, after all the others
    before, scene = _datablock_counts(), bpy.context.scene
    with pytest.raises(RuntimeError, match="the camera failed"):
        imp.build_scene(read_scene_file(CORPUS / "scene4_14_faceted_gem.txt"))
    assert _datablock_counts() == before and bpy.context.scene == scene


def test_a_missing_file_is_an_error_report(empty, tmp_path):
    with pytest.raises(RuntimeError, match="Error: Cannot read .*nowhere.txt"):
        import_file(tmp_path / "nowhere.txt")
    assert len(bpy.data.objects) == 0


# --- renders ---------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "run",
    RUNS,
    ids=run_id,
)
def test_import_renders_like_the_raytracer(empty, run):
    """Every official command line: import with its flags, render with Dürer through F12, compare
    with render_scene_file's image (>= 99.5 % of pixels within 1/255 on every linear channel)."""
    from durer.course.raytracer import render_scene_file

    name, flags = run
    import_file(CORPUS / name, **flags)
    blender = durer_render()
    reference = render_scene_file(CORPUS / name, SIZE, SIZE, passes=("color",), **flags).color[..., :3]
    fraction = match_fraction(blender, reference)
    assert fraction >= MATCH, f"{run_id(run)}: {fraction:.2%} of pixels match"


@pytest.mark.parametrize("plane", ["Plane { normal 0 1 0 offset -1 }", "Plane { normal 1 1 0 offset -1 }",
                                   "Transform { ZRotate 30 Plane { normal 0 1 0 offset -1 } }"])
def test_a_plane_edge_on_to_an_orthographic_camera_is_not_seen(empty, tmp_path, plane):
    """Rays parallel to an infinite plane never meet it: the import's plane, rotated by Blender's
    float32 matrices (a normal off by 4e-8), was met 1e8 away, a band across the view."""
    from durer.course.raytracer import render_scene_file

    path = tmp_path / "edge.txt"
    path.write_text("OrthographicCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 size 6 }\n"
                    "Lights { numLights 1 DirectionalLight { direction -0.3 -0.4 -1 color 0.8 0.8 0.8 } }\n"
                    "Background { color 0.1 0.1 0.1 ambientLight 0.2 0.2 0.2 }\n"
                    "Materials { numMaterials 2 Material { diffuseColor 1 0 0 } Material { diffuseColor 0 1 0 } }\n"
                    f"Group {{ numObjects 2 MaterialIndex 0 Sphere {{ center 0 0 0 radius 1 }} MaterialIndex 1 {plane} }}\n")
    import_file(path)
    reference = render_scene_file(path, SIZE, SIZE, passes="color").color[..., :3]
    assert (reference[..., 1] < 0.5).all()  # no green: the plane is not seen
    assert match_fraction(durer_render(), reference) == 1.0


def test_orthographic_camera_behind_the_spheres_sees_what_6837_sees(empty, tmp_path):
    """scene1_07's camera sits inside its spheres (6.837 counts hits from t = -inf): the moved-back
    camera gives the same image, and its Depth pass is 6.837's t plus the recorded offset."""
    from helpers.blender import render_passes
    from durer.course.raytracer import render_scene_file

    path = CORPUS / "scene1_07.txt"
    scene = import_file(path)
    out = render_passes(scene, tmp_path / "scene1_07.exr", normal=False)
    reference = render_scene_file(path, SIZE, SIZE, passes=("color", "depth"))
    assert match_fraction(out["color"][..., :3], reference.color[..., :3]) == 1.0
    hit = np.isfinite(reference.depth)
    assert (reference.depth[hit] < 0).any()  # hits behind the 6.837 camera's centre
    offset = scene.camera[imp.DEPTH_OFFSET_PROPERTY]
    np.testing.assert_array_equal(out["depth"] < 1e9, hit)
    np.testing.assert_allclose(out["depth"][hit] - offset, reference.depth[hit], atol=1e-4)


SHEARED = """
PerspectiveCamera { center 1 2 12 direction -0.1 -0.15 -1 up 0 1 0 angle 35 }
Lights {
    numLights 2
    DirectionalLight { direction -0.3 -0.6 -1 color 0.6 0.5 0.4 }
    PointLight { position 2 4 5 color 0.8 0.8 0.9 attenuation 0.5 0.05 0.01 }
}
Background { color 0.05 0.1 0.2 ambientLight 0.15 0.1 0.1 }
Materials {
    numMaterials 3
    PhongMaterial { diffuseColor 0.9 0.3 0.2 specularColor 0.5 0.5 0.5 exponent 20 }
    Material { diffuseColor 0.2 0.8 0.3 reflectiveColor 0.3 0.3 0.3 }
    Material { diffuseColor 0.7 0.7 0.7 }
}
Group {
    numObjects 4
    MaterialIndex 0
    Transform { Translate -2 0 0 Scale 1 2 1 ZRotate 40 Scale 1 0.5 1.5 Sphere { center 0.2 0 0 radius 1 } }
    MaterialIndex 1
    Transform { Translate 2 0 0 Scale -1 2 1 ZRotate 30 Scale 1.5 0.5 1 TriangleMesh { obj_file cube.obj } }
    Transform { XRotate 20 Scale 1 1 3 YRotate 45 Triangle { vertex0 -1 2 0 vertex1 1 2 0 vertex2 0 3 0.5 } }
    MaterialIndex 2
    Transform { ZRotate 10 Scale 2 1 1 XRotate 30 Plane { normal 0 1 0 offset -2 } }
}
"""


@pytest.mark.parametrize("shade_back", [False, True])
def test_sheared_and_mirrored_transforms_render_like_the_raytracer(empty, tmp_path, shade_back):
    """Blender objects hold no shear: a sphere under a sheared matrix becomes the same ellipsoid
    without it, a sheared mesh gets the rotation Blender cannot hold baked into its vertices, and
    a mirror stays in the object's scale so that the triangles keep their normals. Every pixel
    matches the raytracer, lit from both sides or only from the front."""
    from durer.course.raytracer import render_scene_file

    path = tmp_path / "sheared.txt"
    path.write_text(SHEARED)
    (tmp_path / "cube.obj").write_text((CORPUS / "cube.obj").read_text())
    f = read_scene_file(path)
    assert all(imp.has_shear(p.matrix) for p in f.primitives[:3])
    import_file(path, shade_back=shade_back, shadows=True, bounces=2, weight=0.01)
    blender = durer_render()
    reference = render_scene_file(path, SIZE, SIZE, passes=("color",), shade_back=shade_back, shadows=True,
                                  bounces=2, weight=0.01).color[..., :3]
    assert match_fraction(blender, reference) == 1.0
    np.testing.assert_allclose(blender, reference, atol=1e-4)


def test_split_shear_keeps_the_matrix_and_moves_mirrors_into_the_scale():
    rng = np.random.default_rng(7)
    for _ in range(20):
        m = np.eye(4)
        m[:3, :3], m[:3, 3] = rng.normal(size=(3, 3)), rng.normal(size=3)
        obj, rotation = imp.split_shear(m)
        np.testing.assert_allclose(obj @ rotation, m, atol=1e-12)
        assert np.linalg.det(rotation[:3, :3]) == pytest.approx(1.0)
        assert not imp.has_shear(obj)  # Blender can hold it: a rotation times a (signed) scale
        assert np.sign(np.linalg.det(obj[:3, :3])) == np.sign(np.linalg.det(m[:3, :3]))
